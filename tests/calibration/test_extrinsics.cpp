// Extrinsics on OpenCV's stereo sample pair, compared with cv::stereoCalibrate; bad input.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "kumite/calibration/commands.hpp"
#include "kumite/calibration/intrinsics.hpp"
#include "kumite/common/error.hpp"
#include "kumite/tracking/calibration_file.hpp"

namespace fs = std::filesystem;
using namespace kumite::calibration;

namespace {

fs::path samples() { return fs::path(KUMITE_SHARED_DATA_DIR) / "calibration/opencv-samples"; }

/// DIR/left/NN.jpg, DIR/right/NN.jpg (symlinks to the samples), as a recording is laid out.
fs::path stereo_dir() {
  const fs::path d = fs::temp_directory_path() / ("kumite_stereo_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d / "left");
  fs::create_directories(d / "right");
  for (const char* n : {"01", "02", "03", "04", "05", "06", "07", "08", "09", "11", "12", "13", "14"}) {
    fs::create_symlink(samples() / (std::string("left") + n + ".jpg"), d / "left" / (std::string(n) + ".jpg"));
    fs::create_symlink(samples() / (std::string("right") + n + ".jpg"), d / "right" / (std::string(n) + ".jpg"));
  }
  std::ofstream(d / "board.toml") << "type = \"chessboard\"\nrows = 6\ncols = 9\nsquare_size_m = 0.025\n";
  return d;
}

}  // namespace

TEST(Extrinsics, StereoSamplesAgreeWithStereoCalibrate) {
  if (!fs::exists(samples())) GTEST_SKIP() << "no shared data at " << samples();
  const fs::path dir = stereo_dir();
  ExtrinsicsCommand cmd;
  cmd.board_file = dir / "board.toml";
  cmd.images_dir = dir;
  cmd.out = dir / "rig.yaml";
  run_extrinsics(cmd);
  const auto rig = kumite::tracking::read_calibration(cmd.out);
  ASSERT_EQ(rig.cameras.size(), 2u);
  const auto& left = *rig.find("left");
  const auto& right = *rig.find("right");
  const double baseline = cv::norm(right.position() - left.position());

  // The reference: OpenCV's stereoCalibrate on the same corners, intrinsics held at ours.
  const Board board = read_board(cmd.board_file);
  const RigImages imgs = scan_rig_images(dir);
  const auto views = detect_rig(board, imgs);
  std::vector<std::vector<cv::Point3f>> obj;
  std::vector<std::vector<cv::Point2f>> pl, pr;
  for (std::size_t f = 0; f < imgs.frames.size(); ++f) {
    if (views[0].detections[f].empty() || views[1].detections[f].empty()) continue;
    obj.push_back(views[0].detections[f].object_points);
    pl.push_back(views[0].detections[f].image_points);
    pr.push_back(views[1].detections[f].image_points);
  }
  cv::Mat K1(left.camera_matrix), D1(left.distortion), K2(right.camera_matrix), D2(right.distortion), R, T, E, F;
  const double cv_rms = cv::stereoCalibrate(obj, pl, pr, K1, D1, K2, D2, cv::Size(640, 480), R, T, E, F,
                                            cv::CALIB_FIX_INTRINSIC);
  const double cv_baseline = cv::norm(T);
  // Ours: right's pose relative to left.
  const cv::Matx33d R_rel = right.rotation * left.rotation.t();
  const cv::Vec3d t_rel = right.translation - R_rel * left.translation;
  const double angle = cv::norm(cv::Mat(R_rel * cv::Matx33d(R).t()) - cv::Mat::eye(3, 3, CV_64F)) / std::sqrt(2.0);
  std::printf("baseline: ours %.5f m, stereoCalibrate %.5f m (RMS %.3f px); T ours (%.5f %.5f %.5f) cv (%.5f %.5f %.5f); "
              "rotation difference %.4f deg\n",
              baseline, cv_baseline, cv_rms, t_rel[0], t_rel[1], t_rel[2], T.at<double>(0), T.at<double>(1),
              T.at<double>(2), angle * 180 / CV_PI);
  EXPECT_NEAR(baseline, cv_baseline, 0.01 * cv_baseline);
  EXPECT_LT(angle * 180 / CV_PI, 0.2);
  EXPECT_NEAR(baseline, 0.083, 0.01);  // ~3.3 squares of 25 mm: OpenCV's sample pair

  // The report on the same data: JSON and the PNGs a technician opens.
  ReportCommand rep;
  rep.calibration = cmd.out;
  rep.board_file = cmd.board_file;
  rep.images_dir = dir;
  rep.out_dir = dir / "report";
  run_report(rep);
  for (const char* f : {"report.json", "rig_top_view.png", "left_coverage.png", "left_view_errors.png",
                        "right_coverage.png", "right_view_errors.png"}) {
    EXPECT_TRUE(fs::exists(rep.out_dir / f)) << f;
  }
  const cv::Mat top = cv::imread((rep.out_dir / "rig_top_view.png").string());
  EXPECT_EQ(top.cols, 800);
  std::ifstream json(rep.out_dir / "report.json");
  const std::string text((std::istreambuf_iterator<char>(json)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"verdict\""), std::string::npos);
  EXPECT_NE(text.find("\"coverage_fraction\""), std::string::npos);
  EXPECT_NE(text.find("\"image\": \"02.jpg\""), std::string::npos);
  EXPECT_NE(text.find("\"rig_verdict\""), std::string::npos);
  EXPECT_NE(text.find("\"rig_check\""), std::string::npos);
  // The report is written as a unit (a hidden folder renamed into place): a second run
  // replaces the first whole, and leaves no hidden folder behind; a stale one of a killed
  // run (its process gone) is cleaned up. (Beside the images now: a report folder inside
  // them would be scanned as a camera.)
  fs::remove_all(rep.out_dir);
  const fs::path side = dir.parent_path() / (dir.filename().string() + "-out");
  fs::remove_all(side);
  rep.out_dir = side / "report";
  run_report(rep);
  fs::create_directories(side / ".report.tmp-999999999");
  std::ofstream(rep.out_dir / "left_coverage.png") << "old";
  run_report(rep);
  EXPECT_GT(fs::file_size(rep.out_dir / "left_coverage.png"), 3U);
  for (const auto& e : fs::directory_iterator(side)) {
    EXPECT_EQ(e.path().filename().string().rfind(".report.tmp-", 0), std::string::npos) << e.path();
  }
  // A folder holding anything but a report is not replaced.
  std::ofstream(rep.out_dir / "notes.txt") << "mine";
  try {
    run_report(rep);
    ADD_FAILURE() << "a folder with other files was replaced";
  } catch (const kumite::Error& e) {
    EXPECT_NE(std::string(e.what()).find("notes.txt"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(fs::exists(rep.out_dir / "notes.txt"));
  EXPECT_TRUE(fs::exists(rep.out_dir / "report.json"));
  fs::remove_all(side);
  fs::remove_all(dir);
}

TEST(Extrinsics, BadInput) {
  if (!fs::exists(samples())) GTEST_SKIP() << "no shared data at " << samples();
  const fs::path dir = stereo_dir();
  ExtrinsicsCommand cmd;
  cmd.board_file = dir / "board.toml";
  cmd.images_dir = dir / "nothing-here";
  cmd.out = dir / "rig.yaml";
  auto error_of = [&] {
    try {
      run_extrinsics(cmd);
    } catch (const kumite::Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of().find("not a folder"), std::string::npos);

  // An intrinsics file that lacks a camera.
  cmd.images_dir = dir;
  kumite::tracking::RigCalibration only_left;
  only_left.cameras.emplace_back();
  only_left.cameras[0].name = "left";
  only_left.cameras[0].image_width = 640;
  only_left.cameras[0].image_height = 480;
  only_left.cameras[0].camera_matrix = cv::Matx33d(530, 0, 320, 0, 530, 240, 0, 0, 1);
  kumite::tracking::write_calibration(dir / "intr.yaml", only_left);
  cmd.intrinsics = dir / "intr.yaml";
  const std::string e = error_of();
  EXPECT_NE(e.find("right"), std::string::npos) << e;
  EXPECT_NE(e.find("intr.yaml"), std::string::npos) << e;
  EXPECT_FALSE(fs::exists(cmd.out));
  fs::remove_all(dir);
}
