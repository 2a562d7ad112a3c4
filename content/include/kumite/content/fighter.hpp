#pragma once
// The fighter as the app sees it: one object fed with the tracked head and the supervisor's
// orders, giving a pose to draw each frame. Behaviour, retrieval (on its own worker thread)
// and adaptation live behind this facade. Engine-agnostic: no GL, no cameras.
//
// CONTRACT (agreed between content/ and app/; the content module implements it). Room frame:
// metres, +Y up, floor y = 0, front wall toward -Z. Times: kumite::Timestamp seconds.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "kumite/common/time.hpp"
#include "kumite/common/wire.hpp"
#include "kumite/content/event.hpp"
#include "kumite/content/planner.hpp"
#include "kumite/content/tunables.hpp"
#include "kumite/recognition/recognition.hpp"  // the visitor's body roles and strike kinds (vocabulary only)

namespace kumite::content {

struct FighterConfig {
  std::filesystem::path database;                  ///< fighter.kdb (kumite-motion build)
  std::vector<std::filesystem::path> characters;   ///< character BVH files, in key order 1..N
  std::vector<std::string> character_names;        ///< shown to the supervisor (same order)
  int initial_character = 0;
  Eigen::Vector3d home{0.0, 0.0, -2.5};  ///< m, room frame: where the fighter rests (floor)
  double strike_distance_m = 0.9;        ///< preferred horizontal distance root -> head
  double min_x_m = -1.4, max_x_m = 1.4;  ///< m, lateral limits of where it may walk
  double min_z_m = -4.0, max_z_m = -1.7; ///< m, depth limits (stays behind the front wall)
  double hit_radius_m = 0.10;            ///< m: the strike reached its frozen target when the hit
                                         ///< point ends this close to it
  /// The visitor's body as tracked at contact: a sphere round the head and a capsule below it
  /// (shoulders to shins). A strike hits when its hit point is inside either (the fist or foot
  /// touches the visitor), whatever the frozen target was: a visitor who ducks or steps away
  /// is missed (dodged).
  double visitor_head_radius_m = 0.12;   ///< m, sphere round the tracked head point
  double visitor_body_radius_m = 0.20;   ///< m, radius of the torso/legs capsule
  double visitor_neck_m = 0.25;          ///< m, head point down to the capsule's top
  double visitor_capsule_bottom_m = 0.25;  ///< m above the floor: the capsule's bottom
  BehaviourTunables behaviour;           ///< [fighter.behaviour] (tunables.hpp)
  RetrievalTunables retrieval;           ///< [fighter.retrieval]
  PlannerTunables planner;               ///< [fighter.planner] (planner.hpp): orders or spar
};

enum class FighterState { resting, following, striking, recovering };
std::string_view to_string(FighterState s);
/// What the fighter is doing (its action state: content/README.md, "Action states"). A
/// strike order: idle -> awaiting_plan -> [stepping_in | stepping_back | restance |
/// support_step -> retaking -> awaiting_plan ...] -> striking -> recovering -> idle.
enum class FighterAction {
  idle,           ///< no strike under way: resting or following
  awaiting_plan,  ///< a strike order sent to the planner (retrieval)
  stepping_in,    ///< stepping toward the strike's target first (it falls short from here)
  stepping_back,  ///< stepping away from it first (the limb would land folded)
  restance,       ///< taking the fighting stance on the way (after a stance step's long stance)
  support_step,   ///< a strike's support foot stepping to where the strike stands on it
  retaking,       ///< the order is taken again at the next update, from where the step ended
  striking,       ///< the strike's clip plays, adapted to its target
  recovering,     ///< blending into rest while the reach offset goes back to zero
  blocking,       ///< a block's clip plays, its forearm brought across an incoming fist's path (spar)
};
std::string_view to_string(FighterAction a);
/// How the body moves while no strike plays (at_spot while striking or recovering).
enum class FighterLocomotion {
  at_spot,      ///< stands at its spot (FighterState::resting)
  walking,      ///< walks its spot, procedural steps (following)
  stance_step,  ///< a stance step from the mocap carries it (following)
};
std::string_view to_string(FighterLocomotion l);

/// Something the fighter did or refused, as data (its line for people: describe()).
struct FighterEvent {
  /// What it is (event.hpp: the one list of events, with the app's and the log's; the fighter
  /// makes order_accepted to warning, stepping_in, support_step and stepping_back).
  using Kind = EventKind;
  /// What an accepted order did, why one was ignored, what a warning is about.
  enum class Reason : std::uint8_t {
    none,
    paused,             ///< accepted pause; or ignored: the fighter is paused
    resumed,            ///< accepted resume
    recentre,           ///< accepted recentre: walking home
    strike,             ///< accepted strike: `target` frozen
    mid_strike,         ///< ignored: a strike is under way
    near_wall,          ///< ignored: the visitor is near a wall, the fighter keeps away
    no_such_character,  ///< warning: `order.character` does not exist (`character_count` do)
    no_strike,          ///< warning: no strike in the database for this order
    restance,           ///< stepping_in, stepping_back: into the fighting stance on the way (from a stance step's long stance)
    blocking,           ///< ignored: a strike order while blocking; or a pending strike dropped for a block
  };
  Timestamp time = 0;
  Kind kind = Kind::warning;
  Order order{};              ///< the order concerned (a strike's outcome: the strike's)
  Reason reason = Reason::none;
  double distance_m = 0;      ///< hit / dodged / miss: m from the hit point to the visitor's
                              ///< body surface at contact (0 when touching); stepping_in, stepping_back: m
                              ///< the fighter steps in; support_step: m the support foot steps
  Eigen::Vector3d target{0, 0, 0};  ///< m, room frame: an accepted strike's frozen target
  int segment = -1;           ///< hit / dodged / miss: the database segment played
  int start_frame = 0, contact_frame = 0;  ///< its frames (start, contact)
  double contact_distance_m = 0;  ///< hit / miss: m from the hit point to the target at contact
  bool out_of_reach = false;  ///< miss: the limb could not reach the target
  int character_count = 0;    ///< no_such_character: how many there are
  /// block, blocked, visitor_hit: the visitor's limb whose strike it is (blocked, visitor_hit:
  /// the limb that met the forearm / the body).
  recognition::Role limb = recognition::Role::right_hand;
  int side = -1;              ///< block, blocked: the forearm; support_step: the foot (0 left, 1 right; -1 none)
  /// block: s from the forearm in place to the fist's predicted arrival (< 0: `late`, in place
  /// after it); blocked, visitor_hit: s since the block was in place (0 without a block).
  double margin_s = 0;
  double speed_mps = 0;       ///< block: the fist's speed seen; blocked, visitor_hit: its speed at contact
  bool recognised = false;    ///< block: answering a recognised strike (not only seen coming)
  bool operator==(const FighterEvent&) const = default;
};
/// The event's line for people, as the log and console show it ("mid-strike", "target at
/// (0.57, 1.61, 0.48) m", "135_06_punch_left_3 (frames 20->50): touched the visitor (0.0 cm
/// from the target)", ...); `segment_name` names e.segment, `character_name` a character.
std::string describe(const FighterEvent& e, const std::function<std::string(int)>& segment_name,
                     const std::function<std::string(int)>& character_name);

/// One frame of the fighter, ready to draw. Spans stay valid until the next update().
struct FighterFrame {
  Timestamp time = 0;
  FighterState state = FighterState::resting;
  FighterAction action = FighterAction::idle;
  FighterLocomotion locomotion = FighterLocomotion::at_spot;
  int character = 0;                         ///< 0-based
  std::span<const Eigen::Vector3d> joints;   ///< m, room frame, one per skeleton joint
  std::span<const int> parents;              ///< parent index per joint (-1 root)
  std::span<const float> joint_radii_m;      ///< suggested capsule radius per bone (to parent)
  std::span<const std::string> joint_names;  ///< the character's skeleton joint names
  /// Per joint, its rotation relative to its parent (the root's: to the room), on the
  /// character's skeleton (BVH offsets, identity = the offsets' pose). Forward kinematics of
  /// these from `root_joint` gives `joints` exactly, except while a character switch eases
  /// the drawn joints from the old character's pose (blend_time_s after the switch).
  std::span<const Eigen::Quaterniond> local_rotations;
  Eigen::Vector3d root_joint{0, 0, 0};       ///< m, room frame: the skeleton's root joint (BVH root)
  std::optional<Eigen::Vector3d> target;     ///< m, room frame: frozen strike target
  Eigen::Vector3d root{0, 0, 0};             ///< m, room frame, on the floor under the pelvis
  double heading_rad = 0;                    ///< rotation about +Y; 0 = facing +Z (the visitor)
};

struct StrikeRequest;  // behaviour.hpp
struct StrikePlan;
class StrikePlanner;
struct StrikeRateJob;
struct StrikeRateResult;
class StrikeRateSolver;

/// Updates between a strike's order and the update its plan is applied on: an order taken
/// at update N starts its strike at update N + kRetrievalDelayUpdates (at 60 Hz: 16.7 ms
/// later), whatever the worker thread's timing. Retrieval takes ~20 µs, so the worker is
/// done long before; if it is not, that update waits for it (counted in RetrievalTiming).
/// The same orders at the same updates therefore always give the same frames.
constexpr int kRetrievalDelayUpdates = 1;

/// How the fighter's retrieval worker kept to its deadline (the update each plan is due on).
struct RetrievalTiming {
  std::uint64_t requests = 0;  ///< strike plans asked for
  std::uint64_t rate_jobs = 0; ///< strikes' playback rates asked for (StrikeRateJob)
  std::uint64_t waits = 0;     ///< updates that had to wait for the worker (plan or rate not ready on time)
  double wait_max_ms = 0;      ///< ms, the longest such wait
  double wait_total_ms = 0;    ///< ms, all waits together
  double rate_solve_max_us = 0;  ///< µs, the longest rate solve on the worker
};

struct FighterOptions {
  int retrieval_delay_updates = kRetrievalDelayUpdates;  ///< >= 0 (0: plan applied on the order's update)
  /// Runs a plan on the worker thread instead of planner.plan(request) (tests: a slow planner).
  std::function<StrikePlan(const StrikePlanner& planner, const StrikeRequest& request)> plan;
  /// Runs a rate job on the worker thread instead of solver.solve(job) (tests: a slow solver).
  std::function<StrikeRateResult(StrikeRateSolver& solver, const StrikeRateJob& job)> rate;
  /// Set: a character whose file cannot be read (cut, damaged) is left out of the fighter and
  /// reported here (its index in FighterConfig::characters, the error's line), and the others
  /// fight; the fighter's characters are then the readable ones, in order. Unset: it throws.
  std::function<void(std::size_t character, const std::string& why)> on_unreadable_character;
};

/// One of the visitor's tracked bodies (the glasses, a glove, a shoe) in an update. Room frame.
struct VisitorBody {
  recognition::Role role = recognition::Role::head;
  Eigen::Vector3d position_m{0, 0, 0};
  Eigen::Quaterniond orientation{1, 0, 0, 0};  ///< body -> room
  bool tracked = false;                         ///< false: lost (the pose is the last known)
  Timestamp t = 0;                              ///< s, when it was measured
};

/// Everything the fighter takes from outside in one update, as plain data (spans into the
/// caller's memory, valid for the call). The same inputs give the same outputs.
struct FighterInput {
  Timestamp now = 0;                       ///< s
  double dt_s = 0;                         ///< s since the last update
  Eigen::Vector3d head_m{0, 0, 0};         ///< m, room: the visitor's eyes' midpoint (faced, struck at)
  bool keep_away = false;                  ///< visitor safety: back off, strike orders ignored
  std::span<const Order> orders;           ///< given since the last update, in order (the fighter's character numbering)
  std::span<const VisitorBody> bodies;     ///< the visitor's tracked bodies by role
  std::span<const VisitorStrikeSeen> strikes;  ///< the visitor's strikes recognised since the last update
  std::uint64_t seed = 0;                  ///< the run's seed: the sparring planner's random draws
};

/// What one update gives: the pose to draw and the events since the last update.
struct FighterOutput {
  FighterFrame frame;                ///< spans valid until the next update
  std::vector<FighterEvent> events;  ///< overwritten each update (its room kept)
};

class Fighter {
 public:
  /// One update from plain data: the orders queued in order, keep_away, update(), the frame
  /// and the events taken. The bodies and strikes are the visitor as the sparring decisions
  /// will read it: today's fighter (orders alone) carries them and reads only head_m.
  void step(const FighterInput& in, FighterOutput& out) {
    for (const Order& o : in.orders) order(o);
    keep_away(in.keep_away);
    decide(in);
    update(in.now, in.dt_s, in.head_m);
    out.frame = frame();
    out.events = take_events();
  }

