#pragma once
// Behaviour's own helpers, shared by its files (content/src, not installed):
//   behaviour.cpp        decisions: orders, the state machine, strikes, following, contact
//   motion_playback.cpp  the MotionPlayer (sampling, placement, a strike's scaled travel)
//   strike_placement.cpp a strike's clip on its support foot, its travel fitted (free functions)
//   contact.cpp          a strike's contact judged against the visitor as tracked
//   switch_easing.cpp    a character switch's eased pose
//   feet.cpp             the Feet (feet.hpp): what the motion says of each foot, the
//                        FootPlanter, the held feet and the pelvis drop's bounds
//   behaviour_steps.cpp  following with stance steps cut from the mocap
//   behaviour_block.cpp, behaviour_guard.cpp (Guard), behaviour_hit.cpp (HitReel): spar mode
#include <limits>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include <Eigen/Core>

#include "kumite/content/behaviour.hpp"

namespace kumite::content::behaviour_detail {

using Eigen::Vector2d;

/// m/s: the most a procedural step redirected to where a strike's clip stands on its foot
/// moves the foot at (FootPlanter::redirect; a 0.3 m procedural step of step_time_s peaks near 2.1 m/s).
inline constexpr double kRedirectPeakSpeed_mps = 2.5;

/// s: an update at least this long is coarse (under 45 a second: a 30 fps clip played at its
/// rate by the strike grid, or a frame loop fallen to 30 Hz). There a limit per second lets a
/// whole-body move start or stop within one frame (60 m/s^2 is 2 m/s in one 33 ms update), so
/// the following spot (update_follow) and the pelvis drop (Feet::bound_drop) also bound how much
/// their step changes from one update to the next. At 60 Hz and above they are left as they
/// were: the same bounds there lagged the pelvis behind its feet in the 120-order sweep (both
/// feet off where the mocap stands 1054 -> 2702 frames, 6 snaps, with the drop's; the fighter
/// late to its spot, hits 535 -> 425 and 8 snaps, with the spot's).
inline constexpr double kCoarseUpdate_s = 1.0 / 45;

/// A strike's (or block's) contact event: its target, the clip's segment, start and contact
/// frames, how far the end was from its target and whether the limb reached (judge_contact,
/// judge_block_in_place).
inline void describe_contact(const Behaviour::StrikeInfo& s, FighterEvent& e) {
  e.target = s.target_room_m;
  e.segment = s.plan.segment;
  e.start_frame = s.plan.start_frame;
  e.contact_frame = s.plan.contact_frame;
  e.contact_distance_m = s.contact_distance_m;
  e.out_of_reach = !s.contact_reached;
}

inline double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}
/// The minimum-jerk profile (0 -> 1, zero speed and acceleration at both ends) at x in [0, 1].
inline double min_jerk(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * x * (10 - 15 * x + 6 * x * x);
}
inline double wrap(double a) { return std::remainder(a, 2 * std::numbers::pi); }
/// Segment time t as the frame before it and the share of the way to the next (clamped to the clip).
struct FramePair {
  std::size_t i0;
  double a;
};
inline FramePair frame_pair(const MotionSegment& seg, double t) {
  const double x = std::clamp(t / seg.frame_time_s, 0.0, static_cast<double>(seg.frame_count() - 1));
  const int i0 = std::min(static_cast<int>(x), seg.frame_count() - 2);
  return {static_cast<std::size_t>(i0), x - i0};
}
/// The clip has `side`'s foot in contact at its frame k (the database's contacts, from the mocap).
inline bool clip_planted(const MotionSegment& seg, int k, int side) {
  return seg.frames[static_cast<std::size_t>(k)].planted[static_cast<std::size_t>(side)] >= 0.5;
}
/// How many frames from `first` through `last` the clip keeps `side`'s foot down without a break
/// (0 where it is up at `first`).
inline int planted_run(const MotionSegment& seg, int side, int first, int last) {
  int run = 0;
  for (int k = first; k <= last && clip_planted(seg, k, side); ++k) ++run;
  return run;
}
/// The first frame, not before `first`, of the clip's run of contact frames of `side` that ends
/// at `frame` (`frame` itself where the foot is not down there).
inline int planted_since(const MotionSegment& seg, int side, int first, int frame) {
  int down = frame;
  while (down > first && clip_planted(seg, down - 1, side)) --down;
  return down;
}
/// The clip's root on the floor at segment time t (clip coordinates, linear between frames).
inline Vector2d root_at(const MotionSegment& seg, double t) {
  const auto [i0, a] = frame_pair(seg, t);
  return (1 - a) * seg.frames[i0].root_xz_m + a * seg.frames[i0 + 1].root_xz_m;
}
/// The floor under a rig's rest pose: its lowest ankle or toe joint (m, rig frame).
inline double rest_floor_y(const Rig& rig) {
  const CanonicalPose& r = rig.rest_pose;
  return std::min({at(r, CanonicalJoint::l_ankle).y(), at(r, CanonicalJoint::l_toe).y(), at(r, CanonicalJoint::r_ankle).y(),
                   at(r, CanonicalJoint::r_toe).y()});
}
/// Where a placed MKM frame puts an ankle (m, room) on a rig, without decoding the whole pose:
/// pelvis, the rest pose's hip offset turned with the pelvis frame, the leg vector.
Eigen::Vector3d mkm_ankle(const Rig& rig, const MkmFrame& f, int side);
/// The rest pose's hip offset from the pelvis in the pelvis frame (m): mkm_ankle's, found once
/// for a loop over many frames.
Eigen::Vector3d hip_in_pelvis_frame(const Rig& rig, int side);
/// mkm_ankle with that offset given (the same operations, so the same numbers).
Eigen::Vector3d mkm_ankle(const Rig& rig, const MkmFrame& f, int side, const Eigen::Vector3d& hip_local);
/// A segment from its first frame, placed at `g` (its pelvis there, facing g's way).
inline PlaybackSource placed_at(const MotionSegment& seg, int index, const GroundFrame& g) {
  const GroundFrame g_clip = ground_frame_of(seg.frames[0]);
  PlaybackSource s;
  s.segment = index;
  s.time_s = 0;
  s.loop = false;
  s.placement.origin_xz = g.origin_xz;
  s.placement.yaw_rad = wrap(g.yaw_rad - g_clip.yaw_rad);
  s.anchor_xz_m = g_clip.origin_xz;
  return s;
}
/// m: how far above its shoulder a side's straight arm reaches, aimed `aim_deg` upward (the
/// steepest a punch goes: BehaviourTunables::max_punch_aim_deg).
inline double aim_rise_m(const Rig& rig, int side, double aim_deg) {
  return rig.morphology.arm_length(side) * std::sin(aim_deg * std::numbers::pi / 180);
}
/// A spot on the floor (m, room x/z) brought into the fighter's area ([fighter] min/max x/z).
inline Vector2d clamp_to_area(const FighterConfig& c, const Vector2d& p) {
  return {std::clamp(p.x(), c.min_x_m, c.max_x_m), std::clamp(p.y(), c.min_z_m, c.max_z_m)};
}
/// The integral of the release weight 1 - smoothstep(x) from 0 to x (x in [0, 1]).
inline double eased_integral(double x) { return x - x * x * x + 0.5 * x * x * x * x; }
inline int group_of(const Effector& e) { return e.side + 2 * (e.leg ? 1 : 0); }
inline std::optional<Effector> effector_of(OrderKind k) {
  switch (k) {
    case OrderKind::punch_left: return Effector{kLeft, false};
    case OrderKind::punch_right: return Effector{kRight, false};
    case OrderKind::kick_left: return Effector{kLeft, true};
    case OrderKind::kick_right: return Effector{kRight, true};
    default: return std::nullopt;
  }
}

