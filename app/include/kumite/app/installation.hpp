#pragma once
// The installation's frame, CPU side: tracking in, orders in, the fighter advanced, eyes and
// per-wall views computed, the console's state updated. Rendering (headless or windows)
// happens elsewhere from FrameData. Nothing here waits on a camera, a file or retrieval.
#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kumite/app/config.hpp"
#include "kumite/app/frame_pacer.hpp"
#include "kumite/app/orders.hpp"
#include "kumite/app/scene.hpp"
#include "kumite/app/visitor_strikes.hpp"
#include "kumite/common/wire.hpp"
#include "kumite/content/fighter_types.hpp"

namespace kumite::app {

/// One camera as the tracker reported it (the console names it: TrackingInput::camera_names).
struct CameraView {
  CameraState state = CameraState::no_frames;
  int blobs = 0;              ///< blobs in its newest frame
  double since_last_ms = -1;  ///< ms since its newest frame (-1: never)
  bool operator==(const CameraView&) const = default;
};

/// Where the tracker stands (text: to_string).
enum class TrackerState : std::uint8_t {
  none,      ///< no tracker (tracking.source = "none", or it could not start)
  waiting,   ///< running, no frame set measured the head yet
  tracked,   ///< the head measured in the newest frame set
  coasting,  ///< the head predicted from its last measurement
  lost,      ///< the head not measured for longer than the coasting limit
  stopped,   ///< the tracker's thread ended (the source ended or failed)
};
/// "no tracking", "waiting for the first frame set", "tracked", "coasting", "lost",
/// "tracker stopped".
std::string_view to_string(TrackerState state);

/// The frame source's counters as numbers (text: describe(SourceStats)).
struct SourceStats {
  bool recording = false;        ///< false: live cameras, or no source
  bool retracked = false;        ///< a replay's re-tracking from the session's camera frames (not recorded)
  bool loading = false;          ///< a recording's preload is under way
  std::uint64_t loaded = 0;      ///< frame sets preloaded so far
  std::uint64_t to_load = 0;     ///< frame sets to preload (0: decoding the first set from disk)
  bool from_memory = false;      ///< the recording loops over its preloaded sets
  double decode_ms = 0;          ///< ms per set decoded (from disk)
  /// Per second over the last second or so, and in all: frame sets tracked, skipped (the
  /// decoder behind) and dropped (the tracker behind).
  std::array<double, 3> rates{0, 0, 0};
  std::array<std::uint64_t, 3> totals{0, 0, 0};
  bool operator==(const SourceStats&) const = default;
};
/// One line about the source ("" when it is not a recording).
std::string describe(const SourceStats& source);
/// What is wrong with the source now, one line (nullopt: nothing).
std::optional<std::string> source_problem(const SourceStats& source);

/// What the tracking side has at one display time: numbers and enums only (the console's
/// text is made from it by whoever shows it).
struct TrackingSnapshot {
  std::optional<BodyPose> head;      ///< newest head pose, predicted to the display time
  /// s, camera time of the newest frame set that measured the head (-1: none yet); the
  /// pose age at render is clock() - measured_at.
  Timestamp measured_at = -1;
  /// s, when that measurement's pose was published (-1: unknown): ready_at - measured_at is
  /// the tracking latency, clock() - ready_at the wait for the display.
  Timestamp measured_ready_at = -1;
  TrackerState state = TrackerState::none;
  std::uint64_t frame_sets = 0;      ///< frame sets the tracker has processed
  std::vector<CameraView> cameras;   ///< per camera, in the rig's order
  SourceStats source;
  /// The visitor's strike events the recognition thread published since the last poll, in
  /// order (empty without [recognition]); a replay takes them from the session.
  std::vector<VisitorStrike> strikes;
  RecognitionStats recognition;
  /// The visitor's tracked bodies by role (index: recognition::Role: head, left_hand,
  /// right_hand, left_foot, right_foot), each the newest pose the source MEASURED of it: not
  /// predicted to the display time as `head` is (the fighter judges a glove's threat from where
  /// it was and when: `timestamp` is the camera time of the frame set, or the poses file's row,
  /// that measured it; position m, room frame; orientation body -> room; frame, markers,
  /// cameras, ready_at as measured). `status` is the body's as of the poll: tracked (measured
  /// by the source's newest frame set or row), coasting (not measured since, still within the
  /// source's coasting time), lost (longer, or the source says so): the pose then stays the
  /// last one measured. nullopt: the source has no such body, or has not measured it yet.
  /// A fixed array: filling it allocates nothing. A session records it (version 5 on).
  std::array<std::optional<BodyPose>, recognition::kRoleCount> bodies{};
};
/// The tracking line of the console: "tracked, 1200 frame sets", "tracker stopped, 30 frame
/// sets", or `none_why` when there is no tracker.
std::string describe(const TrackingSnapshot& snapshot, std::string_view none_why = "no tracking");

class SessionRecorder;

/// Where head poses come from (the tracker, or nothing). poll() never blocks.
class TrackingInput {
 public:
  virtual ~TrackingInput() = default;
  /// At time `now`: the newest head pose predicted to `display_time` (when the frame's
  /// picture will be seen; >= now), camera status as of now, written over `out` (the last
  /// frame's snapshot: overwrite every field; reuse its vectors' room, allocate nothing).
  virtual void poll(Timestamp now, Timestamp display_time, TrackingSnapshot& out) = 0;
  /// The clock the tracker's timestamps use, so pose age can be measured (s).
  virtual Timestamp clock() const = 0;
  virtual std::string describe() const = 0;
  /// The console's tracking line when there is no tracker (TrackerState::none).
  virtual std::string none_why() const { return "no tracking"; }
  /// The source's own line for the console when the snapshot's SourceStats say nothing (a
  /// room's tracker: "dtrack: port 5000, 1200 frames, 0 bad packets, last from ... 0.01 s
  /// ago"); made when asked, live only (a replay has none). "": nothing to say.
  virtual std::string source_line() const { return {}; }
  /// The cameras' names, in the order of TrackingSnapshot::cameras (fixed once it is made).
  virtual const std::vector<std::string>& camera_names() const {
    static const std::vector<std::string> none;
    return none;
  }
  /// The newest head pose out now and when the next is expected (late latching; never blocks).
  virtual PoseTiming pose_timing(Timestamp /*t*/) { return {}; }
  /// False when no tracker is behind it (the head stays at its default): nothing to wait for.
  virtual bool has_tracker() const { return true; }
  /// True when its poses follow the clock its polls give (a file on the simulated clock), not
  /// the wall clock: a simulated run need not wait for it.
  virtual bool follows_simulated_clock() const { return false; }
  /// True while the source is still loading (a recording's preload): the show is not up yet.
  virtual bool loading() const { return false; }
  /// What of the tracking side could not start and stays off, one line each (a recognition
  /// model that is missing or damaged: recognition off, the head tracked as ever).
  virtual std::vector<std::string> faults() const { return {}; }
  /// Hands every camera frame set the tracker gets from now on to `recorder` (nullptr: stop;
  /// returns once no set is being handed over). Sources without cameras ignore it.
  virtual void record_frame_sets(SessionRecorder* /*recorder*/) {}
};

/// No tracking: the head stays at the configured default position (console usable alone).
std::unique_ptr<TrackingInput> make_fixed_head_input(std::string why);

/// What a FrameEvent is: content's EventKind, the one list of events from the fighter to the
/// log (kumite/content/event.hpp: its words, to_string and parse_event_kind, are there).
using EventType = content::EventKind;

/// Where a FrameEvent comes from (its line for people: Installation::event_text).
enum class EventCause : std::uint8_t {
  fighter,               ///< the fighter's own event (FrameEvent::fighter)
  no_fighter,            ///< an order ignored: no fighter (its database or characters missing)
  no_such_character,     ///< an order ignored: that character does not exist
  character_not_loaded,  ///< an order ignored: that character's file is missing
  visitor,               ///< the visitor's safety (visitor_near_wall / visitor_clear) or strikes (visitor_strike)
};

/// One event of a frame, as data: no text (the log and console make it: event_text).
struct FrameEvent {
  EventType type = EventType::warning;
  std::optional<Order> order;  ///< the order concerned (characters in the config's numbering)
  double distance_m = 0; ///< hit / dodged / miss: m from the hit point to the visitor's body (0: touching);
                         ///< visitor events: m from the head to the wall
  double time_s = 0;     ///< s since the start of the run
  EventCause cause = EventCause::fighter;
  content::FighterEvent fighter;  ///< cause fighter: the fighter's event, whole (its order in its own numbering)
  int wall = -1;         ///< visitor events: the wall concerned (-1: none)
  bool outside = false;  ///< visitor_near_wall: beyond the wall's plane
  bool lost = false;     ///< visitor_near_wall: tracking lost near the wall
  VisitorStrike strike;  ///< visitor_strike: the recogniser's event
  bool operator==(const FrameEvent&) const = default;
};
using content::is_strike_outcome;

/// One camera as the console shows it.
struct ConsoleCamera {
  std::string name;
  CameraState state = CameraState::no_frames;
  std::string status;         ///< to_string(state)
  int blobs = 0;              ///< blobs in its newest frame
  double since_last_ms = -1;  ///< ms since its newest frame (-1: never)
};

/// The console's text: made from the frame's plain data by Installation::console() when a
/// presenter asks (ImGui in windows, frames.jsonl, the service's status), never in step().
struct ConsoleState {
  double fps = 0;                  ///< Hz, frames per second (rolling)
  double frame_cpu_ms = 0;         ///< ms, CPU of the last frame's step()
  std::string tracking;            ///< "tracked, 120 frame sets", "lost, ...", "no tracking", ...
  std::string tracking_source;     ///< the frame source: frame sets per second, skipped, dropped
  /// "strike recognition: 7200 pose samples, 12 events" ("" without [recognition])
  std::string recognition;
  std::vector<ConsoleCamera> cameras;
  int markers_seen = 0;
  bool head_live = false;          ///< false: using the last good (or default) head
  /// ms, camera time of the newest head measurement to the moment this frame samples it for
  /// rendering (-1: none yet); logged whether or not the head counts as tracked.
  double pose_age_ms = -1;
  /// ms, the tracking part of pose_age_ms: frame set due to its pose published (-1: unknown,
  /// or the head not tracked now).
  double tracking_latency_ms = -1;
  /// ms, how far into its display frame this frame took the pose (late latching; 0: at the
  /// frame's start), and the drawing time the latch leaves room for (-1: not measured yet).
  double latch_ms = 0;
  double draw_budget_ms = -1;
  bool late_latch = false;         ///< config late_latch
  std::string fighter_state = "none";
  int character = 0;               ///< 0-based
  std::string character_name;
  bool paused = false;
  std::string last_order;          ///< e.g. "punch_right"
  std::string last_outcome;        ///< "accepted", "hit (0.04 m)", "miss (0.31 m)", "ignored: ..."
  /// The sparring planner's line (Installation::planner_line(): mode, state, next decision
  /// with its cause and due time, score); "" without a fighter (no planner).
  std::string planner;
  std::vector<std::string> problems;  ///< what is wrong now (one line each)
  std::deque<std::string> recent;     ///< recent events, newest last
  std::vector<std::string> frame_events;  ///< the frame's own events' texts (event_text), in order
};


/// The fighter's skeleton, made once per character: what a FighterPose's arrays are indexed by.
struct FighterSkeleton {
  int character = 0;                     ///< 0-based, the config's numbering
  std::string character_name;
  std::vector<std::string> joint_names;  ///< one per joint, in skeleton order
  std::vector<int> parents;              ///< parent index per joint (-1: the root)
};

/// The fighter in one frame as plain, copyable data (no spans into the fighter's memory):
/// what the log, a recording and later a render node get. Room frame, metres. The vectors
/// are reserved once per character, so filling it each frame allocates nothing after warm-up.
struct FighterPose {
  bool present = false;                  ///< false: no fighter (database or characters missing)
  content::FighterState state = content::FighterState::resting;
  int character = 0;                     ///< 0-based, the config's numbering
  std::shared_ptr<const FighterSkeleton> skeleton;  ///< the character's (shared, never changes)
  std::vector<glm::dvec3> joints;        ///< m, room frame: the joints as drawn, one per skeleton joint
  /// Per joint, its rotation relative to its parent (the root's: to the room) on the
  /// character's skeleton; forward kinematics from root_joint gives `joints` (except while a
  /// character switch eases the drawn joints, blend_time_s).
  std::vector<glm::dquat> local_rotations;
  glm::dvec3 root_joint{0, 0, 0};        ///< m, room frame: the skeleton's root joint (BVH root)
  std::optional<glm::dvec3> target;      ///< m, room frame: the frozen strike target
  glm::dvec3 root{0, 0, 0};              ///< m, room frame, on the floor under the pelvis (top view)
  double heading_rad = 0;                ///< rotation about +Y; 0 = facing +Z (the visitor)
};

/// The visitor close to a wall (FrameData::visitor_near_wall): for the fighter's back-off and
/// the console. Vertical walls only (not the floor).
struct VisitorNearWall {
  int wall = -1;           ///< index into the config's walls
  double distance_m = 0;   ///< m, the head to the wall's plane (negative: beyond it); last tracked when `lost`
  bool outside = false;    ///< beyond the wall's plane: out of the room
  bool lost = false;       ///< tracking lost while near this wall: the visitor left the tracked area there
};

/// The bout in spar mode (FrameData::spar): the sparring planner's state and the score so far,
/// counted from the fighter's events (content::SparScore).
struct SparFrame {
  content::PlannerState state = content::PlannerState::off;
  int visitor_hits = 0;    ///< the visitor's fist or foot entered the fighter's body fast
  int visitor_dodges = 0;  ///< the fighter's strikes that reached their target with the visitor gone
  int fighter_hits = 0;    ///< the fighter's strikes that touched the visitor
  int blocks = 0;          ///< blocks begun against a visitor strike (late ones included)
  int blocks_late = 0;     ///< of those, in place after the fist's predicted arrival
  int blocked = 0;         ///< the visitor's fist or foot met a forearm
  int unanswered = 0;      ///< visitor strikes seen that no block could answer
  bool operator==(const SparFrame&) const = default;
};

/// Everything a renderer and the log need about one frame.
struct FrameData {
  std::uint64_t frame = 0;
  double time_s = 0;          ///< s since the start of the run
  Timestamp now = 0;          ///< s, the frame loop's clock (display time)
  HeadPose head;              ///< the pose used (predicted, or last good, or default)
  bool head_live = false;     ///< `head` is a fresh tracked pose (false: the last good one, or the default)
  Eyes eyes;
  WallViews views;            ///< [wall][eye]
  std::vector<DrawItem> items;///< the fighter and its target
  std::vector<FrameEvent> events;
  double pose_age_ms = -1;    ///< ms, -1 when no pose
  Timestamp pose_measured_at = -1;  ///< s, camera time of the measurement pose_age_ms counts from
  double tracking_latency_ms = -1;  ///< ms, the tracking part of pose_age_ms (-1: unknown, not tracked)
  double latch_ms = 0;        ///< ms, the pose taken this long after the frame's start (late latching)
  /// ms, how far past the moment it was taken the head is predicted: to the frame's vsync
  /// plus the display latency (config display_latency_ms).
  double predicted_ahead_ms = 0;
  FighterPose fighter;        ///< the fighter as plain data
  /// The visitor within [safety] wall_distance_m of a wall, beyond one, or lost near one
  /// (none: clear, or [safety] enabled = false).
  std::optional<VisitorNearWall> visitor_near_wall;
  /// The bout while the fighter spars (none: orders mode, or no fighter). The score stays
  /// counted across spar rounds of one run.
  std::optional<SparFrame> spar;
};

/// The most one frame's vectors hold in this installation: a session recorder reserves its
/// ring's slots to it up front (SessionRecorder::reserve), so that copying a frame into a slot
/// never allocates on the frame thread, whichever character is drawn or glow shown.
/// Counts, not bytes; a frame beyond one (more events than `events`) still works: that slot
/// then grows once.
struct FrameCapacity {
  std::size_t joints = 0;   ///< the largest character's joints
  std::size_t items = 0;    ///< draw items: the largest character's capsules and target, one wall glow
  std::size_t walls = 0;    ///< views: one per wall
  std::size_t cameras = 0;  ///< the tracker's cameras
  std::size_t events = 16;  ///< events of one frame (a frame has 0-3)
  std::size_t keyed = 8;    ///< orders keyed in one frame
  std::size_t strikes = 16; ///< visitor strike events polled in one frame
  bool operator==(const FrameCapacity&) const = default;
};

/// What one frame took from outside (issue 13): with the same config, orders script and
/// fighter data, the same FrameInputs give the same frames (Installation::replay). Orders of
/// the script are not in it: they follow from the times.
struct FrameInput {
  Timestamp now = 0;        ///< s, the frame loop's clock: the moment the frame takes the head
  Timestamp shown_at = 0;   ///< s, its vsync
  std::vector<Order> keyed; ///< orders from keys / the console taken by this frame
  TrackingSnapshot tracking;///< as the tracker gave it
  Timestamp tracking_clock = -1;  ///< s, the tracker's clock() the pose age was measured with
  double latch_ms = 0;      ///< ms, how far into its frame it took the head (late latching; FrameData::latch_ms)
};

class SessionRecorder;

struct InstallationOptions {
  std::optional<std::filesystem::path> orders_script;  ///< overrides the config's
  bool mono_eyes = false;  ///< mono stereo: both eyes at the midpoint
  /// What the caller could not start and left off (the health report), one line each: shown
  /// with the installation's own problems for the whole run.
  std::vector<std::string> problems;
};

class Installation {
 public:
  /// Builds the fighter (a missing database or character becomes a console problem, not a
  /// stop) and reads the orders script (a bad one is off: a console problem naming file and line).
  Installation(InstallationConfig config, std::unique_ptr<TrackingInput> tracking,
               const InstallationOptions& options);
  ~Installation();

