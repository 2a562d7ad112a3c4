// The installation file: TOML (toml++, included here only) <-> InstallationConfig.
#include "kumite/app/config.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <initializer_list>
#include <set>
#include <sstream>

#include <fmt/format.h>

#include "kumite/common/error.hpp"
#include "kumite/common/toml_reader.hpp"
#include "kumite/common/wire.hpp"
#include "kumite/content/planner.hpp"
#include "kumite/content/tunables.hpp"

namespace kumite::app {

std::optional<KeyAction> parse_key_action(std::string_view text) {
  if (text == "quit") return KeyAction{KeyAction::Kind::quit, OrderKind::punch_right, -1};
  if (text == "record") return KeyAction{KeyAction::Kind::record, OrderKind::punch_right, -1};
  const auto o = parse_order(text);
  if (!o) return std::nullopt;
  return KeyAction{KeyAction::Kind::order, o->kind, o->character};
}

std::string_view to_string(FighterLook l) { return l == FighterLook::skinned ? "skinned" : "capsules"; }

std::optional<FighterLook> fighter_look_from_string(std::string_view s) {
  if (s == "skinned") return FighterLook::skinned;
  if (s == "capsules") return FighterLook::capsules;
  return std::nullopt;
}

std::string to_string(const KeyAction& a) {
  if (a.kind == KeyAction::Kind::record) return "record";
  return a.kind == KeyAction::Kind::quit ? "quit" : to_string(a.to_order(0));
}


namespace {

constexpr double kPi = 3.14159265358979323846;
/// Edges may be off perpendicular by this much before a wall counts as skewed (degrees):
/// a surveyed wall is good to a few millimetres over metres (~0.1 deg).
constexpr double kMaxSkewDeg = 0.5;
/// Edges shorter than this make a wall degenerate (metres).
constexpr double kMinEdgeM = 0.01;
/// A given upper_right corner may miss the implied one by this much (metres).
constexpr double kCornerToleranceM = 0.01;

/// Reads one file into an InstallationConfig. Every value goes through the project's strict
/// reader (kumite/common/toml_reader.hpp): one wording and one set of codes for all files.
/// Ranges and relations between keys are checked afterwards by validate(), which names lines
/// from InstallationConfig::lines (every key of the file, recorded once by toml_key_lines).
class Reader {
 public:
  Reader(std::string file, InstallationConfig& cfg) : file_(std::move(file)), cfg_(cfg) {}

  [[noreturn]] void fail(std::string_view code, int line, const std::string& key,
                         const std::string& msg) const {
    throw file_error("config", code, file_, line, key, msg);
  }

  int line(const toml::node& n) const { return static_cast<int>(n.source().begin.line); }

  TomlTable at(const toml::table& t, const std::string& path) const { return TomlTable(t, "config", file_, path); }

  void only_keys(const toml::table& t, const std::string& path,
                 std::initializer_list<std::string_view> allowed) const {
    at(t, path).only(allowed);
  }

  const toml::table* table(const toml::table& t, std::string_view key, const std::string& path,
                           bool required) {
    const auto sub = at(t, path).opt_table(key);
    if (!sub) {
      if (required) at(t, path).fail("missing_key", key, "is required (a table)");
      return nullptr;
    }
    return &sub->raw();
  }

  const toml::array* array(const toml::table& t, std::string_view key, const std::string& path,
                           bool required) {
    const toml::array* a = at(t, path).opt_array(key);
    if (!a && required) at(t, path).fail("missing_key", key, "is required");
    return a;
  }

  template <typename F>
  bool read(const toml::table& t, std::string_view key, const std::string& path, bool required, F&& f) {
    const TomlTable tt = at(t, path);
    if (!tt.has(key)) {
      if (required) tt.fail("missing_key", key, "is required");
      return false;
    }
    f(tt);
    return true;
  }

  bool number(const toml::table& t, std::string_view key, const std::string& path, double& out,
              bool required = false) {
    return read(t, key, path, required, [&](const TomlTable& tt) { tt.read(key, out); });
  }

  bool integer(const toml::table& t, std::string_view key, const std::string& path, int& out,
               bool required = false) {
    return read(t, key, path, required, [&](const TomlTable& tt) { tt.read(key, out); });
  }

  bool boolean(const toml::table& t, std::string_view key, const std::string& path, bool& out,
               bool required = false) {
    return read(t, key, path, required, [&](const TomlTable& tt) { tt.read(key, out); });
  }

  bool string(const toml::table& t, std::string_view key, const std::string& path,
              std::string& out, bool required = false) {
    return read(t, key, path, required, [&](const TomlTable& tt) { tt.read(key, out); });
  }

  bool path(const toml::table& t, std::string_view key, const std::string& p,
            std::filesystem::path& out, bool required = false) {
    return read(t, key, p, required, [&](const TomlTable& tt) { tt.read(key, out); });
  }

  template <std::size_t N, typename T>
  bool numbers(const toml::table& t, std::string_view key, const std::string& path,
               std::array<T, N>& out, bool required = false) {
    return read(t, key, path, required, [&](const TomlTable& tt) { tt.read(key, out); });
  }

  void parse(const toml::table& root);

 private:
  void parse_windows(const toml::table& root);
  void parse_walls(const toml::table& root);
  void parse_stereo(const toml::table& root);
  void parse_viewer(const toml::table& root);
  void parse_keys(const toml::table& root);
  void parse_characters(const toml::table& root);
  void parse_fighter(const toml::table& root);
  void parse_tracking(const toml::table& root);

  template <typename F>
  void each_table(const toml::table& root, std::string_view key, bool required, F&& f) {
    const toml::array* a = array(root, key, "", required);
    if (!a) return;
    for (const TomlTable& t : at(root, "").tables(key)) f(t.raw(), t.path());
  }

