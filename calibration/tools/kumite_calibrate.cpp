// kumite-calibrate: from a printed board to the calibration file the tracker reads.
// Sub-commands: board, intrinsics, extrinsics, align, report, wand (see calibration/README.md).
// This file only parses arguments; the work is in kumite::calibration (commands.hpp).
#include <cstdio>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "kumite/calibration/commands.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/log.hpp"

namespace kc = kumite::calibration;

namespace {

/// Tag detection settings (apriltag's, named as its own apriltag_demo names them). Edge
/// refinement, unless given, follows --decimate (see fix_refine_edges).
struct DetectorArgs {
  kc::DetectorOptions* options;
  CLI::Option* refine_edges;
};
std::vector<DetectorArgs> g_detector_args;

void add_detector(CLI::App* s, kc::DetectorOptions& d) {
  s->add_option("--decimate", d.quad_decimate,
                "find tags on the image shrunk by this factor. Default 1 (full resolution): offline calibration "
                "puts accuracy first; small, far or steeply tilted tags (the ones that reach the image corners "
                "and show the lens distortion) are only found at full resolution. 2 is ~5x faster per image")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 4.0));
  s->add_option("--blur", d.quad_sigma,
                "Gaussian blur (px) of the image the tags are found on; keeps sensor noise from breaking tags "
                "apart (0 = none)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 3.0));
  auto* refine = s->add_option("--refine-edges", d.refine_edges,
                               "true/false: snap tag edges to the image gradients at full resolution. Default: on "
                               "only when --decimate > 1 (it recovers the resolution lost there; at full "
                               "resolution apriltag's own corners are more accurate: on the synthetic 4-camera "
                               "set, camera positions within 0.8 mm without it, 2 mm with it)");
  g_detector_args.push_back({&d, refine});
}

/// After parsing: edge refinement on exactly when tags are found on a decimated image, unless
/// the technician said otherwise.
void fix_refine_edges() {
  for (auto& a : g_detector_args) {
    if (a.refine_edges->count() == 0) a.options->refine_edges = a.options->quad_decimate > 1.f;
  }
}

void add_board(CLI::App& app, kc::BoardCommand& c, std::string& type) {
  auto* s = app.add_subcommand("board", "write a printable board: <out>.png (at --dpi), <out>.svg (exact size), <out>.toml");
  s->add_option("--type", type, "apriltag_grid or chessboard")->capture_default_str()->check(CLI::IsMember({"apriltag_grid", "chessboard"}));
  s->add_option("--rows", c.board.rows, "tags (grid) or inner corners (chessboard) down the board")->capture_default_str();
  s->add_option("--cols", c.board.cols, "tags or inner corners along a row")->capture_default_str();
  s->add_option("--tag-size", c.board.tag_size_m, "black square edge, m")->capture_default_str();
  s->add_option("--gap", c.board.gap_m, "white gap between tags, m")->capture_default_str();
  s->add_option("--first-id", c.board.first_id, "id of the top-left tag")->capture_default_str();
  s->add_option("--square-size", c.board.square_size_m, "chessboard square edge, m")->capture_default_str();
  s->add_option("--dpi", c.dpi, "PNG resolution")->capture_default_str();
  s->add_option("--margin", c.margin_m, "white margin around the pattern, m (default: the detector's quiet zone)");
  s->add_option("--out", c.out_prefix, "output prefix")->capture_default_str();
}

void add_intrinsics(CLI::App& app, kc::IntrinsicsCommand& c) {
  auto* s = app.add_subcommand("intrinsics", "calibrate one camera's intrinsics from board views");
  s->add_option("--board", c.board_file, "board.toml")->required();
  s->add_option("images", c.images, "board views of this camera")->required();
  s->add_option("--out", c.out, "calibration file to write (other cameras in it are kept)")->required();
  s->add_option("--name", c.name, "camera name (its folder name in recordings)")->capture_default_str();
  s->add_flag("--fix-aspect", c.fix_aspect_ratio, "force fx = fy");
  s->add_option("--outlier-factor", c.outlier_factor, "reject views above this x the median view error")->capture_default_str();
  add_detector(s, c.detector);
}

void add_extrinsics(CLI::App& app, kc::ExtrinsicsCommand& c) {
  auto* s = app.add_subcommand("extrinsics", "camera poses from board views seen by several cameras at once");
  s->add_option("--board", c.board_file, "board.toml")->required();
  s->add_option("--images", c.images_dir, "DIR/<camera>/<frame>.png")->required();
  s->add_option("--out", c.out, "calibration file to write")->required();
  s->add_option("--intrinsics", c.intrinsics, "calibration file with each camera's intrinsics (default: calibrate them from these images)");
  s->add_flag("--refine-intrinsics", c.refine_intrinsics, "let the bundle adjustment refine the intrinsics given with --intrinsics too (always done when they are calibrated from these images)");
  s->add_option("--huber", c.huber_px, "robust loss scale, px")->capture_default_str();
  add_detector(s, c.detector);
}

