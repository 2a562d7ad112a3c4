// Intrinsics: OpenCV's sample views (known answer) and the bad-input messages.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "kumite/calibration/commands.hpp"
#include "kumite/calibration/intrinsics.hpp"
#include "kumite/common/error.hpp"
#include "kumite/tracking/calibration_file.hpp"

namespace fs = std::filesystem;
using namespace kumite::calibration;

namespace {

fs::path samples() { return fs::path(KUMITE_SHARED_DATA_DIR) / "calibration/opencv-samples"; }

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("kumite_calib_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

fs::path write_chessboard_toml(const fs::path& dir) {
  const fs::path p = dir / "board.toml";
  std::ofstream(p) << "type = \"chessboard\"\nrows = 6\ncols = 9\nsquare_size_m = 0.025\n";
  return p;
}

std::vector<fs::path> left_images() {
  std::vector<fs::path> v;
  for (const char* n : {"01", "02", "03", "04", "05", "06", "07", "08", "09", "11", "12", "13", "14"}) {
    v.push_back(samples() / (std::string("left") + n + ".jpg"));
  }
  return v;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const kumite::Error& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST(Intrinsics, OpenCvSamplesKnownAnswer) {
  if (!fs::exists(samples())) GTEST_SKIP() << "no shared data at " << samples();
  const fs::path dir = temp_dir("intr");
  IntrinsicsCommand cmd;
  cmd.board_file = write_chessboard_toml(dir);
  cmd.images = left_images();
  cmd.out = dir / "cal.yaml";
  cmd.name = "left";
  run_intrinsics(cmd);
  const auto rig = kumite::tracking::read_calibration(cmd.out);
  ASSERT_EQ(rig.cameras.size(), 1u);
  const auto& c = rig.cameras[0];
  EXPECT_EQ(c.name, "left");
  EXPECT_EQ(c.image_width, 640);
  EXPECT_NEAR(c.camera_matrix(0, 0), 535.9, 0.01 * 535.9);
  EXPECT_NEAR(c.camera_matrix(1, 1), 535.9, 0.01 * 535.9);
  ASSERT_TRUE(c.rms_px.has_value());
  EXPECT_LE(*c.rms_px, 0.45);
  ASSERT_EQ(c.per_view_errors_px.size(), 13u);
  const auto worst = std::max_element(c.per_view_errors_px.begin(), c.per_view_errors_px.end());
  EXPECT_EQ(worst - c.per_view_errors_px.begin(), 1) << "left02 must be the worst view";

  // Running again keeps the previous file as a backup.
  run_intrinsics(cmd);
  int backups = 0;
  for (const auto& e : fs::directory_iterator(dir)) backups += e.path().extension() == ".bak";
  EXPECT_EQ(backups, 1);
  fs::remove_all(dir);
}

TEST(Intrinsics, OutlierIsRejectedAndNamed) {
  if (!fs::exists(samples())) GTEST_SKIP() << "no shared data at " << samples();
  Board b;
  b.type = BoardType::chessboard;
  b.rows = 6;
  b.cols = 9;
  b.square_size_m = 0.025;
  const CameraViews v = detect_views(b, left_images(), "left");
  const IntrinsicsResult r = calibrate_intrinsics(v.detections, v.image_size);
  ASSERT_EQ(r.rejected.size(), 1u);
  EXPECT_EQ(r.rejected[0], 1);  // left02
  EXPECT_EQ(r.worst_view, 1);
  EXPECT_FALSE(r.used[1]);
}

TEST(Intrinsics, BadInputGivesOneLineAdvice) {
  if (!fs::exists(samples())) GTEST_SKIP() << "no shared data at " << samples();
  const fs::path dir = temp_dir("bad");
  IntrinsicsCommand cmd;
  cmd.board_file = write_chessboard_toml(dir);
  cmd.out = dir / "cal.yaml";

  // Unreadable image.
  std::ofstream(dir / "broken.png") << "not a png";
  cmd.images = {samples() / "left01.jpg", dir / "broken.png"};
  std::string e = error_of([&] { run_intrinsics(cmd); });
  EXPECT_NE(e.find("broken.png"), std::string::npos) << e;
  EXPECT_NE(e.find("cannot read"), std::string::npos) << e;

  // Different image sizes for one camera.
  cv::Mat small = cv::imread((samples() / "left03.jpg").string());
  cv::imwrite((dir / "small.png").string(), small(cv::Rect(0, 0, 320, 240)));
  cmd.images = {samples() / "left01.jpg", dir / "small.png"};
  e = error_of([&] { run_intrinsics(cmd); });
  EXPECT_NE(e.find("small.png"), std::string::npos) << e;
  EXPECT_NE(e.find("same resolution"), std::string::npos) << e;

  // Too few views.
  cmd.images = {samples() / "left01.jpg", samples() / "left03.jpg"};
  e = error_of([&] { run_intrinsics(cmd); });
  EXPECT_NE(e.find("only 2 of 2"), std::string::npos) << e;

  // Board never seen: a 7x5 chessboard is not in these images.
  std::ofstream(dir / "wrong.toml") << "type = \"chessboard\"\nrows = 5\ncols = 7\nsquare_size_m = 0.025\n";
  cmd.board_file = dir / "wrong.toml";
  cmd.images = {samples() / "left01.jpg", samples() / "left03.jpg", samples() / "left04.jpg"};
  e = error_of([&] { run_intrinsics(cmd); });
  EXPECT_NE(e.find("not found in any of the 3 images"), std::string::npos) << e;

  for (const auto& f : {e}) EXPECT_EQ(f.find('\n'), std::string::npos);
  EXPECT_FALSE(fs::exists(cmd.out)) << "nothing written on failure";
  fs::remove_all(dir);
}
