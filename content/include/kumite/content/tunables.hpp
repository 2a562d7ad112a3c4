#pragma once
// The fighter's tunables: plain structs with their defaults, and their keys in the
// installation file (issue 13), where a technician may change them without a rebuild:
//
//   [fighter.behaviour]        BehaviourTunables   (following, strike placement, blends)
//   [fighter.behaviour.feet]   FootPlantingTunables (holding feet, swings, procedural steps)
//   [fighter.retrieval]        RetrievalTunables   (the strike search's cost weights)
//
// Every key has a unit and a range (fighter_tunable_keys()); a file's value outside it, nan or
// inf, an unknown key or two keys that contradict each other is an error naming file, line and
// key. Values made in code are checked by validate() the same way. Lengths in metres, times in
// seconds, speeds in metres per second, angles in degrees where the key says _deg.
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace kumite::content {

struct FootPlantingTunables {
  double max_heading_lag_rad = 0.6;  ///< rad: a held foot steps when the motion turns it this far
  double heading_release_s = 0.2;  ///< s: a lifted foot turns from its held heading to the motion's over this
  double step_threshold_m = 0.12;  ///< m: a held foot steps when its free place is this far
  double max_leg_stretch = 0.97;   ///< hip->held ankle / leg length beyond which the foot steps
  double step_time_s = 0.30;       ///< s per procedural step
  double step_height_m = 0.06;     ///< m: foot lift at mid-step
  double min_swing_s = 0.15;       ///< s: the shortest time over which a lifted foot sheds its offset
  double landing_height_m = 0.04;  ///< m: a lifted foot is put down only this close to its standing height
  double landing_window_m = 0.08;  ///< m above standing height: a foot the motion puts down this low
                                   ///< comes straight down where it is (higher: it follows the motion)
  double landing_speed_mps = 0.6;  ///< m/s: the least speed at which such a foot comes down
  double max_landing_speed_mps = 2.0;  ///< m/s: the most
  double return_speed_mps = 4.0;   ///< m/s: a foot the motion has down but that is higher than
                                   ///< landing_window_m goes back to the motion's foot this fast
  double min_swing_path_m = 0.05;  ///< m: a lifted foot heads for the motion's landing when the
                                   ///< source still travels its ankle this far (else it follows the source)
  double max_swing_speed_ratio = 1.5;  ///< a foot heading for its landing moves at most this
                                       ///< many times the source's horizontal speed
  double swing_lift_m = 0.10;      ///< m: a foot heading for its landing clears the floor by at
                                   ///< least this at mid-way (at most 0.25 x its way), a sine over
                                   ///< the way: a step, never a skim along the floor
  bool operator==(const FootPlantingTunables&) const = default;
};

struct RetrievalTunables {
  double pose_weight = 1.0;               ///< per unit of feature distance (dimensionless)
  double trajectory_weight_per_m = 5.0;   ///< 1/m: 20 cm of hit-point miss = 1 unit of pose
  double box_margin_m = 0.15;             ///< m: how far adaptation may comfortably move the
                                          ///< hit point outside the clip's own hit window
  bool operator==(const RetrievalTunables&) const = default;
};

struct BehaviourTunables {
  double follow_tolerance_m = 0.25;   ///< m: start following when farther than this off the spot
  double arrive_tolerance_m = 0.05;   ///< m: stop following this close to the spot
  double walk_speed_mps = 0.7;        ///< m/s of the root while following
  double turn_speed_rad_s = 2.5;      ///< rad/s while turning to face the visitor
  /// deg: the spot the fighter keeps (at its distance from the visitor's head) lies within this
  /// angle either side of the way from the head to the fighter's home (the walls' side of the
  /// room): a lunge that carries it past the visitor, or a visitor walking past it, is not
  /// followed round to the visitor's back, where no wall shows it. 180: anywhere round. Orders
  /// mode's; sparring has its own key, [fighter.planner] follow_arc_deg (45 there).
  double follow_arc_deg = 180;
  double kick_target_drop_m = 0.45;   ///< m: kicks aim this far below the head (the torso)
  double max_root_drop_m = 0.30;      ///< m: the most the pelvis is lowered for held feet (a knee bend)
  double max_drop_rate_mps = 2.0;     ///< m/s: how fast that drop may change
  double max_drop_accel_mps2 = 60;    ///< m/s^2: how fast that rate may change
  double keep_away_extra_m = 0.8;     ///< m: how much further than the strike distance the fighter
                                      ///< stands while the visitor is near a wall
  double release_time_s = 0.25;       ///< s: the shortest time d(t) takes to return to zero after
                                      ///< contact (it carries on through the blend into rest)
  double max_support_shift_m = 0.30;  ///< m: a strike clip is shifted at most this far on the floor
                                      ///< so that its support foot starts where that foot is held
  double min_contact_distance_m = 0.45;  ///< m: at contact the pelvis stays this far short of the
                                         ///< target (horizontally) when the clip is placed
  double min_travel_scale = 0.35;     ///< a strike clip's floor travel to contact is scaled to
  double max_travel_scale = 1.5;      ///< fit the target, within these factors (a shorter or
                                      ///< longer lunge)
  double min_scaled_travel_m = 0.12;  ///< m: clips that travel less to contact keep their travel
  /// A target farther than the strike clip reaches with its support foot where it stands (the
  /// hip at contact beyond the leg's reach of that foot: the foot would be dragged, or the
  /// pelvis sink and a punch go up with its elbow above the head): the fighter first steps in
  /// by the distance missing, at least step_in_min_m and at most max_step_in_m (0: never
  /// steps in; the lunge is then only as long as the foot allows and the arm reaches on).
  double step_in_min_m = 0.05;
  double max_step_in_m = 0.8;
  double step_in_speed_mps = 1.5;     ///< m/s of the root while stepping in (faster than following)
  /// A target so near that, with the strike's travel shortened all it may be (min_travel_scale,
  /// max_support_shift_m), the limb would land less extended than min_strike_extension of its
  /// length (shoulder or hip to wrist or ankle): a straight punch folded onto the target, its
  /// wrist by its elbow. The fighter first steps back (at step_in_speed_mps) by as much as
  /// brings the limb to the clip's own extension at contact, and at least back to
  /// strike_distance_m from the target (a strike is placed on its support foot, which a short
  /// step leaves nearly where it was), at most max_step_back_m (0: never steps back; the
  /// strike lands as folded as it must). Only where that gains step_in_min_m or more.
  double min_strike_extension = 0.5;
  double max_step_back_m = 0.8;
  /// Following forward or back uses a stance step cut from the mocap (a `walk` segment of
  /// motions.toml: a karate step in stance, its floor travel scaled to the distance within
  /// [min, max]_stance_step_scale, the rest motion or its mirror after, whichever stance the
  /// step ends in); a spot off mostly sideways, or one a step cannot reach, is followed with
  /// procedural steps. Forward the fighter lets the visitor stand up to stance_step_min_m
  /// farther than strike_distance_m before it steps (a real step is longer than
  /// follow_tolerance_m); a visitor who stays closer than follow_tolerance_m for 0.5 s makes
  /// it step back (a whole step, farther than needed where the distance is short; procedural
  /// steps follow meanwhile, so a lunge that returns is not stepped back from). 0: procedural only.
  double stance_step_min_m = 0;
  double min_stance_step_scale = 0.85;
  double max_stance_step_scale = 1.1;
  /// m: a kick whose clip puts its support foot down more than this far (on the floor) from
  /// where that foot is held first steps the foot there (a procedural step while the kicking
  /// foot stands), then starts: the kick then turns on a foot the leg reaches, instead of the
  /// support foot being dragged or hopped under the rising body (0: never).
  double kick_support_step_m = 0.25;
  /// m: the same for a punch, on the foot its clip keeps down longest from its start: a held
  /// foot more than this from where the clip has it steps there first; a foot still in a
  /// procedural step is sent on to there and the punch waits for it to land (a lunge taken
  /// from a step lifted its front foot while the back foot was still in the air: both feet off
  /// where the mocap stands on one). 0: never (the punch starts at once, its stepping foot
  /// landing where it is or carried on under it).
  double punch_support_step_m = 0.4;
  double max_strike_rise_m = 0.12;    ///< m: the most the pelvis is raised toward standing for a
                                      ///< target above the clip's own hit
  double max_punch_elevation_deg = 20;  ///< a punch aims at most this steeply upward before the
                                        ///< pelvis is raised (up to max_strike_rise_m)
  double max_punch_aim_deg = 40;      ///< a visitor's head higher than a standing shoulder's arm
                                      ///< reaches at this elevation is punched lower (neck, chest)
  double blend_time_s = 0.25;         ///< s, cross-fade into a new motion (and a character switch's easing)
  /// A strike whose correction (d(t), a scaled lunge, a raised pelvis) would move its hit
  /// point faster than max_strike_speed_ratio times the source clip's own peak speed (scaled
  /// to the character) is played slower, down to min_strike_rate segment seconds per second:
  /// a longer way at the captured speed, not a captured strike sped up (1: off). Finding the
  /// rate decodes the strike's way (~0.2-0.3 ms): the Fighter does it on its retrieval worker
  /// (StrikeRateSolver), not on the frame, and the rate enters kStrikeRateDelayUpdates after
  /// the strike starts. Chosen on the 240-strike grid (kumite-motion quality, 26 Nov): with
  /// blend_time_s 0.25 the p99 joint speed ratio output/source is p50/p95/max 1.01/1.18/1.37
  /// (rate off: 1.25/1.51/1.64), support-foot slide p95 0.95 m/s, no snaps; min_strike_rate
  /// 0.5 and 0.6 give the same grid, 0.7 slide max 1.65 m/s; blend_time_s 0.2 with the rate
  /// p95 1.30 and slide p95 1.35, 0.3 three snaps; max_strike_speed_ratio 1.0 p95 1.14 but
  /// slide p95 0.99, 1.1 one snap. Since 27 Nov the solver also holds the p99 of every
  /// joint's speed over the way to this ratio of the source's (the figure the grid judges: a
  /// knee turned faster than its own while the limb's fastest joint stayed within bounds), and
  /// the ratio is 1.0: p99 ratio over 1.2 on the grid 7 -> 2 of 240 (max 1.36 -> 1.21),
  /// stepping feet over 1.2x the source's 1 -> 0, slide unchanged; punches' order -> contact
  /// p50 0.38 -> 0.42 s (1.05 with the p99 rule: 6 over 1.2, max 1.27).
  double max_strike_speed_ratio = 1.0;
  double min_strike_rate = 0.6;
  FootPlantingTunables feet;          ///< foot holding, swings and procedural steps
  bool operator==(const BehaviourTunables&) const = default;
};

/// One tunable as a file names it: its dotted key under [fighter] ("behaviour.walk_speed_mps",
/// "behaviour.feet.swing_lift_m", "retrieval.pose_weight"), unit and closed range.
struct TunableKey {
  std::string_view table;  ///< "behaviour", "behaviour.feet" or "retrieval"
  std::string_view key;    ///< within that table
  std::string_view unit;   ///< "m", "s", "m/s", "rad/s", "deg", "1/m", "" (a ratio)
  double min = 0, max = 0;
  double BehaviourTunables::*behaviour = nullptr;  ///< one of these three is set
  double FootPlantingTunables::*feet = nullptr;
  double RetrievalTunables::*retrieval = nullptr;
};
/// Every tunable key, in the order they are documented and written.
const std::vector<TunableKey>& fighter_tunable_keys();

/// The value of `key` in (b, r).
double tunable_value(const TunableKey& key, const BehaviourTunables& b, const RetrievalTunables& r);

/// Reads [fighter.behaviour], [fighter.behaviour.feet] and [fighter.retrieval] from an
/// installation file's text (other tables are not looked at: the installation's reader checks
/// them), over `b` and `r` (keys absent keep their values). Errors: kumite::Error, component
/// "config", "file:line: fighter.behaviour.key: message".
void parse_fighter_tunables(std::string_view text, std::string_view file, BehaviourTunables& b,
                            RetrievalTunables& r);
void read_fighter_tunables(const std::filesystem::path& file, BehaviourTunables& b, RetrievalTunables& r);
struct PlannerTunables;  // planner.hpp
/// [fighter.planner] of an installation file's text: `preset` (its values first), `mode`, `seed`
/// and each tunable (planner.hpp), ranges checked; file:line: key: message errors. Absent: unchanged.
/// `follow_tolerance_m`: [fighter.behaviour]'s, read first (a stance_step_min_m over 0 and
/// below it is an error, as the behaviour's own key is).
void parse_planner_tunables(std::string_view text, std::string_view file, PlannerTunables& p, std::uint64_t& seed,
                            double follow_tolerance_m = BehaviourTunables{}.follow_tolerance_m);

/// The first key out of its range or contradicting another: its key under [fighter]
/// ("behaviour.feet.swing_lift_m"), code ("range", "not_finite") and message.
struct TunableProblem {
  std::string key, code, message;
};
std::optional<TunableProblem> tunables_problem(const BehaviourTunables& b, const RetrievalTunables& r);

/// Throws kumite::Error ("config", "range") naming the first key out of its range, or two
/// keys that contradict each other (arrive_tolerance_m >= follow_tolerance_m, ...).
void validate(const BehaviourTunables& b, const RetrievalTunables& r);

/// The three tables as TOML, every key with its value, unit and range (kumite-motion tunables
/// prints the defaults; parse_fighter_tunables reads it back to the same values).
std::string format_fighter_tunables(const BehaviourTunables& b, const RetrievalTunables& r);

}  // namespace kumite::content
