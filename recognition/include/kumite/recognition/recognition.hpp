#pragma once
// Strike recognition: the visitor's punches and kicks from tracked head / glove / shoe poses,
// as they start. Depends on poses only (no cameras, no GL, no fighter).
//
// Pipeline (one Recogniser per visitor, fed every pose sample in time order):
//   1. Frontend: each body role's position is exponentially smoothed (Touché), resampled to a
//      60 Hz loop and expressed relative to the head: origin at the head, axes along the
//      head's smoothed heading (x right, y up, z backward: the room frame when the visitor
//      faces -Z), lengths divided by the head's height above the floor (so actors of any
//      stature compare). Left limbs are mirrored (x -> -x): one template serves both sides.
//   2. Dual-buffer DTW (Shum, Komura, Takagi): a limb starting to move (speed above onset)
//      fills a 6-frame main buffer; when it is full the buffer is matched against every
//      per-action mean template of that limb kind (open-end DTW: the buffer against a
//      template prefix) and a match under the template's threshold gives `begin` at once.
//      A supplementary buffer (up to 60 frames) is re-matched every loop; a better action
//      gives `switch`; no action matching any more gives `cancel`. A null signal (limb speed
//      below `null_speed` for beta = 6 frames) gives `end`. When the buffer is full (the
//      recognition is over before the visitor's movement) the limb's input is discarded until
//      a null signal or 20 frames. A limb whose poses stop (lost, or older than
//      `max_gap_s`) or a stream that ends mid-strike gives `cancel`.
//
// Room frame: metres, +Y up, floor y = 0, the visitor faces the front wall toward -Z.
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "kumite/common/time.hpp"

