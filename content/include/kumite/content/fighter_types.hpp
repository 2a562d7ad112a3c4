#pragma once
// The fighter's vocabulary as the rest of the installation sees it: its states, events and
// frames, what one update takes and gives, the sparring planner's status and score. No
// tunables and no behaviour here (fighter.hpp, tunables.hpp, planner.hpp hold those), so a unit
// that only feeds, draws or logs the fighter does not recompile when a tunable is added.
//
// Room frame: metres, +Y up, floor y = 0, front wall toward -Z. Times: kumite::Timestamp seconds.
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "kumite/common/time.hpp"
#include "kumite/common/wire.hpp"
#include "kumite/content/event.hpp"
#include "kumite/recognition/recognition.hpp"  // the visitor's body roles and strike kinds (vocabulary only)

namespace kumite::content {

class Fighter;            // fighter.hpp
struct PlannerTunables;   // planner.hpp

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

/// A strike of the visitor's as the recogniser reported it in an update (recognition::Event).
struct VisitorStrikeSeen {
  Timestamp t = 0;  ///< s, the camera time of the sample that decided it
  recognition::EventType type = recognition::EventType::begin;
  recognition::Role limb = recognition::Role::right_hand;
  recognition::Action action = recognition::Action::other;
  double progress = 0;                       ///< 0..1, onset to full extension
  double confidence = 0;                     ///< 0..1
  Eigen::Vector3d impact_m{0, 0, 0};         ///< m, room: where the fist or foot will be at full extension
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


enum class PlannerMode { orders, spar };
std::string_view to_string(PlannerMode m);

enum class PlannerState {
  off,          ///< orders mode: the planner decides nothing
  approaching,  ///< farther than the fighting distance: the fighter closes in
  guarding,     ///< engaged, its attack timer running
  countering,   ///< a counter is due (PlannerDecision::due)
};
std::string_view to_string(PlannerState s);

/// Why the planner ordered a strike.
enum class PlannerCause { timer, counter };
std::string_view to_string(PlannerCause c);

/// The planner's next decision: what, why and when (for the console and the log).
struct PlannerDecision {
  OrderKind kind = OrderKind::punch_right;
  PlannerCause cause = PlannerCause::timer;
  Timestamp due = 0;  ///< s
};

/// Counts, for the statistics the planner is judged by (kumite-motion spar).
struct PlannerCounts {
  int attacks = 0;            ///< its own attacks ordered (timer)
  int visitor_strikes = 0;    ///< visitor strike begins seen while engaged
  int counters_drawn = 0;     ///< of those, drawn to be countered
  int counters = 0;           ///< counters ordered
  int counters_dropped = 0;   ///< counters past counter_deadline_s
  int counters_superseded = 0;  ///< counters still due when a newer strike was drawn to be countered
  double reaction_sum_s = 0;  ///< s, summed delay visitor strike -> counter order
  double reaction_drawn_sum_s = 0;  ///< s, ...of which drawn (the rest: the update nearest the due time, and waiting for the fighter to be idle)
  double engaged_s = 0;       ///< s spent engaged (guarding or countering)
  double timer_running_s = 0; ///< s the attack timer ran (engaged, the fighter idle, no counter due)
  int abort_draws = 0;        ///< visitor strike begins seen while its own strike was under way
  int aborts = 0;             ///< of those, drawn to abort it (abort_probability)
};

/// The bout's score (spar mode), from the fighter's events as they happened.
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

/// The sparring planner as the console and the log show it (Fighter::planner_status()). Its
/// tunables whole: Fighter::planner_tunables() (planner.hpp).
struct PlannerStatus {
  PlannerMode mode = PlannerMode::orders;  ///< [fighter.planner] mode
  bool block = false;                      ///< [fighter.planner] block: it blocks the visitor's strikes
  PlannerState state = PlannerState::off;
  std::optional<PlannerDecision> next;
  PlannerCounts counts;
  SparScore score;
};
}  // namespace kumite::content