  /// Starts the run's clock. The orders script's times count from here when there is no
  /// tracker; with one, from the first frame with the head tracked (at most
  /// kScriptWaitForHead_s later), so scripted strikes aim at the visitor, not at the
  /// default head while the tracker starts (the demo's recording takes ~10 s to load).
  void start(Timestamp now);
  /// s, the longest an orders script waits for the head to be tracked before it starts.
  static constexpr double kScriptWaitForHead_s = 30.0;
  /// A supervisor order (keys), applied at the next step().
  void order(const Order& order);
  /// Late latching (config late_latch), for a frame loop whose frame runs from `start`
  /// (vsync, or its tick) to `deadline` (the next one): sleeps until the tracker's next pose
  /// is out, but never past the last moment drawing (as measured through drawn()) still
  /// fits before the deadline; returns at once when latching is off or the tracker's timing
  /// unknown. Returns the time to step() with (see frame_pacer.hpp).
  Timestamp latch(Timestamp start, Timestamp deadline);
  /// The window the last latch() waited in (nullopt: it did not wait), for measuring how late
  /// the waiting thread woke past its end.
  const std::optional<LatchWindow>& last_latch_window() const { return last_window_; }
  /// The last frame's drawing time (s): from its step() to its picture handed to the display.
  void drawn(double seconds) { pacer_.drawn(seconds); }
  /// One frame that takes the head pose at `now` and is seen at `shown_at` (its vsync,
  /// >= now): the head predicted to shown_at + display_latency_ms, then orders, fighter,
  /// eyes, views, console, all at `now`.
  const FrameData& step(Timestamp now, Timestamp shown_at);
  /// A frame seen at once (simulated time, tests).
  const FrameData& step(Timestamp now) { return step(now, now); }
  /// The frame again from a recorded input: the tracker is not asked, `input.keyed` are the
  /// orders given before it. Deterministic: the same inputs give bit-identical FrameData.
  const FrameData& replay(const FrameInput& input);
  /// What the last step() took from outside.
  const FrameInput& input() const { return input_; }
  /// Every step from now on hands its input and its state's hashes to `recorder` (never
  /// waiting on it); nullptr stops. The recorder must outlive the steps. Given after start(),
  /// the recording begins at the next frame (the record key).
  /// The recorder's ring is reserved to frame_capacity() here (once per recorder).
  void record_to(SessionRecorder* recorder);
  /// What this installation's frames may hold at most (its characters, walls, cameras).
  FrameCapacity frame_capacity() const;
  const SessionRecorder* recorder() const { return recorder_; }
  /// The record key (KeyAction::Kind::record): calls what on_record_key() set, if anything.
  void record_key() {
    if (record_key_) record_key_();
  }
  void on_record_key(std::function<void()> f) { record_key_ = std::move(f); }
  Timestamp start_time() const { return start_; }
  bool has_tracker() const;
  /// The tracking input follows the clock the frames give it (TrackingInput::follows_simulated_clock).
  bool tracking_follows_frames() const;
  /// The tracker's source is still loading (a recording's preload): the show is not up yet.
  bool tracking_loading() const;

