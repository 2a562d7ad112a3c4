#pragma once
// The installation file (TOML, e.g. config/demo.toml) as plain structs (as SGCT does): every
// optional part is std::optional or has a documented default, validate() checks the meaning,
// to_toml() writes it back (round trip). toml++ is included in config.cpp only.
//
// Room frame: metres, right-handed, +Y up, floor at y = 0, the visitor faces the front wall,
// which lies toward -Z. Head frame (the tracked glasses): +X right, +Y up, looking -Z.
// Relative paths in the file are relative to the file's own folder (resolve()). A path may
// start with "${data_dir}/": the data made at set-up (database, recording), found in
// `kumite --data-dir`, else $KUMITE_DATA_DIR, else the file's top-level `data_dir` key
// (relative to the file's folder); see resolve().
#include <array>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kumite/cluster/cluster.hpp"
#include "kumite/common/boxed.hpp"
#include "kumite/common/wire.hpp"
#include "kumite/tracking/interop.hpp"

namespace kumite::content {
// The fighter's tunables, held boxed (common/boxed.hpp): a unit that reads or writes them
// includes content/tunables.hpp (Behaviour, Retrieval) or content/planner.hpp (Planner); the
// others do not recompile when a tunable is added.
struct BehaviourTunables;
struct RetrievalTunables;
struct PlannerTunables;
}  // namespace kumite::content

