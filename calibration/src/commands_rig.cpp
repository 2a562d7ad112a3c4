// extrinsics sub-command: several cameras, one board, a pose graph and a bundle adjustment.
#include <cmath>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "kumite/calibration/commands.hpp"
#include "kumite/calibration/intrinsics.hpp"
#include "kumite/calibration/rig.hpp"
#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/tracking/calibration_file.hpp"

namespace kumite::calibration {

/// Detections [camera][frame] of a recording-style folder (all images of one camera must
/// have one size).
std::vector<CameraViews> detect_rig(const Board& board, const RigImages& rig, const DetectorOptions& det) {
  std::vector<CameraViews> out;
  for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
    std::vector<fs::path> present;
    for (const auto& p : rig.paths[c]) {
      if (!p.empty()) present.push_back(p);
    }
    CameraViews v = detect_views(board, present, rig.cameras[c], det);
    // Back onto the common frame list (missing frames stay empty).
    CameraViews full;
    full.image_size = v.image_size;
    std::size_t k = 0;
    for (const auto& p : rig.paths[c]) {
      full.images.push_back(p);
      full.detections.push_back(p.empty() ? BoardDetection{} : v.detections[k++]);
    }
    out.push_back(std::move(full));
  }
  return out;
}

namespace {
/// Before the full scan (~60 ms a view per camera: a minute for a few hundred views): a few
/// views of each camera, spread over the capture. When none of them shows the board, the
/// board file or the folder is wrong: say so at once instead of after the whole scan.
void check_board_is_seen(const Board& board, const fs::path& board_file, const RigImages& rig,
                         const DetectorOptions& det) {
  constexpr std::size_t kPerCamera = 8;
  BoardDetector detector(board, det);
  std::size_t tried = 0;
  for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
    std::vector<fs::path> present;
    for (const auto& p : rig.paths[c]) {
      if (!p.empty()) present.push_back(p);
    }
    const std::size_t n = std::min(kPerCamera, present.size());
    for (std::size_t k = 0; k < n; ++k) {
      const fs::path& p = present[k * present.size() / n];
      ++tried;
      if (!detector.detect(read_image_grey(p)).empty()) return;
    }
  }
  throw file_error("calibration", "not_seen", board_file.string(), 0, "",
                   fmt::format("this board is in none of {} views sampled across the {} cameras (up to {} each, spread "
                               "over the capture): check that the board file describes the printed board (type, family, "
                               "rows, cols, first_id) and that the images show it",
                               tried, rig.cameras.size(), kPerCamera));
}
}  // namespace

