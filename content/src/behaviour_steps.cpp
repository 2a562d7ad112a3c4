// Behaviour: following with stance steps cut from the mocap (issue 12, item 3). A `walk`
// segment of motions.toml (a karate step in stance: one foot passes the other, forward or
// back) is chosen by the stance it starts in and the distance it travels, placed on the foot
// it stands on, and played with its floor travel scaled to the distance; the rest motion, or
// its mirror, whichever stance the step ends in, takes over after it.
#include <algorithm>
#include <cmath>
#include <limits>

#include "behaviour_internal.hpp"
#include "kumite/content/behaviour.hpp"
#include "kumite/content/canonical.hpp"

namespace kumite::content {

using namespace behaviour_detail;
using CJ = CanonicalJoint;
using Eigen::Vector2d;
using Eigen::Vector3d;

namespace {
/// m: a walk segment whose first frame lays the feet out (one ankle relative to the other, on
/// the floor) farther than this from the feet drawn now is not stepped from: the blend into it
/// would carry the foot it stands on away.
constexpr double kMaxStanceMismatch_m = 0.3;
/// A rest segment starting within this many source frames after a stance step ends is its
/// continuation in the take; one shorter than kMinRestAfterStep_s (s) is not held after it
/// (its ping-pong would show).
constexpr int kRestAfterStepFrames = 4;
constexpr double kMinRestAfterStep_s = 0.4;
/// m of cost per unit of arm mismatch (the two arms' vectors / arm length, pelvis frame).
constexpr double kArmMismatchWeight_m = 0.2;
/// How much a difference of stance width counts beside one of stance length.
constexpr double kSidewaysMismatchWeight = 0.5;
/// m: a walk segment whose pelvis travels less than this (at the character's size) is no step.
constexpr double kMinStepTravel_m = 0.2;
/// rad: a stance step is turned about the foot it stands on by at most this, so that its pelvis
/// travels toward the spot to keep. Placed by the pelvis's heading, the mocap's steps travel
/// 0.22-0.35 m to the side of the way wanted (the hips of a stance are turned off the way the
/// actor steps): each step forward left the fighter ~0.25 m to the side, off the line of a
/// visitor punching straight ahead.
constexpr double kMaxStepTurn_rad = 0.5;

Vector2d layout(const Vector3d& left, const Vector3d& right) { return {right.x() - left.x(), right.z() - left.z()}; }

}  // namespace

int Behaviour::rest_for_stance() const {
  // A stance step cut from a take whose actor then stood still (135_03: a step, a rest, a
  // step...): that rest, the mocap's own continuation, in the stance the step ends in.
  if (!player_.current().loop && player_.current().segment >= 0) {
    const MotionSegment& step = db_->segments[static_cast<std::size_t>(player_.current().segment)];
    const int next = step.source_first_frame + step.frame_count();
    for (std::size_t i = 0; i < db_->segments.size(); ++i) {
      const MotionSegment& r = db_->segments[i];
      if (r.kind == SegmentKind::rest && r.mirrored == step.mirrored && r.source_clip == step.source_clip &&
          r.source_first_frame >= next - 1 && r.source_first_frame <= next + kRestAfterStepFrames &&
          r.frame_count() * r.frame_time_s >= kMinRestAfterStep_s)
        return static_cast<int>(i);
    }
  }
  if (mirrored_rest_segment_ < 0 || !have_pose_) return rest_segment_;
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  // The stance to fit: where the motion playing sets the feet at its end (a stance step's
  // last frame), else the feet drawn now.
  Vector2d want = layout(rig_positions_[static_cast<std::size_t>(rig.skeleton.index(CJ::l_ankle))],
                         rig_positions_[static_cast<std::size_t>(rig.skeleton.index(CJ::r_ankle))]);
  if (!player_.current().loop && player_.current().segment >= 0) {
    const MotionSegment& seg = db_->segments[static_cast<std::size_t>(player_.current().segment)];
    MkmFrame end;
    player_.sample_frame(player_.current(), seg.frame_count() - 1, end);
    want = layout(mkm_ankle(rig, end, kLeft), mkm_ankle(rig, end, kRight));
  }
  GroundFrame g = ground_frame_of(pose_);
  g.yaw_rad = facing_rad_;
  int best = rest_segment_;
  double best_cost = std::numeric_limits<double>::infinity();
  for (const int i : {rest_segment_, mirrored_rest_segment_}) {
    const MotionSegment& seg = db_->segments[static_cast<std::size_t>(i)];
    PlaybackSource s = placed_at(seg, i, g);
    s.placement.yaw_rad = wrap(facing_rad_ - ground_frame_of(seg.frames[0]).yaw_rad);
    MkmFrame f;
    player_.sample_frame(s, 0, f);
    const double cost = (layout(mkm_ankle(rig, f, kLeft), mkm_ankle(rig, f, kRight)) - want).norm();
    if (cost < best_cost) {
      best_cost = cost;
      best = i;
    }
  }
  return best;
}

bool Behaviour::rest_with(int segment) {
  if (segment < 0 || segment >= static_cast<int>(db_->segments.size()) ||
      db_->segments[static_cast<std::size_t>(segment)].kind != SegmentKind::rest)
    return false;
  if (stance_step()) set_locomotion(Walking{});  // (the stance step's clip no longer plays)
  start_rest(time_, segment);
  player_.end_blend();
  feet_.reset();
  return true;
}

bool Behaviour::begin_stance_step(const Vector2d& goal) {
  if (walk_segments_.empty() || stance_step_min_m() <= 0 || !have_pose_) return false;
  if (!feet_.held(kLeft) || !feet_.held(kRight)) return false;
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  std::array<Vector3d, 2> held;
  for (int side = 0; side < 2; ++side)
    held[static_cast<std::size_t>(side)] =
        rig_positions_[static_cast<std::size_t>(rig.skeleton.index(side == kLeft ? CJ::l_ankle : CJ::r_ankle))];
  const Vector2d drawn = layout(held[kLeft], held[kRight]);
  const Vector2d fwd(std::sin(facing_rad_), std::cos(facing_rad_));
  const GroundFrame g = ground_frame_of(pose_);
  int best = -1;
  double best_cost = std::numeric_limits<double>::infinity();
  Source best_source;
  int best_support = 0;
  for (const int i : walk_segments_) {
    const MotionSegment& seg = db_->segments[static_cast<std::size_t>(i)];
    Source s = placed_at(seg, i, g);
    MkmFrame first, last;
    player_.sample_frame(s, 0, first);
    player_.sample_frame(s, seg.frame_count() - 1, last);
    const Vector2d clip = layout(mkm_ankle(rig, first, kLeft), mkm_ankle(rig, first, kRight));
    // (sideways counts half: the stepping foot leaves from where it stands, and stances of the
    // same length but wider or narrower are the same stance to the eye)
    const Vector2d diff = clip - drawn;
    const double mismatch = std::hypot(diff.dot(fwd), kSidewaysMismatchWeight * (diff - diff.dot(fwd) * fwd).norm());
    // The arms it starts with beside the arms drawn now (pelvis frame, / arm length): a step
    // whose arms begin elsewhere (a block chambered) would swing them there in the blend.
    double arms = 0;
    for (int side = 0; side < 2; ++side)
      arms += (first.pelvis.conjugate() * first.arm_n[static_cast<std::size_t>(side)] -
               pose_.pelvis.conjugate() * pose_.arm_n[static_cast<std::size_t>(side)]).norm();
    if (mismatch > kMaxStanceMismatch_m) continue;
    // The foot it stands on: the one the clip moves least on the floor from its first frame
    // to its last (the other passes it: a step travels twice the pelvis's way; the contacts
    // alone mislead where the stepping foot waits down at the start and the support foot turns
    // on its ball). The clip is shifted on the floor so that this foot is where the held one
    // is (at most max_support_shift_m): the step swings the other foot round a foot that stays.
    std::array<double, 2> moved{};
    for (int side = 0; side < 2; ++side) {
      const Vector3d d = mkm_ankle(rig, last, side) - mkm_ankle(rig, first, side);
      moved[static_cast<std::size_t>(side)] = std::hypot(d.x(), d.z());
    }
    const int support = moved[kLeft] <= moved[kRight] ? kLeft : kRight;
    const Vector3d a = mkm_ankle(rig, first, support);
    Vector2d shift(held[static_cast<std::size_t>(support)].x() - a.x(), held[static_cast<std::size_t>(support)].z() - a.z());
    if (shift.norm() > tun_.max_support_shift_m) shift *= tun_.max_support_shift_m / shift.norm();
    // Its floor travel, scaled to bring the pelvis to the goal along the facing direction.
    const Vector2d travel = last.root_xz_m - first.root_xz_m;
    const double t_along = travel.dot(fwd);
    const Vector2d want = goal - (first.root_xz_m + shift);
    const double along = want.dot(fwd);
    if (std::abs(t_along) < kMinStepTravel_m || t_along * along <= 0) continue;
    const double scale = std::clamp(along / t_along, tun_.min_stance_step_scale, tun_.max_stance_step_scale);
    const double cost = mismatch + (want - scale * travel).norm() + kArmMismatchWeight_m * arms;
    if (cost < best_cost) {
      best_cost = cost;
      best = i;
      best_source = s;
      best_source.placement.origin_xz += shift;
      best_source.travel.scale = scale;
      best_support = support;
    }
  }
  if (best < 0) return false;
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(best)];
  {
    // Turned about the foot it stands on so that the pelvis travels toward the goal (the
    // placement's heading turned by `turn`, its origin turned with it about that foot).
    MkmFrame first, last;
    player_.sample_frame(best_source, 0, first);
    player_.sample_frame(best_source, seg.frame_count() - 1, last);
    const Vector2d travel = last.root_xz_m - first.root_xz_m, want = goal - first.root_xz_m;
    if (travel.norm() > 1e-6 && want.norm() > 1e-6) {
      // The heading increment taking `travel` to `want` (a heading h faces (sin h, cos h)).
      const double turn = std::clamp(std::atan2(travel.y() * want.x() - travel.x() * want.y(), travel.dot(want)),
                                     -kMaxStepTurn_rad, kMaxStepTurn_rad);
      const Vector3d& foot = held[static_cast<std::size_t>(best_support)];
      const Vector2d pivot(foot.x(), foot.z());
      const Vector2d o = best_source.placement.origin_xz - pivot;
      const Vector3d turned = GroundFrame{pivot, turn}.to_world(Vector3d(o.x(), 0, o.y()));
      best_source.placement.origin_xz = Vector2d(turned.x(), turned.z());
      best_source.placement.yaw_rad = wrap(best_source.placement.yaw_rad + turn);
    }
  }
  const double end_s = (seg.frame_count() - 1) * seg.frame_time_s;
  best_source.travel.from_s = 0;
  best_source.travel.contact_s = end_s;
  best_source.travel.release_s = 0;
  best_source.travel.rise_n = 0;
  player_.play(best_source);
  set_locomotion(StanceStepping{StanceStep{best, std::max(0.0, end_s - tun_.blend_time_s), best_source.travel.scale, best_support}});
  ++stance_steps_;
  return true;
}