namespace kumite::app {

using Vec3 = std::array<double, 3>;

enum class StereoMode { quad_buffer, side_by_side, top_bottom, anaglyph, mono };
std::string_view to_string(StereoMode m);
std::optional<StereoMode> stereo_mode_from_string(std::string_view s);

/// One output window (or, with several walls in it, one window split into viewports).
/// [console]: the supervisor console window (windowed runs), placed apart from the walls'.
struct ConsoleWindowConfig {
  std::array<int, 2> size{960, 760};             ///< pixels; at least 640 x 480
  std::optional<std::array<int, 2>> position;    ///< pixels, top-left on the desktop (none: the window system's choice)
  /// s: the quit key (and closing the console) only arms a quit, shown in a banner; a second
  /// press within this long quits. 0: one press quits.
  double quit_confirm_s = 3.0;
  bool operator==(const ConsoleWindowConfig&) const = default;
};

struct WindowConfig {
  std::string name;
  std::array<int, 2> size{1280, 720};     ///< pixels (windowed); fullscreen uses the monitor's
  std::array<int, 2> position{0, 0};      ///< pixels, top-left on the desktop (windowed)
  int monitor = 0;                        ///< 0-based monitor index for fullscreen
  bool fullscreen = false;
  bool operator==(const WindowConfig&) const = default;
};

/// One projection wall: a rectangle given by three corners (the fourth is implied).
struct WallConfig {
  std::string name;
  Vec3 lower_left{}, lower_right{}, upper_left{};  ///< m, room frame
  std::optional<Vec3> upper_right;  ///< m; optional, checked against the implied corner
  std::array<int, 2> resolution{1920, 1080};       ///< pixels of the wall's image
  std::string window;                               ///< window showing it ("" = the first)
  /// Pixels in the window: x, y (from the window's lower-left, as OpenGL), width, height.
  /// Absent: the whole window.
  std::optional<std::array<int, 4>> viewport;
  bool operator==(const WallConfig&) const = default;
};

struct StereoConfig {
  StereoMode mode = StereoMode::mono;
  /// Quad-buffer only: when no stereo context exists, use `fallback` instead of failing.
  bool allow_fallback = false;
  StereoMode fallback = StereoMode::anaglyph;
  bool operator==(const StereoConfig&) const = default;
};

struct ViewerConfig {
  double interpupillary_distance_m = 0.064;  ///< m, between the eye centres
  /// m, head frame: eye midpoint relative to the marker centroid (+X right, +Y up, -Z ahead).
  Vec3 eye_offset_m{0.0, -0.03, -0.01};
  /// m, room frame: head position used until tracking delivers (and with source = "none").
  Vec3 default_head_m{0.0, 1.70, 0.0};
  bool operator==(const ViewerConfig&) const = default;
};

struct ProjectionConfig {
  double near_m = 0.05;  ///< m, near clip distance from the eye
  double far_m = 100.0;  ///< m, far clip distance
  bool operator==(const ProjectionConfig&) const = default;
};

/// What a key of the supervisor console does, parsed once when the file is read: an order
/// to the fighter, or quit. Text form (the file, the console): "punch_left", "punch_right",
/// "kick_left", "kick_right", "pause", "resume", "recentre", "character N" (1-based), "quit".
struct KeyAction {
  enum class Kind : std::uint8_t { order, quit, record };  ///< record: start / stop recording
  Kind kind = Kind::order;
  OrderKind order = OrderKind::punch_right;  ///< kind == order
  int character = -1;                        ///< 0-based, for OrderKind::select_character
  bool operator==(const KeyAction&) const = default;
  /// The order it gives at `time` (kind == order).
  Order to_order(Timestamp time) const { return Order{time, order, character}; }
};
std::optional<KeyAction> parse_key_action(std::string_view text);
std::string to_string(const KeyAction& action);

/// One key of the supervisor console.
struct KeyBinding {
  KeyAction action;
  std::string key;  ///< key name as written ("J", "SPACE", "F1", "KP_1", ...)
  std::string name; ///< the same, canonical ("j" -> "J"); the windowed runner maps it to its key code
  bool operator==(const KeyBinding&) const = default;
};

struct CharacterConfig {
  std::string name;
  std::filesystem::path bvh;  ///< as written (relative to the file's folder)
  bool operator==(const CharacterConfig&) const = default;
};

struct FighterSection {
  std::filesystem::path database;  ///< fighter.kdb (kumite-motion build), as written
  int initial_character = 0;       ///< 0-based
  Vec3 home_m{0.0, 0.0, -2.5};     ///< m, room frame, on the floor
  double strike_distance_m = 0.9;  ///< m, horizontal root -> head when striking
  double hit_radius_m = 0.10;      ///< m: the strike reached its frozen target this close
  double visitor_head_radius_m = 0.12;  ///< m: a strike hits when its fist/foot is this close to the tracked head
  double visitor_body_radius_m = 0.20;  ///< m: ... or this close to the body axis below the head
  std::array<double, 2> x_limits_m{-1.4, 1.4};   ///< m, where it may walk (room x)
  std::array<double, 2> z_limits_m{-4.0, -1.7};  ///< m, where it may walk (room z)
  /// [fighter.behaviour] (with [fighter.behaviour.feet]) and [fighter.retrieval]: the
  /// fighter's tunables, every key with its unit and range (content/tunables.hpp,
  /// `kumite-motion tunables` prints them with their defaults). Boxed: `->` reads a key.
  Boxed<content::BehaviourTunables> behaviour;
  Boxed<content::RetrievalTunables> retrieval;
  /// [fighter.planner]: orders (the supervisor alone) or spar (content/planner.hpp), a preset
  /// and the planner's tunables, and the seed of its random draws (the same seed, the same bout).
  Boxed<content::PlannerTunables> planner;
  std::uint64_t planner_seed = 1;
  bool operator==(const FighterSection&) const = default;
};

/// none: the head at its default; recording: the tracker on recorded camera frames; live: on
/// the cameras; poses: a poses.csv (kumite-track --out, or a room's own tracker) played on its
/// timestamps as if tracked (issue 14); dtrack: a room's own ART DTrack tracker (DTrack ASCII
/// over UDP, [tracking.dtrack]); osc: poses sent as OSC (/rigidbody/<id>/transformation, in
/// Kumite's room, [tracking.osc]; e.g. an OptiTrack room through NatNetThree2OSC) (issue 55).
enum class TrackingSource { none, recording, live, poses, dtrack, osc };
std::string_view to_string(TrackingSource s);

struct TrackingConfig {
  TrackingSource source = TrackingSource::none;
  std::filesystem::path calibration;  ///< rig calibration (OpenCV YAML), as written
  std::filesystem::path tracking;     ///< tracking.toml, as written
  std::filesystem::path recording;    ///< recording folder (source = "recording")
  std::filesystem::path poses;        ///< poses.csv (source = "poses")
  bool poses_loop = true;             ///< source = "poses": start the file again at its end
  /// [tracking.dtrack] (source = "dtrack"): port, multicast group, room transform, body id of
  /// each role, per-role offsets; read by kumite::tracking::parse_dtrack_config (tracking/README.md).
  tracking::DtrackInput dtrack;
  /// [tracking.osc] (source = "osc"): port, multicast_group and [tracking.osc.bodies] only (the
  /// poses come in Kumite's room: no room transform). Default port 9000.
  tracking::DtrackInput osc = [] {
    tracking::DtrackInput o;
    o.port = 9000;
    return o;
  }();
  /// The glasses' body: by default the body tracking.toml names by its role, `head` (body 0,
  /// said once, when none is named so); `head_body = N` picks body N by its index instead.
  std::optional<int> head_body;
  /// s, how long a lost head keeps its last good pose before the console calls it lost.
  double lost_after_s = 0.25;
  /// Frame sets of the recording decoded into memory before playback starts, then played
  /// (looped) from memory at the recording's rate; 0 = stream from disk, where sets that
  /// cannot be decoded before they are due are skipped (as a camera drops frames).
  int recording_preload = 0;
  int decode_threads = 1;  ///< threads decoding the recording's PNGs ahead of its clock
  /// SCHED_FIFO priority of the tracker thread (1..99; 0 = normal scheduling): its pose is
  /// then ready about a millisecond after each frame set whatever the renderer does. Needs
  /// CAP_SYS_NICE or an rtprio limit; without them the tracker says so and runs normally.
  int realtime_priority = 0;
  /// [tracking.out]: the visitor's tracked bodies sent on as the tracker measures them, from
  /// whichever source (own cameras, a poses file, a room's tracker), so that other software
  /// reads Kumite's tracker. `dtrack`: "host:port", DTrack ASCII (fr, ts, 6dcal, 6d with Euler
  /// angles) in DTrack's room ([tracking.dtrack]'s transform inverted; ids from
  /// [tracking.dtrack.bodies], else head 0, left_hand 1, right_hand 2, left_foot 3, right_foot 4).
  /// `osc`: "host:port", one OSC bundle per measurement (/rigidbody/<id>/transformation, Kumite's
  /// room, the same ids). Empty: not sent.
  std::string out_dtrack, out_osc;
  bool operator==(const TrackingConfig&) const = default;
};

/// [recognition]: the visitor's strikes recognised from the tracked bodies (issue 14). Every
/// pose sample of the bodies named by a role (head, left_hand, right_hand, left_foot,
/// right_foot) goes to a recognition thread; its events enter the frame (TrackingSnapshot::strikes).
struct RecognitionConfig {
  /// The recogniser's model (.krec, kumite-recognise train; the shipped one is
  /// recognition/models/strikes.krec); empty: no recognition.
  std::filesystem::path model;
  bool operator==(const RecognitionConfig&) const = default;
};

/// [safety]: the visitor near a wall (or out of the tracked area): a glow on that wall and an
/// event; the fighter's back-off reads FrameData::visitor_near_wall.
struct SafetyConfig {
  bool enabled = true;
  double wall_distance_m = 0.4;  ///< m, 0.05..2: the tracked head this close to a wall's plane
  bool operator==(const SafetyConfig&) const = default;
};

/// [health]: the health report staff read from another machine (`kumite status`).
struct HealthConfig {
  /// JSON status file, rewritten atomically about every interval_s (relative: to the file's
  /// folder, like every path); none: no report.
  std::optional<std::filesystem::path> file;
  double interval_s = 1.0;  ///< s, 0.1..60
  bool operator==(const HealthConfig&) const = default;
};

/// [render] fighter: how the fighter is drawn.
enum class FighterLook { skinned, capsules };
std::string_view to_string(FighterLook l);
std::optional<FighterLook> fighter_look_from_string(std::string_view s);

/// [render]: what the walls show besides the views.
struct RenderConfig {
  /// "skinned": each character wears its body from `bodies` (glTF, GPU-skinned; a body that
  /// cannot be loaded is one warning and its capsules); "capsules": the technician's view
  /// (a cylinder per bone, a sphere per joint). Absent: capsules; the shipped demos say skinned.
  FighterLook fighter = FighterLook::capsules;
  /// bodies.toml (body/assets/bodies.toml: which body and outfit each character wears), as
  /// written; needed for fighter = "skinned".
  std::filesystem::path bodies;
  /// Technician's marks: the strike's target sphere, the floor grid and the walls' outlines.
  /// Off in the show.
  bool debug_marks = false;
  /// The training hall around the fighter (floor, walls, contact shadow); false: the dark void.
  bool hall = true;
  bool operator==(const RenderConfig&) const = default;
};

/// The placeholder a path in the file may start with (see InstallationConfig::resolve).
inline constexpr std::string_view kDataDirPlaceholder = "${data_dir}";
/// Environment variable overriding `data_dir` (load_installation_config reads it).
inline constexpr const char* kDataDirEnv = "KUMITE_DATA_DIR";

struct InstallationConfig {
  std::filesystem::path file;  ///< where it was read from ("" when built in code)
  /// `data_dir` as written (relative to the file's folder): what "${data_dir}" in a path means.
  std::filesystem::path data_dir;
  /// Overrides data_dir (absolute, or relative to the working directory): set from
  /// $KUMITE_DATA_DIR by load_installation_config, or by `kumite --data-dir`. Not written back.
  std::optional<std::filesystem::path> data_dir_override;
  double display_rate_hz = 60.0;
  /// Take each frame's head pose as late as drawing allows, just after the tracker's next
  /// pose is out, instead of at the frame's start (lower pose age; see frame_pacer.hpp).
  bool late_latch = true;
  /// ms from a frame's vsync to its light on the wall (the projectors' input lag, measured
  /// per installation; 0..100): the head pose is predicted that far past the vsync.
  double display_latency_ms = 0.0;
  std::vector<WindowConfig> windows;
  std::vector<WallConfig> walls;
  StereoConfig stereo;
  ViewerConfig viewer;
  ProjectionConfig projection;
  std::vector<KeyBinding> keys;
  std::vector<CharacterConfig> characters;
  FighterSection fighter;
  TrackingConfig tracking;
  RecognitionConfig recognition;
  std::optional<std::filesystem::path> orders_script;  ///< `time_s,order` rows, as written
  HealthConfig health;
  SafetyConfig safety;
  ConsoleWindowConfig console;
  RenderConfig render;
  /// [record] budget_mb: MB a session recording (kumite --record, the record key) may take on
  /// disk; recording stops there with a warning (kumite --record-budget-mb overrides).
  double record_budget_mb = 2048.0;
  /// [log] frames_budget_mb: MB frames.jsonl may take on disk, kept as two halves
  /// (frames.jsonl, the newest, and frames.1.jsonl): a run of any length stays bounded.
  double frames_log_budget_mb = 2048.0;
  /// [cluster] and its [[cluster.nodes]]: the render cluster (none: one process draws every
  /// wall). Checked against the walls and windows: every node's walls and windows exist, and no
  /// wall is drawn by two nodes.
  std::optional<cluster::ClusterConfig> cluster;
  /// The file's bytes' hash (cluster::config_hash): every cluster message carries it, and a
  /// node whose file differs from the master's is refused. 0 when built in code.
  std::uint64_t file_hash = 0;

