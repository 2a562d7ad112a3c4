// tracking.toml reader: the one .cpp of the tracking library that includes toml++.
#include "kumite/tracking/config.hpp"

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include <toml++/toml.h>

#include "kumite/common/error.hpp"

namespace kumite::tracking {
namespace {

class Reader {
 public:
  explicit Reader(std::string_view source) : source_(source) {}

  [[noreturn]] void fail(const toml::node* node, std::string_view key, std::string_view msg) const {
    const int line = node ? static_cast<int>(node->source().begin.line) : 0;
    throw file_error("config", "invalid", source_, line, key, msg);
  }

  void check_keys(const toml::table& t, std::string_view where,
                  std::initializer_list<std::string_view> known) const {
    for (const auto& [k, v] : t) {
      bool ok = false;
      for (auto name : known) ok = ok || k.str() == name;
      if (!ok) fail(&v, join(where, k.str()), "unknown key");
    }
  }

  static std::string join(std::string_view where, std::string_view key) {
    return where.empty() ? std::string(key) : std::string(where) + "." + std::string(key);
  }

  /// Every number of the file comes through here: toml++ reads nan and inf (also +inf,
  /// -nan) as numbers, which no key means.
  double finite(const toml::node* n, const std::string& key) const {
    const auto v = n->value<double>();
    if (!v || !(n->is_integer() || n->is_floating_point())) fail(n, key, "must be a number");
    if (!std::isfinite(*v)) fail(n, key, "must be a finite number");
    return *v;
  }

  void number(const toml::table& t, std::string_view where, std::string_view key, double& out,
              double min, double max) const {
    const toml::node* n = t.get(key);
    if (!n) return;
    const double v = finite(n, join(where, key));
    if (v < min || v > max) {
      fail(n, join(where, key), fmt::format("must be in [{}, {}], found {}", min, max, v));
    }
    out = v;
  }

  void integer(const toml::table& t, std::string_view where, std::string_view key, int& out,
               int min, int max) const {
    const toml::node* n = t.get(key);
    if (!n) return;
    if (!n->is_integer()) fail(n, join(where, key), "must be an integer");
    const auto v = *n->value<std::int64_t>();
    if (v < min || v > max) fail(n, join(where, key), fmt::format("must be in [{}, {}], found {}", min, max, v));
    out = static_cast<int>(v);
  }

  void boolean(const toml::table& t, std::string_view where, std::string_view key, bool& out) const {
    const toml::node* n = t.get(key);
    if (!n) return;
    if (!n->is_boolean()) fail(n, join(where, key), "must be true or false");
    out = *n->value<bool>();
  }

  void string(const toml::table& t, std::string_view where, std::string_view key, std::string& out,
              bool required, const toml::node* owner) const {
    const toml::node* n = t.get(key);
    if (!n) {
      if (required) fail(owner, join(where, key), "missing");
      return;
    }
    if (!n->is_string()) fail(n, join(where, key), "must be a string");
    out = *n->value<std::string>();
    if (out.empty()) fail(n, join(where, key), "must not be empty");
  }

  const toml::table* table(const toml::table& t, std::string_view key) const {
    const toml::node* n = t.get(key);
    if (!n) return nullptr;
    if (!n->is_table()) fail(n, key, "must be a table");
    return n->as_table();
  }