  /// Loads the database and characters. Throws kumite::Error naming the file at fault.
  static std::unique_ptr<Fighter> create(const FighterConfig& config, FighterOptions options = {});
  virtual ~Fighter() = default;

  /// Queue an order (any thread that owns the fighter; not thread-safe by itself).
  virtual void order(const Order& order) = 0;
  /// Visitor safety: while on, the fighter backs off and ignores strike orders with a reason
  /// (Behaviour::keep_away); the app sets it while the visitor is near a wall.
  virtual void keep_away(bool on) = 0;
  /// The sparring planner's decision for this update (spar mode; after the supervisor's orders,
  /// which come first): queues its order, if it gives one, and the distance to keep.
  virtual void decide(const FighterInput& in) = 0;
  /// Mode and tunables of the planner from the next update (a key, a preset from the console).
  virtual void set_planner(const PlannerTunables& tunables) = 0;
  /// The bout's score (spar mode), from the events as they happened.
  struct SparScore {
    int visitor_hits = 0;    ///< the visitor's fist or foot entered the fighter's body fast (visitor_hit)
    int blocks = 0;          ///< blocks begun against a strike (block events; `late` included)
    int blocks_late = 0;     ///< of those, in place after the fist's predicted arrival
    int blocked = 0;         ///< the visitor's fist or foot met a forearm (blocked)
    int fighter_hits = 0;    ///< the fighter's strikes that touched the visitor (hit)
    int visitor_dodges = 0;  ///< the fighter's strikes that reached their target with the visitor gone (dodged)
    int unanswered = 0;      ///< threats seen that no block could answer (the fighter busy, no block fitting)
    bool operator==(const SparScore&) const = default;
  };
  struct PlannerStatus {
    PlannerTunables tunables;
    PlannerState state = PlannerState::off;
    std::optional<PlannerDecision> next;
    PlannerCounts counts;
    SparScore score;
  };
  virtual PlannerStatus planner_status() const = 0;
  /// Advance to `now` (dt = seconds since the last update) toward the visitor's head
  /// (room frame). Retrieval runs on a worker thread; its plan is applied exactly
  /// retrieval_delay_updates updates after the order (waiting for the worker only if it is
  /// late), so the frames depend on the inputs alone, not on thread timing.
  virtual void update(Timestamp now, double dt, const Eigen::Vector3d& head) = 0;
  virtual FighterFrame frame() const = 0;
  /// Events since the last call (orders accepted/ignored, hit/miss, warnings).
  virtual std::vector<FighterEvent> take_events() = 0;
  /// The event's line for people (describe(), with this fighter's clips and characters).
  virtual std::string describe(const FighterEvent& event) const = 0;
  virtual int character_count() const = 0;
  virtual std::string character_name(int index) const = 0;
  /// The most joints any of its characters has (what a frame's joints may grow to).
  virtual std::size_t most_joints() const = 0;
  virtual RetrievalTiming retrieval_timing() const = 0;
};

}  // namespace kumite::content
