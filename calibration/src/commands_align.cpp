// align sub-command: fix the room frame (metres, +Y up, floor y = 0, front wall toward -Z).
#include <cmath>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "kumite/calibration/commands.hpp"
#include "kumite/calibration/rig.hpp"
#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/tracking/calibration_file.hpp"

namespace kumite::calibration {
namespace {

RigidPose room_from_floor_board(const AlignCommand& cmd, const tracking::RigCalibration& rig) {
  if (cmd.board_file.empty() || cmd.images_dir.empty()) {
    throw Error("calibration", "args", "align needs --board and --images (the board on the floor), or --points");
  }
  const Board board = read_board(cmd.board_file);
  const RigImages images = scan_rig_images(cmd.images_dir);
  std::vector<BoardDetection> views(rig.cameras.size());
  const DetectorOptions& det = cmd.detector;
  BoardDetector detector(board, det);
  int seen = 0;
  for (std::size_t c = 0; c < images.cameras.size(); ++c) {
    int idx = -1;
    for (std::size_t i = 0; i < rig.cameras.size(); ++i) {
      if (rig.cameras[i].name == images.cameras[c]) idx = static_cast<int>(i);
    }
    if (idx < 0) {
      spdlog::warn("{}: no camera of that name in {}; ignored", (cmd.images_dir / images.cameras[c]).string(),
                   cmd.calibration.string());
      continue;
    }
    // The first image of each camera (one picture of the floor board is enough).
    for (const auto& p : images.paths[c]) {
      if (p.empty()) continue;
      views[static_cast<std::size_t>(idx)] = detector.detect(read_image_grey(p));
      spdlog::info("{}: {} board corners in {}", images.cameras[c], views[static_cast<std::size_t>(idx)].size(),
                   p.filename().string());
      seen += !views[static_cast<std::size_t>(idx)].empty();
      break;
    }
  }
  if (seen == 0) {
    throw Error("calibration", "not_seen",
                fmt::format("no camera sees the floor board in {}: lay it flat where several cameras see it whole and "
                            "take one picture per camera",
                            cmd.images_dir.string()));
  }
  const RigidPose board_in_rig = board_pose_in_rig(rig.cameras, views);
  // Say where the board is taken to be: a forgotten --origin/--yaw silently means (0, 0, 0), 0.
  spdlog::info("floor board origin (its top-left tag corner) taken at room x {:.3f} y {:.3f} z {:.3f} m, yaw {:.1f} deg "
               "(--origin, --yaw)",
               cmd.board_origin_room[0], cmd.board_origin_room[1], cmd.board_origin_room[2], cmd.board_yaw_deg);
  return floor_board_pose(cmd.board_origin_room, cmd.board_yaw_deg) * board_in_rig.inverse();
}

RigidPose room_from_points(const fs::path& file, const tracking::RigCalibration& rig) {
  const auto points = read_floor_points(file);
  std::vector<cv::Vec3d> in_rig, in_room;
  for (const auto& p : points) {
    std::vector<std::pair<int, cv::Point2d>> px;
    for (const auto& [name, uv] : p.pixels) {
      int idx = -1;
      for (std::size_t i = 0; i < rig.cameras.size(); ++i) {
        if (rig.cameras[i].name == name) idx = static_cast<int>(i);
      }
      if (idx < 0) throw file_error("calibration", "points", file.string(), p.line, name, "no camera of that name in the calibration");
      px.emplace_back(idx, uv);
    }
    in_rig.push_back(triangulate(rig.cameras, px));
    in_room.push_back(p.room);
  }
  const RigidPose fit = fit_rigid(in_rig, in_room);
  for (std::size_t i = 0; i < in_rig.size(); ++i) {
    const double e = cv::norm(fit.R * in_rig[i] + fit.t - in_room[i]);
    spdlog::info("floor point {} (line {}): residual {:.1f} mm", i, points[i].line, e * 1000);
  }
  return fit;
}

}  // namespace

void run_align(const AlignCommand& cmd) {
  tracking::RigCalibration rig = tracking::read_calibration(cmd.calibration);
  const RigidPose room_from_rig = cmd.points_file ? room_from_points(*cmd.points_file, rig) : room_from_floor_board(cmd, rig);
  apply_room_frame(rig.cameras, room_from_rig);
  for (const auto& c : rig.cameras) {
    const cv::Vec3d p = c.position();
    spdlog::info("{}: at x {:.3f} y {:.3f} z {:.3f} m in the room", c.name, p[0], p[1], p[2]);
    if (p[1] <= 0) {
      spdlog::warn("{} is below the floor (y = {:.3f} m): is the board face down, or --origin/--yaw wrong?", c.name, p[1]);
    }
  }
  const fs::path out = cmd.out.value_or(cmd.calibration);
  const fs::path backup = keep_previous_version(out);
  if (!backup.empty()) spdlog::info("kept the previous calibration as {}", backup.string());
  tracking::write_calibration(out, rig);
  spdlog::info("wrote {} in the room frame (metres, +Y up, floor y = 0, front wall toward -Z)", out.string());
}

}  // namespace kumite::calibration
