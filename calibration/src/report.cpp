// report sub-command: what a technician reads (the one nlohmann/json translation unit).
// Per camera: RMS, per-view errors (bar chart), a coverage heat map of where board corners
// fell in the image; for the rig: a top view (cameras, frusta, tracked area, walls).
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "kumite/calibration/commands.hpp"
#include "kumite/calibration/intrinsics.hpp"
#include "kumite/calibration/rig.hpp"
#include "kumite/calibration/wand.hpp"
#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/tracking/calibration_file.hpp"

namespace kumite::calibration {
namespace {

using nlohmann::json;

constexpr int kHeatCells = 16;           // heat-map cells along the image width
constexpr double kGoodRmsPx = 0.5;       // px: above this a camera needs attention
constexpr double kGoodCoverage = 0.6;    // fraction of heat-map cells with a corner

void text(cv::Mat& img, const std::string& s, cv::Point at, double scale = 0.5, cv::Scalar colour = {255, 255, 255}) {
  cv::putText(img, s, at, cv::FONT_HERSHEY_SIMPLEX, scale, {0, 0, 0}, 3, cv::LINE_AA);
  cv::putText(img, s, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
}

/// Heat map of corner counts over the image (cells of width/kHeatCells), corners as dots.
cv::Mat coverage_map(const std::vector<BoardDetection>& views, cv::Size size, double& coverage) {
  const double cell = static_cast<double>(size.width) / kHeatCells;
  const int gy = std::max(1, static_cast<int>(std::ceil(size.height / cell)));
  cv::Mat counts = cv::Mat::zeros(gy, kHeatCells, CV_32F);
  for (const auto& v : views) {
    for (const auto& p : v.image_points) {
      const int cx = std::clamp(static_cast<int>(p.x / cell), 0, kHeatCells - 1);
      const int cy = std::clamp(static_cast<int>(p.y / cell), 0, gy - 1);
      counts.at<float>(cy, cx) += 1.f;
    }
  }
  coverage = cv::countNonZero(counts) / static_cast<double>(counts.total());
  double maxv = 0;
  cv::minMaxLoc(counts, nullptr, &maxv);
  cv::Mat norm8;
  counts.convertTo(norm8, CV_8U, maxv > 0 ? 255.0 / maxv : 0.0);
  const double scale = std::min(1.0, 960.0 / size.width);
  const cv::Size out_size(static_cast<int>(size.width * scale), static_cast<int>(size.height * scale));
  cv::Mat big;
  cv::resize(norm8, big, cv::Size(static_cast<int>(kHeatCells * cell * scale), static_cast<int>(gy * cell * scale)), 0, 0,
             cv::INTER_NEAREST);
  cv::Mat colour;
  cv::applyColorMap(big, colour, cv::COLORMAP_INFERNO);
  colour = colour(cv::Rect(0, 0, out_size.width, out_size.height)).clone();
  for (const auto& v : views) {
    for (const auto& p : v.image_points) cv::circle(colour, p * scale, 1, {200, 255, 200}, -1, cv::LINE_AA);
  }
  for (int i = 1; i < kHeatCells; ++i) {
    cv::line(colour, {static_cast<int>(i * cell * scale), 0}, {static_cast<int>(i * cell * scale), out_size.height},
             {70, 70, 70});
  }
  for (int j = 1; j < gy; ++j) {
    cv::line(colour, {0, static_cast<int>(j * cell * scale)}, {out_size.width, static_cast<int>(j * cell * scale)},
             {70, 70, 70});
  }
  return colour;
}

/// Bar chart of per-view errors with the median and the outlier limit (3 x median).
cv::Mat error_chart(const std::string& title, const std::vector<std::string>& labels, const std::vector<double>& err) {
  const int w = std::max(720, 40 + 26 * static_cast<int>(err.size())), h = 330, base = 260, top = 40;
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(40, 40, 40));
  std::vector<double> finite;
  for (double e : err) {
    if (std::isfinite(e)) finite.push_back(e);
  }
  std::sort(finite.begin(), finite.end());
  const double med = finite.empty() ? 0 : finite[finite.size() / 2];
  const double maxv = std::max({finite.empty() ? 0.0 : finite.back(), 3 * med, 0.5});
  const auto y_of = [&](double v) { return base - static_cast<int>((base - top) * v / maxv); };
  for (std::size_t i = 0; i < err.size(); ++i) {
    const int x = 30 + 26 * static_cast<int>(i);
    if (std::isfinite(err[i])) {
      const bool bad = err[i] > 3 * med;
      cv::rectangle(img, {x, y_of(err[i])}, {x + 18, base}, bad ? cv::Scalar(60, 60, 230) : cv::Scalar(120, 200, 90), -1);
    } else {
      text(img, "x", {x + 4, base - 4}, 0.45, {60, 60, 230});
    }
    // The end of the name tells views apart ("000012" -> "0012", "left02" -> "ft02"); labels
    // alternate between two lines, as four characters are wider than a bar's pitch.
    const std::string& l = labels[i];
    cv::putText(img, l.substr(l.size() > 4 ? l.size() - 4 : 0), {x - 3, base + 14 + 13 * static_cast<int>(i % 2)},
                cv::FONT_HERSHEY_PLAIN, 0.8, {220, 220, 220});
  }
  cv::line(img, {25, y_of(med)}, {w - 5, y_of(med)}, {0, 220, 255}, 1, cv::LINE_AA);
  cv::line(img, {25, y_of(3 * med)}, {w - 5, y_of(3 * med)}, {60, 60, 230}, 1, cv::LINE_AA);
  text(img, title, {10, 22}, 0.55);
  text(img, fmt::format("median {:.2f} px (yellow); outlier limit {:.2f} px (red); x = board not found", med, 3 * med),
       {10, h - 16}, 0.42);
  text(img, fmt::format("{:.2f} px", maxv), {w - 80, top - 4}, 0.4);
  return img;
}

/// Top view of the room (x right, z down the picture: front wall at the top).
/// `extrinsics` writes the rig in its first camera's frame (that camera at the origin, axes
/// aligned); `align` moves it into the room. Exactly that pose means: not aligned yet.
bool is_aligned(const tracking::RigCalibration& rig) {
  if (rig.cameras.empty()) return false;
  const auto& c = rig.cameras[0];
  return cv::norm(c.rotation - cv::Matx33d::eye()) > 1e-9 || cv::norm(c.translation) > 1e-9;
}

cv::Mat top_view(const tracking::RigCalibration& rig, double area_w, double area_d) {
  const bool aligned = is_aligned(rig);
  double extent = std::max(area_w, area_d) / 2 + 0.5;
  for (const auto& c : rig.cameras) {
    const cv::Vec3d p = c.position();
    extent = std::max({extent, std::abs(p[0]) + 0.5, std::abs(p[2]) + 0.5});
  }
  const int size = 800;
  const double s = size / (2 * extent);
  const auto px = [&](double x, double z) { return cv::Point(static_cast<int>(size / 2 + x * s), static_cast<int>(size / 2 + z * s)); };
  cv::Mat img(size, size, CV_8UC3, cv::Scalar(245, 245, 245));
  // 0.5 m grid.
  for (double g = -std::floor(extent * 2) / 2; g <= extent; g += 0.5) {
    cv::line(img, px(g, -extent), px(g, extent), {225, 225, 225});
    cv::line(img, px(-extent, g), px(extent, g), {225, 225, 225});
  }
  cv::rectangle(img, px(-area_w / 2, -area_d / 2), px(area_w / 2, area_d / 2), {200, 235, 200}, -1);
  // Walls of the CAVE: front (-Z), left, right.
  cv::line(img, px(-area_w / 2, -area_d / 2), px(area_w / 2, -area_d / 2), {40, 40, 40}, 4);
  cv::line(img, px(-area_w / 2, -area_d / 2), px(-area_w / 2, area_d / 2), {90, 90, 90}, 3);
  cv::line(img, px(area_w / 2, -area_d / 2), px(area_w / 2, area_d / 2), {90, 90, 90}, 3);
  cv::putText(img, "front wall (-Z)", px(-0.6, -area_d / 2 - 0.08), cv::FONT_HERSHEY_SIMPLEX, 0.5, {40, 40, 40}, 1, cv::LINE_AA);
  cv::arrowedLine(img, px(0, 0), px(0.4, 0), {0, 0, 200}, 2, cv::LINE_AA, 0, 0.2);
  cv::arrowedLine(img, px(0, 0), px(0, 0.4), {200, 0, 0}, 2, cv::LINE_AA, 0, 0.2);
  cv::putText(img, "+X", px(0.42, 0.03), cv::FONT_HERSHEY_SIMPLEX, 0.45, {0, 0, 200}, 1, cv::LINE_AA);
  cv::putText(img, "+Z", px(0.03, 0.5), cv::FONT_HERSHEY_SIMPLEX, 0.45, {200, 0, 0}, 1, cv::LINE_AA);
  std::vector<cv::Rect> labels;  // where camera labels went
  const std::vector<cv::Scalar> colours{{200, 90, 30}, {30, 140, 220}, {60, 170, 60}, {180, 60, 170}, {40, 40, 200}, {140, 140, 20}};
  for (std::size_t i = 0; i < rig.cameras.size(); ++i) {
    const auto& c = rig.cameras[i];
    const cv::Scalar col = colours[i % colours.size()];
    const cv::Vec3d p = c.position();
    // Frustum: rays through the left and right image edges (centre row) and the centre.
    std::vector<cv::Point2d> edge{{0, (c.image_height - 1) / 2.0}, {c.image_width - 1.0, (c.image_height - 1) / 2.0},
                                  {(c.image_width - 1) / 2.0, (c.image_height - 1) / 2.0}},
        norm;
    cv::undistortPoints(edge, norm, c.camera_matrix, c.distortion);
    std::vector<cv::Point> poly{px(p[0], p[2])};
    for (int k = 0; k < 3; ++k) {
      cv::Vec3d d = c.rotation.t() * cv::Vec3d(norm[static_cast<std::size_t>(k)].x, norm[static_cast<std::size_t>(k)].y, 1.0);
      const double horiz = std::hypot(d[0], d[2]);
      if (horiz < 1e-6) continue;
      const double len = 2.5;
      const cv::Point q = px(p[0] + d[0] / horiz * len, p[2] + d[2] / horiz * len);
      if (k < 2) {
        poly.push_back(q);
      } else {
        cv::line(img, px(p[0], p[2]), q, col, 1, cv::LINE_AA);
      }
    }
    if (poly.size() == 3) {
      cv::Mat overlay = img.clone();
      cv::fillConvexPoly(overlay, poly, col, cv::LINE_AA);
      cv::addWeighted(overlay, 0.18, img, 0.82, 0, img);
      cv::polylines(img, poly, true, col, 1, cv::LINE_AA);
    }
    cv::circle(img, px(p[0], p[2]), 7, col, -1, cv::LINE_AA);
    const double height = std::abs(p[1]) < 0.005 ? 0.0 : p[1];  // no "-0.00"
    const std::string label = fmt::format("{} (y {:.2f} m)", c.name, height);
    int baseline = 0;
    const cv::Size ts = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, 0.5, 1, &baseline);
    const cv::Point at = px(p[0], p[2]);
    const int lx = at.x + 10 + ts.width < size ? at.x + 10 : at.x - 10 - ts.width;  // keep it on the picture
    int ly = at.y - 8 - ts.height > 0 ? at.y - 8 : at.y + 8 + ts.height;
    // Cameras close together (a stereo pair): stack their labels instead of overprinting them.
    for (const cv::Rect& r : labels) {
      if ((r & cv::Rect(lx, ly - ts.height, ts.width, ts.height + baseline)).area() > 0) ly = r.y - 4;
    }
    labels.emplace_back(lx, ly - ts.height, ts.width, ts.height + baseline);
    cv::putText(img, label, {lx, ly}, cv::FONT_HERSHEY_SIMPLEX, 0.5, {20, 20, 20}, 1, cv::LINE_AA);
  }
  if (!aligned) {
    text(img, fmt::format("NOT ALIGNED: drawn in {}'s camera frame; run `align` to place the rig in the room",
                          rig.cameras.empty() ? std::string("the first camera") : rig.cameras[0].name),
         {10, 44}, 0.5, {60, 60, 230});
  }
  cv::putText(img, fmt::format("top view, 0.5 m grid; green: tracked area {:.1f} x {:.1f} m", area_w, area_d), {10, 20},
              cv::FONT_HERSHEY_SIMPLEX, 0.5, {20, 20, 20}, 1, cv::LINE_AA);
  return img;
}

/// `rms`: the camera's RMS; `high_is_its_own`: false when another camera is to blame for the
/// rig's errors (the file's per-camera RMS then carries that camera's misfit: not advice here).
/// `rig_problem`: what the rig check says of this camera ("" = nothing).
std::string advice(double rms, double coverage, int views, bool high_is_its_own, const std::string& rig_problem) {
  std::vector<std::string> a;
  if (!rig_problem.empty()) a.push_back(rig_problem);
  if (views < 10) a.push_back("capture more views (15+)");
  if (coverage < kGoodCoverage) a.push_back("move the board into the empty (dark) parts of the image, especially corners and edges");
  if (rig_problem.empty() && high_is_its_own && rms > kGoodRmsPx) {
    a.push_back("errors are high: check focus, motion blur and that the board is flat; retake the red views");
  }
  return a.empty() ? "good" : fmt::format("needs attention: {}", fmt::join(a, "; "));
}

/// The report is written as a unit: into a hidden sibling folder, which then takes the
/// report folder's place (one rename, or an atomic exchange with the previous report), so a
/// killed run leaves the old report whole, never old and new PNGs mixed.
class ReportFolder {
 public:
  explicit ReportFolder(fs::path out) : out_(std::move(out)) {
    if (out_.filename().empty()) out_ = out_.parent_path();  // "report/"
    const fs::path parent = out_.has_parent_path() ? out_.parent_path() : fs::path(".");
    std::error_code ec;
    fs::create_directories(parent, ec);
    if (ec) throw file_error("calibration", "io", parent.string(), 0, "", "cannot create the folder: " + ec.message());
    if (fs::exists(out_, ec) && !fs::is_directory(out_, ec)) {
      throw file_error("calibration", "io", out_.string(), 0, "", "is a file, not a folder");
    }
    if (fs::is_directory(out_, ec)) {
      // Only a previous report is replaced: refuse a folder holding anything else.
      for (const auto& e : fs::directory_iterator(out_, ec)) {
        const std::string n = e.path().filename().string();
        const bool ours = e.is_regular_file() && (n == "report.json" || e.path().extension() == ".png");
        if (!ours) {
          throw file_error("calibration", "io", out_.string(), 0, "",
                           fmt::format("holds {}, which is not part of a report: give an empty or new folder", n));
        }
      }
    }
    // Hidden folders left by killed runs (their process gone) are removed.
    const std::string prefix = "." + out_.filename().string() + ".tmp-";
    for (const auto& e : fs::directory_iterator(parent, ec)) {
      const std::string n = e.path().filename().string();
      if (n.rfind(prefix, 0) != 0) continue;
      const long pid = std::strtol(n.c_str() + prefix.size(), nullptr, 10);
      if (pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) fs::remove_all(e.path(), ec);
    }
    tmp_ = parent / (prefix + std::to_string(::getpid()));
    fs::remove_all(tmp_, ec);
    fs::create_directory(tmp_, ec);
    if (ec) throw file_error("calibration", "io", tmp_.string(), 0, "", "cannot create the folder: " + ec.message());
  }
  ~ReportFolder() {
    std::error_code ec;
    if (!tmp_.empty()) fs::remove_all(tmp_, ec);  // not committed: the old report stays
  }
  ReportFolder(const ReportFolder&) = delete;
  ReportFolder& operator=(const ReportFolder&) = delete;
  /// Where the files go until commit().
  const fs::path& dir() const { return tmp_; }
  /// Puts the new report in place of the old one.
  void commit() {
    std::error_code ec;
    if (fs::is_directory(out_, ec)) {
      if (::renameat2(AT_FDCWD, tmp_.c_str(), AT_FDCWD, out_.c_str(), RENAME_EXCHANGE) == 0) {
        fs::remove_all(tmp_, ec);  // now the old report
        tmp_.clear();
        return;
      }
      // No atomic exchange on this file system: the old report goes first (a killed run
      // here leaves no report folder, the new one complete beside it, never a mix).
      fs::remove_all(out_, ec);
    }
    fs::rename(tmp_, out_, ec);
    if (ec) throw file_error("calibration", "io", out_.string(), 0, "", "cannot move the report into place: " + ec.message());
    tmp_.clear();
  }

