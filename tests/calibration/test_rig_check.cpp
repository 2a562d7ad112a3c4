// Issue 15: a camera knocked out of place halfway through the extrinsics capture. SYNTHETIC
// detections (board corners projected through four known cameras, 0.2 px noise); the truth
// of what went wrong is how the test made it: camera 2's views from frame 20 on are shifted
// by 12 px. check_rig must blame that camera alone, find the move between frames 19 and 20,
// and flag the views on one side; an untouched rig blames no one. Also the bad-input lines of
// the calibration commands (a JPEG cut short, board-less views, a folder given as a file, a
// report folder holding other files).
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "kumite/calibration/commands.hpp"
#include "kumite/calibration/detect.hpp"
#include "kumite/calibration/intrinsics.hpp"
#include "kumite/calibration/rig.hpp"
#include "kumite/calibration/synthetic.hpp"
#include "kumite/common/error.hpp"

using namespace kumite::calibration;
namespace syn = kumite::calibration::synthetic;
namespace fs = std::filesystem;
using kumite::tracking::CameraCalibration;

namespace {

constexpr int kFrames = 40;

struct ProjectedRig {
  std::vector<CameraCalibration> cams;  // intrinsics only (R/t left to the solver)
  std::vector<std::vector<BoardDetection>> views;
  std::vector<std::string> frame_names;
};

ProjectedRig projected_rig(int frames = kFrames, double noise_px = 0.2) {
  Board board;
  board.rows = 5;
  board.cols = 7;
  board.tag_size_m = 0.09;
  board.gap_m = 0.02;
  std::vector<syn::Camera> truth;
  int i = 0;
  for (const auto& xz : {cv::Vec2d(-1.7, -1.7), cv::Vec2d(1.7, -1.7), cv::Vec2d(1.7, 1.7), cv::Vec2d(-1.7, 1.7)}) {
    truth.push_back(syn::look_at({xz[0], 2.5, xz[1]}, {0, 0.9, 0}, {0, 1, 0}, {1280, 720}, 1000 + 20 * i));
    ++i;
  }
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> ux(-0.8, 0.8), uy(0.7, 1.5), uyaw(0, 360), utilt(-30, 30), uaxis(0, 180);
  std::vector<syn::Pose> poses;
  for (int f = 0; f < frames; ++f) {
    const RigidPose face_up = floor_board_pose({0, 0, 0}, uyaw(rng));
    const double a = uaxis(rng) * CV_PI / 180;
    syn::Pose p;
    p.R = syn::rotation({std::cos(a), 0, std::sin(a)}, utilt(rng)) * face_up.R;
    const cv::Rect2d e = board.pattern_extent();
    p.t = cv::Vec3d(ux(rng), uy(rng), ux(rng)) - p.R * cv::Vec3d(e.x + e.width / 2, e.y + e.height / 2, 0);
    poses.push_back(p);
  }
  ProjectedRig r;
  r.views = syn::project_views(board, truth, poses, noise_px, 3);
  for (std::size_t c = 0; c < truth.size(); ++c) {
    CameraCalibration k;
    k.name = "cam" + std::to_string(c);
    k.image_width = truth[c].size.width;
    k.image_height = truth[c].size.height;
    k.camera_matrix = truth[c].K;
    k.distortion = truth[c].dist;
    r.cams.push_back(k);
  }
  for (int f = 0; f < frames; ++f) r.frame_names.push_back(fmt::format("{:06d}", f));
  return r;
}

struct Knock {
  int last_before = -1, first_after = -1, moved = 0;  ///< cam2's last view before, first after, views moved
};

/// cam2 knocked 12 px (8.4 px right, 8.6 px down) from view `from` on.
Knock knock_cam2(ProjectedRig& rig, int from) {
  Knock k;
  for (int f = 0; f < static_cast<int>(rig.views[2].size()); ++f) {
    auto& d = rig.views[2][static_cast<std::size_t>(f)];
    if (d.empty()) continue;
    if (f < from) {
      k.last_before = f;
      continue;
    }
    if (k.first_after < 0) k.first_after = f;
    ++k.moved;
    for (auto& p : d.image_points) p += cv::Point2f(8.4f, 8.6f);
  }
  return k;
}

}  // namespace