namespace kumite::recognition {

using Vec3 = std::array<double, 3>;

/// Tracked body roles (the names bodies carry in tracking.toml and poses.csv).
enum class Role : std::uint8_t { head, left_hand, right_hand, left_foot, right_foot };
inline constexpr int kRoleCount = 5;
std::string_view to_string(Role r);
std::optional<Role> role_from_string(std::string_view name);

/// The four striking limbs (Role minus the head): index = Role - 1.
inline constexpr int kLimbCount = 4;
enum class LimbKind : std::uint8_t { hand, foot };
inline LimbKind limb_kind(Role limb) {
  return (limb == Role::left_hand || limb == Role::right_hand) ? LimbKind::hand : LimbKind::foot;
}
inline bool is_left(Role limb) { return limb == Role::left_hand || limb == Role::left_foot; }
std::string_view to_string(LimbKind k);
std::optional<LimbKind> limb_kind_from_string(std::string_view s);

/// One pose sample of one body: what the tracker publishes (BodyPose) reduced to what the
/// recogniser uses. `orientation` (w,x,y,z, body -> room; identity = facing -Z) is read for
/// the head only (its heading); `tracked` false = lost (no pose).
struct PoseSample {
  Timestamp t = 0;  ///< s
  Role role = Role::head;
  Vec3 position{0, 0, 0};  ///< m, room frame
  std::array<double, 4> orientation{1, 0, 0, 0};
  bool tracked = true;
};

/// The strike kinds the project knows (an event's `action` as text; templates may name others:
/// Action::other). Hooks and uppercuts have no training data yet (recognition/README.md).
enum class Action : std::uint8_t { other, straight_punch, hook, uppercut, front_kick, side_kick, roundhouse_kick };
std::string_view to_string(Action a);             ///< "straight_punch", ...; "other"
Action action_from_string(std::string_view name);  ///< Action::other for a name it does not know

enum class EventType : std::uint8_t { begin, switch_, end, cancel };
std::string_view to_string(EventType t);  ///< "begin" | "switch" | "end" | "cancel"

struct Event {
  /// s (sample clock): when the event could be known, i.e. the time of the sample whose
  /// arrival ran the loop (a loop for tick T runs once a sample later than T arrives)
  Timestamp t = 0;
  EventType type = EventType::begin;
  Role limb = Role::right_hand;
  std::string action;     ///< e.g. "straight_punch", "front_kick"
  double progress = 0;    ///< 0..1: matched fraction of the template from onset to full extension
  double confidence = 0;  ///< 0..1: 1 - distance / threshold of the match (0 at the threshold)
  Vec3 impact{0, 0, 0};   ///< m, room frame: predicted limb position at full extension
};

/// One JSON object (one line, no newline): {"t":..,"type":..,"limb":..,"action":..,
/// "progress":..,"confidence":..,"impact":[x,y,z]}.
std::string to_json(const Event& e);

// ---- Frontend ---------------------------------------------------------------------------------

/// What DTW compares, per loop of a buffered movement (head frame, lengths / head height,
/// left limbs mirrored): displacement since the movement's first loop (3), position x
/// absolute_weight (3), velocity x velocity_weight (3). See make_feature().
inline constexpr int kFeatureDim = 9;
using Feature = std::array<float, kFeatureDim>;
using Float3 = std::array<float, 3>;

struct FrontendSettings {
  double loop_hz = 60;           ///< Hz, recognition loop rate
  double smoothing_tau_s = 0.01; ///< s, exponential smoothing of every position
  double heading_tau_s = 0.3;    ///< s, exponential smoothing of the head's heading
  double height_tau_s = 3.0;     ///< s, slow average of the head's height (the length unit)
  double velocity_weight = 0.15; ///< 1/s -> feature units: how much velocity counts beside position
  double max_gap_s = 0.1;        ///< s, a role without a sample for longer is lost
};

/// A loop's view of one limb.
struct LimbFrame {
  bool valid = false;     ///< the limb and the head are tracked
  Float3 pos{};           ///< head frame / head height, mirrored for left limbs
  Float3 vel{};           ///< 1/s: head frame / head height x velocity_weight, mirrored
  double speed = 0;       ///< m/s, limb speed relative to the head (not normalised)
  Vec3 room{0, 0, 0};     ///< m, smoothed room position
};

struct Frame {
  Timestamp t = 0;
  bool head_valid = false;
  Vec3 head{0, 0, 0};           ///< m, smoothed head position
  Vec3 forward{0, 0, -1};       ///< smoothed horizontal heading (unit)
  double head_height = 1.6;     ///< m, the length unit
  std::array<LimbFrame, kLimbCount> limbs{};
};

/// Head-frame vector (normalised, mirrored when `left`) back to a room-frame displacement (m).
Vec3 to_room_displacement(const Frame& f, const std::array<float, 3>& local, bool left);

/// The DTW feature of a loop of a movement that started at `origin` (the first loop's pos).
inline Feature make_feature(const LimbFrame& lf, const Float3& origin, double absolute_weight) {
  const auto w = static_cast<float>(absolute_weight);
  return {lf.pos[0] - origin[0], lf.pos[1] - origin[1], lf.pos[2] - origin[2], w * lf.pos[0], w * lf.pos[1],
          w * lf.pos[2], lf.vel[0], lf.vel[1], lf.vel[2]};
}

class Frontend {
 public:
  explicit Frontend(FrontendSettings s = {});
  /// Feeds one sample (any rate, time order; older samples of a role are ignored). A sample
  /// newer than every one before completes the samples of the time before it: appends a Frame
  /// for every 60 Hz loop tick up to that time (each role's position interpolated at the tick).
  void push(const PoseSample& s, std::vector<Frame>& out);
  /// Every sample up to time t has been pushed (a tracker's frame set is whole): appends the
  /// Frames of the ticks up to t now instead of at the next, newer sample.
  void end_of_set(Timestamp t, std::vector<Frame>& out);
  const FrontendSettings& settings() const { return s_; }

 private:
  struct RoleState {
    bool have = false, tracked = false;
    Timestamp last_t = 0;
    Vec3 smoothed{0, 0, 0};
    std::array<double, 4> q{1, 0, 0, 0};
    bool has_prev = false;    ///< the sample before the last, in the same tracked run
    Timestamp prev_t = 0;
    Vec3 prev{0, 0, 0};       ///< its smoothed position
  };
  /// The role's smoothed position at loop time t: interpolated between its last two samples,
  /// or extrapolated from them by at most one sample interval (first order: a loop's value
  /// moves continuously with the samples' timing, so a tracker whose samples fall on the loop's
  /// ticks, give or take rounding, gives the same features as one between them).
  Vec3 position_at(const RoleState& r, Timestamp t) const;
  Frame make_frame(Timestamp t);
  FrontendSettings s_;
  std::array<RoleState, kRoleCount> roles_{};
  /// The loops for every tick up to u (at most ~loop_hz of them).
  void run_through(Timestamp u, std::vector<Frame>& out);
  bool started_ = false;
  Timestamp next_tick_ = 0;
  Timestamp newest_ = 0;  ///< the newest sample time pushed
  bool have_heading_ = false, have_height_ = false;
  Vec3 forward_{0, 0, -1};
  double head_height_ = 1.6;
  std::array<Vec3, kLimbCount> last_local_{};  ///< m, head frame, previous loop
  std::array<bool, kLimbCount> last_valid_{};
};

// ---- Model --------------------------------------------------------------------------------

/// A per-action mean template (trials aligned by DTW and averaged), from onset to the end of
/// the annotated window; `hit` = the frame of full extension. Action "none": the start of a
/// movement that is no strike (a step, a block, a turn), kept as it was (not averaged); a
/// buffer closer to a "none" template than to every strike's gives no `begin`.
struct Template {
  std::string action;  ///< "straight_punch", "front_kick", "side_kick", "roundhouse_kick", ...
  LimbKind kind = LimbKind::hand;
  std::vector<Feature> frames;  ///< at loop_hz
  int hit = 0;                  ///< index into frames
  double threshold = 0;         ///< DTW distance (per path step) above which it does not match
  /// Per buffer length n (index n - 1, n = 1..max_frames): the threshold for an n-frame
  /// buffer (early buffers match closely, long ones less so); empty = `threshold` for all.
  std::vector<double> thresholds;
  int trials = 0;               ///< how many trials were averaged