void add_align(CLI::App& app, kc::AlignCommand& c, std::vector<double>& origin) {
  auto* s = app.add_subcommand("align", "fix the room frame from a board on the floor (or three marked floor points)");
  s->add_option("--calibration", c.calibration, "calibration file to align")->required();
  s->add_option("--out", c.out, "write here instead of replacing --calibration");
  s->add_option("--board", c.board_file, "board.toml of the floor board");
  s->add_option("--images", c.images_dir, "DIR/<camera>/<image>: the floor board seen by the cameras");
  s->add_option("--origin", origin, "room position x y z (m) of the board origin (its top-left tag corner)")->expected(3);
  s->add_option("--yaw", c.board_yaw_deg, "board rotation about room +Y, degrees (0: board +X = room +X, top edge toward the front wall)")->capture_default_str();
  s->add_option("--points", c.points_file, "alternative: TOML with three floor points (room x y z and pixels per camera)");
  add_detector(s, c.detector);
}

void add_report(CLI::App& app, kc::ReportCommand& c) {
  auto* s = app.add_subcommand("report", "JSON + PNG report: RMS, per-view errors, coverage, top view of the rig");
  s->add_option("--calibration", c.calibration, "calibration file")->required();
  s->add_option("--board", c.board_file, "board.toml")->required();
  s->add_option("--images", c.images_dir, "DIR/<camera>/<frame>.png used for the calibration")->required();
  s->add_option("--out", c.out_dir, "report folder")->capture_default_str();
  s->add_option("--area-width", c.area_width_m, "tracked area along x, m")->capture_default_str();
  s->add_option("--area-depth", c.area_depth_m, "tracked area along z, m")->capture_default_str();
  add_detector(s, c.detector);
}

void add_wand(CLI::App& app, kc::WandCommand& c) {
  auto* s = app.add_subcommand("wand", "check a calibration with a two-marker wand waved through the volume");
  s->add_option("--calibration", c.calibration, "calibration file")->required();
  s->add_option("--recording", c.recording_dir, "recording folder: frames.csv, <camera>/<frame>.png")->required();
  s->add_option("--length", c.wand_length_m, "distance between the wand's markers, m")->required();
  s->add_option("--threshold", c.blob_threshold, "blob threshold, grey level")->capture_default_str();
  s->add_option("--json", c.out_json, "write the figures as JSON here");
  s->add_option("--refine", c.refine_out, "refine the camera poses with the wand and write the calibration here");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"kumite-calibrate: camera calibration for the Kumite installation"};
  app.require_subcommand(1);
  int verbosity = 1;
  app.add_option("-v,--verbosity", verbosity, "0 warnings, 1 info, 2 debug")->capture_default_str();
  kc::BoardCommand board;
  board.board.tag_size_m = 0.035;  // 6 x 8 tags of 35 mm + 10 mm gaps: 370 x 280 mm, fits A3 landscape
  board.board.gap_m = 0.01;
  std::string board_type = "apriltag_grid";
  kc::IntrinsicsCommand intrinsics;
  kc::ExtrinsicsCommand extrinsics;
  kc::AlignCommand align;
  std::vector<double> origin;
  kc::ReportCommand report;
  kc::WandCommand wand;
  add_board(app, board, board_type);
  add_intrinsics(app, intrinsics);
  add_extrinsics(app, extrinsics);
  add_align(app, align, origin);
  add_report(app, report);
  add_wand(app, wand);
  CLI11_PARSE(app, argc, argv);
  fix_refine_edges();
  kumite::init_logging(verbosity);
  try {
    if (app.got_subcommand("board")) {
      board.board.type = board_type == "chessboard" ? kc::BoardType::chessboard : kc::BoardType::apriltag_grid;
      kc::run_board(board);
    } else if (app.got_subcommand("intrinsics")) {
      kc::run_intrinsics(intrinsics);
    } else if (app.got_subcommand("extrinsics")) {
      kc::run_extrinsics(extrinsics);
    } else if (app.got_subcommand("align")) {
      if (origin.size() == 3) align.board_origin_room = {origin[0], origin[1], origin[2]};
      kc::run_align(align);
    } else if (app.got_subcommand("report")) {
      kc::run_report(report);
    } else if (app.got_subcommand("wand")) {
      kc::run_wand(wand);
    }
  } catch (const kumite::Error& e) {
    std::fprintf(stderr, "kumite-calibrate: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kumite-calibrate: unexpected error: %s\n", e.what());
    return 1;
  }
  return 0;
}