  const FrameData& frame() const { return frame_; }
  /// The console's text for the last frame, made now (a presenter's call, not the step's).
  ConsoleState console() const { return console(frame_); }
  /// The same, with `shown`'s events as the frame's own (a replay showing a recorded frame).
  ConsoleState console(const FrameData& shown) const;
  /// An event's line for people ("target at (0.57, 1.61, 0.48) m", "135_06_punch_left_3
  /// (frames 20->50): touched the visitor (0.0 cm from the target)", ...), and the whole line
  /// the log and console show ("   12.34 s  hit punch_right: ...").
  std::string event_text(const FrameEvent& event) const;
  std::string event_line(const FrameEvent& event) const;
  /// What is wrong now, one line each (ConsoleState::problems), made now.
  std::vector<std::string> problems() const;
  /// The head pose of the last frame is a fresh tracked one (FrameData::head_live).
  bool head_live() const { return frame_.head_live; }
  const InstallationConfig& config() const { return config_; }
  /// The sparring planner's mode, state, next decision and counts (nullopt without a fighter).
  std::optional<content::PlannerStatus> planner_status() const;
  /// The visitor's bodies the last frame gave the fighter (content::FighterInput::bodies): every
  /// body of TrackingSnapshot::bodies the source has, in role order, as measured (tracked =
  /// status not lost; t = its measurement's time). Empty without a fighter.
  std::span<const content::VisitorBody> visitor_bodies() const { return visitor_bodies_; }
  /// Its line for the console: "spar  guarding  next punch_left (timer) in 1.2 s  attacks 3  counters 2"
  /// ("no fighter" without one; ConsoleState::planner is "" then).
  std::string planner_line() const;
  std::span<const WallFrame> walls() const { return walls_; }
  int character_count() const;
  std::string character_name(int index) const;
  bool quit_requested() const { return quit_; }
  /// How the fighter's retrieval worker kept to the updates its plans were due on (zeros
  /// without a fighter).
  content::RetrievalTiming retrieval_timing() const;
  void request_quit() { quit_ = true; }
  /// The quit key (or closing the console) at `now`: the first press arms a quit for
  /// [console] quit_confirm_s, a second within that quits; returns whether it quit.
  bool quit_key(Timestamp now);
  /// Until when an armed quit waits for its second press (nullopt: none armed, or expired at `now`).
  std::optional<Timestamp> quit_armed_until(Timestamp now) const;

