// wand: a SYNTHETIC wand dance (two bright spots 0.5 m apart drawn through the true cameras)
// measured with the tracker's blob detector and triangulator, then used to refine a rig.
#include <filesystem>
#include <random>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "kumite/calibration/commands.hpp"
#include "kumite/calibration/synthetic.hpp"
#include "kumite/calibration/wand.hpp"
#include "kumite/common/error.hpp"
#include "kumite/tracking/recording.hpp"
#include "kumite/tracking/synth.hpp"

namespace fs = std::filesystem;
using namespace kumite::calibration;
namespace syn = kumite::calibration::synthetic;

namespace {

constexpr double kLength = 0.5;

syn::Camera as_synthetic(const kumite::tracking::CameraCalibration& c) {
  syn::Camera s;
  s.size = {c.image_width, c.image_height};
  s.K = c.camera_matrix;
  s.dist = c.distortion;
  s.R = c.rotation;
  s.t = c.translation;
  return s;
}

/// Writes the recording and returns its folder.
fs::path write_wand_recording(const kumite::tracking::RigCalibration& rig, int frames) {
  const fs::path dir = fs::temp_directory_path() / fmt::format("kumite_wand_{}", ::getpid());
  fs::remove_all(dir);
  for (const auto& c : rig.cameras) fs::create_directories(dir / c.name);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> ux(-1.0, 1.0), uy(0.6, 2.0), ua(0, 2 * CV_PI), uel(-0.8, 0.8);
  std::vector<kumite::tracking::FrameRow> rows;
  for (int f = 0; f < frames; ++f) {
    const cv::Vec3d mid(ux(rng), uy(rng), ux(rng));
    const double az = ua(rng), el = uel(rng);
    const cv::Vec3d dir_v(std::cos(el) * std::cos(az), std::sin(el), std::cos(el) * std::sin(az));
    const cv::Vec3d a = mid - dir_v * (kLength / 2), b = mid + dir_v * (kLength / 2);
    for (const auto& c : rig.cameras) {
      const syn::Camera cam = as_synthetic(c);
      cv::Mat img(cam.size, CV_32F, cv::Scalar(12));
      for (const auto& p : {a, b}) {
        if ((cam.R * p + cam.t)[2] <= 0.2) continue;
        const cv::Point2d q = syn::project(cam, p);
        // A Gaussian spot (sigma 1.3 px), drawn analytically around its true centre.
        for (int y = static_cast<int>(q.y) - 6; y <= static_cast<int>(q.y) + 6; ++y) {
          for (int x = static_cast<int>(q.x) - 6; x <= static_cast<int>(q.x) + 6; ++x) {
            if (x < 0 || y < 0 || x >= img.cols || y >= img.rows) continue;
            const double d2 = (x - q.x) * (x - q.x) + (y - q.y) * (y - q.y);
            img.at<float>(y, x) += static_cast<float>(200 * std::exp(-d2 / (2 * 1.3 * 1.3)));
          }
        }
      }
      cv::Mat n(img.size(), CV_32F);
      cv::randn(n, 0.0, 2.0);
      img += n;
      cv::Mat out;
      img.convertTo(out, CV_8U);
      cv::imwrite((dir / c.name / kumite::tracking::frame_file_name(static_cast<std::uint64_t>(f))).string(), out);
    }
    rows.push_back({static_cast<std::uint64_t>(f), f / 60.0});
  }
  kumite::tracking::write_frames_csv(dir / "frames.csv", rows);
  return dir;
}

}  // namespace

TEST(Wand, LengthAndRefinement) {
  const auto truth = kumite::tracking::corner_rig(3.0, 2.6, 640, 512, 410);
  const fs::path dir = write_wand_recording(truth, 60);
  WandOptions opt;
  opt.length_m = kLength;
  const WandResult good = measure_wand(truth, dir, opt);
  std::printf("true rig: %d of %d frames, mean %.2f mm, std %.2f mm\n", good.stats.samples, good.frames,
              good.stats.mean_m * 1000, good.stats.std_m * 1000);
  EXPECT_GE(good.stats.samples, 45);
  EXPECT_NEAR(good.stats.mean_m, kLength, 0.002);
  EXPECT_LT(good.stats.std_m, 0.003);

  // A rig whose cam2 moved by 15 mm and turned by 0.3 degrees: the wand sees it.
  auto bad = truth;
  bad.cameras[2].translation += cv::Vec3d(0.015, -0.01, 0.0);
  bad.cameras[2].rotation = syn::rotation({0, 1, 0.2}, 0.3) * bad.cameras[2].rotation;
  WandResult r = measure_wand(bad, dir, opt);
  std::printf("disturbed rig: mean %.2f mm, std %.2f mm, RMS error %.2f mm\n", r.stats.mean_m * 1000,
              r.stats.std_m * 1000, r.stats.rms_error_m * 1000);
  EXPECT_GT(r.camera_rms_px[2], 1.0) << "the moved camera stands out";
  EXPECT_LT(r.camera_rms_px[0], 1.0);
  refine_with_wand(bad, opt, r);
  ASSERT_TRUE(r.refined.has_value());
  const double before = cv::norm(bad.cameras[2].position() - truth.cameras[2].position());
  const double after = cv::norm(r.refined->cameras[2].position() - truth.cameras[2].position());
  std::printf("after refinement: mean %.2f mm, std %.2f mm, RMS error %.2f mm; cam2 off by %.2f mm (was %.2f mm)\n",
              r.refined_stats.mean_m * 1000, r.refined_stats.std_m * 1000, r.refined_stats.rms_error_m * 1000,
              after * 1000, before * 1000);
  EXPECT_LT(r.refined_stats.rms_error_m, r.stats.rms_error_m);
  EXPECT_LT(after, before / 3);
  fs::remove_all(dir);
}

TEST(Wand, NoMarkersSaysWhatToDo) {
  const auto rig = kumite::tracking::corner_rig(3.0, 2.6, 320, 256, 205);
  const fs::path dir = fs::temp_directory_path() / fmt::format("kumite_wand_empty_{}", ::getpid());
  fs::remove_all(dir);
  for (const auto& c : rig.cameras) {
    fs::create_directories(dir / c.name);
    cv::imwrite((dir / c.name / "000000.png").string(), cv::Mat(256, 320, CV_8U, cv::Scalar(10)));
  }
  kumite::tracking::write_frames_csv(dir / "frames.csv", {{0, 0.0}});
  try {
    measure_wand(rig, dir, {});
    FAIL();
  } catch (const kumite::Error& e) {
    EXPECT_NE(std::string(e.what()).find("wand markers"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}