/// Playing a PlaybackSource: sampling a segment at a time and placing it in the room (with a
/// strike's scaled travel and pelvis rise), for whichever thread owns `eased` (Behaviour's
/// update thread, or a StrikeRateSolver's). Nothing else is written.
struct Playback {
  const Database& db;
  double stride_scale = 1;     ///< character leg / actor leg
  EasedTravelCache& eased;

  void sample(const PlaybackSource& s, MkmFrame& out) const;
  void place_sample(const PlaybackSource& s, const MotionSegment& seg, double t, MkmFrame& mixed, MkmFrame& out) const;
  /// The ankle (m, room) at one of the source's own frames, placed as place_sample places it:
  /// mkm_ankle of that placed frame, the same operations on the fields it reads only (the
  /// pelvis, its height, the leg), with s.placement.rotation() found once by the caller. For
  /// loops over a swing's frames (a strike's start walks up to ~150 of them: through whole
  /// placed frames that was up to 60 us of the update).
  Eigen::Vector3d frame_ankle(const PlaybackSource& s, const Eigen::Quaterniond& placement_rotation, int frame, const Rig& rig,
                              int side, const Eigen::Vector3d& hip_local) const;
  Vector2d scaled_travel(const PlaybackSource& s, const MotionSegment& seg, double t) const;
  /// The pose of `cur` cross-faded from `prev` `blend_elapsed_s` into a blend of
  /// `blend_time_s` (cur_pose: `cur` alone), as Behaviour::update() composes every frame.
  /// `turns`: the cross-fade's pole turns so far (PoleTurns), carried on and updated when they
  /// belong to this cross-fade, begun afresh when not; nullptr: the shorter way.
  void compose(const PlaybackSource& cur, const PlaybackSource& prev, double blend_elapsed_s, double blend_time_s,
               MkmFrame& cur_pose, MkmFrame& out, PoleTurns* turns = nullptr) const;
};

