// board and intrinsics sub-commands, and the image helpers every sub-command shares.
#include "kumite/calibration/commands.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

#include "kumite/calibration/intrinsics.hpp"
#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/tracking/calibration_file.hpp"

namespace kumite::calibration {

namespace {

bool is_image(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return e == ".png" || e == ".jpg" || e == ".jpeg" || e == ".bmp" || e == ".tif" || e == ".tiff" || e == ".pgm";
}

}  // namespace

void write_png_atomically(const fs::path& path, const cv::Mat& img) {
  std::vector<unsigned char> buf;
  if (!cv::imencode(".png", img, buf)) throw Error("calibration", "io", fmt::format("{}: cannot encode PNG", path.string()));
  write_file_atomically(path, std::string_view(reinterpret_cast<const char*>(buf.data()), buf.size()));
}

CameraViews detect_views(const Board& board, const std::vector<fs::path>& images, const std::string& camera,
                         const DetectorOptions& detector_options) {
  CameraViews out;
  BoardDetector detector(board, detector_options);
  std::size_t found = 0;
  for (std::size_t i = 0; i < images.size(); ++i) {
    const cv::Mat grey = read_image_grey(images[i]);
    if (i == 0) {
      out.image_size = grey.size();
    } else if (grey.size() != out.image_size) {
      throw file_error("calibration", "image_size", images[i].string(), 0, "",
                       fmt::format("{}x{} px, but {} is {}x{} px: all images of camera {} must come from the same "
                                   "camera at the same resolution",
                                   grey.cols, grey.rows, images[0].string(), out.image_size.width,
                                   out.image_size.height, camera));
    }
    out.images.push_back(images[i]);
    out.detections.push_back(detector.detect(grey));
    if (!out.detections.back().empty()) ++found;
    if ((i + 1) % 10 == 0 || i + 1 == images.size()) {
      if (i + 1 < images.size()) {
        spdlog::info("{}: {} of {} images read, board found in {} so far", camera, i + 1, images.size(), found);
      } else {
        spdlog::info("{}: board found in {} of {} images", camera, found, images.size());
      }
    }
  }
  return out;
}

RigImages scan_rig_images(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw file_error("calibration", "missing", dir.string(), 0, "",
                     "not a folder: expected DIR/<camera>/<frame>.png (e.g. DIR/cam0/000000.png)");
  }
  RigImages rig;
  std::map<std::string, std::map<std::string, fs::path>> files;
  std::set<std::string> frames;
  for (const auto& cam : fs::directory_iterator(dir)) {
    if (!cam.is_directory()) continue;
    for (const auto& f : fs::directory_iterator(cam.path())) {
      if (!f.is_regular_file() || !is_image(f.path())) continue;
      files[cam.path().filename().string()][f.path().stem().string()] = f.path();
      frames.insert(f.path().stem().string());
    }
  }
  if (files.empty()) {
    throw file_error("calibration", "no_images", dir.string(), 0, "",
                     "no camera folders with images: expected DIR/<camera>/<frame>.png (e.g. DIR/cam0/000000.png)");
  }
  rig.frames.assign(frames.begin(), frames.end());
  for (const auto& [cam, fr] : files) {
    rig.cameras.push_back(cam);
    std::vector<fs::path> row;
    for (const auto& f : rig.frames) {
      const auto it = fr.find(f);
      row.push_back(it == fr.end() ? fs::path() : it->second);
    }
    rig.paths.push_back(std::move(row));
  }
  return rig;
}

void run_board(const BoardCommand& cmd) {
  validate(cmd.board);
  if (!(cmd.dpi >= 30 && cmd.dpi <= 2400)) throw Error("calibration", "args", "--dpi must be between 30 and 2400");
  const double margin = cmd.margin_m.value_or(cmd.board.default_margin_m());
  const double px_per_m = cmd.dpi / 0.0254;
  const cv::Mat img = render_board(cmd.board, px_per_m, margin);
  fs::path png = cmd.out_prefix, svg = cmd.out_prefix, toml = cmd.out_prefix;
  png += ".png";
  svg += ".svg";
  toml += ".toml";
  write_png_atomically(png, img);
  write_file_atomically(svg, board_svg(cmd.board, margin));
  write_file_atomically(toml, board_to_toml(cmd.board));
  const cv::Rect2d ext = cmd.board.pattern_extent();
  spdlog::info("wrote {} ({}x{} px at {} DPI), {} ({:.1f} x {:.1f} mm with margins; print at 100 %) and {}",
               png.string(), img.cols, img.rows, cmd.dpi, svg.string(), (ext.width + 2 * margin) * 1000,
               (ext.height + 2 * margin) * 1000, toml.string());
}

