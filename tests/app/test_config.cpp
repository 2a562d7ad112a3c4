// The installation file: round trips and every bad-config case, each naming file, line, key.
#include <gtest/gtest.h>

#include <set>

#include <algorithm>
#include <string>
#include <vector>

#include "kumite/app/config.hpp"
#include "kumite/app/run.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/tunables.hpp"

using namespace kumite::app;

namespace {

// Line numbers below matter: the tests check that errors name them.
const std::string kBase = R"(display_rate_hz = 60.0
[[windows]]
name = "main"
size = [1280, 720]

[[walls]]
name = "front"
lower_left = [-1.5, 0.0, -1.5]
lower_right = [1.5, 0.0, -1.5]
upper_left = [-1.5, 2.4, -1.5]
resolution = [1920, 1080]
window = "main"

[stereo]
mode = "side_by_side"

[keys]
punch_left = "J"
character_1 = "1"

[[characters]]
name = "Wu"
bvh = "wu.bvh"
)";

std::string replace(std::string s, const std::string& from, const std::string& to) {
  const auto at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

/// The one-line message of the error parsing `text` raises ("" when it parses).
std::string error_of(const std::string& text, std::string* code = nullptr) {
  try {
    parse_installation_config(text, "bad.toml");
  } catch (const kumite::Error& e) {
    if (code) *code = e.code();
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Config, BaseParses) {
  const auto c = parse_installation_config(kBase, "base.toml");
  ASSERT_EQ(c.walls.size(), 1u);
  EXPECT_EQ(c.walls[0].name, "front");
  EXPECT_EQ(c.stereo.mode, StereoMode::side_by_side);
  ASSERT_EQ(c.keys.size(), 2u);
  // toml++ keeps keys sorted: "character_1" comes first.
  EXPECT_EQ(to_string(c.keys[0].action), "character 1");
  EXPECT_EQ(to_string(c.keys[1].action), "punch_left");
  EXPECT_EQ(c.window_of(0), 0);
  EXPECT_EQ(c.line_of("walls[0].lower_left"), 8);
}

TEST(Config, RoundTrip) {
  const auto a = parse_installation_config(kBase, "base.toml");
  const std::string text = to_toml(a);
  const auto b = parse_installation_config(text, "again.toml");
  EXPECT_EQ(a, b) << text;
  EXPECT_EQ(to_toml(b), text);
}

TEST(Config, DemoFileRoundTrips) {
  const auto a = load_installation_config(KUMITE_SOURCE_DIR + "/config/demo.toml");
  EXPECT_GE(a.walls.size(), 4u);
  const auto b = parse_installation_config(to_toml(a), "again.toml");
  EXPECT_EQ(a, b);
}

TEST(Config, MissingWall) {
  std::string code;
  const auto text = kBase.substr(0, kBase.find("[[walls]]")) + kBase.substr(kBase.find("[stereo]"));
  const auto msg = error_of(text, &code);
  EXPECT_EQ(code, "missing_wall");
  EXPECT_NE(msg.find("bad.toml:1: walls:"), std::string::npos) << msg;
}

TEST(Config, UnknownStereoMode) {
  std::string code;
  const auto msg = error_of(replace(kBase, "\"side_by_side\"", "\"interlaced\""), &code);
  EXPECT_EQ(code, "unknown_stereo_mode");
  EXPECT_NE(msg.find("bad.toml:15: stereo.mode: unknown stereo mode \"interlaced\""),
            std::string::npos) << msg;
}

TEST(Config, UnknownKeyName) {
  std::string code;
  const auto msg = error_of(replace(kBase, "punch_left = \"J\"", "punch_left = \"Jay\""), &code);
  EXPECT_EQ(code, "unknown_key_name");
  EXPECT_NE(msg.find("bad.toml:18: keys.punch_left: unknown key name \"Jay\""), std::string::npos)
      << msg;
}

// The config reader knows key names without GLFW; every name it accepts has a GLFW code in the
// windowed runner (run.hpp), and no two names share one.
TEST(Config, EveryKeyNameTheReaderAcceptsHasAWindowKeyCode) {
  std::vector<std::string> names = {"SPACE", "ENTER", "TAB", "BACKSPACE", "ESCAPE", "LEFT", "RIGHT", "UP",
                                    "DOWN", "HOME", "END", "INSERT", "DELETE", "PAGE_UP", "PAGE_DOWN",
                                    "COMMA", "PERIOD", "MINUS", "SLASH", "SEMICOLON"};
  for (char c = 'A'; c <= 'Z'; ++c) names.emplace_back(1, c);
  for (char c = '0'; c <= '9'; ++c) names.emplace_back(1, c);
  for (int f = 1; f <= 12; ++f) names.push_back("F" + std::to_string(f));
  for (int k = 0; k <= 9; ++k) names.push_back("KP_" + std::to_string(k));
  std::set<int> codes;
  for (const auto& n : names) {
    ASSERT_EQ(canonical_key_name(n), n);
    const auto code = glfw_key_code(n);
    ASSERT_TRUE(code.has_value()) << n;
    EXPECT_TRUE(codes.insert(*code).second) << n << " shares its code";
  }
  EXPECT_EQ(canonical_key_name("j"), "J");
  for (const char* bad : {"F13", "F0", "F01", "KP_A", "Jay", "", "space"}) EXPECT_FALSE(canonical_key_name(bad)) << bad;
  // "j" and "J" are one key: binding both is refused.
  EXPECT_NE(error_of(replace(kBase, "character_1 = \"1\"", "character_1 = \"j\"")).find("is already bound"),
            std::string::npos);
}

TEST(Config, UnknownAction) {
  const auto msg = error_of(replace(kBase, "punch_left = \"J\"", "uppercut = \"J\""));
  EXPECT_NE(msg.find("bad.toml:18: keys.uppercut: unknown action"), std::string::npos) << msg;
}

TEST(Config, KeyBoundTwice) {
  const auto msg = error_of(replace(kBase, "character_1 = \"1\"", "character_1 = \"j\""));
  EXPECT_NE(msg.find("bad.toml:18: keys.punch_left: key \"J\" is already bound to \"character 1\""),
            std::string::npos) << msg;
}

TEST(Config, KeyForCharacterThatDoesNotExist) {
  std::string code;
  const auto msg = error_of(replace(kBase, "character_1 = \"1\"", "character_3 = \"3\""), &code);
  EXPECT_EQ(code, "unknown_character");
  EXPECT_NE(msg.find("bad.toml:19: keys.character_3: character 3 does not exist (1 characters"),
            std::string::npos) << msg;
}

TEST(Config, DegenerateWall) {
  std::string code;
  const auto msg = error_of(replace(kBase, "upper_left = [-1.5, 2.4, -1.5]",
                                    "upper_left = [-1.5, 0.0, -1.5]"), &code);
  EXPECT_EQ(code, "wall_geometry");
  EXPECT_NE(msg.find("bad.toml:6: walls[0]: wall \"front\" is degenerate"), std::string::npos)
      << msg;
  // Collinear corners are degenerate too.
  const auto msg2 = error_of(replace(kBase, "upper_left = [-1.5, 2.4, -1.5]",
                                     "upper_left = [4.5, 0.0, -1.5]"));
  EXPECT_NE(msg2.find("wall \"front\" is degenerate: the three corners lie on one line"),
            std::string::npos) << msg2;
}

TEST(Config, SkewedWall) {
  const auto msg = error_of(replace(kBase, "upper_left = [-1.5, 2.4, -1.5]",
                                    "upper_left = [-1.2, 2.4, -1.5]"));
  EXPECT_NE(msg.find("walls[0]: wall \"front\" is skewed"), std::string::npos) << msg;
  // A survey a millimetre off is fine.
  EXPECT_EQ(error_of(replace(kBase, "upper_left = [-1.5, 2.4, -1.5]",
                             "upper_left = [-1.501, 2.4, -1.5]")), "");
}

TEST(Config, WallListedFromOutsideTheRoom) {
  // lower_left and lower_right swapped: the wall's front faces away from the visitor.
  const auto msg = error_of(replace(replace(kBase, "lower_left = [-1.5, 0.0, -1.5]", "lower_left = [1.5, 0.0, -1.5]"),
                                    "lower_right = [1.5, 0.0, -1.5]\nupper_left = [-1.5, 2.4, -1.5]",
                                    "lower_right = [-1.5, 0.0, -1.5]\nupper_left = [1.5, 2.4, -1.5]"));
  EXPECT_NE(msg.find("walls[0]: wall \"front\" faces away from the default head [0, 1.7, 0] (1.50 m behind its plane)"),
            std::string::npos) << msg;
}

TEST(Config, ViewportOutsideItsWindow) {
  const auto msg = error_of(replace(kBase, "window = \"main\"\n", "window = \"main\"\nviewport = [640, 360, 960, 540]\n"));
  EXPECT_NE(msg.find("walls[0].viewport: wall \"front\": viewport [640, 360, 960, 540] does not fit window \"main\" (1280x720)"),
            std::string::npos) << msg;
  EXPECT_EQ(error_of(replace(kBase, "window = \"main\"\n", "window = \"main\"\nviewport = [640, 360, 640, 360]\n")), "");
}

TEST(Config, NonRectangularWall) {
  const auto msg = error_of(replace(kBase, "resolution = [1920, 1080]",
                                    "upper_right = [1.5, 2.6, -1.5]\nresolution = [1920, 1080]"));
  EXPECT_NE(msg.find("wall \"front\" is not rectangular: upper_right is 0.200 m"),
            std::string::npos) << msg;
  EXPECT_EQ(error_of(replace(kBase, "resolution = [1920, 1080]",
                             "upper_right = [1.5, 2.4, -1.5]\nresolution = [1920, 1080]")), "");
}

TEST(Config, WallOnUnknownWindow) {
  const auto msg = error_of(replace(kBase, "window = \"main\"", "window = \"side\""));
  EXPECT_NE(msg.find("bad.toml:12: walls[0].window: wall \"front\" names window \"side\""),
            std::string::npos) << msg;
}

TEST(Config, UnknownKeyInTable) {
  const auto msg = error_of(replace(kBase, "resolution = [1920, 1080]", "resolutoin = [1920, 1080]"));
  EXPECT_NE(msg.find("bad.toml:11: walls[0].resolutoin: unknown key"), std::string::npos) << msg;
}

TEST(Config, WrongTypeAndMissingCorner) {
  auto msg = error_of(replace(kBase, "lower_left = [-1.5, 0.0, -1.5]", "lower_left = [-1.5, 0.0]"));
  EXPECT_NE(msg.find("bad.toml:8: walls[0].lower_left: must be an array of 3 numbers"),
            std::string::npos) << msg;
  msg = error_of(replace(kBase, "lower_left = [-1.5, 0.0, -1.5]\n", ""));
  EXPECT_NE(msg.find("walls[0].lower_left: is required"), std::string::npos) << msg;
}

TEST(Config, SyntaxErrorNamesTheLine) {
  const auto msg = error_of(replace(kBase, "mode = \"side_by_side\"", "mode = side_by_side\""));
  EXPECT_NE(msg.find("bad.toml:15:"), std::string::npos) << msg;
}

TEST(Config, TrackingNeedsItsFiles) {
  const auto msg = error_of(kBase + "[tracking]\nsource = \"recording\"\ncalibration = \"c.yaml\"\n"
                                    "tracking = \"t.toml\"\n");
  EXPECT_NE(msg.find("tracking.recording is needed"), std::string::npos) << msg;
  const auto msg2 = error_of(kBase + "[tracking]\nsource = \"tape\"\n");
  EXPECT_NE(msg2.find("tracking.source: unknown tracking source \"tape\""), std::string::npos) << msg2;
}

TEST(Config, TrackingPlaybackSettingsOutOfRange) {
  // The bad key stands on line 25: kBase has 23 lines, then "[tracking]".
  const auto priority = error_of(kBase + "[tracking]\nrealtime_priority = 120\n");
  EXPECT_NE(priority.find("bad.toml:25: tracking.realtime_priority: must be 0..99"), std::string::npos) << priority;
  const auto threads = error_of(kBase + "[tracking]\ndecode_threads = 0\n");
  EXPECT_NE(threads.find("bad.toml:25: tracking.decode_threads: must be 1..16"), std::string::npos) << threads;
  const auto preload = error_of(kBase + "[tracking]\nrecording_preload = -1\n");
  EXPECT_NE(preload.find("bad.toml:25: tracking.recording_preload: must be in [0, 1000000] frame sets (found -1)"), std::string::npos) << preload;
  EXPECT_EQ(error_of(kBase + "[tracking]\nrealtime_priority = 10\ndecode_threads = 2\nrecording_preload = 480\n"), "");
}

TEST(Config, MissingFile) {
  try {
    load_installation_config("/nonexistent/kumite.toml");
    FAIL();
  } catch (const kumite::Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/kumite.toml"), std::string::npos);
  }
}

TEST(Config, ResolveIsRelativeToTheFile) {
  auto c = parse_installation_config(kBase, "/etc/kumite/room.toml");
  EXPECT_EQ(c.resolve("wu.bvh"), std::filesystem::path("/etc/kumite/wu.bvh"));
  EXPECT_EQ(c.resolve("/abs/x"), std::filesystem::path("/abs/x"));
}

TEST(Config, CaveWithOneWindowPerWall) {
  const auto a = load_installation_config(KUMITE_SOURCE_DIR + "/config/walls-cave-4windows.toml");
  ASSERT_EQ(a.windows.size(), 4u);
  ASSERT_EQ(a.walls.size(), 4u);
  for (std::size_t w = 0; w < 4; ++w) EXPECT_EQ(a.window_of(w), static_cast<int>(w));
  EXPECT_EQ(a.stereo.mode, StereoMode::quad_buffer);
  EXPECT_FALSE(a.stereo.allow_fallback);
  EXPECT_EQ(parse_installation_config(to_toml(a), "again.toml"), a);
}

TEST(Config, DataDirPlaceholder) {
  const std::string fighter = "[fighter]\ndatabase = \"${data_dir}/fighter.kdb\"\n";
  // Used without a data folder: the key is named.
  const auto msg = error_of(kBase + fighter);
  EXPECT_NE(msg.find("bad.toml:25: fighter.database: ${data_dir}/fighter.kdb uses ${data_dir}"), std::string::npos)
      << msg;
  // data_dir is relative to the file's folder; an override (--data-dir, KUMITE_DATA_DIR) wins.
  auto c = parse_installation_config("data_dir = \"../build/demo\"\n" + kBase + fighter, "/etc/kumite/room.toml");
  EXPECT_EQ(c.resolve(c.fighter.database), std::filesystem::path("/etc/kumite/../build/demo/fighter.kdb"));
  EXPECT_EQ(c.resolve("wu.bvh"), std::filesystem::path("/etc/kumite/wu.bvh"));
  c.data_dir_override = "/data/run7";
  EXPECT_EQ(c.resolve(c.fighter.database), std::filesystem::path("/data/run7/fighter.kdb"));
  // It round-trips (the override is not written back).
  EXPECT_EQ(parse_installation_config(to_toml(c), "/etc/kumite/room.toml"), c);
}

TEST(Config, DemoFindsItsDataThroughTheOverride) {
  const auto c = load_installation_config(KUMITE_SOURCE_DIR + "/config/demo.toml", std::filesystem::path("/x/demo"));
  EXPECT_EQ(c.resolve(c.tracking.recording), std::filesystem::path("/x/demo/recording"));
  EXPECT_EQ(c.resolve(c.fighter.database), std::filesystem::path("/x/demo/fighter.kdb"));
}

TEST(Config, DisplayLatencyIsZeroUnlessMeasured) {
  EXPECT_EQ(parse_installation_config(kBase, "base.toml").display_latency_ms, 0.0);
  const auto lag = parse_installation_config("display_latency_ms = 35.5\n" + std::string(kBase), "lag.toml");
  EXPECT_EQ(lag.display_latency_ms, 35.5);
  EXPECT_EQ(parse_installation_config(to_toml(lag), "again.toml"), lag);
  const auto msg = error_of("display_latency_ms = -3\n" + std::string(kBase));
  EXPECT_NE(msg.find("bad.toml:1: display_latency_ms: must be in [0, 100] ms"), std::string::npos) << msg;
}

TEST(Config, LateLatchIsOnUnlessTurnedOff) {
  EXPECT_TRUE(parse_installation_config(kBase, "base.toml").late_latch);
  const auto off = parse_installation_config("late_latch = false\n" + std::string(kBase), "off.toml");
  EXPECT_FALSE(off.late_latch);
  EXPECT_EQ(parse_installation_config(to_toml(off), "again.toml"), off);
  const auto msg = error_of("late_latch = \"yes\"\n" + std::string(kBase));
  EXPECT_NE(msg.find("bad.toml:1: late_latch: must be true or false"), std::string::npos) << msg;
}

// toml++ reads nan, inf, +inf and -nan as floating-point numbers: every number of the file,
// scalar or in an array, is refused with its line and key (they made null matrices in
// frames.jsonl and a 0.0 cm contact logged as a miss).
TEST(Config, VisitorBodyRadiiInRange) {
  const int base_lines = static_cast<int>(std::count(kBase.begin(), kBase.end(), '\n'));
  for (const char* bad : {"0", "-0.1", "1.5"}) {
    std::string code;
    EXPECT_EQ(error_of(kBase + "[fighter]\nvisitor_body_radius_m = " + bad + "\n", &code),
              "bad.toml:" + std::to_string(base_lines + 2) + ": fighter.visitor_body_radius_m: must be in (0, 1] m")
        << bad;
    EXPECT_EQ(code, "range");
  }
}

TEST(Config, NonFiniteNumbersAreRefusedWithLineAndKey) {
  const int base_lines = static_cast<int>(std::count(kBase.begin(), kBase.end(), '\n'));
  struct Case {
    std::string from, to;  // a line of kBase replaced ("" = `to` appended as a new table)
    int line;
    std::string key;
  };
  const int app = base_lines + 2;  // the key's line in an appended "[table]\nkey = ..."
  const std::vector<Case> cases = {
      {"display_rate_hz = 60.0", "display_rate_hz = {}", 1, "display_rate_hz"},
      {"display_rate_hz = 60.0", "display_latency_ms = {}", 1, "display_latency_ms"},
      {"lower_left = [-1.5, 0.0, -1.5]", "lower_left = [-1.5, {}, -1.5]", 8, "walls[0].lower_left"},
      {"lower_right = [1.5, 0.0, -1.5]", "lower_right = [{}, 0.0, -1.5]", 9, "walls[0].lower_right"},
      {"upper_left = [-1.5, 2.4, -1.5]", "upper_left = [-1.5, 2.4, {}]", 10, "walls[0].upper_left"},
      {"resolution = [1920, 1080]", "upper_right = [1.5, 2.4, {}]", 11, "walls[0].upper_right"},
      {"", "[viewer]\ninterpupillary_distance_m = {}", app, "viewer.interpupillary_distance_m"},
      {"", "[viewer]\neye_offset_m = [0, {}, 0]", app, "viewer.eye_offset_m"},
      {"", "[viewer]\ndefault_head_m = [{}, 1.7, 0]", app, "viewer.default_head_m"},
      {"", "[projection]\nnear_m = {}", app, "projection.near_m"},
      {"", "[projection]\nfar_m = {}", app, "projection.far_m"},
      {"", "[fighter]\nhome_m = [0, 0, {}]", app, "fighter.home_m"},
      {"", "[fighter]\nstrike_distance_m = {}", app, "fighter.strike_distance_m"},
      {"", "[fighter]\nhit_radius_m = {}", app, "fighter.hit_radius_m"},
      {"", "[fighter]\nvisitor_head_radius_m = {}", app, "fighter.visitor_head_radius_m"},
      {"", "[fighter]\nvisitor_body_radius_m = {}", app, "fighter.visitor_body_radius_m"},
      {"", "[fighter]\nx_limits_m = [{}, 1]", app, "fighter.x_limits_m"},
      {"", "[fighter]\nz_limits_m = [-4, {}]", app, "fighter.z_limits_m"},
      {"", "[tracking]\nlost_after_s = {}", app, "tracking.lost_after_s"},
      {"", "[fighter.behaviour]\nwalk_speed_mps = {}", app, "fighter.behaviour.walk_speed_mps"},
      {"", "[fighter.behaviour.feet]\nswing_lift_m = {}", app, "fighter.behaviour.feet.swing_lift_m"},
      {"", "[fighter.retrieval]\nbox_margin_m = {}", app, "fighter.retrieval.box_margin_m"},
  };
  for (const char* value : {"nan", "inf", "+inf", "-inf", "-nan", "+nan"}) {
    for (const auto& c : cases) {
      std::string to = c.to;
      to.replace(to.find("{}"), 2, value);
      const std::string text = c.from.empty() ? kBase + to + "\n" : replace(kBase, c.from, to);
      std::string code;
      EXPECT_EQ(error_of(text, &code),
                "bad.toml:" + std::to_string(c.line) + ": " + c.key + ": must be a finite number")
          << to;
      EXPECT_EQ(code, "not_finite") << to;
    }
  }
  // An element on a line of its own is named by its line.
  EXPECT_EQ(error_of(kBase + "[viewer]\ndefault_head_m = [\n  0,\n  nan,\n  0]\n"),
            "bad.toml:" + std::to_string(base_lines + 4) + ": viewer.default_head_m: must be a finite number");
}

// Every number has a range: a value that parses but makes no sense in a room (a negative
// timeout, a radius of 1e308, a home outside where the fighter may walk, a head 1e308 m up,
// corners in millimetres) is refused with its line and key, not played as if nothing were wrong.
TEST(Config, EveryNumberHasARange) {
  const int app = static_cast<int>(std::count(kBase.begin(), kBase.end(), '\n')) + 2;
  struct Case {
    std::string text, key, words;
    int line;
  };
  const std::vector<Case> cases = {
      {"[tracking]\nlost_after_s = -0.25", "tracking.lost_after_s", "must be in [0.01, 10] s (found -0.25)", app},
      {"[tracking]\nlost_after_s = 0", "tracking.lost_after_s", "must be in [0.01, 10] s", app},
      {"[fighter]\nstrike_distance_m = -0.9", "fighter.strike_distance_m", "must be in [0.3, 3] m (found -0.9)", app},
      {"[fighter]\nhit_radius_m = 1e308", "fighter.hit_radius_m", "must be in [0.01, 1] m (found 1e+308)", app},
      {"[fighter]\nhome_m = [0, 0, -1e30]", "fighter.home_m", "within +-100 m of the room's origin", app},
      {"[fighter]\nhome_m = [0, 0, -1.0]", "fighter.home_m", "lies outside where the fighter may walk", app},
      {"[fighter]\nhome_m = [0, 1.2, -2.5]", "fighter.home_m", "m high (on the floor)", app},
      {"[fighter]\nx_limits_m = [-1e9, 1]", "fighter.x_limits_m", "must be in [-100, 100] m", app},
      {"[viewer]\ndefault_head_m = [0, 1e308, 0]", "viewer.default_head_m", "within +-100 m", app},
      {"[viewer]\ndefault_head_m = [0, 0.1, 0]", "viewer.default_head_m", "m high (a standing visitor's eyes)", app},
      {"[projection]\nfar_m = 1e9", "projection.far_m", "must be in [1, 10000] m", app},
      {"[tracking]\nrecording_preload = 100000000", "tracking.recording_preload", "must be in [0, 1000000]", app},
  };
  for (const auto& c : cases) {
    std::string code;
    const std::string msg = error_of(kBase + c.text + "\n", &code);
    EXPECT_EQ(msg.rfind("bad.toml:" + std::to_string(c.line) + ": " + c.key + ": ", 0), 0u) << c.text << " -> " << msg;
    EXPECT_NE(msg.find(c.words), std::string::npos) << c.text << " -> " << msg;
    EXPECT_EQ(code, "range") << c.text;
  }
  // Corners in millimetres: named by the wall's key.
  const std::string mm = replace(kBase, "lower_left = [-1.5, 0.0, -1.5]", "lower_left = [-1500, 0.0, -1.5]");
  EXPECT_NE(error_of(mm).find("bad.toml:8: walls[0].lower_left: [-1500, 0, -1.5]: each coordinate must be within"),
            std::string::npos)
      << error_of(mm);
  // The values a site uses are fine.
  EXPECT_EQ(error_of(kBase + "[tracking]\nlost_after_s = 0.5\n[fighter]\nhome_m = [0.5, 0, -3]\nstrike_distance_m = "
                             "1.1\nhit_radius_m = 0.2\n[viewer]\ndefault_head_m = [0, 1.55, 0.3]\n"),
            "");
}

// Issue 13: the fighter's tunables live in the installation file, checked like every key, and
// survive the round trip a session snapshot makes.
TEST(Config, FighterTunablesAreReadCheckedAndWrittenBack) {
  const int base_lines = static_cast<int>(std::count(kBase.begin(), kBase.end(), '\n'));
  const auto c = parse_installation_config(
      kBase + "[fighter]\nstrike_distance_m = 0.8\n[fighter.behaviour]\nwalk_speed_mps = 0.5\nblend_time_s = 0.3\n"
              "[fighter.behaviour.feet]\nswing_lift_m = 0.08\n[fighter.retrieval]\npose_weight = 2\n",
      "room.toml");
  EXPECT_EQ(c.fighter.behaviour->walk_speed_mps, 0.5);
  EXPECT_EQ(c.fighter.behaviour->blend_time_s, 0.3);
  EXPECT_EQ(c.fighter.behaviour->feet.swing_lift_m, 0.08);
  EXPECT_EQ(c.fighter.retrieval->pose_weight, 2.0);
  EXPECT_EQ(c.fighter.behaviour->turn_speed_rad_s, kumite::content::BehaviourTunables{}.turn_speed_rad_s);
  const std::string text = to_toml(c);
  EXPECT_EQ(parse_installation_config(text, "again.toml"), c) << text;
  EXPECT_EQ(text.find("turn_speed_rad_s"), std::string::npos) << "defaults are not written";
  // A default file writes no tunables at all.
  EXPECT_EQ(to_toml(parse_installation_config(kBase, "base.toml")).find("behaviour"), std::string::npos);
  EXPECT_EQ(error_of(kBase + "[fighter.behaviour]\nwalk_speed_mps = 9\n"),
            "bad.toml:" + std::to_string(base_lines + 2) +
                ": fighter.behaviour.walk_speed_mps: must be in [0.05, 3] m/s, found 9");
  EXPECT_EQ(error_of(kBase + "[fighter]\nbehavior = 1\n").find("bad.toml:" + std::to_string(base_lines + 2) +
                                                                 ": fighter.behavior: unknown key (allowed here:"),
            0u);
}

// Issue 15: the console window's size and place (apart from the walls') and the quit
// confirmation, checked like every key and written back.
TEST(Config, ConsoleWindowIsPlacedSizedAndCheckedInTheConfig) {
  const int base_lines = static_cast<int>(std::count(kBase.begin(), kBase.end(), '\n'));
  const auto c = parse_installation_config(kBase + "[console]\nsize = [1024, 768]\nposition = [1930, 0]\nquit_confirm_s = 5\n",
                                           "room.toml");
  EXPECT_EQ(c.console.size, (std::array<int, 2>{1024, 768}));
  ASSERT_TRUE(c.console.position);
  EXPECT_EQ(*c.console.position, (std::array<int, 2>{1930, 0}));
  EXPECT_EQ(c.console.quit_confirm_s, 5.0);
  EXPECT_EQ(parse_installation_config(to_toml(c), "again.toml").console, c.console);
  EXPECT_NE(parse_installation_config(kBase, "base.toml"), c) << "the console is part of the config's equality";
  EXPECT_EQ(parse_installation_config(kBase, "base.toml").console, ConsoleWindowConfig{});
  EXPECT_EQ(error_of(kBase + "[console]\nsize = [320, 200]\n"),
            "bad.toml:" + std::to_string(base_lines + 2) +
                ": console.size: must be at least [640, 480] px (everything on the console must fit), found [320, 200]");
  EXPECT_EQ(error_of(kBase + "[console]\nquit_confirm_s = nan\n"),
            "bad.toml:" + std::to_string(base_lines + 2) + ": console.quit_confirm_s: must be a finite number");
  EXPECT_EQ(error_of(kBase + "[console]\nposition = [0]\n"),
            "bad.toml:" + std::to_string(base_lines + 2) + ": console.position: must be an array of 2 integers");
}

// Issue 13: key actions and event types are enums parsed once; text only at the edges.
TEST(Config, KeyActionsAndEventTypesRoundTripThroughTheirText) {
  for (const char* t : {"punch_left", "punch_right", "kick_left", "kick_right", "pause", "resume", "recentre",
                        "character 3", "quit"}) {
    const auto a = parse_key_action(t);
    ASSERT_TRUE(a) << t;
    EXPECT_EQ(to_string(*a), t);
  }
  EXPECT_EQ(parse_key_action("character 3")->character, 2);
  EXPECT_EQ(parse_key_action("quit")->kind, KeyAction::Kind::quit);
  EXPECT_FALSE(parse_key_action("uppercut"));
  EXPECT_FALSE(parse_key_action(""));
  for (const char* t : {"order", "order_ignored", "hit", "dodged", "miss", "character_changed", "warning"}) {
    const auto e = kumite::content::parse_event_kind(t);
    ASSERT_TRUE(e) << t;
    EXPECT_EQ(to_string(*e), t);
  }
  EXPECT_FALSE(kumite::content::parse_event_kind("Hit"));
  EXPECT_TRUE(is_strike_outcome(EventType::dodged));
  EXPECT_FALSE(is_strike_outcome(EventType::order_accepted));
}

TEST(Config, RenderSectionReadsChecksAndRoundTrips) {
  // Absent: capsules in the hall, no debug marks.
  const auto none = parse_installation_config(kBase, "base.toml");
  EXPECT_EQ(none.render.fighter, FighterLook::capsules);
  EXPECT_TRUE(none.render.hall);
  EXPECT_FALSE(none.render.debug_marks);
  const std::string render = "\n[render]\nfighter = \"skinned\"\nbodies = \"bodies.toml\"\ndebug_marks = true\nhall = false\n";
  const auto c = parse_installation_config(kBase + render, "r.toml");
  EXPECT_EQ(c.render.fighter, FighterLook::skinned);
  EXPECT_EQ(c.render.bodies, "bodies.toml");
  EXPECT_TRUE(c.render.debug_marks);
  EXPECT_FALSE(c.render.hall);
  EXPECT_EQ(parse_installation_config(to_toml(c), "again.toml"), c);
  // The shipped demos wear bodies.
  for (const char* demo : {"demo.toml", "demo-poses.toml", "demo-spar.toml", "demo-dtrack.toml"}) {
    const auto d = load_installation_config(KUMITE_SOURCE_DIR + "/config/" + demo);
    EXPECT_EQ(d.render.fighter, FighterLook::skinned) << demo;
    EXPECT_TRUE(std::filesystem::exists(d.resolve(d.render.bodies))) << demo;
    EXPECT_FALSE(d.render.debug_marks) << demo;
  }
  std::string code;
  auto msg = error_of(kBase + "\n[render]\nfighter = \"voxels\"\nbodies = \"b.toml\"\n", &code);
  EXPECT_EQ(code, "unknown_value");
  EXPECT_NE(msg.find("bad.toml:26: render.fighter: unknown fighter look \"voxels\" (skinned, capsules)"), std::string::npos) << msg;
  msg = error_of(kBase + "\n[render]\nfighter = \"skinned\"\n", &code);
  EXPECT_EQ(code, "missing_key");
  EXPECT_NE(msg.find("bad.toml:26: render.fighter: fighter = \"skinned\" needs render.bodies"), std::string::npos) << msg;
  msg = error_of(kBase + "\n[render]\ndebug_mark = true\n", &code);
  EXPECT_NE(msg.find("render"), std::string::npos) << msg;
  EXPECT_NE(msg.find("debug_mark"), std::string::npos) << msg;
}

// Issue 55: `[tracking] source = "dtrack"` with the interop library's [tracking.dtrack] table
// (port, multicast, room transform, body roles, per-role offsets), read from the same file;
// its mistakes name file, line and key; to_toml gives it back (a rotation of its own, the
// default room_axes, offsets). "osc" reads [tracking.osc]: port, multicast_group, bodies only.
TEST(Config, DtrackSourceReadsItsTableAndRoundTrips) {
  const std::string dtrack = R"([tracking]
source = "dtrack"
lost_after_s = 0.4
[tracking.dtrack]
port = 5123
multicast_group = "224.0.1.7"
rotation = [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]
translation_m = [0.5, 0.0, -0.25]
conjugate_body = false
[tracking.dtrack.bodies]
head = 3
left_hand = 7
right_foot = 11
[tracking.dtrack.offsets]
head = [0.0, -0.04, -0.09]
)";
  const auto c = parse_installation_config(kBase + dtrack, "room.toml");
  EXPECT_EQ(c.tracking.source, TrackingSource::dtrack);
  const auto& d = c.tracking.dtrack;
  EXPECT_EQ(d.port, 5123);
  EXPECT_EQ(d.multicast_group, "224.0.1.7");
  EXPECT_EQ(d.room.rotation, (std::array<double, 9>{0, 1, 0, 0, 0, 1, 1, 0, 0}));
  EXPECT_EQ(d.room.translation_m, (std::array<double, 3>{0.5, 0.0, -0.25}));
  EXPECT_FALSE(d.room.conjugate_body);
  EXPECT_EQ(d.role_body, (std::array<std::int32_t, 5>{3, 7, -1, -1, 11}));
  EXPECT_EQ(d.role_offset_m[0], (std::array<double, 3>{0.0, -0.04, -0.09}));
  EXPECT_EQ(d.role_offset_m[1], (std::array<double, 3>{0, 0, 0}));
  EXPECT_EQ(parse_installation_config(to_toml(c), "again.toml"), c);
  EXPECT_NE(to_toml(c).find("[tracking.dtrack.offsets]"), std::string::npos) << to_toml(c);

  // Defaults: DTrack's own room (z_up), port 5000; written back as room_axes.
  const auto plain = parse_installation_config(kBase + "[tracking]\nsource = \"dtrack\"\n", "room.toml");
  EXPECT_EQ(plain.tracking.dtrack.port, 5000);
  EXPECT_EQ(plain.tracking.dtrack.room, kumite::tracking::RoomTransform::z_up());
  EXPECT_NE(to_toml(plain).find("room_axes = 'z_up'"), std::string::npos) << to_toml(plain);
  EXPECT_EQ(parse_installation_config(to_toml(plain), "again.toml"), plain);

  // OSC: its own port (9000 unless given) and roles; DTrack's room keys are not its own.
  const auto osc = parse_installation_config(
      kBase + "[tracking]\nsource = \"osc\"\n[tracking.osc]\nmulticast_group = \"239.1.2.3\"\n[tracking.osc.bodies]\nhead = 1\n",
      "room.toml");
  EXPECT_EQ(osc.tracking.source, TrackingSource::osc);
  EXPECT_EQ(osc.tracking.osc.port, 9000);
  EXPECT_EQ(osc.tracking.osc.multicast_group, "239.1.2.3");
  EXPECT_EQ(osc.tracking.osc.role_body[0], 1);
  EXPECT_EQ(parse_installation_config(to_toml(osc), "again.toml"), osc);

  // The shipped example: DTrack's default room on port 5000, bodies 0..4 (kumite-dtrack send's).
  const auto demo = load_installation_config(KUMITE_SOURCE_DIR + "/config/demo-dtrack.toml");
  EXPECT_EQ(demo.tracking.source, TrackingSource::dtrack);
  EXPECT_EQ(demo.tracking.dtrack.port, 5000);
  EXPECT_EQ(demo.tracking.dtrack.room, kumite::tracking::RoomTransform::z_up());
  EXPECT_EQ(demo.tracking.dtrack.role_body, (std::array<std::int32_t, 5>{0, 1, 2, 3, 4}));
  EXPECT_FALSE(demo.recognition.model.empty());
  EXPECT_EQ(parse_installation_config(to_toml(demo), "again.toml"), demo);

  // Mistakes: one line each, file:line: key: message (kBase has 23 lines).
  std::string msg = error_of(kBase + replace(dtrack, "port = 5123", "port = 70000"));
  EXPECT_NE(msg.find("bad.toml:28: tracking.dtrack.port: "), std::string::npos) << msg;
  msg = error_of(kBase + replace(dtrack, "left_hand = 7", "left_hand = 3"));
  EXPECT_NE(msg.find("bad.toml:35: tracking.dtrack.bodies.left_hand: body 3 is already head"), std::string::npos) << msg;
  msg = error_of(kBase + replace(dtrack, "head = [0.0, -0.04, -0.09]", "head = [0.0, -40.0, -90.0]"));
  EXPECT_NE(msg.find("bad.toml:38: tracking.dtrack.offsets.head: "), std::string::npos) << msg;
  msg = error_of(kBase + replace(dtrack, "rotation = [[0.0, 1.0, 0.0]", "rotation = [[0.0, 2.0, 0.0]"));
  EXPECT_NE(msg.find("bad.toml:30: tracking.dtrack.rotation: not a rotation"), std::string::npos) << msg;
  msg = error_of(kBase + replace(dtrack, "port = 5123", "prot = 5123"));
  EXPECT_NE(msg.find("bad.toml:28: tracking.dtrack.prot: "), std::string::npos) << msg;
  msg = error_of(kBase + replace(dtrack, "source = \"dtrack\"", "source = \"vrpn\""));
  EXPECT_NE(msg.find("bad.toml:25: tracking.source: unknown tracking source \"vrpn\" (none, recording, live, poses, "
                     "dtrack, osc)"),
            std::string::npos)
      << msg;
  msg = error_of(kBase + "[tracking]\nsource = \"osc\"\n[tracking.osc]\nroom_axes = \"y_up\"\n");
  EXPECT_NE(msg.find("bad.toml:27: tracking.osc.room_axes: not an OSC key"), std::string::npos) << msg;
}

TEST(Config, TheClusterNodeLevelIsReadCheckedAgainstTheWallsAndWrittenBack) {
  const std::string cluster = "\n[cluster]\nstate = \"tcp://10.0.0.1:7700\"\ncontrol = \"tcp://10.0.0.1:7701\"\n"
                              "deadline_ms = 30\n[[cluster.nodes]]\nname = \"front\"\naddress = \"10.0.0.11\"\n"
                              "walls = [\"front\"]\nwindows = [\"main\"]\n";
  const auto a = parse_installation_config(kBase + cluster, "room.toml");
  ASSERT_TRUE(a.cluster);
  EXPECT_EQ(a.cluster->nodes.at(0).walls, std::vector<std::string>{"front"});
  EXPECT_NE(a.file_hash, parse_installation_config(kBase, "room.toml").file_hash);
  const auto b = parse_installation_config(to_toml(a), "again.toml");
  EXPECT_EQ(a, b);  // the node level survives a session's snapshot
  EXPECT_NE(a, parse_installation_config(kBase, "room.toml"));
  // A node's wall or window that the file does not have; a wall drawn by two nodes.
  EXPECT_EQ(error_of(kBase + replace(cluster, "walls = [\"front\"]", "walls = [\"ceiling\"]")),
            "bad.toml:32: cluster.nodes[0].walls: node \"front\": no wall \"ceiling\" in [[walls]]");
  EXPECT_EQ(error_of(kBase + replace(cluster, "windows = [\"main\"]", "windows = [\"side\"]")),
            "bad.toml:33: cluster.nodes[0].windows: node \"front\": no window \"side\" in [[windows]]");
  EXPECT_EQ(error_of(kBase + cluster + "[[cluster.nodes]]\nname = \"again\"\nwalls = [\"front\"]\n"),
            "bad.toml:36: cluster.nodes[1].walls: wall \"front\" is drawn by nodes \"front\" and \"again\": one node per wall");
  EXPECT_EQ(error_of(kBase + replace(cluster, "deadline_ms = 30", "deadline_ms = inf")).substr(0, 34),
            "bad.toml:28: cluster.deadline_ms: ");
}
