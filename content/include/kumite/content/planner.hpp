#pragma once
// The sparring planner: what the fighter does on its own in spar mode (Touché's planner: Dehesa
// et al., CHI 2020). It approaches to the fighting distance, then attacks on an exponential
// random timer and counters the visitor's strikes with a probability after an exponential
// reaction delay, striking with the arm on the side the visitor's strike leaves open. Its
// decisions are the orders a supervisor gives (content::Order), taken through the same path.
//
// Deterministic: the same inputs and seed give the same decisions on any machine. Random draws
// come from a counter-based generator (SplitMix64 of the seed and the draw's number; no
// std::*_distribution, whose algorithms differ between standard libraries); exponential
// delays are -ln(1 - u) * mean with u from 53 bits. One draw per decision, in a fixed order.
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>

#include <Eigen/Core>

#include "kumite/common/time.hpp"
#include "kumite/common/wire.hpp"
#include "kumite/content/fighter_types.hpp"  // VisitorStrikeSeen, PlannerMode, PlannerState, PlannerDecision, PlannerCounts
#include "kumite/content/threat.hpp"
#include "kumite/recognition/recognition.hpp"

namespace kumite::content {

/// SplitMix64's output for state `x` (the state advanced by its constant, then mixed): the same
/// on every machine. unit_interval: [0, 1) from the top 53 bits.
std::uint64_t splitmix64(std::uint64_t x);
double unit_interval(std::uint64_t bits);


/// [fighter.planner] (the installation file). Units on every name.
struct PlannerTunables {
  PlannerMode mode = PlannerMode::orders;     ///< "orders": the supervisor's alone; "spar": the planner's too
  double fighting_distance_m = 0.65;          ///< m, fighter root -> visitor head, horizontal: engaged within it
  double engage_tolerance_m = 0.25;           ///< m: engaged while no farther than fighting distance + this
  /// m: sparring, the fighting distance is kept with stance steps from the mocap: forward once the
  /// spot to keep is this far ahead (a spot nearer is walked to with procedural steps), back once
  /// the visitor has stayed closer than [fighter.behaviour] follow_tolerance_m for 0.5 s. 0:
  /// procedural steps only (the defence of content/README.md then blocks 10 of 12 punches
  /// instead of 12). Orders mode has its own key, [fighter.behaviour] stance_step_min_m (0 there).
  double stance_step_min_m = 0.5;
  /// deg: sparring, the spot kept lies within this angle either side of the way from the
  /// visitor's head to the fighter's home ([fighter.behaviour] follow_arc_deg, orders mode's:
  /// 180 there): its lunges into a visitor walking in carried it past them, and it kept its
  /// distance from there, at their back, where no wall shows it (180: anywhere round).
  double follow_arc_deg = 45;
  /// 1/s: the rate of its own attacks (0: none). An exponential timer that runs while the
  /// fighter is engaged and could strike (idle), so this is attacks per second of that time.
  double attack_rate_per_s = 0.5;
  double counter_probability = 0.3;           ///< a visitor strike (recognised begin) is countered with this probability
  double reaction_time_s = 0.3;               ///< s: mean of the exponential delay from the visitor's strike to the counter
  double counter_deadline_s = 1.0;            ///< s: a counter the fighter cannot start this late after it was due is dropped
  double kick_share = 0.25;                   ///< share of its own attacks (not counters) that are kicks
  /// A strike of its own under way (before its contact) is aborted with this probability when a
  /// visitor strike begins (recognised begin): it goes back to its guard. Hit, it always aborts.
  double abort_probability = 0.3;
  /// Spar: keeps a guard up and parries a fist or foot coming at its head or torso (ThreatWatch:
  /// seen coming, or recognised; Behaviour::parry, a block clip while the guard is not up).
  /// Off by default (content/README.md, "Blocks": judged on punches of unseen visitors).
  bool block = false;
 double block_max_rate = 2.0;                ///< a block is played up to this fast (segment s per s) to be in place in time
  ThreatTunables threat;                      ///< threat_* keys: what counts as a fist coming at it
  /// Hit reactions (spar): the visitor's fist or foot entering the fighter's drawn head or
  /// torso at least this fast is a blow (visitor_hit) and the fighter reels; slower is a touch
  /// (nothing). Also the least speed of a fist meeting a forearm (blocked).
  double hit_min_speed_mps = 1.5;
  double hit_full_speed_mps = 6.0;            ///< m/s: a blow this fast or faster reels the fighter fully
  double hit_head_max_deg = 15;               ///< deg: the head's largest reel about the neck (a full head blow)
  double hit_trunk_max_deg = 8;               ///< deg: the trunk's about the pelvis (a full torso blow)
  double hit_shoulder_max_deg = 12;           ///< deg: the struck side's shoulder's (a full blow off the midline)
  double hit_stiffness_rad_s = 10;            ///< rad/s: the reel's spring (undamped angular frequency)
  double hit_damping_ratio = 0.8;             ///< the spring's damping ratio (1: critical, < 1 overshoots a little)
  double hit_step_back_m = 0.3;               ///< m: a large blow steps the fighter back this far (0: never)
  double hit_step_back_share = 0.6;           ///< a blow of at least this share of full size steps back
  bool operator==(const PlannerTunables&) const = default;
};

/// The named presets of Touché's study: "aggressive_unskilled" (1 attack/s, no counter) and
/// "defensive_skilled" (0.3 attacks/s, counters often, 0.1 s reaction). nullopt: unknown name.
std::optional<PlannerTunables> planner_preset(std::string_view name);
/// "" when every value is finite and in range, else "key: message" for the first that is not.
std::string validate(const PlannerTunables& t);



/// What the planner reads each update.
struct PlannerInput {
  Timestamp now = 0;                            ///< s
  std::uint64_t seed = 0;                       ///< the run's seed (FighterInput::seed)
  Eigen::Vector3d head_m{0, 0, 0};              ///< m, room: the visitor's head
  Eigen::Vector3d fighter_root_m{0, 0, 0};      ///< m, room: the fighter's root on the floor
  bool fighter_idle = false;                    ///< the fighter can take a strike order now
  bool supervisor_strike = false;               ///< the supervisor ordered a strike this update (comes first)
  bool fighter_attacking = false;               ///< a strike of its own is under way, before its contact (it may be aborted)
  std::span<const VisitorStrikeSeen> strikes;   ///< the visitor's strikes recognised since the last update
};


class SparPlanner {
 public:
  explicit SparPlanner(PlannerTunables tunables = {});
  /// One update: the order it gives now, if any (orders mode: never).
  std::optional<Order> step(const PlannerInput& in);
  /// Changes the tunables (a preset, the mode) from the next update; the timers start anew.
  void set_tunables(const PlannerTunables& t);
  const PlannerTunables& tunables() const { return tun_; }
  PlannerState state() const { return state_; }
  /// The next decision while one is drawn (the attack timer's or a due counter).
  std::optional<PlannerDecision> next() const;
  const PlannerCounts& counts() const { return counts_; }
  /// True once after an update that drew to abort the fighter's strike under way.
  bool take_abort() { return std::exchange(abort_, false); }

 private:
  double uniform(std::uint64_t seed);  ///< [0, 1), 53 bits; advances the draw counter
  double exponential(std::uint64_t seed, double mean_s);
  PlannerTunables tun_;
  PlannerState state_ = PlannerState::off;
  std::uint64_t draws_ = 0;
  std::optional<PlannerDecision> attack_, counter_;
  double attack_left_s_ = 0;      ///< s left on the attack timer
  Timestamp counter_strike_t_ = 0;  ///< s: when the strike the due counter answers was seen
  Timestamp last_now_ = 0;
  bool have_now_ = false;
  bool abort_ = false;
  PlannerCounts counts_;
};

}  // namespace kumite::content