void run_intrinsics(const IntrinsicsCommand& cmd) {
  const Board board = read_board(cmd.board_file);
  if (cmd.images.empty()) throw Error("calibration", "args", "no images given: pass the board views of this camera");
  if (cmd.name.empty()) throw Error("calibration", "args", "--name must not be empty");
  const DetectorOptions& det = cmd.detector;
  const CameraViews views = detect_views(board, cmd.images, cmd.name, det);
  IntrinsicsOptions opt;
  opt.outlier_factor = cmd.outlier_factor;
  opt.fix_aspect_ratio = cmd.fix_aspect_ratio;
  const IntrinsicsResult r = calibrate_intrinsics(views.detections, views.image_size, opt);

  for (int i : r.not_detected) spdlog::warn("{}: board not found (not used)", views.images[static_cast<std::size_t>(i)].string());
  for (int i : r.rejected) {
    spdlog::warn("{}: rejected as an outlier ({:.3f} px > {} x the median view error): blurred, moved or mis-detected; "
                 "retake it",
                 views.images[static_cast<std::size_t>(i)].string(), r.per_view_errors_px[static_cast<std::size_t>(i)],
                 cmd.outlier_factor);
  }
  if (r.worst_view >= 0) {
    spdlog::info("worst view: {} ({:.3f} px)", views.images[static_cast<std::size_t>(r.worst_view)].filename().string(),
                 r.per_view_errors_px[static_cast<std::size_t>(r.worst_view)]);
  }
  spdlog::info("{}: fx {:.2f} fy {:.2f} cx {:.2f} cy {:.2f} px, k1 {:.4f} k2 {:.4f} p1 {:.5f} p2 {:.5f} k3 {:.4f}; "
               "RMS {:.3f} px over {} views",
               cmd.name, r.camera_matrix(0, 0), r.camera_matrix(1, 1), r.camera_matrix(0, 2), r.camera_matrix(1, 2),
               r.distortion[0], r.distortion[1], r.distortion[2], r.distortion[3], r.distortion[4], r.rms_px,
               std::count(r.used.begin(), r.used.end(), true));

  tracking::RigCalibration rig;
  std::error_code ec;
  if (fs::exists(cmd.out, ec)) rig = tracking::read_calibration(cmd.out);  // keep the other cameras
  tracking::CameraCalibration* cam = nullptr;
  for (auto& c : rig.cameras) {
    if (c.name == cmd.name) cam = &c;
  }
  if (!cam) {
    rig.cameras.emplace_back();
    cam = &rig.cameras.back();
    cam->name = cmd.name;
  } else {
    spdlog::warn("{}: replacing its intrinsics in {}; re-run extrinsics, its pose was measured with the old ones",
                 cmd.name, cmd.out.string());
  }
  cam->image_width = views.image_size.width;
  cam->image_height = views.image_size.height;
  cam->camera_matrix = r.camera_matrix;
  cam->distortion = r.distortion;
  cam->rms_px = r.rms_px;
  cam->per_view_errors_px.clear();
  for (double e : r.per_view_errors_px) cam->per_view_errors_px.push_back(std::isfinite(e) ? e : -1.0);
  const fs::path backup = keep_previous_version(cmd.out);
  if (!backup.empty()) spdlog::info("kept the previous calibration as {}", backup.string());
  tracking::write_calibration(cmd.out, rig);
  spdlog::info("wrote {} (per-view errors in input order; -1 = board not found)", cmd.out.string());
}

}  // namespace kumite::calibration
