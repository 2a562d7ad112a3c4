// PackedImage: lossless, small for dark frames with blobs, kept as is where packing would not pay.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "kumite/tracking/packed_image.hpp"

namespace kt = kumite::tracking;

namespace {
bool same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}
}  // namespace

TEST(PackedImage, DarkFrameWithBlobsRoundTripsAndShrinks) {
  cv::Mat im = cv::Mat::zeros(1024, 1280, CV_8UC1);
  cv::RNG rng(3);
  for (int k = 0; k < 12; ++k)
    cv::circle(im, {rng.uniform(0, 1280), rng.uniform(0, 1024)}, rng.uniform(2, 9), cv::Scalar(rng.uniform(40, 256)), -1,
               cv::LINE_AA);
  im.at<std::uint8_t>(0, 0) = 7;           // first pixel
  im.at<std::uint8_t>(1023, 1279) = 9;     // last pixel
  im.at<std::uint8_t>(500, 3) = 1;         // lone pixels with short and long gaps
  im.at<std::uint8_t>(500, 6) = 2;
  im.at<std::uint8_t>(500, 40) = 3;
  const kt::PackedImage p(im);
  EXPECT_TRUE(p.packed());
  EXPECT_LT(p.bytes(), im.total() / 100);
  EXPECT_TRUE(same(p.unpack(), im));
}

TEST(PackedImage, FrameOnABlackLevelAboveZeroPacksToo) {
  // Cameras' (and kumite-track synth's) background is a grey a little above 0 (12 there).
  cv::Mat im(1024, 1280, CV_8UC1, cv::Scalar(12));
  cv::circle(im, {300, 200}, 6, cv::Scalar(230), -1, cv::LINE_AA);
  cv::circle(im, {900, 700}, 4, cv::Scalar(180), -1, cv::LINE_AA);
  im.at<std::uint8_t>(0, 0) = 0;  // darker than the background
  const kt::PackedImage p(im);
  EXPECT_TRUE(p.packed());
  EXPECT_LT(p.bytes(), im.total() / 100);
  EXPECT_TRUE(same(p.unpack(), im));
}

TEST(PackedImage, NoisyFrameIsKeptAsIs) {
  cv::Mat im(480, 640, CV_8UC1);
  cv::randu(im, 0, 256);
  const kt::PackedImage p(im);
  EXPECT_FALSE(p.packed());
  EXPECT_TRUE(same(p.unpack(), im));
}

TEST(PackedImage, OtherTypesAndEmpty) {
  cv::Mat im16(10, 12, CV_16UC1, cv::Scalar(300));
  const kt::PackedImage p16(im16);
  EXPECT_FALSE(p16.packed());
  EXPECT_TRUE(same(p16.unpack(), im16));
  const kt::PackedImage none{cv::Mat()};
  EXPECT_TRUE(none.empty());
  EXPECT_TRUE(none.unpack().empty());
  const kt::PackedImage black(cv::Mat::zeros(8, 8, CV_8UC1));
  EXPECT_TRUE(black.packed());
  EXPECT_EQ(black.bytes(), 0u);
  EXPECT_TRUE(same(black.unpack(), cv::Mat::zeros(8, 8, CV_8UC1)));
}