void Behaviour::end_stance_step(Timestamp now) {
  const int support = stance_step()->support;
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  // Where the step puts the body and the feet at its last frame (the rest blends in over its
  // last blend_time_s): the foot it stands on where it is held, the other where it lands.
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(player_.current().segment)];
  MkmFrame end;
  player_.sample_frame(player_.current(), seg.frame_count() - 1, end);
  std::array<Vector3d, 2> feet;
  for (int side = 0; side < 2; ++side)
    feet[static_cast<std::size_t>(side)] =
        side == support ? rig_positions_[static_cast<std::size_t>(rig.skeleton.index(side == kLeft ? CJ::l_ankle : CJ::r_ankle))]
                        : mkm_ankle(rig, end, side);
  const int rest = rest_for_stance();
  start_rest(now, rest);
  // The step was the following: from here the fighter decides anew (a spot still off by less
  // than follow_tolerance_m is not walked to with procedural steps).
  set_locomotion(AtSpot{});
  spot_xz_m_ = end.root_xz_m;
  // The rest motion turned as the step ends: a karate stance stands with the hips turned off
  // the way it faces, the other way after each step (the steps turn the pelvis 0.5-1 rad).
  // The fighter still faces the visitor (facing_rad_); the rest keeps the step's hips.
  const MotionSegment& rest_seg = db_->segments[static_cast<std::size_t>(rest)];
  rest_yaw_rad_ = wrap(ground_frame_of(end).yaw_rad - facing_rad_);
  player_.place(spot_xz_m_, wrap(facing_rad_ + rest_yaw_rad_ - ground_frame_of(rest_seg.frames[0]).yaw_rad));
  // Centred over those feet (a step scaled shorter or longer than captured ends in a longer or
  // shorter stance than the rest motion's): each foot then lies half the stances' difference
  // from where the rest motion has it, within the leg's reach, rather than one foot on it and
  // the other out of reach (both would step at once: a hop).
  MkmFrame f;
  player_.sample(player_.current(), f);
  Vector2d shift(0, 0);
  for (int side = 0; side < 2; ++side) {
    const Vector3d a = mkm_ankle(rig, f, side);
    shift += 0.5 * Vector2d(feet[static_cast<std::size_t>(side)].x() - a.x(), feet[static_cast<std::size_t>(side)].z() - a.z());
  }
  if (shift.norm() > tun_.max_support_shift_m) shift *= tun_.max_support_shift_m / shift.norm();
  spot_xz_m_ += shift;
  player_.shift(shift);
}

}  // namespace kumite::content
