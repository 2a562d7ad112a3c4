#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <opencv2/imgproc.hpp>

#include "kumite/common/error.hpp"
#include "kumite/tracking/blobs.hpp"

using namespace kumite::tracking;

namespace {

/// Adds a Gaussian spot (peak grey levels above the background, sigma px) centred at (x, y).
void add_spot(cv::Mat& img, double x, double y, double sigma, double peak) {
  const int r = static_cast<int>(std::ceil(4 * sigma));
  for (int row = std::max(0, int(y) - r); row <= std::min(img.rows - 1, int(y) + r + 1); ++row) {
    for (int col = std::max(0, int(x) - r); col <= std::min(img.cols - 1, int(x) + r + 1); ++col) {
      const double d2 = (col - x) * (col - x) + (row - y) * (row - y);
      const double v = img.at<std::uint8_t>(row, col) + peak * std::exp(-d2 / (2 * sigma * sigma));
      img.at<std::uint8_t>(row, col) = cv::saturate_cast<std::uint8_t>(v);
    }
  }
}

}  // namespace

TEST(Blobs, SubPixelCentroidsOfGaussianSpots) {
  cv::Mat img(1024, 1280, CV_8UC1, cv::Scalar(10));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(20, 1260), uy(20, 1000);
  std::vector<cv::Point2d> truth;
  for (int i = 0; i < 30; ++i) {
    cv::Point2d p(ux(rng), uy(rng));
    truth.push_back(p);
    add_spot(img, p.x, p.y, 1.3, 220);
  }
  BlobDetector detector;
  const auto& blobs = detector.detect(img);
  ASSERT_EQ(blobs.size(), truth.size());
  double worst = 0;
  for (const auto& p : truth) {
    double best = 1e9;
    const Blob* match = nullptr;
    for (const auto& b : blobs) {
      const double d = std::hypot(b.x - p.x, b.y - p.y);
      if (d < best) best = d, match = &b;
    }
    worst = std::max(worst, best);
    EXPECT_GT(match->roundness, 0.8);
    EXPECT_GT(match->area, 6);
    EXPECT_LE(match->peak, 230);
  }
  EXPECT_LT(worst, 0.05) << "worst centroid error, px";
}

TEST(Blobs, RejectsStreaksLargeAreasAndTinySpecks) {
  cv::Mat img(200, 300, CV_8UC1, cv::Scalar(0));
  cv::line(img, {20, 20}, {120, 30}, cv::Scalar(255), 2);        // streak
  cv::rectangle(img, {150, 100}, {280, 190}, cv::Scalar(255), -1);  // window / lamp
  img.at<std::uint8_t>(10, 250) = 255;                              // single hot pixel
  cv::circle(img, {60, 150}, 4, cv::Scalar(200), -1);               // a marker
  BlobDetector detector;
  const auto& blobs = detector.detect(img);
  ASSERT_EQ(blobs.size(), 1U);
  EXPECT_NEAR(blobs[0].x, 60, 0.01);
  EXPECT_NEAR(blobs[0].y, 150, 0.01);
  EXPECT_EQ(detector.last_stats().not_round, 1);
  EXPECT_EQ(detector.last_stats().too_large, 1);
  EXPECT_EQ(detector.last_stats().too_small, 0);  // the speck sits on an unscanned row
}

TEST(Blobs, SeedRowStepOneFindsSinglePixelsButMinAreaDropsThem) {
  cv::Mat img(50, 50, CV_8UC1, cv::Scalar(0));
  img.at<std::uint8_t>(11, 7) = 255;
  BlobParams p;
  p.seed_row_step = 1;
  BlobDetector detector(p);
  EXPECT_TRUE(detector.detect(img).empty());
  EXPECT_EQ(detector.last_stats().too_small, 1);
  p.min_area = 1;
  detector.set_params(p);
  ASSERT_EQ(detector.detect(img).size(), 1U);
}

TEST(Blobs, HighThresholdsAndRepeatedCallsAreConsistent) {
  cv::Mat img(64, 67, CV_8UC1, cv::Scalar(0));  // width not a multiple of 8
  cv::circle(img, {64, 30}, 2, cv::Scalar(201), -1);
  cv::circle(img, {10, 30}, 2, cv::Scalar(199), -1);
  BlobDetector detector({.threshold = 200});
  for (int i = 0; i < 3; ++i) {
    const auto& blobs = detector.detect(img);
    ASSERT_EQ(blobs.size(), 1U);
    EXPECT_NEAR(blobs[0].x, 64, 1e-9);
  }
}

TEST(Blobs, RejectsNonGreyImages) {
  cv::Mat colour(10, 10, CV_8UC3);
  EXPECT_THROW(detect_blobs(colour), kumite::Error);
}

TEST(StaticMask, LearnsBlobsThatNeverMoveButNotUsedOnes) {
  StaticMask mask({.still_px = 1.0, .learn_s = 1.0});
  std::vector<Blob> blobs{{100, 100, 12, 1, 100, 200}, {300, 50, 12, 1, 100, 200}};
  const std::vector<std::uint8_t> used{0, 1};
  for (int i = 0; i <= 70; ++i) {
    blobs[0].x = 100 + 0.1 * std::sin(i);  // a lamp, jittering a little
    mask.update(blobs, used, i / 60.0);
  }
  EXPECT_EQ(mask.regions(), 1U);
  EXPECT_TRUE(mask.masked(101, 100));
  EXPECT_FALSE(mask.masked(300, 50));  // a marker of a tracked body standing still
  std::vector<Blob> next = blobs;
  EXPECT_EQ(mask.apply(next), 1);
  ASSERT_EQ(next.size(), 1U);
  EXPECT_EQ(next[0].x, 300);
}

TEST(StaticMask, MovingBlobsAreNeverMasked) {
  StaticMask mask({.still_px = 1.0, .learn_s = 0.5});
  for (int i = 0; i < 120; ++i) {
    const std::vector<Blob> blobs{{100.0 + 2 * i, 100, 12, 1, 100, 200}};
    mask.update(blobs, {}, i / 60.0);
  }
  EXPECT_EQ(mask.regions(), 0U);
}