  double threshold_at(int n) const {
    if (thresholds.empty() || n < 1) return threshold;
    return thresholds[static_cast<std::size_t>(std::min<int>(n, static_cast<int>(thresholds.size())) - 1)];
  }
};

struct RecogniserSettings {
  FrontendSettings frontend;
  double absolute_weight = 0.3;  ///< feature weight of the head-relative position beside the displacement
  double onset_speed = 1.0;  ///< m/s, a limb faster than this (relative to the head) starts a motion
  double null_speed = 0.5;   ///< m/s, below this for `null_frames` loops: the null signal
  int null_frames = 6;       ///< beta
  int main_frames = 6;       ///< main buffer
  int lead_frames = 1;       ///< 0 or 1: the buffer also holds the loop before the onset
  int max_frames = 60;       ///< supplementary buffer
  int discard_frames = 20;   ///< input discarded after a full buffer until null or this many
  int rearm_frames = 2;      ///< a buffer that matched nothing restarts after this many loops below onset_speed
  double none_margin = 1.0;  ///< begin only when strike distance < margin x the nearest "none" distance
  /// One strike at a time: no `begin` on a limb while another limb's strike is active (a
  /// kick swings the arms, a lunge punch steps)
  bool one_at_a_time = false;
  double switch_margin = 0.9;///< switch when another action's distance < margin x current one's
};

struct Model {
  static constexpr int kVersion = 1;
  RecogniserSettings settings;
  std::vector<Template> templates;
  std::string note;  ///< provenance, one line (what it was trained on)
};

/// Model file (.krec): text, "kumite-recognition-model <version>", a FNV-1a 64 checksum of
/// the rest, then settings and templates. Reading refuses another version, a bad checksum
/// or malformed / non-finite / out-of-range numbers with kumite::Error "file:line: key:
/// message".
std::string format_model(const Model& m);
Model parse_model(std::string_view text, std::string_view source);
Model read_model(const std::filesystem::path& path);
void write_model(const std::filesystem::path& path, const Model& m);  ///< atomically

// ---- DTW ----------------------------------------------------------------------------------

struct DtwMatch {
  double distance = 1e30;  ///< accumulated cost / path length
  int template_end = 0;    ///< template frame aligned with the query's last frame
};
/// Open-end DTW: the whole query against a prefix of the template (both start together).
/// `scratch` is reused between calls (no allocation once large enough).
DtwMatch dtw_open_end(std::span<const Feature> query, std::span<const Feature> templ,
                      std::vector<double>& scratch);
/// Full DTW (both ends anchored) with the warping path (pairs query index, template index).
double dtw_full(std::span<const Feature> a, std::span<const Feature> b,
                std::vector<std::pair<int, int>>* path);

// ---- Training -----------------------------------------------------------------------------

/// One annotated strike as the frontend saw it: frames from onset to the window's end.
struct Trial {
  std::string action;
  LimbKind kind = LimbKind::hand;
  std::vector<Feature> frames;
  int hit = 0;
  std::string source;  ///< e.g. "135_04_kick_right_1"
  std::string style;   ///< who performed it (the actor): TrainSettings::template_per_style groups by it
};

inline constexpr std::string_view kNoneAction = "none";

struct TrainSettings {
  int averaging_iterations = 3;  ///< DTW barycentre averaging passes
  int none_frames = 12;          ///< "none" templates: the first frames of a non-strike movement
  int max_none_templates = 48;   ///< per limb kind (evenly thinned; bounds the per-loop cost)
  /// threshold(n) = factor x the largest distance of a training trial's n-frame prefix to the
  /// template (n = main buffer .. supplementary buffer; made non-decreasing in n)
  double threshold_factor = 1.3;
  /// Hand strikes: one template per (action, style) instead of per action, so a lunge from the
  /// hip and a straight from a guard are not averaged into one shape (evaluation only: the
  /// model file holds one template per action). Kicks keep one mean: per style, CMU 135's
  /// 3-trial front kick matched the same actor's kata steps (false triggers 2.6 -> 6.2 / min).
  bool template_per_style = false;
};

/// Mean templates per (kind, action): the medoid trial refined by DTW barycentre averaging;
/// thresholds per buffer length from the training trials' prefixes (TrainSettings). Sorted by
/// (kind, action).
std::vector<Template> build_templates(std::span<const Trial> trials, const RecogniserSettings& rs,
                                      const TrainSettings& s = {});

/// "none" trials: every movement start (as the recogniser would buffer it) of `limb` in the
/// frames, its first `frames` loops (movements shorter than the main buffer are left out).
std::vector<Trial> none_trials(std::span<const Frame> frames, Role limb, int frames_per_trial,
                               const RecogniserSettings& s);

/// Cuts a trial out of a frontend's frames for `limb`: the onset is where the recogniser would
/// start its buffer: searching back from the loop nearest `hit_t`, the first loop of the run of
/// loops faster than onset_speed (not before `first_t`; a run that began earlier starts at
/// `first_t`). The trial runs from there to `last_t`, hit = the loop nearest `hit_t`.
/// nullopt when the limb is not valid over the window or never moves faster than onset.
std::optional<Trial> cut_trial(std::span<const Frame> frames, Role limb, Timestamp first_t,
                               Timestamp hit_t, Timestamp last_t, const RecogniserSettings& s);

// ---- Recogniser ---------------------------------------------------------------------------

class Recogniser {
 public:
  explicit Recogniser(Model model);
  /// Feeds one sample; appends the events it caused. Cheap: one loop per 60 Hz tick.
  void push(const PoseSample& s, std::vector<Event>& out);
  /// Every sample up to t was pushed (the tracker's frame set is whole): the loops up to t run
  /// now (Frontend::end_of_set), their events stamped t.
  void end_of_set(Timestamp t, std::vector<Event>& out);
  /// The stream ended (or the tracker stopped) at time t: active strikes are cancelled.
  void finish(Timestamp t, std::vector<Event>& out);
  const Model& model() const { return model_; }
  /// Seconds of thread CPU the loops took (total) and how many loops ran.
  double loop_cpu_s() const { return loop_cpu_s_; }
  long loops() const { return loops_; }
  /// Times every loop with the thread CPU clock when set (benchmarks).
  void set_timing(bool on) { timing_ = on; }
  /// Per-loop CPU times (s) recorded while timing.
  const std::vector<double>& loop_times() const { return loop_times_; }