  std::string source_;
};

BodyConfig read_body(const Reader& r, const toml::table& t, const toml::node* node, std::size_t i) {
  const std::string where = fmt::format("bodies[{}]", i);
  r.check_keys(t, where, {"name", "markers", "distance_tolerance_m", "match_radius_m"});
  BodyConfig b;
  r.string(t, where, "name", b.name, true, node);
  const toml::node* m = t.get("markers");
  if (!m) r.fail(node, where + ".markers", "missing");
  if (!m->is_array()) r.fail(m, where + ".markers", "must be an array of [x, y, z] (m)");
  for (const auto& p : *m->as_array()) {
    const auto* xyz = p.as_array();
    if (!xyz || xyz->size() != 3) r.fail(&p, where + ".markers", "each marker must be [x, y, z] (m)");
    Eigen::Vector3d v;
    for (int k = 0; k < 3; ++k) {
      const toml::node& e = (*xyz)[k];
      if (!e.is_number()) r.fail(&e, where + ".markers", "marker coordinates must be numbers in metres (|v| <= 10)");
      const double c = r.finite(&e, where + ".markers");
      if (std::abs(c) > 10) r.fail(&e, where + ".markers", "marker coordinates must be numbers in metres (|v| <= 10)");
      v[k] = c;
    }
    b.markers.push_back(v);
  }
  if (b.markers.size() < 3) r.fail(m, where + ".markers", "a rigid body needs at least 3 markers");
  if (b.markers.size() > 32) r.fail(m, where + ".markers", "at most 32 markers per body");
  for (std::size_t a = 0; a < b.markers.size(); ++a) {
    for (std::size_t c = a + 1; c < b.markers.size(); ++c) {
      if ((b.markers[a] - b.markers[c]).norm() < 0.01) {
        r.fail(m, where + ".markers", fmt::format("markers {} and {} are closer than 1 cm", a, c));
      }
    }
  }
  r.number(t, where, "distance_tolerance_m", b.distance_tolerance_m, 1e-4, 0.05);
  r.number(t, where, "match_radius_m", b.match_radius_m, 1e-3, 0.5);
  return b;
}

LiveCameraConfig read_camera(const Reader& r, const toml::table& t, const toml::node* node, std::size_t i) {
  const std::string where = fmt::format("cameras[{}]", i);
  r.check_keys(t, where, {"name", "device", "pixel_format", "width", "height", "fps", "exposure",
                          "gain", "buffers"});
  LiveCameraConfig c;
  r.string(t, where, "name", c.name, true, node);
  r.string(t, where, "device", c.device, true, node);
  r.string(t, where, "pixel_format", c.pixel_format, false, node);
  if (c.pixel_format == "Y8") c.pixel_format = "GREY";
  if (c.pixel_format != "GREY" && c.pixel_format != "Y16" && c.pixel_format != "MJPG" &&
      c.pixel_format != "YUYV") {
    r.fail(t.get("pixel_format"), where + ".pixel_format", "must be GREY, Y8, Y16, MJPG or YUYV");
  }
  r.integer(t, where, "width", c.width, 16, 16384);
  r.integer(t, where, "height", c.height, 16, 16384);
  r.number(t, where, "fps", c.fps, 1, 1000);
  r.integer(t, where, "exposure", c.exposure, -1, 1 << 30);
  r.integer(t, where, "gain", c.gain, -1, 1 << 30);
  r.integer(t, where, "buffers", c.buffers, 1, 32);
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
  Reader r(source);
  toml::table root;
  try {
    root = toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    throw file_error("config", "parse", source, static_cast<int>(e.source().begin.line), "",
                     std::string(e.description()));
  }
  r.check_keys(root, "", {"bodies", "blobs", "static_mask", "matching", "filter", "cameras",
                          "frame_tolerance_s", "coasting_s", "camera_timeout_s", "camera_blind_s"});
  TrackingConfig c;
  r.number(root, "", "frame_tolerance_s", c.frame_tolerance_s, 0, 1);
  r.number(root, "", "coasting_s", c.coasting_s, 0, 10);
  r.number(root, "", "camera_timeout_s", c.camera_timeout_s, 0.01, 60);
  r.number(root, "", "camera_blind_s", c.camera_blind_s, 0.1, 600);

  if (const auto* t = r.table(root, "blobs")) {
    r.check_keys(*t, "blobs", {"threshold", "seed_row_step", "min_area", "max_area", "min_roundness", "max_blobs"});
    r.integer(*t, "blobs", "threshold", c.blobs.threshold, 0, 254);
    r.integer(*t, "blobs", "seed_row_step", c.blobs.seed_row_step, 1, 64);
    r.integer(*t, "blobs", "min_area", c.blobs.min_area, 1, 1 << 20);
    r.integer(*t, "blobs", "max_area", c.blobs.max_area, 1, 1 << 24);
    r.number(*t, "blobs", "min_roundness", c.blobs.min_roundness, 0, 1);
    r.integer(*t, "blobs", "max_blobs", c.blobs.max_blobs, 1, 10000);
    if (c.blobs.max_area < c.blobs.min_area) r.fail(t->get("max_area"), "blobs.max_area", "must be >= min_area");
  }
  if (const auto* t = r.table(root, "static_mask")) {
    r.check_keys(*t, "static_mask", {"enabled", "still_px", "learn_s", "margin_px", "forget_s"});
    r.boolean(*t, "static_mask", "enabled", c.static_mask);
    r.number(*t, "static_mask", "still_px", c.mask.still_px, 0, 100);
    r.number(*t, "static_mask", "learn_s", c.mask.learn_s, 0, 3600);
    r.number(*t, "static_mask", "margin_px", c.mask.margin_px, 0, 100);
    r.number(*t, "static_mask", "forget_s", c.mask.forget_s, 0, 60);
  }
  if (const auto* t = r.table(root, "matching")) {
    r.check_keys(*t, "matching", {"max_ray_distance_m", "max_reprojection_px", "outlier_px", "min_cameras",
                                  "max_residual_m", "min_depth_m"});
    r.number(*t, "matching", "max_ray_distance_m", c.match.max_ray_distance_m, 1e-5, 1);
    r.number(*t, "matching", "max_reprojection_px", c.match.max_reprojection_px, 0.01, 100);
    r.number(*t, "matching", "outlier_px", c.match.outlier_px, 0.01, 100);
    r.integer(*t, "matching", "min_cameras", c.match.min_cameras, 2, 16);
    r.number(*t, "matching", "max_residual_m", c.match.max_residual_m, 1e-5, 1);
    r.number(*t, "matching", "min_depth_m", c.match.min_depth_m, 0, 100);
  }
  if (const auto* t = r.table(root, "filter")) {
    r.check_keys(*t, "filter", {"enabled", "min_cutoff_hz", "beta", "d_cutoff_hz", "rot_min_cutoff_hz",
                                "rot_beta", "rot_d_cutoff_hz", "max_prediction_s"});
    r.boolean(*t, "filter", "enabled", c.filter.enabled);
    r.number(*t, "filter", "min_cutoff_hz", c.filter.min_cutoff_hz, 1e-4, 1000);
    r.number(*t, "filter", "beta", c.filter.beta, 0, 1e6);
    r.number(*t, "filter", "d_cutoff_hz", c.filter.d_cutoff_hz, 1e-4, 1000);
    r.number(*t, "filter", "rot_min_cutoff_hz", c.filter.rot_min_cutoff_hz, 1e-4, 1000);
    r.number(*t, "filter", "rot_beta", c.filter.rot_beta, 0, 1e6);
    r.number(*t, "filter", "rot_d_cutoff_hz", c.filter.rot_d_cutoff_hz, 1e-4, 1000);
    r.number(*t, "filter", "max_prediction_s", c.filter.max_prediction_s, 0, 1);
  }
  const toml::node* bodies = root.get("bodies");
  if (!bodies) r.fail(nullptr, "bodies", "missing: add [[bodies]] with name and markers");
  if (!bodies->is_array_of_tables()) r.fail(bodies, "bodies", "must be [[bodies]] tables");
  std::size_t i = 0;
  for (const auto& b : *bodies->as_array()) {
    c.bodies.push_back(read_body(r, *b.as_table(), &b, i));
    if (c.find_body(c.bodies.back().name) != static_cast<int>(i)) {
      r.fail(&b, fmt::format("bodies[{}].name", i), "duplicate body name \"" + c.bodies.back().name + "\"");
    }
    ++i;
  }
  if (c.bodies.empty()) r.fail(bodies, "bodies", "at least one body is needed");
  if (const toml::node* cams = root.get("cameras")) {
    if (!cams->is_array_of_tables()) r.fail(cams, "cameras", "must be [[cameras]] tables");
    std::size_t k = 0;
    for (const auto& cam : *cams->as_array()) c.cameras.push_back(read_camera(r, *cam.as_table(), &cam, k++));
  }
  return c;
}

TrackingConfig read_tracking_config(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw Error("config", "missing", fmt::format("{}: is a folder, not a file: give the tracking .toml file", path.string()));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("config", "missing", fmt::format("{}: cannot open tracking config", path.string()));
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_tracking_config(ss.str(), path.string());
}

}  // namespace kumite::tracking