TEST(RigCheck, AnUntouchedRigBlamesNoCamera) {
  const ProjectedRig rig = projected_rig();
  const ExtrinsicsResult res = solve_extrinsics(rig.cams, rig.views);
  const RigCheck check = check_rig(res.cameras, rig.views);
  ASSERT_EQ(check.cameras.size(), 4U);
  EXPECT_LT(check.median_rms_px, 0.5);
  for (std::size_t c = 0; c < 4; ++c) {
    EXPECT_FALSE(check.cameras[c].blamed) << c;
    EXPECT_FALSE(check.cameras[c].moved_between.has_value()) << c;
    EXPECT_GE(check.cameras[c].views, 15) << c;
    EXPECT_EQ(describe_check(res.cameras[c].name, check.cameras[c], check, rig.frame_names), "");
  }
}

TEST(RigCheck, ACameraMovedHalfwayIsBlamedAloneWithTheFramesItMovedBetween) {
  ProjectedRig rig = projected_rig();
  // cam2 knocked 12 px (8.4 px right, 8.6 px down) from frame 20 on.
  constexpr int kMovedFrom = 20;
  const auto [last_before, first_after, moved] = knock_cam2(rig, kMovedFrom);
  ASSERT_GE(last_before, 0);
  ASSERT_GE(first_after, 0);
  const ExtrinsicsResult res = solve_extrinsics(rig.cams, rig.views);
  const RigCheck check = check_rig(res.cameras, rig.views);
  ASSERT_EQ(check.cameras.size(), 4U);
  for (std::size_t c = 0; c < 4; ++c) {
    std::printf("cam%zu: bundle RMS %.3f px, against the others %.3f px, blamed %d, jump %.2f px\n", c, res.rms_px[c],
                check.cameras[c].rms_all_px, static_cast<int>(check.cameras[c].blamed), check.cameras[c].jump_px);
  }
  for (std::size_t c : {0U, 1U, 3U}) {
    EXPECT_FALSE(check.cameras[c].blamed) << c;
    EXPECT_FALSE(check.cameras[c].moved_between.has_value()) << c;
  }
  const CameraCheck& k = check.cameras[2];
  EXPECT_TRUE(k.blamed);
  ASSERT_TRUE(k.moved_between.has_value());
  EXPECT_EQ(k.moved_between->first, last_before);
  EXPECT_EQ(k.moved_between->second, first_after);
  // 12 px made; measured after the adjustment, which spread part of it over the other
  // cameras' poses (10.9 px here).
  EXPECT_GT(k.jump_px, 8.0);
  EXPECT_LT(k.jump_px, 14.0);
  // The flagged views are exactly one side of the move.
  int flagged_before = 0, flagged_after = 0, seen_before = 0;
  for (int f = 0; f < kFrames; ++f) {
    if (!std::isfinite(k.rms_px[static_cast<std::size_t>(f)])) continue;
    if (f < kMovedFrom) ++seen_before;
    if (!k.flagged[static_cast<std::size_t>(f)]) continue;
    (f < kMovedFrom ? flagged_before : flagged_after)++;
  }
  EXPECT_TRUE((flagged_before == 0 && flagged_after == moved) || (flagged_after == 0 && flagged_before == seen_before))
      << flagged_before << " " << flagged_after;
  const std::string line = describe_check("cam2", k, check, rig.frame_names);
  EXPECT_NE(line.find(fmt::format("cam2 moved between views {:06d} and {:06d}", last_before, first_after)), std::string::npos)
      << line;
}