 private:
  enum class State : std::uint8_t { idle, collecting, active, discard };
  struct LimbState {
    State state = State::idle;
    std::vector<Feature> buffer;
    Float3 origin{};
    LimbFrame prev{};  ///< the previous loop's view of the limb
    bool prev_valid = false;
    int null_run = 0;
    int slow_run = 0;  ///< loops below onset_speed while collecting
    int discard_count = 0;
    int current = -1;  ///< template index of the active action
    double progress = 0, confidence = 0;
    Vec3 impact{0, 0, 0};
  };
  void loop(const Frame& f, std::vector<Event>& out);
  void run_frames(std::vector<Event>& out);  ///< loops over frames_
  void limb_loop(const Frame& f, int limb, std::vector<Event>& out);
  struct Best { int index = -1; double distance = 1e30; int end = 0; };
  Best classify(int limb, int exclude = -1);
  bool closer_to_none(int limb, int strike);
  bool another_active(int limb) const;
  Event make_event(const Frame& f, int limb, EventType type, int templ, const DtwMatch& m);
  /// The cancel event of an active limb's action, as of time t.
  Event cancel_event(int limb, const LimbState& st, Timestamp t) const;

  Model model_;
  Frontend frontend_;
  std::array<LimbState, kLimbCount> limbs_{};
  std::vector<Frame> frames_;
  std::vector<double> scratch_;
  Frame last_frame_{};
  Timestamp now_ = 0;  ///< time of the sample being pushed
  double loop_cpu_s_ = 0;
  long loops_ = 0;
  bool timing_ = false;
  std::vector<double> loop_times_;
};

/// Runs a recogniser over samples (sorted by time; end_of_set after each time's samples) and
/// finishes at the last one.
std::vector<Event> recognise(const Model& model, std::span<const PoseSample> samples);

}  // namespace kumite::recognition