 private:
  fs::path out_, tmp_;
};

}  // namespace

void run_report(const ReportCommand& cmd) {
  const tracking::RigCalibration rig = tracking::read_calibration(cmd.calibration);
  const Board board = read_board(cmd.board_file);
  const RigImages images = scan_rig_images(cmd.images_dir);
  ReportFolder folder(cmd.out_dir);
  const fs::path& out_dir = folder.dir();
  const DetectorOptions& det = cmd.detector;
  const std::vector<CameraViews> views = detect_rig(board, images, det);

  json report;
  report["calibration"] = cmd.calibration.string();
  report["board"] = cmd.board_file.string();
  report["images"] = cmd.images_dir.string();
  report["thresholds"] = {{"good_rms_px", kGoodRmsPx}, {"good_coverage", kGoodCoverage}, {"outlier_factor", 3.0}};
  // Each camera against the board as the other cameras see it (a camera that moved during
  // the capture, or one whose views disagree with the rest): over the cameras with images.
  std::vector<tracking::CameraCalibration> checked;
  std::vector<std::vector<BoardDetection>> checked_views;
  for (const auto& c : rig.cameras) {
    const auto it = std::find(images.cameras.begin(), images.cameras.end(), c.name);
    if (it == images.cameras.end()) continue;
    checked.push_back(c);
    checked_views.push_back(views[static_cast<std::size_t>(it - images.cameras.begin())].detections);
  }
  const RigCheck check = check_rig(checked, checked_views);
  const auto check_of = [&](const std::string& name) -> const CameraCheck* {
    for (std::size_t i = 0; i < checked.size(); ++i) {
      if (checked[i].name == name && i < check.cameras.size()) return &check.cameras[i];
    }
    return nullptr;
  };
  std::vector<std::string> rig_problems;
  for (std::size_t i = 0; i < checked.size() && i < check.cameras.size(); ++i) {
    if (const std::string s = describe_check(checked[i].name, check.cameras[i], check, images.frames); !s.empty()) {
      rig_problems.push_back(s);
    }
  }
  json cams = json::array();
  for (const auto& c : rig.cameras) {
    json jc;
    jc["name"] = c.name;
    jc["image_size"] = {c.image_width, c.image_height};
    jc["fx_px"] = c.camera_matrix(0, 0);
    jc["fy_px"] = c.camera_matrix(1, 1);
    jc["cx_px"] = c.camera_matrix(0, 2);
    jc["cy_px"] = c.camera_matrix(1, 2);
    jc["distortion_k1_k2_p1_p2_k3"] = {c.distortion[0], c.distortion[1], c.distortion[2], c.distortion[3], c.distortion[4]};
    const cv::Vec3d p = c.position();
    jc["position_m"] = {p[0], p[1], p[2]};
    if (c.rms_px) jc["rms_px_in_file"] = *c.rms_px;
    const auto it = std::find(images.cameras.begin(), images.cameras.end(), c.name);
    if (it == images.cameras.end()) {
      jc["verdict"] = fmt::format("no images for this camera in {}", cmd.images_dir.string());
      spdlog::warn("{}: no folder {} in {}; its report has no views", c.name, c.name, cmd.images_dir.string());
      cams.push_back(jc);
      continue;
    }
    const auto& cv_views = views[static_cast<std::size_t>(it - images.cameras.begin())];
    if (cv_views.image_size != cv::Size(c.image_width, c.image_height)) {
      throw file_error("calibration", "image_size", (cmd.images_dir / c.name).string(), 0, "",
                       fmt::format("images are {}x{} px but {} was calibrated at {}x{} px", cv_views.image_size.width,
                                   cv_views.image_size.height, c.name, c.image_width, c.image_height));
    }
    const CameraCheck* ck = check_of(c.name);
    json jv = json::array();
    std::vector<std::string> labels;
    std::vector<double> errs;
    std::vector<BoardDetection> seen;
    double sum2 = 0;
    std::size_t n = 0;
    for (std::size_t f = 0; f < cv_views.images.size(); ++f) {
      if (cv_views.images[f].empty()) continue;
      const auto& d = cv_views.detections[f];
      double e = std::numeric_limits<double>::quiet_NaN();
      if (const auto pose = board_pose_in_camera(d, c)) {
        cv::Vec3d rv;
        cv::Rodrigues(pose->R, rv);
        e = view_rms(d, c.camera_matrix, c.distortion, rv, pose->t);
        sum2 += e * e * static_cast<double>(d.size());
        n += d.size();
        seen.push_back(d);
      }
      labels.push_back(cv_views.images[f].stem().string());
      errs.push_back(e);
      json view{{"image", cv_views.images[f].filename().string()},
                {"corners", d.size()},
                {"rms_px", std::isfinite(e) ? json(e) : json(nullptr)}};
      if (ck && f < ck->rms_px.size()) {
        const double r = ck->rms_px[f];
        view["rig_rms_px"] = std::isfinite(r) ? json(r) : json(nullptr);
        view["rig_mean_residual_px"] = std::isfinite(r) ? json({ck->mean_px[f][0], ck->mean_px[f][1]}) : json(nullptr);
        if (ck->blamed && ck->flagged[f]) view["flagged"] = true;
      }
      jv.push_back(view);
    }
    const double rms = n ? std::sqrt(sum2 / static_cast<double>(n)) : 0.0;
    double coverage = 0;
    const cv::Mat heat = coverage_map(seen, cv_views.image_size, coverage);
    const fs::path heat_png = out_dir / (c.name + "_coverage.png");
    const fs::path err_png = out_dir / (c.name + "_view_errors.png");
    cv::Mat heat_annotated = heat.clone();
    text(heat_annotated, fmt::format("{}: board corners over the image, {:.0f} % of cells covered", c.name, std::floor(coverage * 100)),
         {10, 22}, 0.55);
    write_png_atomically(heat_png, heat_annotated);
    write_png_atomically(err_png, error_chart(fmt::format("{}: per-view reprojection RMS (board pose per view)", c.name), labels, errs));
    jc["views"] = jv;
    jc["views_with_board"] = seen.size();
    jc["rms_px_per_view_fit"] = rms;
    jc["coverage_fraction"] = coverage;
    jc["coverage_png"] = heat_png.filename().string();
    jc["view_errors_png"] = err_png.filename().string();
    if (ck) {
      jc["rig_check"] = {{"rms_px", std::isfinite(ck->rms_all_px) ? json(ck->rms_all_px) : json(nullptr)},
                         {"views", ck->views},
                         {"blamed", ck->blamed},
                         {"moved_between", ck->moved_between ? json({images.frames[static_cast<std::size_t>(ck->moved_between->first)],
                                                                     images.frames[static_cast<std::size_t>(ck->moved_between->second)]})
                                                             : json(nullptr)},
                         {"jump_px", ck->jump_px}};
    }
    const std::string rig_problem = ck ? describe_check(c.name, *ck, check, images.frames) : std::string();
    jc["verdict"] = advice(c.rms_px.value_or(rms), coverage, static_cast<int>(seen.size()), rig_problems.empty(), rig_problem);
    // Percentages rounded down, so that "60 %" is never a "needs attention" below the 60 % mark.
    spdlog::log(rig_problem.empty() ? spdlog::level::info : spdlog::level::warn,
     "{}: {} views with the board, RMS {:.3f} px, coverage {:.0f} %: {}", c.name, seen.size(), rms,
     std::floor(coverage * 100), jc["verdict"].get<std::string>());
    cams.push_back(jc);
  }
  report["cameras"] = cams;
  const fs::path top_png = out_dir / "rig_top_view.png";
  write_png_atomically(top_png, top_view(rig, cmd.area_width_m, cmd.area_depth_m));
  report["rig_top_view_png"] = top_png.filename().string();
  report["aligned_to_room"] = is_aligned(rig);
  if (!is_aligned(rig)) spdlog::warn("the rig is not aligned to the room yet (run `align`): the top view shows it in {}'s frame",
                                     rig.cameras.empty() ? std::string("the first camera") : rig.cameras[0].name);
  report["tracked_area_m"] = {cmd.area_width_m, cmd.area_depth_m};
  // The rig as a whole: good, or which camera to fix first.
  std::string rig_verdict = "good";
  if (!rig_problems.empty()) {
    rig_verdict = fmt::format("needs attention: {}", fmt::join(rig_problems, "; "));
  } else {
    for (const auto& jc : cams) {
      if (jc.value("verdict", std::string("good")) != "good") {
        rig_verdict = "needs attention: see the cameras' verdicts";
        break;
      }
    }
  }
  if (!is_aligned(rig)) rig_verdict += rig_verdict == "good" ? " (not aligned to the room yet)" : "; not aligned to the room yet";
  report["rig_verdict"] = rig_verdict;
  report["rig_check_median_rms_px"] = check.median_rms_px;
  (rig_problems.empty() ? spdlog::info("rig: {}", rig_verdict) : spdlog::warn("rig: {}", rig_verdict));
  write_file_atomically(out_dir / "report.json", report.dump(2) + "\n");
  folder.commit();
  spdlog::info("wrote {} and the PNGs beside it", (cmd.out_dir / "report.json").string());
}