TEST(RigCheck, AMoveIsFoundInFewViewsWithIntrinsicsFromTheSameImages) {
  // 24 views, cam2 knocked 12 px from view 12 on, and (as `extrinsics` does by default) each
  // camera's intrinsics calibrated from its own views, the moved ones included: they absorb part
  // of the move. The audit of issue 15 (27 Nov) saw "no one camera to blame" in this set-up with
  // rendered views: the split explained 58 % of cam2's residual variance, under the 60 % then
  // asked (now 45 %). These projected views (cam2: 73 %) pass with either: a check of the
  // set-up, not of the threshold, whose evidence is the rendered rigs in rig_check.cpp.
  constexpr int kViews = 24, kMovedFrom = 12;
  ProjectedRig rig = projected_rig(kViews, 1.0);  // 1 px of corner noise (rendered views: ~0.2-2)
  const auto [last_before, first_after, moved] = knock_cam2(rig, kMovedFrom);
  (void)moved;
  for (std::size_t c = 0; c < rig.cams.size(); ++c) {
    const IntrinsicsResult in =
        calibrate_intrinsics(rig.views[c], cv::Size(rig.cams[c].image_width, rig.cams[c].image_height));
    rig.cams[c].camera_matrix = in.camera_matrix;
    rig.cams[c].distortion = in.distortion;
  }
  const ExtrinsicsResult res = solve_extrinsics(rig.cams, rig.views);
  const RigCheck check = check_rig(res.cameras, rig.views);
  for (std::size_t c = 0; c < 4; ++c)
    std::printf("cam%zu: against the others %.3f px, blamed %d, jump %.2f px, spread %.2f px, explains %.0f %%\n", c,
                check.cameras[c].rms_all_px, static_cast<int>(check.cameras[c].blamed), check.cameras[c].jump_px,
                check.cameras[c].spread_px, 100 * check.cameras[c].explained);
  for (std::size_t c : {0U, 1U, 3U}) EXPECT_FALSE(check.cameras[c].moved_between.has_value()) << c;
  const CameraCheck& k = check.cameras[2];
  EXPECT_TRUE(k.blamed);
  ASSERT_TRUE(k.moved_between.has_value());
  EXPECT_EQ(k.moved_between->first, last_before);
  EXPECT_EQ(k.moved_between->second, first_after);
}

// --- bad input -------------------------------------------------------------------------

namespace {
fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / fmt::format("kumite-cal-{}-{}", ::getpid(), name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
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

TEST(CalibrationInput, AJpegCutShortSaysSo) {
  const fs::path d = temp_dir("jpeg");
  cv::Mat img(120, 160, CV_8UC1);
  cv::randu(img, 0, 255);
  std::vector<unsigned char> bytes;
  ASSERT_TRUE(cv::imencode(".jpg", img, bytes));
  std::ofstream(d / "whole.jpg", std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()),
                                                         static_cast<std::streamsize>(bytes.size()));
  std::ofstream(d / "cut.jpg", std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()),
                                                       static_cast<std::streamsize>(bytes.size() / 2));
  EXPECT_EQ(read_image_grey(d / "whole.jpg").size(), img.size());
  const std::string e = error_of([&] { (void)read_image_grey(d / "cut.jpg"); });
  EXPECT_NE(e.find("cut.jpg"), std::string::npos) << e;
  EXPECT_NE(e.find("JPEG cut short"), std::string::npos) << e;
  fs::remove_all(d);
}