void run_extrinsics(const ExtrinsicsCommand& cmd) {
  const Board board = read_board(cmd.board_file);
  const RigImages images = scan_rig_images(cmd.images_dir);
  const DetectorOptions& det = cmd.detector;
  check_board_is_seen(board, cmd.board_file, images, det);
  const std::vector<CameraViews> views = detect_rig(board, images, det);

  std::vector<tracking::CameraCalibration> cams;
  std::optional<tracking::RigCalibration> given;
  if (cmd.intrinsics) given = tracking::read_calibration(*cmd.intrinsics);
  for (std::size_t c = 0; c < images.cameras.size(); ++c) {
    const std::string& name = images.cameras[c];
    tracking::CameraCalibration cam;
    if (given) {
      const auto* found = given->find(name);
      if (!found) {
        throw file_error("calibration", "missing_camera", cmd.intrinsics->string(), 0, name,
                         fmt::format("no camera called {} (the folder {}): run `intrinsics --name {}` first or leave "
                                     "out --intrinsics",
                                     name, (cmd.images_dir / name).string(), name));
      }
      cam = *found;
      if (cam.image_width != views[c].image_size.width || cam.image_height != views[c].image_size.height) {
        throw file_error("calibration", "image_size", cmd.intrinsics->string(), 0, name,
                         fmt::format("calibrated for {}x{} px but the images are {}x{} px: recalibrate its intrinsics",
                                     cam.image_width, cam.image_height, views[c].image_size.width,
                                     views[c].image_size.height));
      }
    } else {
      spdlog::info("{}: calibrating intrinsics from its {} images", name, views[c].images.size());
      std::vector<BoardDetection> dets;
      for (const auto& d : views[c].detections) dets.push_back(d);
      IntrinsicsResult r;
      try {
        r = calibrate_intrinsics(dets, views[c].image_size);
      } catch (const Error& e) {
        throw Error("calibration", e.code(), fmt::format("camera {}: {}", name, e.what()));
      }
      cam.name = name;
      cam.image_width = views[c].image_size.width;
      cam.image_height = views[c].image_size.height;
      cam.camera_matrix = r.camera_matrix;
      cam.distortion = r.distortion;
      spdlog::info("{}: fx {:.2f} fy {:.2f} cx {:.2f} cy {:.2f}, RMS {:.3f} px", name, r.camera_matrix(0, 0),
                   r.camera_matrix(1, 1), r.camera_matrix(0, 2), r.camera_matrix(1, 2), r.rms_px);
    }
    cam.name = name;
    cams.push_back(cam);
  }
  std::vector<std::vector<BoardDetection>> dets;
  for (const auto& v : views) dets.push_back(v.detections);
  ExtrinsicsOptions opt;
  // Intrinsics calibrated here from these same views are refined jointly with the poses: on
  // the synthetic 4-camera set that takes the camera positions from ~5 mm to ~2 mm.
  opt.refine_intrinsics = cmd.refine_intrinsics || !given;
  if (opt.refine_intrinsics) spdlog::info("the bundle adjustment refines the intrinsics too");
  opt.huber_px = cmd.huber_px;
  opt.progress = [](const std::string& s) { spdlog::info("{}", s); };
  const ExtrinsicsResult r = solve_extrinsics(cams, dets, opt);

  // Tens of pixels after the adjustment is not a rig to write: the board file does not
  // describe the print (tags found by id, but at the wrong size or spacing).
  constexpr double kImplausibleRmsPx = 20.0;
  if (!(r.rms_px_all <= kImplausibleRmsPx)) {
    throw file_error("calibration", "rms", cmd.board_file.string(), 0, "",
                     fmt::format("the adjustment ends at RMS {:.1f} px over all cameras: the board file does not describe "
                                 "the printed board (type, rows, cols, tag_size_m, gap_m, first_id)? nothing written",
                                 r.rms_px_all));
  }
  // Each camera against the board as the others see it: a camera that moved during the
  // capture (or whose views disagree with the rest) is named, at warning level.
  const RigCheck check = check_rig(r.cameras, dets);
  std::vector<std::string> blamed;
  for (std::size_t c = 0; c < r.cameras.size(); ++c) {
    const cv::Vec3d p = r.cameras[c].position();
    const cv::Vec3d p0 = r.cameras[0].position();
    const std::string line = fmt::format("{}: position ({:.4f}, {:.4f}, {:.4f}) m in {}'s frame, {:.4f} m from {}; RMS {:.3f} px",
                                         r.cameras[c].name, p[0], p[1], p[2], r.cameras[0].name, cv::norm(p - p0),
                                         r.cameras[0].name, r.rms_px[c]);
    if (c < check.cameras.size()) {
      const CameraCheck& k = check.cameras[c];
      spdlog::debug("{}: against the other cameras' board {:.3f} px over {} views; best split: jump {:.2f} px, spread "
                    "{:.2f} px, explains {:.0f} %",
                    r.cameras[c].name, k.rms_all_px, k.views, k.jump_px, k.spread_px, 100 * k.explained);
    }
    if (c < check.cameras.size() && check.cameras[c].blamed) {
      spdlog::warn("{}: {}", line, describe_check(r.cameras[c].name, check.cameras[c], check, images.frames));
      blamed.push_back(r.cameras[c].name);
    } else {
      spdlog::info("{}", line);
    }
  }
  if (!blamed.empty()) {
    spdlog::warn("{} disagree(s) with the rest of the rig (RMS {:.2f} px over all cameras): check that it is fixed, "
                 "then capture its views again or leave out the flagged ones; `report` shows which",
                 fmt::join(blamed, ", "), r.rms_px_all);
  } else if (r.rms_px_all > kBlameFloorPx) {
    spdlog::warn("RMS {:.2f} px over all cameras, no one camera to blame: check focus, motion blur, that the board "
                 "is flat and that the cameras capture at the same moments",
                 r.rms_px_all);
  }
  tracking::RigCalibration out;
  out.cameras = r.cameras;
  const fs::path backup = keep_previous_version(cmd.out);
  if (!backup.empty()) spdlog::info("kept the previous calibration as {}", backup.string());
  tracking::write_calibration(cmd.out, out);
  spdlog::info("wrote {}: rig frame = {}'s camera frame; run `align` to fix the room frame", cmd.out.string(),
               r.cameras[0].name);
}

}  // namespace kumite::calibration