namespace {
json stats_json(const WandStats& s) {
  return {{"samples", s.samples}, {"mean_m", s.mean_m}, {"std_m", s.std_m}, {"min_m", s.min_m},
          {"max_m", s.max_m}, {"rms_error_m", s.rms_error_m}};
}
}  // namespace

std::string wand_json(const WandCommand& cmd, const WandResult& r) {
  json j;
  j["calibration"] = cmd.calibration.string();
  j["recording"] = cmd.recording_dir.string();
  j["true_length_m"] = cmd.wand_length_m;
  j["frames"] = r.frames;
  j["length"] = stats_json(r.stats);
  json regions = json::array();
  for (const auto& g : r.regions) {
    regions.push_back({{"centre_m", {g.centre[0], g.centre[1], g.centre[2]}}, {"length", stats_json(g.stats)}});
  }
  j["regions_1m"] = regions;
  json cams = json::array();
  for (std::size_t c = 0; c < r.camera_blobs.size(); ++c) {
    cams.push_back({{"index", c}, {"wand_blobs", r.camera_blobs[c]},
                    {"rms_px", std::isfinite(r.camera_rms_px[c]) ? json(r.camera_rms_px[c]) : json(nullptr)}});
  }
  j["cameras"] = cams;
  if (r.refined) j["length_after_refinement"] = stats_json(r.refined_stats);
  return j.dump(2) + "\n";
}

}  // namespace kumite::calibration