TEST(CalibrationInput, ExtrinsicsOnBoardlessViewsFailsAfterASampleNotAFullScan) {
  const fs::path d = temp_dir("noboard");
  cv::Mat img(240, 320, CV_8UC1);
  for (const char* cam : {"cam0", "cam1"}) {
    fs::create_directories(d / "views" / cam);
    for (int f = 0; f < 30; ++f) {
      cv::randu(img, 90, 140);
      ASSERT_TRUE(cv::imwrite((d / "views" / cam / fmt::format("{:06d}.png", f)).string(), img));
    }
  }
  std::ofstream(d / "board.toml") << "type = \"apriltag_grid\"\nfamily = \"tag36h11\"\nrows = 5\ncols = 7\n"
                                     "tag_size_m = 0.09\ngap_m = 0.02\nfirst_id = 100\n";
  ExtrinsicsCommand cmd;
  cmd.board_file = d / "board.toml";
  cmd.images_dir = d / "views";
  cmd.out = d / "rig.yaml";
  const std::string e = error_of([&] { run_extrinsics(cmd); });
  // 8 views sampled per camera, not 60 detections.
  EXPECT_NE(e.find("none of 16 views sampled across the 2 cameras"), std::string::npos) << e;
  EXPECT_NE(e.find("board.toml"), std::string::npos) << e;
  EXPECT_FALSE(fs::exists(cmd.out));
  // A folder given for the board file.
  const std::string f = error_of([&] { (void)read_board(d); });
  EXPECT_NE(f.find("is a folder, not a file"), std::string::npos) << f;
  fs::remove_all(d);
}

// fuzz_board's finding (seed regression-negative-zero.toml): "gap_m = -0.0" passed the range
// check and was written back as "gap_m = -0", which reads as 0: what the writer writes must
// read back to the same text. -0 is read as 0; non-finite numbers are refused by name.
TEST(CalibrationInput, BoardNumbersAreFiniteAndMinusZeroIsZero) {
  const std::string base = "type = \"apriltag_grid\"\nfamily = \"tag36h11\"\nrows = 5\ncols = 7\ntag_size_m = 0.09\n";
  const Board b = parse_board(base + "gap_m = -0.0\n", "b.toml");
  EXPECT_FALSE(std::signbit(b.gap_m));
  const std::string out = board_to_toml(b);
  EXPECT_EQ(board_to_toml(parse_board(out, "b2.toml")), out);
  EXPECT_EQ(out.find("-0"), std::string::npos) << out;
  const std::string e = error_of([&] { (void)parse_board(base + "gap_m = nan\n", "b.toml"); });
  EXPECT_NE(e.find("b.toml:6: gap_m: must be a finite number"), std::string::npos) << e;
}

TEST(RigCheck, AViewCaughtMidMoveWidensTheRangeAndIsFlagged) {
  // SYNTHETIC: cam2 knocked 12 px from frame 20 on, and the last view it saw before that caught
  // it half-way (6 px: the camera still moving). That view fits neither run: the move is said to
  // lie between the view before it and the first moved one, and it is flagged with the moved
  // run (the audit's 40-view rig: "between 16 and 17" for a camera moved at 20).
  ProjectedRig rig = projected_rig();
  constexpr int kMovedFrom = 20;
  const auto [last_before, first_after, moved] = knock_cam2(rig, kMovedFrom);
  ASSERT_GE(last_before, 1);
  int before_that = -1;
  for (int f = last_before - 1; f >= 0 && before_that < 0; --f)
    if (!rig.views[2][static_cast<std::size_t>(f)].empty()) before_that = f;
  ASSERT_GE(before_that, 0);
  for (auto& p : rig.views[2][static_cast<std::size_t>(last_before)].image_points) p += cv::Point2f(4.2f, 4.3f);
  const ExtrinsicsResult res = solve_extrinsics(rig.cams, rig.views);
  const RigCheck check = check_rig(res.cameras, rig.views);
  const CameraCheck& k = check.cameras[2];
  ASSERT_TRUE(k.moved_between.has_value());
  EXPECT_EQ(k.moved_between->first, before_that);
  EXPECT_EQ(k.moved_between->second, first_after);
  EXPECT_TRUE(k.flagged[static_cast<std::size_t>(last_before)]) << "the view caught mid-move is left out";
  const std::string line = describe_check("cam2", k, check, rig.frame_names);
  EXPECT_NE(line.find(fmt::format("cam2 moved between views {:06d} and {:06d}", before_that, first_after)), std::string::npos)
      << line;
}