  /// Source line of each key path ("walls[1].lower_left", "stereo.mode"); 0 when unknown.
  std::map<std::string, int> lines;
  int line_of(const std::string& key) const;

  /// A path from the file made usable: "${data_dir}/rest" becomes data_root() / rest; other
  /// relative paths are taken against the file's folder; absolute ones are unchanged.
  std::filesystem::path resolve(const std::filesystem::path& p) const;
  /// The folder "${data_dir}" stands for (data_dir_override, else data_dir against the
  /// file's folder); empty when neither is set.
  std::filesystem::path data_root() const;
  /// The window index showing wall `w` (after validate(), always valid).
  int window_of(std::size_t w) const;

  bool operator==(const InstallationConfig& o) const;  ///< ignores `file`, `lines` and `file_hash`
};

/// Reads and validates an installation file. Throws kumite::Error("config", ...) whose message
/// is "file:line: key: what is wrong".
/// `data_dir` overrides the file's data_dir key (default: $KUMITE_DATA_DIR when set).
InstallationConfig load_installation_config(const std::filesystem::path& file,
                                            std::optional<std::filesystem::path> data_dir = std::nullopt);
/// Parses and validates TOML text; `file_name` is used in messages (and for resolve()).
InstallationConfig parse_installation_config(std::string_view text,
                                             const std::filesystem::path& file_name);
/// Semantic checks (walls, windows, keys, characters, ranges). Throws like the loaders.
void validate(const InstallationConfig& config);
/// Geometry checks of one wall: degenerate, skewed (edges not perpendicular) and
/// non-rectangular (a given upper_right off the implied corner). "" when fine.
std::string check_wall_geometry(const WallConfig& wall);
/// TOML text that parse_installation_config() reads back to an equal config.
std::string to_toml(const InstallationConfig& config);

/// The canonical form of a key name ("a" -> "A", "7", "SPACE", "F5", "KP_2", "LEFT", ...), or
/// nullopt when no keyboard has it. GLFW-free: the windowed runner turns names into codes.
std::optional<std::string> canonical_key_name(std::string_view name);

}  // namespace kumite::app
