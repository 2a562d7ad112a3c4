// align: room frame from a (SYNTHETIC) floor board image per camera, or three floor points.
#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "kumite/calibration/commands.hpp"
#include "kumite/calibration/rig.hpp"
#include "kumite/calibration/synthetic.hpp"
#include "kumite/common/error.hpp"
#include "kumite/tracking/calibration_file.hpp"

namespace fs = std::filesystem;
using namespace kumite::calibration;
namespace syn = kumite::calibration::synthetic;

namespace {

double angle_deg(const cv::Matx33d& a, const cv::Matx33d& b) {
  const double c = std::clamp((cv::trace(a * b.t()) - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c) * 180.0 / CV_PI;
}

struct AlignSetup {
  fs::path dir;
  std::vector<syn::Camera> truth;  // in the room
};

/// Three cameras in the room; a calibration file in cam0's frame (as extrinsics writes it).
AlignSetup make_setup(const std::string& tag) {
  AlignSetup s;
  s.dir = fs::temp_directory_path() / fmt::format("kumite_align_{}_{}", tag, ::getpid());
  fs::remove_all(s.dir);
  fs::create_directories(s.dir);
  const cv::Size size(1280, 720);
  s.truth.push_back(syn::look_at({-1.5, 2.4, -1.5}, {0, 0, 0}, {0, 1, 0}, size, 1000));
  s.truth.push_back(syn::look_at({1.5, 2.4, -1.5}, {0, 0, 0}, {0, 1, 0}, size, 1000));
  s.truth.push_back(syn::look_at({0.2, 2.6, 1.6}, {0, 0, 0}, {0, 1, 0}, size, 1000));
  const RigidPose cam0{s.truth[0].R, s.truth[0].t};
  kumite::tracking::RigCalibration rig;
  for (std::size_t c = 0; c < s.truth.size(); ++c) {
    kumite::tracking::CameraCalibration k;
    k.name = fmt::format("cam{}", c);
    k.image_width = size.width;
    k.image_height = size.height;
    k.camera_matrix = s.truth[c].K;
    const RigidPose rel = RigidPose{s.truth[c].R, s.truth[c].t} * cam0.inverse();
    k.rotation = rel.R;
    k.translation = rel.t;
    rig.cameras.push_back(k);
  }
  kumite::tracking::write_calibration(s.dir / "rig.yaml", rig);
  return s;
}

void expect_in_room(const AlignSetup& s, const fs::path& file, double mm, double deg) {
  const auto rig = kumite::tracking::read_calibration(file);
  for (std::size_t c = 0; c < s.truth.size(); ++c) {
    const double e_mm = cv::norm(rig.cameras[c].position() - s.truth[c].position()) * 1000;
    const double e_deg = angle_deg(rig.cameras[c].rotation, s.truth[c].R);
    std::printf("cam%zu aligned: %.3f mm, %.4f deg\n", c, e_mm, e_deg);
    EXPECT_LT(e_mm, mm) << c;
    EXPECT_LT(e_deg, deg) << c;
  }
}

}  // namespace

TEST(Align, FloorBoardFixesTheRoomFrame) {
  const AlignSetup s = make_setup("board");
  Board b;
  b.rows = 5;
  b.cols = 7;
  b.tag_size_m = 0.09;
  b.gap_m = 0.02;
  std::ofstream(s.dir / "board.toml") << board_to_toml(b);
  const RigidPose floor = floor_board_pose({0.4, 0.0, -0.3}, -20.0);
  const BoardPattern pattern(b);
  for (std::size_t c = 0; c < s.truth.size(); ++c) {
    fs::create_directories(s.dir / "floor" / fmt::format("cam{}", c));
    syn::RenderOptions ro;
    ro.seed = 40 + c;
    cv::imwrite((s.dir / "floor" / fmt::format("cam{}", c) / "000000.png").string(),
                syn::render_view(pattern, b, s.truth[c], {floor.R, floor.t}, ro));
  }
  AlignCommand cmd;
  cmd.calibration = s.dir / "rig.yaml";
  cmd.board_file = s.dir / "board.toml";
  cmd.images_dir = s.dir / "floor";
  cmd.board_origin_room = {0.4, 0.0, -0.3};
  cmd.board_yaw_deg = -20.0;
  run_align(cmd);
  expect_in_room(s, cmd.calibration, 3.0, 0.2);
  // The cam0-frame file was kept.
  int backups = 0;
  for (const auto& e : fs::directory_iterator(s.dir)) backups += e.path().extension() == ".bak";
  EXPECT_EQ(backups, 1);
  fs::remove_all(s.dir);
}

TEST(Align, ThreeFloorPoints) {
  const AlignSetup s = make_setup("points");
  // Marks on the floor; their pixels from the true cameras plus 0.2 px of clicking error.
  const std::vector<cv::Vec3d> marks{{-1.0, 0, -1.0}, {1.0, 0, -1.0}, {0.0, 0, 1.0}, {0.5, 0, 0.2}};
  std::string toml;
  cv::RNG rng(5);
  for (const auto& m : marks) {
    toml += fmt::format("[[points]]\nroom = [{}, {}, {}]\npixels = {{ ", m[0], m[1], m[2]);
    for (std::size_t c = 0; c < s.truth.size(); ++c) {
      const cv::Point2d p = syn::project(s.truth[c], m);
      toml += fmt::format("{}cam{} = [{:.3f}, {:.3f}]", c ? ", " : "", c, p.x + rng.gaussian(0.2), p.y + rng.gaussian(0.2));
    }
    toml += " }\n";
  }
  std::ofstream(s.dir / "points.toml") << toml;
  AlignCommand cmd;
  cmd.calibration = s.dir / "rig.yaml";
  cmd.points_file = s.dir / "points.toml";
  cmd.out = s.dir / "room.yaml";
  run_align(cmd);
  expect_in_room(s, *cmd.out, 3.0, 0.2);
  fs::remove_all(s.dir);
}

TEST(Align, PointsFileErrorsNameTheLine) {
  const fs::path f = fs::temp_directory_path() / fmt::format("kumite_points_{}.toml", ::getpid());
  std::ofstream(f) << "[[points]]\nroom = [0, 0]\npixels = { cam0 = [1, 2], cam1 = [3, 4] }\n";
  try {
    read_floor_points(f);
    FAIL();
  } catch (const kumite::Error& e) {
    EXPECT_NE(std::string(e.what()).find(":2: points[0].room: must be [x, y, z]"), std::string::npos) << e.what();
  }
  // Every number is checked finite (nan used to be read as a floor point at nan).
  std::ofstream(f) << "[[points]]\nroom = [0, 0, 0]\npixels = { cam0 = [1, 2], cam1 = [nan, 4] }\n";
  try {
    read_floor_points(f);
    FAIL();
  } catch (const kumite::Error& e) {
    EXPECT_NE(std::string(e.what()).find(":3: points[0].pixels.cam1: must be a finite number"), std::string::npos) << e.what();
  }
  fs::remove(f);
}