  std::string file_;
  InstallationConfig& cfg_;
};

void Reader::parse(const toml::table& root) {
  only_keys(root, "", {"display_rate_hz", "late_latch", "display_latency_ms", "data_dir", "windows", "walls", "stereo", "viewer",
                       "projection", "keys", "characters", "fighter", "tracking", "recognition", "orders", "health", "safety", "record", "console", "log", "render", "cluster"});
  number(root, "display_rate_hz", "", cfg_.display_rate_hz);
  boolean(root, "late_latch", "", cfg_.late_latch);
  number(root, "display_latency_ms", "", cfg_.display_latency_ms);
  path(root, "data_dir", "", cfg_.data_dir);
  parse_windows(root);
  parse_walls(root);
  parse_stereo(root);
  parse_viewer(root);
  if (const auto* p = table(root, "projection", "", false)) {
    only_keys(*p, "projection", {"near_m", "far_m"});
    number(*p, "near_m", "projection", cfg_.projection.near_m);
    number(*p, "far_m", "projection", cfg_.projection.far_m);
  }
  parse_keys(root);
  parse_characters(root);
  parse_fighter(root);
  parse_tracking(root);
  if (const auto* r = table(root, "recognition", "", false)) {
    only_keys(*r, "recognition", {"model"});
    path(*r, "model", "recognition", cfg_.recognition.model);
  }
  if (const auto* o = table(root, "orders", "", false)) {
    only_keys(*o, "orders", {"script"});
    std::filesystem::path s;
    if (path(*o, "script", "orders", s)) cfg_.orders_script = s;
  }
  if (const auto* h = table(root, "health", "", false)) {
    only_keys(*h, "health", {"file", "interval_s"});
    std::filesystem::path f;
    if (path(*h, "file", "health", f)) cfg_.health.file = f;
    number(*h, "interval_s", "health", cfg_.health.interval_s);
  }
  if (const auto* sf = table(root, "safety", "", false)) {
    only_keys(*sf, "safety", {"enabled", "wall_distance_m"});
    boolean(*sf, "enabled", "safety", cfg_.safety.enabled);
    number(*sf, "wall_distance_m", "safety", cfg_.safety.wall_distance_m);
  }
  if (const auto* rd = table(root, "render", "", false)) {
    only_keys(*rd, "render", {"fighter", "bodies", "debug_marks", "hall"});
    std::string look;
    if (string(*rd, "fighter", "render", look)) {
      const auto l = fighter_look_from_string(look);
      if (!l)
        fail("unknown_value", cfg_.line_of("render.fighter"), "render.fighter",
             fmt::format("unknown fighter look \"{}\" (skinned, capsules)", look));
      cfg_.render.fighter = *l;
    }
    path(*rd, "bodies", "render", cfg_.render.bodies);
    boolean(*rd, "debug_marks", "render", cfg_.render.debug_marks);
    boolean(*rd, "hall", "render", cfg_.render.hall);
  }
  if (const auto* r = table(root, "record", "", false)) {
    only_keys(*r, "record", {"budget_mb"});
    number(*r, "budget_mb", "record", cfg_.record_budget_mb);
  }
  if (const auto* lg = table(root, "log", "", false)) {
    const TomlTable t = at(*lg, "log");
    t.only({"frames_budget_mb"});
    t.read("frames_budget_mb", cfg_.frames_log_budget_mb, {1, 1e7, "MB"});
  }
  if (const auto* con = table(root, "console", "", false)) {
    const TomlTable t = at(*con, "console");
    t.only({"size", "position", "quit_confirm_s"});
    t.read("size", cfg_.console.size, 1, 16384);
    std::array<int, 2> pos{};
    if (t.read("position", pos, -32768, 32767)) cfg_.console.position = pos;
    t.read("quit_confirm_s", cfg_.console.quit_confirm_s, {0, 30, "s"});
    if (cfg_.console.size[0] < 640 || cfg_.console.size[1] < 480)
      t.fail("range", "size", fmt::format("must be at least [640, 480] px (everything on the console must fit), found "
                                          "[{}, {}]", cfg_.console.size[0], cfg_.console.size[1]));
  }
}

void Reader::parse_windows(const toml::table& root) {
  each_table(root, "windows", false, [&](const toml::table& t, const std::string& p) {
    only_keys(t, p, {"name", "size", "position", "monitor", "fullscreen"});
    WindowConfig w;
    string(t, "name", p, w.name, true);
    numbers(t, "size", p, w.size);
    numbers(t, "position", p, w.position);
    integer(t, "monitor", p, w.monitor);
    boolean(t, "fullscreen", p, w.fullscreen);
    cfg_.windows.push_back(w);
  });
}

void Reader::parse_walls(const toml::table& root) {
  if (!root.get("walls")) fail("missing_wall", 1, "walls", "no [[walls]]: at least one wall is needed");
  each_table(root, "walls", true, [&](const toml::table& t, const std::string& p) {
    only_keys(t, p, {"name", "lower_left", "lower_right", "upper_left", "upper_right",
                     "resolution", "window", "viewport"});
    WallConfig w;
    string(t, "name", p, w.name, true);
    numbers(t, "lower_left", p, w.lower_left, true);
    numbers(t, "lower_right", p, w.lower_right, true);
    numbers(t, "upper_left", p, w.upper_left, true);
    Vec3 ur{};
    if (numbers(t, "upper_right", p, ur)) w.upper_right = ur;
    numbers(t, "resolution", p, w.resolution);
    string(t, "window", p, w.window);
    std::array<int, 4> vp{};
    if (numbers(t, "viewport", p, vp)) w.viewport = vp;
    cfg_.walls.push_back(w);
  });
}

void Reader::parse_stereo(const toml::table& root) {
  const auto* s = table(root, "stereo", "", false);
  if (!s) return;
  only_keys(*s, "stereo", {"mode", "allow_fallback", "fallback"});
  auto mode = [&](std::string_view key, StereoMode& out) {
    std::string text;
    if (!string(*s, key, "stereo", text)) return;
    const auto m = stereo_mode_from_string(text);
    if (!m)
      fail("unknown_stereo_mode", cfg_.line_of("stereo." + std::string(key)),
           "stereo." + std::string(key),
           fmt::format("unknown stereo mode \"{}\" (quad_buffer, side_by_side, top_bottom, "
                       "anaglyph, mono)", text));
    out = *m;
  };
  mode("mode", cfg_.stereo.mode);
  boolean(*s, "allow_fallback", "stereo", cfg_.stereo.allow_fallback);
  mode("fallback", cfg_.stereo.fallback);
}

void Reader::parse_viewer(const toml::table& root) {
  const auto* v = table(root, "viewer", "", false);
  if (!v) return;
  only_keys(*v, "viewer", {"interpupillary_distance_m", "eye_offset_m", "default_head_m"});
  number(*v, "interpupillary_distance_m", "viewer", cfg_.viewer.interpupillary_distance_m);
  numbers(*v, "eye_offset_m", "viewer", cfg_.viewer.eye_offset_m);
  numbers(*v, "default_head_m", "viewer", cfg_.viewer.default_head_m);
}

void Reader::parse_keys(const toml::table& root) {
  const auto* k = table(root, "keys", "", false);
  if (!k) return;
  for (auto&& [action_key, node] : *k) {
    const std::string action(action_key.str());
    const std::string full = "keys." + action;
    if (!node.is_string()) fail("type", line(node), full, "must be a key name (a string)");
    const std::string name = node.value<std::string>().value();
    const auto canonical = canonical_key_name(name);
    if (!canonical)
      fail("unknown_key_name", line(node), full,
           fmt::format("unknown key name \"{}\" (A-Z, 0-9, F1-F12, KP_0-KP_9, SPACE, ENTER, "
                       "TAB, BACKSPACE, ESCAPE, LEFT, RIGHT, UP, DOWN, ...)", name));
    // "character_2" in the file is the action "character 2".
    std::string act = action;
    if (act.rfind("character_", 0) == 0) act = "character " + act.substr(10);
    const auto parsed = parse_key_action(act);
    if (!parsed)
      fail("unknown_action", line(node), full,
           "unknown action (punch_left, punch_right, kick_left, kick_right, pause, resume, recentre, spar, orders, character_N, quit, "
           "record)");
    cfg_.keys.push_back({*parsed, name, *canonical});
  }
}

void Reader::parse_characters(const toml::table& root) {
  each_table(root, "characters", false, [&](const toml::table& t, const std::string& p) {
    only_keys(t, p, {"name", "bvh"});
    CharacterConfig c;
    string(t, "name", p, c.name, true);
    path(t, "bvh", p, c.bvh, true);
    cfg_.characters.push_back(c);
  });
}

void Reader::parse_fighter(const toml::table& root) {
  const auto* f = table(root, "fighter", "", false);
  if (!f) return;
  only_keys(*f, "fighter", {"database", "initial_character", "home_m", "strike_distance_m",
                            "hit_radius_m", "visitor_head_radius_m", "visitor_body_radius_m", "x_limits_m",
                            "z_limits_m", "behaviour", "retrieval", "planner"});
  // [fighter.behaviour], [fighter.behaviour.feet], [fighter.retrieval]: content's keys, read by
  // content::parse_fighter_tunables from the same text (parse_config).
  auto& s = cfg_.fighter;
  path(*f, "database", "fighter", s.database);
  if (integer(*f, "initial_character", "fighter", s.initial_character)) s.initial_character -= 1;
  numbers(*f, "home_m", "fighter", s.home_m);
  number(*f, "strike_distance_m", "fighter", s.strike_distance_m);
  number(*f, "hit_radius_m", "fighter", s.hit_radius_m);
  for (const auto& [key, value] : {std::pair{"visitor_head_radius_m", &s.visitor_head_radius_m},
                                   std::pair{"visitor_body_radius_m", &s.visitor_body_radius_m}}) {
    if (number(*f, key, "fighter", *value) && (*value <= 0 || *value > 1))
      fail("range", cfg_.line_of(std::string("fighter.") + key), std::string("fighter.") + key, "must be in (0, 1] m");
  }
  numbers(*f, "x_limits_m", "fighter", s.x_limits_m);
  numbers(*f, "z_limits_m", "fighter", s.z_limits_m);
}

void Reader::parse_tracking(const toml::table& root) {
  const auto* t = table(root, "tracking", "", false);
  if (!t) return;
  only_keys(*t, "tracking",
            {"source", "calibration", "tracking", "recording", "poses", "poses_loop", "head_body", "lost_after_s",
             "recording_preload", "decode_threads", "realtime_priority", "dtrack", "osc", "out"});
  // [tracking.dtrack] and [tracking.osc]: the interop library's keys, read by
  // tracking::parse_dtrack_config from the same text (parse_config).
  auto& c = cfg_.tracking;
  std::string src;
  if (string(*t, "source", "tracking", src)) {
    if (src == "none") c.source = TrackingSource::none;
    else if (src == "recording") c.source = TrackingSource::recording;
    else if (src == "live") c.source = TrackingSource::live;
    else if (src == "poses") c.source = TrackingSource::poses;
    else if (src == "dtrack") c.source = TrackingSource::dtrack;
    else if (src == "osc") c.source = TrackingSource::osc;
    else
      fail("unknown_source", cfg_.line_of("tracking.source"), "tracking.source",
           fmt::format("unknown tracking source \"{}\" (none, recording, live, poses, dtrack, osc)", src));
  }
  path(*t, "calibration", "tracking", c.calibration);
  path(*t, "tracking", "tracking", c.tracking);
  path(*t, "recording", "tracking", c.recording);
  path(*t, "poses", "tracking", c.poses);
  boolean(*t, "poses_loop", "tracking", c.poses_loop);
  if (int hb = 0; integer(*t, "head_body", "tracking", hb)) c.head_body = hb;
  number(*t, "lost_after_s", "tracking", c.lost_after_s);
  integer(*t, "recording_preload", "tracking", c.recording_preload);
  integer(*t, "decode_threads", "tracking", c.decode_threads);
  integer(*t, "realtime_priority", "tracking", c.realtime_priority);
  if (const auto* out = table(*t, "out", "tracking", false)) {
    only_keys(*out, "tracking.out", {"dtrack", "osc"});
    for (const auto& [key, value] : {std::pair{"dtrack", &c.out_dtrack}, std::pair{"osc", &c.out_osc}}) {
      if (!string(*out, key, "tracking.out", *value)) continue;
      const std::string k = std::string("tracking.out.") + key;
      // host:port: a host (a name, an IPv4 address or a multicast group) and a port 1..65535.
      const auto colon = value->rfind(':');
      const std::string host = colon == std::string::npos ? "" : value->substr(0, colon);
      const std::string port = colon == std::string::npos ? "" : value->substr(colon + 1);
      const bool digits = !port.empty() && port.size() <= 5 &&
                          std::all_of(port.begin(), port.end(), [](char ch) { return ch >= '0' && ch <= '9'; });
      if (host.empty() || !digits || std::stoi(port) < 1 || std::stoi(port) > 65535)
        fail("format", cfg_.line_of(k), k, fmt::format("\"{}\": must be \"host:port\" (port 1..65535)", *value));
    }
  }
}

[[noreturn]] void fail_at(const InstallationConfig& c, std::string_view code,
                          const std::string& key, const std::string& msg) {
  throw file_error("config", code, c.file.string(), c.line_of(key), key, msg);
}

double norm(const Vec3& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }
Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

toml::array to_array(const Vec3& v) { return toml::array{v[0], v[1], v[2]}; }
template <std::size_t N>
toml::array to_array(const std::array<int, N>& v) {
  toml::array a;
  for (int x : v) a.push_back(x);
  return a;
}
toml::array to_array(const std::array<double, 2>& v) { return toml::array{v[0], v[1]}; }

/// [tracking.dtrack] / [tracking.osc] as parse_dtrack_config reads it back (`room`: with the
/// room transform and offsets, DTrack's; OSC has none).
toml::table dtrack_table(const tracking::DtrackInput& d, bool room) {
  toml::table t{{"port", d.port}};
  if (!d.multicast_group.empty()) t.insert("multicast_group", d.multicast_group);
  if (room) {
    t.insert("bind_address", d.bind_address);
    if (d.room.rotation == tracking::RoomTransform::z_up().rotation) {
      t.insert("room_axes", "z_up");
    } else if (d.room.rotation == tracking::RoomTransform::y_up().rotation) {
      t.insert("room_axes", "y_up");
    } else {
      toml::array rows;
      for (std::size_t i = 0; i < 3; ++i)
        rows.push_back(toml::array{d.room.rotation[i * 3], d.room.rotation[i * 3 + 1], d.room.rotation[i * 3 + 2]});
      t.insert("rotation", std::move(rows));
    }
    t.insert("translation_m", to_array(d.room.translation_m));
    t.insert("conjugate_body", d.room.conjugate_body);
  }
  toml::table bodies, offsets;
  for (std::size_t r = 0; r < tracking::kRoleNames.size(); ++r) {
    if (d.role_body[r] >= 0) bodies.insert(tracking::kRoleNames[r], d.role_body[r]);
    if (room && d.role_offset_m[r] != std::array<double, 3>{0, 0, 0})
      offsets.insert(tracking::kRoleNames[r], to_array(d.role_offset_m[r]));
  }
  if (!bodies.empty()) t.insert("bodies", std::move(bodies));
  if (!offsets.empty()) t.insert("offsets", std::move(offsets));
  return t;
}

}  // namespace

std::string_view to_string(StereoMode m) {
  switch (m) {
    case StereoMode::quad_buffer: return "quad_buffer";
    case StereoMode::side_by_side: return "side_by_side";
    case StereoMode::top_bottom: return "top_bottom";
    case StereoMode::anaglyph: return "anaglyph";
    case StereoMode::mono: return "mono";
  }
  return "?";
}

std::optional<StereoMode> stereo_mode_from_string(std::string_view s) {
  for (auto m : {StereoMode::quad_buffer, StereoMode::side_by_side, StereoMode::top_bottom,
                 StereoMode::anaglyph, StereoMode::mono})
    if (to_string(m) == s) return m;
  return std::nullopt;
}

std::string_view to_string(TrackingSource s) {
  switch (s) {
    case TrackingSource::none: return "none";
    case TrackingSource::recording: return "recording";
    case TrackingSource::live: return "live";
    case TrackingSource::poses: return "poses";
    case TrackingSource::dtrack: return "dtrack";
    case TrackingSource::osc: return "osc";
  }
  return "?";
}

std::optional<std::string> canonical_key_name(std::string_view name) {
  if (name.size() == 1) {
    const char c = name[0];
    if (c >= 'A' && c <= 'Z') return std::string(1, c);
    if (c >= 'a' && c <= 'z') return std::string(1, static_cast<char>(c - 'a' + 'A'));
    if (c >= '0' && c <= '9') return std::string(1, c);
  }
  if (name.size() >= 2 && name.size() <= 3 && name[0] == 'F') {
    int n = 0;
    for (char c : name.substr(1)) {
      if (c < '0' || c > '9') return std::nullopt;
      n = n * 10 + (c - '0');
    }
    if (n >= 1 && n <= 12 && name[1] != '0') return std::string(name);
    return std::nullopt;
  }
  if (name.size() == 4 && name.substr(0, 3) == "KP_" && name[3] >= '0' && name[3] <= '9') return std::string(name);
  static constexpr std::string_view named[] = {
      "SPACE", "ENTER", "TAB",      "BACKSPACE", "ESCAPE", "LEFT",  "RIGHT", "UP",        "DOWN", "HOME",
      "END",   "INSERT", "DELETE", "PAGE_UP",   "PAGE_DOWN", "COMMA", "PERIOD", "MINUS", "SLASH", "SEMICOLON",
  };
  for (const auto n : named)
    if (n == name) return std::string(name);
  return std::nullopt;
}

int InstallationConfig::line_of(const std::string& key) const {
  const auto it = lines.find(key);
  return it == lines.end() ? 0 : it->second;
}

namespace {
/// The rest of `p` after "${data_dir}" (and its separator), or nullopt when it does not start so.
std::optional<std::string> after_data_dir(const std::filesystem::path& p) {
  const std::string s = p.generic_string();
  if (s.rfind(kDataDirPlaceholder, 0) != 0) return std::nullopt;
  std::string rest = s.substr(kDataDirPlaceholder.size());
  while (!rest.empty() && rest.front() == '/') rest.erase(0, 1);
  return rest;
}
}  // namespace

std::filesystem::path InstallationConfig::data_root() const {
  if (data_dir_override && !data_dir_override->empty()) return *data_dir_override;
  if (data_dir.empty()) return {};
  if (data_dir.is_absolute()) return data_dir;
  return (file.has_parent_path() ? file.parent_path() : std::filesystem::path(".")) / data_dir;
}

std::filesystem::path InstallationConfig::resolve(const std::filesystem::path& p) const {
  if (const auto rest = after_data_dir(p)) return rest->empty() ? data_root() : data_root() / *rest;
  if (p.empty() || p.is_absolute()) return p;
  return (file.has_parent_path() ? file.parent_path() : std::filesystem::path(".")) / p;
}

int InstallationConfig::window_of(std::size_t w) const {
  const auto& name = walls.at(w).window;
  if (name.empty()) return 0;
  for (std::size_t i = 0; i < windows.size(); ++i)
    if (windows[i].name == name) return static_cast<int>(i);
  return -1;
}

bool InstallationConfig::operator==(const InstallationConfig& o) const {
  return display_rate_hz == o.display_rate_hz && late_latch == o.late_latch &&
         display_latency_ms == o.display_latency_ms && windows == o.windows && walls == o.walls &&
         stereo == o.stereo && viewer == o.viewer && projection == o.projection &&
         keys == o.keys && characters == o.characters && fighter == o.fighter &&
         tracking == o.tracking && recognition == o.recognition && orders_script == o.orders_script && data_dir == o.data_dir &&
         health == o.health && safety == o.safety && record_budget_mb == o.record_budget_mb &&
         console == o.console && frames_log_budget_mb == o.frames_log_budget_mb && render == o.render &&
         cluster == o.cluster;
}

std::string check_wall_geometry(const WallConfig& w) {
  const Vec3 right = sub(w.lower_right, w.lower_left);
  const Vec3 up = sub(w.upper_left, w.lower_left);
  const double lr = norm(right), lu = norm(up);
  if (lr < kMinEdgeM || lu < kMinEdgeM)
    return fmt::format("degenerate: corners coincide (edges {:.3f} m and {:.3f} m)", lr, lu);
  const double c = dot(right, up) / (lr * lu);
  if (std::abs(c) > 1.0 - 1e-9) return "degenerate: the three corners lie on one line";
  const double angle = std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / kPi;
  if (std::abs(angle - 90.0) > kMaxSkewDeg)
    return fmt::format(
        "skewed: lower_left->lower_right and lower_left->upper_left meet at {:.2f} deg, not 90 "
        "(tolerance {} deg)",
        angle, kMaxSkewDeg);
  if (w.upper_right) {
    const Vec3 implied{w.lower_right[0] + up[0], w.lower_right[1] + up[1], w.lower_right[2] + up[2]};
    const double miss = norm(sub(*w.upper_right, implied));
    if (miss > kCornerToleranceM)
      return fmt::format(
          "not rectangular: upper_right is {:.3f} m from the corner the other three imply "
          "[{:.3f}, {:.3f}, {:.3f}]",
          miss, implied[0], implied[1], implied[2]);
  }
  return {};
}

namespace {
/// Every number of the file has a range: `key` (its file line) fails with it otherwise. NaN
/// fails too (the reader refuses it first; a config built in code meets it here).
void in_range(const InstallationConfig& c, const std::string& key, double v, double lo, double hi, std::string_view unit) {
  if (!(v >= lo && v <= hi))
    fail_at(c, "range", key, fmt::format("must be in [{}, {}]{}{} (found {})", lo, hi, unit.empty() ? "" : " ", unit, v));
}
/// The room's extent a position may lie in (m, each coordinate): no CAVE is 100 m across; a
/// value beyond it is a unit mistake (millimetres) or a typo.
constexpr double kRoomExtentM = 100.0;
void in_room(const InstallationConfig& c, const std::string& key, const Vec3& v) {
  for (int k = 0; k < 3; ++k)
    if (!(std::abs(v[static_cast<std::size_t>(k)]) <= kRoomExtentM))
      fail_at(c, "range", key,
              fmt::format("[{}, {}, {}]: each coordinate must be within +-{} m of the room's origin (millimetres "
                          "instead of metres?)",
                          v[0], v[1], v[2], kRoomExtentM));
}
/// The ranges of the numbers validate() does not check with a relation of their own.
void validate_ranges(const InstallationConfig& c) {
  for (std::size_t i = 0; i < c.walls.size(); ++i) {
    const auto& w = c.walls[i];
    const std::string p = fmt::format("walls[{}]", i);
    in_room(c, p + ".lower_left", w.lower_left);
    in_room(c, p + ".lower_right", w.lower_right);
    in_room(c, p + ".upper_left", w.upper_left);
    if (w.upper_right) in_room(c, p + ".upper_right", *w.upper_right);
  }
  for (std::size_t i = 0; i < c.windows.size(); ++i) {
    const auto& w = c.windows[i];
    const std::string p = fmt::format("windows[{}]", i);
    for (int k = 0; k < 2; ++k) {
      in_range(c, p + ".size", w.size[static_cast<std::size_t>(k)], 1, 16384, "px");
      in_range(c, p + ".position", w.position[static_cast<std::size_t>(k)], -32768, 32767, "px");
    }
    in_range(c, p + ".monitor", w.monitor, 0, 64, "");
  }
  const auto& v = c.viewer;
  in_room(c, "viewer.default_head_m", v.default_head_m);
  in_range(c, "viewer.default_head_m", v.default_head_m[1], 0.5, 2.5, "m high (a standing visitor's eyes)");
  in_range(c, "projection.near_m", c.projection.near_m, 1e-3, 1, "m");
  in_range(c, "projection.far_m", c.projection.far_m, 1, 1e4, "m");
  const auto& f = c.fighter;
  in_range(c, "fighter.strike_distance_m", f.strike_distance_m, 0.3, 3, "m");
  in_range(c, "fighter.hit_radius_m", f.hit_radius_m, 0.01, 1, "m");
  for (const auto& [key, lim] : {std::pair{"fighter.x_limits_m", f.x_limits_m}, std::pair{"fighter.z_limits_m", f.z_limits_m}})
    for (const double x : lim) in_range(c, key, x, -kRoomExtentM, kRoomExtentM, "m");
  in_room(c, "fighter.home_m", f.home_m);
  in_range(c, "fighter.home_m", f.home_m[1], -0.5, 0.5, "m high (on the floor)");
  const auto& t = c.tracking;
  in_range(c, "tracking.lost_after_s", t.lost_after_s, 0.01, 10, "s");
  in_range(c, "tracking.recording_preload", t.recording_preload, 0, 1e6, "frame sets");
  if (t.head_body) in_range(c, "tracking.head_body", *t.head_body, 0, 1024, "");
}
}  // namespace

namespace {
/// The cluster's nodes against the walls and windows (cluster::parse_cluster_config checked
/// each node alone): every wall and window a node names exists, no wall is drawn by two nodes.
void validate_cluster(const InstallationConfig& c) {
  if (!c.cluster) return;
  std::map<std::string, std::string> drawn_by;
  for (std::size_t i = 0; i < c.cluster->nodes.size(); ++i) {
    const auto& n = c.cluster->nodes[i];
    const std::string p = fmt::format("cluster.nodes[{}]", i);
    for (const auto& w : n.walls) {
      if (std::none_of(c.walls.begin(), c.walls.end(), [&](const WallConfig& x) { return x.name == w; }))
        fail_at(c, "unknown_wall", p + ".walls", fmt::format("node \"{}\": no wall \"{}\" in [[walls]]", n.name, w));
      if (const auto [it, fresh] = drawn_by.emplace(w, n.name); !fresh)
        fail_at(c, "duplicate", p + ".walls",
                fmt::format("wall \"{}\" is drawn by nodes \"{}\" and \"{}\": one node per wall", w, it->second, n.name));
    }
    for (const auto& w : n.windows)
      if (std::none_of(c.windows.begin(), c.windows.end(), [&](const WindowConfig& x) { return x.name == w; }))
        fail_at(c, "unknown_window", p + ".windows", fmt::format("node \"{}\": no window \"{}\" in [[windows]]", n.name, w));
  }
}
}  // namespace

void validate(const InstallationConfig& c) {
  validate_ranges(c);
  validate_cluster(c);
  if (!(c.display_rate_hz > 0 && c.display_rate_hz <= 1000))
    fail_at(c, "range", "display_rate_hz", "must be in (0, 1000] Hz");
  if (!(c.record_budget_mb > 0 && c.record_budget_mb <= 1e7))
    fail_at(c, "range", "record.budget_mb", "must be in (0, 10000000] MB");
  if (!(c.display_latency_ms >= 0 && c.display_latency_ms <= 100))
    fail_at(c, "range", "display_latency_ms", "must be in [0, 100] ms (the projectors' input lag)");
  if (c.walls.empty()) fail_at(c, "missing_wall", "walls", "no [[walls]]: at least one wall is needed");
  std::set<std::string> names;
  for (std::size_t i = 0; i < c.windows.size(); ++i) {
    const auto& w = c.windows[i];
    const std::string p = fmt::format("windows[{}]", i);
    if (w.name.empty()) fail_at(c, "empty", p + ".name", "empty window name");
    if (!names.insert(w.name).second)
      fail_at(c, "duplicate", p + ".name", "window \"" + w.name + "\" is defined twice");
    if (w.size[0] <= 0 || w.size[1] <= 0) fail_at(c, "range", p + ".size", "size must be positive");
    if (w.monitor < 0) fail_at(c, "range", p + ".monitor", "monitor index must be >= 0");
  }
  names.clear();
  for (std::size_t i = 0; i < c.walls.size(); ++i) {
    const auto& w = c.walls[i];
    const std::string p = fmt::format("walls[{}]", i);
    if (w.name.empty()) fail_at(c, "empty", p + ".name", "empty wall name");
    if (!names.insert(w.name).second)
      fail_at(c, "duplicate", p + ".name", "wall \"" + w.name + "\" is defined twice");
    if (const std::string geo = check_wall_geometry(w); !geo.empty())
      fail_at(c, "wall_geometry", p, "wall \"" + w.name + "\" is " + geo);
    if (w.resolution[0] <= 0 || w.resolution[1] <= 0 || w.resolution[0] > 16384 ||
        w.resolution[1] > 16384)
      fail_at(c, "range", p + ".resolution",
              "wall \"" + w.name + "\": resolution must be 1..16384 pixels each way");
    if (!w.window.empty() && c.window_of(i) < 0)
      fail_at(c, "unknown_window", p + ".window",
              "wall \"" + w.name + "\" names window \"" + w.window + "\", which is not defined");
    if (w.viewport && ((*w.viewport)[2] <= 0 || (*w.viewport)[3] <= 0))
      fail_at(c, "range", p + ".viewport", "wall \"" + w.name + "\": viewport size must be positive");
    if (const int win = c.window_of(i); w.viewport && win >= 0 && win < static_cast<int>(c.windows.size())) {
      const auto& v = *w.viewport;
      const auto& size = c.windows[static_cast<std::size_t>(win)].size;
      if (v[0] < 0 || v[1] < 0 || v[0] + v[2] > size[0] || v[1] + v[3] > size[1])
        fail_at(c, "range", p + ".viewport",
                fmt::format("wall \"{}\": viewport [{}, {}, {}, {}] does not fit window \"{}\" ({}x{})", w.name,
                            v[0], v[1], v[2], v[3], c.windows[static_cast<std::size_t>(win)].name, size[0], size[1]));
    }
    // The corners as seen from inside the room: the wall's front (lower_left->lower_right x
    // lower_left->upper_left) faces the visitor. Listed from outside, every eye is behind it.
    const Vec3 normal = cross(sub(w.lower_right, w.lower_left), sub(w.upper_left, w.lower_left));
    const double ahead = dot(sub(c.viewer.default_head_m, w.lower_left), normal) / norm(normal);
    if (ahead < kMinEdgeM)
      fail_at(c, "wall_geometry", p,
              fmt::format("wall \"{}\" faces away from the default head [{}, {}, {}] ({:.2f} m behind its plane): "
                          "give its corners as seen from inside the room (swap lower_left and lower_right)",
                          w.name, c.viewer.default_head_m[0], c.viewer.default_head_m[1],
                          c.viewer.default_head_m[2], -ahead));
  }
  if (c.stereo.fallback == StereoMode::quad_buffer)
    fail_at(c, "stereo_fallback", "stereo.fallback", "quad_buffer cannot be its own fallback");
  const auto& v = c.viewer;
  if (!(v.interpupillary_distance_m >= 0 && v.interpupillary_distance_m <= 0.1))
    fail_at(c, "range", "viewer.interpupillary_distance_m", "must be in [0, 0.1] m");
  if (norm(v.eye_offset_m) > 0.3)
    fail_at(c, "range", "viewer.eye_offset_m", "more than 0.3 m from the markers: check the units");
  const auto& pr = c.projection;
  if (!(pr.near_m > 0 && pr.far_m > pr.near_m))
    fail_at(c, "range", "projection.near_m", "need 0 < near_m < far_m");
  // Keys: known actions, no key bound twice, characters that exist.
  std::map<std::string, std::string> used;  // canonical key name -> action
  for (const auto& k : c.keys) {
    const std::string action = to_string(k.action);
    const std::string key = "keys." + (action.rfind("character ", 0) == 0 ? "character_" + action.substr(10) : action);
    if (k.action.kind == KeyAction::Kind::order && k.action.order == OrderKind::select_character &&
        (k.action.character < 0 || k.action.character >= static_cast<int>(c.characters.size())))
      fail_at(c, "unknown_character", key,
              fmt::format("character {} does not exist ({} characters defined)", k.action.character + 1,
                          c.characters.size()));
    if (auto [it, fresh] = used.emplace(k.name, action); !fresh)
      fail_at(c, "duplicate_key", key,
              "key \"" + k.key + "\" is already bound to \"" + it->second + "\"");
  }
  for (std::size_t i = 0; i < c.characters.size(); ++i)
    if (c.characters[i].name.empty())
      fail_at(c, "empty", fmt::format("characters[{}].name", i), "empty character name");
  if (!c.characters.empty() &&
      (c.fighter.initial_character < 0 ||
       c.fighter.initial_character >= static_cast<int>(c.characters.size())))
    fail_at(c, "unknown_character", "fighter.initial_character",
            fmt::format("character {} does not exist ({} characters defined)",
                        c.fighter.initial_character + 1, c.characters.size()));
  if (c.fighter.x_limits_m[0] >= c.fighter.x_limits_m[1])
    fail_at(c, "range", "fighter.x_limits_m", "need min < max");
  if (c.fighter.z_limits_m[0] >= c.fighter.z_limits_m[1])
    fail_at(c, "range", "fighter.z_limits_m", "need min < max");
  if (const auto& f = c.fighter; !(f.home_m[0] >= f.x_limits_m[0] && f.home_m[0] <= f.x_limits_m[1] &&
                                    f.home_m[2] >= f.z_limits_m[0] && f.home_m[2] <= f.z_limits_m[1]))
    fail_at(c, "range", "fighter.home_m",
            fmt::format("[{}, {}, {}] lies outside where the fighter may walk (x_limits_m [{}, {}], z_limits_m [{}, {}])",
                        f.home_m[0], f.home_m[1], f.home_m[2], f.x_limits_m[0], f.x_limits_m[1], f.z_limits_m[0],
                        f.z_limits_m[1]));
  const auto& t = c.tracking;
  if (t.source == TrackingSource::recording || t.source == TrackingSource::live) {
    if (t.calibration.empty())
      fail_at(c, "missing_key", "tracking", "tracking.calibration is needed for source = \"" +
                                                std::string(to_string(t.source)) + "\"");
    if (t.tracking.empty())
      fail_at(c, "missing_key", "tracking", "tracking.tracking (tracking.toml) is needed");
  }
  if (t.source == TrackingSource::recording && t.recording.empty())
    fail_at(c, "missing_key", "tracking", "tracking.recording is needed for source = \"recording\"");
  if (t.source == TrackingSource::poses && t.poses.empty())
    fail_at(c, "missing_key", "tracking", "tracking.poses (a poses.csv) is needed for source = \"poses\"");
  if (t.head_body && *t.head_body < 0) fail_at(c, "range", "tracking.head_body", "must be >= 0");
  if (t.recording_preload < 0) fail_at(c, "range", "tracking.recording_preload", "must be >= 0");
  // "${data_dir}" needs a data folder from somewhere.
  if (c.data_root().empty()) {
    std::vector<std::pair<std::string, std::filesystem::path>> paths{
        {"fighter.database", c.fighter.database}, {"tracking.calibration", t.calibration},
        {"tracking.tracking", t.tracking}, {"tracking.recording", t.recording}, {"tracking.poses", t.poses},
        {"recognition.model", c.recognition.model}};
    for (std::size_t i = 0; i < c.characters.size(); ++i)
      paths.emplace_back(fmt::format("characters[{}].bvh", i), c.characters[i].bvh);
    if (c.orders_script) paths.emplace_back("orders.script", *c.orders_script);
    if (!c.render.bodies.empty()) paths.emplace_back("render.bodies", c.render.bodies);
    for (const auto& [key, p] : paths)
      if (after_data_dir(p))
        fail_at(c, "missing_key", key,
                fmt::format("{} uses {} but no data folder is given (top-level data_dir, ${}, or "
                            "kumite --data-dir)",
                            p.generic_string(), kDataDirPlaceholder, kDataDirEnv));
  }
  if (t.decode_threads < 1 || t.decode_threads > 16)
    fail_at(c, "range", "tracking.decode_threads", "must be 1..16");
  if (t.realtime_priority < 0 || t.realtime_priority > 99)
    fail_at(c, "range", "tracking.realtime_priority", "must be 0..99 (0 = normal scheduling)");
  if (!(c.health.interval_s >= 0.1 && c.health.interval_s <= 60))
    fail_at(c, "range", "health.interval_s", "must be 0.1..60 s");
  if (c.render.fighter == FighterLook::skinned && c.render.bodies.empty())
    fail_at(c, "missing_key", "render.fighter",
            "fighter = \"skinned\" needs render.bodies (a bodies.toml, e.g. body/assets/bodies.toml)");
  if (!(c.safety.wall_distance_m >= 0.05 && c.safety.wall_distance_m <= 2))
    fail_at(c, "range", "safety.wall_distance_m", "must be 0.05..2 m");
  if (c.health.file && std::filesystem::is_directory(c.resolve(*c.health.file)))
    fail_at(c, "folder", "health.file", c.resolve(*c.health.file).string() + " is a folder, not a file");
}

namespace {
InstallationConfig parse_config(std::string_view text, const std::filesystem::path& file_name,
                                std::optional<std::filesystem::path> data_dir_override) {
  InstallationConfig cfg;
  cfg.file = file_name;
  cfg.data_dir_override = std::move(data_dir_override);
  const toml::table root = parse_toml(text, file_name.string(), "config");
  cfg.lines = toml_key_lines(root);
  Reader(file_name.string(), cfg).parse(root);
  cfg.tracking.dtrack = tracking::parse_dtrack_config(text, file_name.string(), "tracking.dtrack");
  if (cfg.lines.contains("tracking.osc")) {
    // OSC poses come in Kumite's room: the room transform and offsets are DTrack's alone.
    for (const char* key : {"bind_address", "room_axes", "rotation", "translation_m", "conjugate_body", "offsets"})
      if (const std::string k = std::string("tracking.osc.") + key; cfg.lines.contains(k))
        throw file_error("config", "unknown_key", file_name.string(), cfg.line_of(k), k,
                         "not an OSC key (OSC sends poses in Kumite's room): port, multicast_group, bodies");
    const int port = cfg.tracking.osc.port;
    cfg.tracking.osc = tracking::parse_dtrack_config(text, file_name.string(), "tracking.osc");
    if (!cfg.lines.contains("tracking.osc.port")) cfg.tracking.osc.port = port;
  }
  cfg.cluster = cluster::parse_cluster_config(text, file_name.string());
  cfg.file_hash = cluster::config_hash(text);
  content::parse_fighter_tunables(text, file_name.string(), *cfg.fighter.behaviour, *cfg.fighter.retrieval);
  content::parse_planner_tunables(text, file_name.string(), *cfg.fighter.planner, cfg.fighter.planner_seed,
                                  cfg.fighter.behaviour->follow_tolerance_m);
  validate(cfg);
  return cfg;
}
}  // namespace

InstallationConfig parse_installation_config(std::string_view text,
                                             const std::filesystem::path& file_name) {
  return parse_config(text, file_name, std::nullopt);
}

InstallationConfig load_installation_config(const std::filesystem::path& file,
                                            std::optional<std::filesystem::path> data_dir) {
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec)) {
    throw file_error("config", "open", file.string(), 0, "", "is a folder, not a file: give the installation's .toml file");
  }
  if (std::filesystem::exists(file, ec) && !std::filesystem::is_regular_file(file, ec)) {
    throw file_error("config", "open", file.string(), 0, "", "is not a regular file: give the installation's .toml file");
  }
  std::ifstream in(file, std::ios::binary);
  if (!in) throw file_error("config", "open", file.string(), 0, "", "cannot open the file");
  std::stringstream ss;
  ss << in.rdbuf();
  if (!data_dir)
    if (const char* env = std::getenv(kDataDirEnv); env && *env) data_dir = std::filesystem::path(env);
  return parse_config(ss.str(), file, std::move(data_dir));
}