/// d(t)'s weight at segment time t: in from the strike's start to contact, out from contact
/// to the end of its release.
inline double reach_ramp_in(double start_s, double contact_s, double t) {
  return smoothstep((t - start_s) / std::max(1e-6, contact_s - start_s));
}
inline double reach_ramp_out(double contact_s, double release_end_s, double t) {
  return 1 - smoothstep((t - contact_s) / std::max(1e-6, release_end_s - contact_s));
}
/// The segment time of the update that draws a strike's contact: the first of the times the
/// updates reach from `from_s` in steps of `step_s` (segment seconds per update: dt x rate)
/// at or past the clip's contact `contact_s`, a hair early so that the updates' summed clock,
/// which may fall short of it by rounding, still reaches it then. d(t) found for that time
/// lands the contact frame on the target as planned (found for the clip's contact instead,
/// the contact frame found it again there: a kick's foot, which moves ~9 m/s at contact,
/// jumped 10 cm in that frame at a rate of 0.65). `contact_s` where step_s is not > 0.
inline double contact_frame_time(double from_s, double contact_s, double step_s) {
  if (!(step_s > 0) || !std::isfinite(from_s) || !std::isfinite(contact_s)) return contact_s;
  const double k = std::max(1.0, std::ceil((contact_s - from_s) / step_s - 1e-9));
  return from_s + k * step_s - 1e-9 * step_s;
}
/// d(t) at contact: the gap from the effector to the target, and the turn and stretch of the
/// limb about its root (shoulder or hip) that point it at the target, for `pose` (composed as
/// the update at contact will compose it) decoded on `rig` (into `scratch`).
/// A kick aimed beyond the leg's reach stretches the leg to this share of its length, short of
/// a locked knee (reach_correction).
inline constexpr double kKickLockOutShare = 0.99;
struct ReachCorrection {
  Eigen::Vector3d error_m{0, 0, 0};
  Eigen::Quaterniond turn = Eigen::Quaterniond::Identity();
  double stretch = 1;
  /// A kick's target beyond the leg's reach: stretched to kKickLockOutShare of the leg instead.
  bool capped = false;
  /// A punch's trunk lean at contact: what AdaptJob's trunk fallback bends to bring the target
  /// within the arm's reach (identity when the arm reaches alone, and for kicks).
  TrunkLean lean;
  /// A punch's striking shoulder and head (m, room) at contact with the whole d(t) and the
  /// planned lean applied (NaN unless the lean was planned).
  Eigen::Vector3d shoulder_m = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d head_m = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d elbow_m = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());  ///< the striking elbow, likewise
  double root_drop_m = std::numeric_limits<double>::quiet_NaN();  ///< m the pelvis drops for the held feet there
  double elbow_under_head_m = std::numeric_limits<double>::quiet_NaN();  ///< m, head joint - striking elbow, heights there
};
/// `feet` (optional): the feet held through to contact; the planned lean is found with the
/// pelvis lowered for them (no lower than puts the striking shoulder at `lowest_shoulder_y_m`),
/// as the frames will draw it.
ReachCorrection reach_correction(const Rig& rig, const Effector& effector, const Eigen::Vector3d& target_room_m,
                                 const MkmFrame& pose, CanonicalPose& scratch, bool plan_lean = true,
                                 const FootLocks* feet = nullptr,
                                 double lowest_shoulder_y_m = -std::numeric_limits<double>::infinity());

/// d(t) at weight `ramp` of its full turn and stretch.
inline ReachGoal reach_goal_at(const Effector& effector, const Eigen::Quaterniond& turn, double stretch, double ramp,
                               const TrunkLean& lean = {}) {
  ReachGoal goal;
  goal.effector = effector;
  goal.turn = Eigen::Quaterniond::Identity().slerp(ramp, turn);
  goal.stretch = 1 + ramp * (stretch - 1);
  goal.pin = ramp;
  goal.lean = lean.scaled(ramp);
  return goal;
}

}  // namespace kumite::content::behaviour_detail
