// tracking.toml reader (through the project's strict TOML reader, kumite/common/toml_reader.hpp).
#include "kumite/tracking/config.hpp"

#include <cmath>
#include <optional>
#include <fstream>
#include <set>
#include <sstream>


#include "kumite/common/error.hpp"
#include "kumite/common/toml_reader.hpp"

namespace kumite::tracking {
namespace {

using T = TomlTable;

/// [filter], or a body's own [bodies.filter] (over `f`: keys absent keep its values).
void read_filter(const T& t, FilterConfig& f) {
  t.only({"enabled", "min_cutoff_hz", "beta", "d_cutoff_hz", "rot_min_cutoff_hz", "rot_beta", "rot_d_cutoff_hz",
          "max_prediction_s"});
  t.read("enabled", f.enabled);
  t.read("min_cutoff_hz", f.min_cutoff_hz, {1e-4, 1000, "Hz"});
  t.read("beta", f.beta, {0, 1e6, ""});
  t.read("d_cutoff_hz", f.d_cutoff_hz, {1e-4, 1000, "Hz"});
  t.read("rot_min_cutoff_hz", f.rot_min_cutoff_hz, {1e-4, 1000, "Hz"});
  t.read("rot_beta", f.rot_beta, {0, 1e6, ""});
  t.read("rot_d_cutoff_hz", f.rot_d_cutoff_hz, {1e-4, 1000, "Hz"});
  t.read("max_prediction_s", f.max_prediction_s, {0, 1, "s"});
}

BodyConfig read_body(const T& t, const FilterConfig& shared_filter) {
  t.only({"name", "markers", "distance_tolerance_m", "match_radius_m", "filter", "coasting_s"});
  BodyConfig b;
  b.name = t.string("name", false);
  const toml::array* m = t.opt_array("markers");
  if (!m) t.fail("missing_key", "markers", "is required: [[x, y, z], ...] (m)");
  for (const auto& p : *m) {
    const auto* xyz = p.as_array();
    if (!xyz || xyz->size() != 3) t.fail_at(p, "type", "markers", "each marker must be [x, y, z] (m)");
    Eigen::Vector3d v;
    for (int k = 0; k < 3; ++k) {
      const toml::node& e = (*xyz)[static_cast<std::size_t>(k)];
      if (!e.is_number()) t.fail_at(e, "type", "markers", "marker coordinates must be numbers in metres (|v| <= 10)");
      // An integer past 2^53 has no exact double: toml++ gives none (fuzz_tracking_config found
      // -66666666666666630 throwing bad_optional_access here).
      const std::optional<double> number = e.value<double>();
      if (!number) t.fail_at(e, "range", "markers", "marker coordinates must be numbers in metres (|v| <= 10)");
      const double c = *number;
      if (!std::isfinite(c)) t.fail_at(e, "not_finite", "markers", "must be a finite number");
      if (std::abs(c) > 10) t.fail_at(e, "range", "markers", "marker coordinates must be numbers in metres (|v| <= 10)");
      v[k] = c;
    }
    b.markers.push_back(v);
  }
  if (b.markers.size() < 3) t.fail("value", "markers", "a rigid body needs at least 3 markers");
  if (b.markers.size() > 32) t.fail("value", "markers", "at most 32 markers per body");
  for (std::size_t a = 0; a < b.markers.size(); ++a) {
    for (std::size_t c = a + 1; c < b.markers.size(); ++c) {
      if ((b.markers[a] - b.markers[c]).norm() < 0.01) {
        t.fail("value", "markers", fmt::format("markers {} and {} are closer than 1 cm", a, c));
      }
    }
  }
  t.read("distance_tolerance_m", b.distance_tolerance_m, {1e-4, 0.05, "m"});
  t.read("match_radius_m", b.match_radius_m, {1e-3, 0.5, "m"});
  // Its own filter starts from the file's [filter]: only what differs need be written.
  if (const auto f = t.opt_table("filter")) {
    FilterConfig own = shared_filter;
    read_filter(*f, own);
    b.filter = own;
  }
  if (double c = 0; t.read("coasting_s", c, {0, 10, "s"})) b.coasting_s = c;
  return b;
}

LiveCameraConfig read_camera(const T& t) {
  t.only({"name", "device", "pixel_format", "width", "height", "fps", "exposure", "gain", "buffers"});
  LiveCameraConfig c;
  c.name = t.string("name", false);
  c.device = t.string("device", false);
  t.read("pixel_format", c.pixel_format, false);
  if (c.pixel_format == "Y8") c.pixel_format = "GREY";
  if (c.pixel_format != "GREY" && c.pixel_format != "Y16" && c.pixel_format != "MJPG" &&
      c.pixel_format != "YUYV") {
    t.fail("value", "pixel_format", "must be GREY, Y8, Y16, MJPG or YUYV");
  }
  t.read("width", c.width, 16, 16384);
  t.read("height", c.height, 16, 16384);
  t.read("fps", c.fps, {1, 1000, "Hz"});
  t.read("exposure", c.exposure, -1, 1 << 30);
  t.read("gain", c.gain, -1, 1 << 30);
  t.read("buffers", c.buffers, 1, 32);
  return c;
}

}  // namespace

int TrackingConfig::find_body(std::string_view name) const {
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    if (bodies[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

TrackingConfig parse_tracking_config(std::string_view text, std::string_view source) {
  const toml::table root_table = parse_toml(text, source, "config");
  const T root(root_table, "config", source);
  root.only({"bodies", "blobs", "static_mask", "matching", "filter", "cameras", "frame_tolerance_s",
             "coasting_s", "camera_timeout_s", "camera_blind_s"});
  TrackingConfig c;
  root.read("frame_tolerance_s", c.frame_tolerance_s, {0, 1, "s"});
  root.read("coasting_s", c.coasting_s, {0, 10, "s"});
  root.read("camera_timeout_s", c.camera_timeout_s, {0.01, 60, "s"});
  root.read("camera_blind_s", c.camera_blind_s, {0.1, 600, "s"});

  if (const auto t = root.opt_table("blobs")) {
    t->only({"threshold", "seed_row_step", "min_area", "max_area", "min_roundness", "max_blobs"});
    t->read("threshold", c.blobs.threshold, 0, 254);
    t->read("seed_row_step", c.blobs.seed_row_step, 1, 64);
    t->read("min_area", c.blobs.min_area, 1, 1 << 20);
    t->read("max_area", c.blobs.max_area, 1, 1 << 24);
    t->read("min_roundness", c.blobs.min_roundness, {0, 1, ""});
    t->read("max_blobs", c.blobs.max_blobs, 1, 10000);
    if (c.blobs.max_area < c.blobs.min_area) t->fail("range", "max_area", "must be >= min_area");
  }
  if (const auto t = root.opt_table("static_mask")) {
    t->only({"enabled", "still_px", "learn_s", "margin_px", "forget_s"});
    t->read("enabled", c.static_mask);
    t->read("still_px", c.mask.still_px, {0, 100, "px"});
    t->read("learn_s", c.mask.learn_s, {0, 3600, "s"});
    t->read("margin_px", c.mask.margin_px, {0, 100, "px"});
    t->read("forget_s", c.mask.forget_s, {0, 60, "s"});
  }
  if (const auto t = root.opt_table("matching")) {
    t->only({"max_ray_distance_m", "max_reprojection_px", "outlier_px", "min_cameras", "max_residual_m",
             "min_depth_m"});
    t->read("max_ray_distance_m", c.match.max_ray_distance_m, {1e-5, 1, "m"});
    t->read("max_reprojection_px", c.match.max_reprojection_px, {0.01, 100, "px"});
    t->read("outlier_px", c.match.outlier_px, {0.01, 100, "px"});
    t->read("min_cameras", c.match.min_cameras, 2, 16);
    t->read("max_residual_m", c.match.max_residual_m, {1e-5, 1, "m"});
    t->read("min_depth_m", c.match.min_depth_m, {0, 100, "m"});
  }
  if (const auto t = root.opt_table("filter")) read_filter(*t, c.filter);
  if (!root.has("bodies")) root.fail("missing_key", "bodies", "is required: add [[bodies]] with name and markers");
  const auto bodies = root.tables("bodies");
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    c.bodies.push_back(read_body(bodies[i], c.filter));
    if (c.find_body(c.bodies.back().name) != static_cast<int>(i)) {
      bodies[i].fail("value", "name", "duplicate body name \"" + c.bodies.back().name + "\"");
    }
  }
  if (c.bodies.empty()) root.fail("value", "bodies", "at least one body is needed");
  for (const auto& cam : root.tables("cameras")) c.cameras.push_back(read_camera(cam));
  return c;
}

TrackingConfig read_tracking_config(const std::filesystem::path& path) {
  return parse_tracking_config(read_text_file(path, "config"), path.string());
}

}  // namespace kumite::tracking