std::string to_toml(const InstallationConfig& c) {
  toml::table root;
  if (!c.data_dir.empty()) root.insert("data_dir", c.data_dir.generic_string());
  root.insert("display_rate_hz", c.display_rate_hz);
  root.insert("late_latch", c.late_latch);
  root.insert("display_latency_ms", c.display_latency_ms);
  toml::array windows;
  for (const auto& w : c.windows)
    windows.push_back(toml::table{{"name", w.name},
                                  {"size", to_array(w.size)},
                                  {"position", to_array(w.position)},
                                  {"monitor", w.monitor},
                                  {"fullscreen", w.fullscreen}});
  if (!windows.empty()) root.insert("windows", std::move(windows));
  toml::array walls;
  for (const auto& w : c.walls) {
    toml::table t{{"name", w.name},
                  {"lower_left", to_array(w.lower_left)},
                  {"lower_right", to_array(w.lower_right)},
                  {"upper_left", to_array(w.upper_left)},
                  {"resolution", to_array(w.resolution)}};
    if (w.upper_right) t.insert("upper_right", to_array(*w.upper_right));
    if (!w.window.empty()) t.insert("window", w.window);
    if (w.viewport) t.insert("viewport", to_array(*w.viewport));
    walls.push_back(std::move(t));
  }
  root.insert("walls", std::move(walls));
  root.insert("stereo", toml::table{{"mode", std::string(to_string(c.stereo.mode))},
                                    {"allow_fallback", c.stereo.allow_fallback},
                                    {"fallback", std::string(to_string(c.stereo.fallback))}});
  root.insert("viewer",
              toml::table{{"interpupillary_distance_m", c.viewer.interpupillary_distance_m},
                          {"eye_offset_m", to_array(c.viewer.eye_offset_m)},
                          {"default_head_m", to_array(c.viewer.default_head_m)}});
  root.insert("projection",
              toml::table{{"near_m", c.projection.near_m}, {"far_m", c.projection.far_m}});
  toml::table keys;
  for (const auto& k : c.keys) {
    std::string action = to_string(k.action);
    if (action.rfind("character ", 0) == 0) action = "character_" + action.substr(10);
    keys.insert(action, k.key);
  }
  root.insert("keys", std::move(keys));
  toml::array chars;
  for (const auto& ch : c.characters)
    chars.push_back(toml::table{{"name", ch.name}, {"bvh", ch.bvh.generic_string()}});
  if (!chars.empty()) root.insert("characters", std::move(chars));
  const auto& f = c.fighter;
  toml::table fighter{{"initial_character", f.initial_character + 1},
                      {"home_m", to_array(f.home_m)},
                      {"strike_distance_m", f.strike_distance_m},
                      {"hit_radius_m", f.hit_radius_m},
                      {"visitor_head_radius_m", f.visitor_head_radius_m},
                      {"visitor_body_radius_m", f.visitor_body_radius_m},
                      {"x_limits_m", to_array(f.x_limits_m)},
                      {"z_limits_m", to_array(f.z_limits_m)}};
  if (!f.database.empty()) fighter.insert("database", f.database.generic_string());
  {  // the tunables that differ from their defaults (absent keys read back as the defaults)
    toml::table behaviour, feet, retrieval;
    const content::BehaviourTunables db;
    const content::RetrievalTunables dr;
    for (const content::TunableKey& k : content::fighter_tunable_keys()) {
      const double v = content::tunable_value(k, *f.behaviour, *f.retrieval);
      if (v == content::tunable_value(k, db, dr)) continue;
      (k.feet ? feet : k.retrieval ? retrieval : behaviour).insert(k.key, v);
    }
    if (!feet.empty()) behaviour.insert("feet", std::move(feet));
    if (!behaviour.empty()) fighter.insert("behaviour", std::move(behaviour));
    if (!retrieval.empty()) fighter.insert("retrieval", std::move(retrieval));
  }
  if (*f.planner != content::PlannerTunables{} || f.planner_seed != 1) {  // every key (no preset: the values are written)
    const auto& p = *f.planner;
    fighter.insert("planner", toml::table{{"mode", std::string(content::to_string(p.mode))},
                                          {"seed", static_cast<std::int64_t>(f.planner_seed)},
                                          {"fighting_distance_m", p.fighting_distance_m},
                                          {"engage_tolerance_m", p.engage_tolerance_m},
                                          {"stance_step_min_m", p.stance_step_min_m},
                                          {"follow_arc_deg", p.follow_arc_deg},
                                          {"attack_rate_per_s", p.attack_rate_per_s},
                                          {"counter_probability", p.counter_probability},
                                          {"reaction_time_s", p.reaction_time_s},
                                          {"counter_deadline_s", p.counter_deadline_s},
                                          {"kick_share", p.kick_share},
                                          {"abort_probability", p.abort_probability},
                                          {"block", p.block},
                                          {"block_max_rate", p.block_max_rate},
                                          {"threat_min_speed_mps", p.threat.min_speed_mps},
                                          {"threat_min_closing_mps", p.threat.min_closing_mps},
                                          {"threat_horizon_s", p.threat.horizon_s},
                                          {"threat_aim_radius_m", p.threat.aim_radius_m},
                                          {"threat_velocity_window_s", p.threat.velocity_window_s},
                                          {"threat_min_extension", p.threat.min_extension},
                                          {"threat_two_hand_mirror", p.threat.two_hand_mirror},
                                          {"hit_min_speed_mps", p.hit_min_speed_mps},
                                          {"hit_full_speed_mps", p.hit_full_speed_mps},
                                          {"hit_head_max_deg", p.hit_head_max_deg},
                                          {"hit_trunk_max_deg", p.hit_trunk_max_deg},
                                          {"hit_shoulder_max_deg", p.hit_shoulder_max_deg},
                                          {"hit_stiffness_rad_s", p.hit_stiffness_rad_s},
                                          {"hit_damping_ratio", p.hit_damping_ratio},
                                          {"hit_step_back_m", p.hit_step_back_m},
                                          {"hit_step_back_share", p.hit_step_back_share}});
  }
  root.insert("fighter", std::move(fighter));
  const auto& t = c.tracking;
  toml::table tracking{{"source", std::string(to_string(t.source))},
                       {"lost_after_s", t.lost_after_s},
                       {"recording_preload", t.recording_preload},
                       {"decode_threads", t.decode_threads},
                       {"realtime_priority", t.realtime_priority}};
  if (t.head_body) tracking.insert("head_body", *t.head_body);
  if (!t.calibration.empty()) tracking.insert("calibration", t.calibration.generic_string());
  if (!t.tracking.empty()) tracking.insert("tracking", t.tracking.generic_string());
  if (!t.recording.empty()) tracking.insert("recording", t.recording.generic_string());
  if (!t.poses.empty()) tracking.insert("poses", t.poses.generic_string());
  if (!t.poses_loop) tracking.insert("poses_loop", false);
  if (t.source == TrackingSource::dtrack || t.dtrack != tracking::DtrackInput{})
    tracking.insert("dtrack", dtrack_table(t.dtrack, true));
  if (t.source == TrackingSource::osc || t.osc != TrackingConfig{}.osc) tracking.insert("osc", dtrack_table(t.osc, false));
  if (!t.out_dtrack.empty() || !t.out_osc.empty()) {
    toml::table out;
    if (!t.out_dtrack.empty()) out.insert("dtrack", t.out_dtrack);
    if (!t.out_osc.empty()) out.insert("osc", t.out_osc);
    tracking.insert("out", std::move(out));
  }
  root.insert("tracking", std::move(tracking));
  if (!c.recognition.model.empty())
    root.insert("recognition", toml::table{{"model", c.recognition.model.generic_string()}});
  if (c.orders_script) root.insert("orders", toml::table{{"script", c.orders_script->generic_string()}});
  if (c.health.file || c.health.interval_s != HealthConfig{}.interval_s) {
    toml::table health{{"interval_s", c.health.interval_s}};
    if (c.health.file) health.insert("file", c.health.file->generic_string());
    root.insert("health", std::move(health));
  }
  if (c.safety != SafetyConfig{})
    root.insert("safety", toml::table{{"enabled", c.safety.enabled}, {"wall_distance_m", c.safety.wall_distance_m}});
  if (c.frames_log_budget_mb != InstallationConfig{}.frames_log_budget_mb)
    root.insert("log", toml::table{{"frames_budget_mb", c.frames_log_budget_mb}});
  if (c.console != ConsoleWindowConfig{}) {
    toml::table con{{"size", toml::array{c.console.size[0], c.console.size[1]}},
                    {"quit_confirm_s", c.console.quit_confirm_s}};
    if (c.console.position) con.insert("position", toml::array{(*c.console.position)[0], (*c.console.position)[1]});
    root.insert("console", std::move(con));
  }
  if (c.render != RenderConfig{}) {
    toml::table rd{{"fighter", std::string(to_string(c.render.fighter))},
                   {"debug_marks", c.render.debug_marks},
                   {"hall", c.render.hall}};
    if (!c.render.bodies.empty()) rd.insert("bodies", c.render.bodies.generic_string());
    root.insert("render", std::move(rd));
  }
  root.insert("record", toml::table{{"budget_mb", c.record_budget_mb}});
  if (const auto& cl = c.cluster) {
    toml::table ct{{"state", cl->state}, {"control", cl->control}, {"max_misses", cl->max_misses},
                  {"master_lost_ms", cl->master_lost_ms}};
    if (cl->state_bind) ct.insert("state_bind", *cl->state_bind);
    if (cl->control_bind) ct.insert("control_bind", *cl->control_bind);
    if (cl->deadline_ms) ct.insert("deadline_ms", *cl->deadline_ms);
    toml::array nodes;
    for (const auto& n : cl->nodes) {
      toml::array node_walls, node_windows;
      for (const auto& w : n.walls) node_walls.push_back(w);
      for (const auto& w : n.windows) node_windows.push_back(w);
      toml::table nt{{"name", n.name}, {"walls", std::move(node_walls)}};
      if (n.address) nt.insert("address", *n.address);
      if (!n.windows.empty()) nt.insert("windows", std::move(node_windows));
      if (n.swap_group) nt.insert("swap_group", *n.swap_group);
      if (n.swap_barrier) nt.insert("swap_barrier", *n.swap_barrier);
      nodes.push_back(std::move(nt));
    }
    ct.insert("nodes", std::move(nodes));
    root.insert("cluster", std::move(ct));
  }
  std::ostringstream out;
  out << root << "\n";
  return out.str();
}

}  // namespace kumite::app