 private:
  void update_head(Timestamp now, Timestamp shown_at);
  void apply_orders(Timestamp now);
  void update_fighter(Timestamp now, double dt);
  /// frame_.spar from the planner's status after the fighter's update (none outside spar mode).
  void note_spar(const content::PlannerStatus& st);
  void update_safety(Timestamp now);
  void copy_pose(const content::FighterFrame& f, int character, FighterPose& pose);
  void note(const FrameEvent& e);
  std::string camera_name(std::size_t index) const;

  InstallationConfig config_;
  std::vector<WallFrame> walls_;
  std::vector<std::uint8_t> kept_walls_;  ///< per wall, from plan_views: an eye view kept
  std::unique_ptr<TrackingInput> tracking_;
  std::unique_ptr<content::Fighter> fighter_;
  // The fighter's input and output of a frame (their room kept from frame to frame).
  std::vector<Order> fighter_orders_;
  std::vector<content::VisitorBody> visitor_bodies_;
  std::vector<content::VisitorStrikeSeen> visitor_strikes_;
  content::FighterOutput fighter_out_;
  std::string fighter_problem_;
  std::vector<std::string> missing_characters_;  // one line each (left out of the fighter)
  std::vector<int> fighter_of_config_;  // config character -> the fighter's (-1: not loaded)
  std::vector<int> config_of_fighter_;
  /// Per fighter character, its skeleton for FighterPose (made at the first frame it is drawn).
  std::vector<std::shared_ptr<const FighterSkeleton>> skeletons_;
  OrderScript script_;
  std::string script_problem_;  ///< why the orders script is off ("": it is not)
  std::vector<std::string> start_problems_;  ///< InstallationOptions::problems
  std::vector<Order> pending_;
  std::vector<Order> due_;
  FrameData frame_;
  // The console's facts, kept by step() as plain data (console() makes the text).
  int markers_seen_ = 0;
  bool paused_ = false;
  std::optional<double> script_waited_s_;  ///< s, the orders script still waits for the head
  double frame_cpu_ms_ = 0;
  std::deque<FrameEvent> recent_;          ///< newest last
  std::optional<FrameEvent> last_order_;   ///< the last order, or strike outcome, noted
  FramePacer pacer_;
  double latch_ms_ = 0;  ///< from the last latch(), for the next step()
  std::optional<LatchWindow> last_window_;
  HeadPose last_good_head_;
  Timestamp start_ = 0, last_step_ = 0;
  bool started_ = false, quit_ = false, mono_ = false;
  std::optional<Timestamp> quit_armed_until_;
  std::vector<std::optional<CameraState>> camera_states_;  ///< per camera, at the last frame (log on change)
  bool script_waits_ = false;  ///< the orders script waits for the head to be tracked
  double dt_filtered_ = 0;  ///< s, smoothed frame interval
  std::optional<VisitorNearWall> near_wall_;  ///< the safety state across frames (hysteresis)
  std::uint64_t steps_ = 0;
  FrameInput input_;
  const FrameInput* replaying_ = nullptr;
  SessionRecorder* recorder_ = nullptr;
  std::function<void()> record_key_;
};

}  // namespace kumite::app
