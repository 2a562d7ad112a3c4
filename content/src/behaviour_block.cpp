// Behaviour: blocks (issue 53, item 3). A block is played by the strike machinery: its clip
// from the block's start frame, placed where the fighter stands and aligned on its support
// foot, cross-faded in; d(t) brings the forearm's middle onto the fist's path at the intercept
// frame ("contact": the forearm in place) and holds it there until the fist has passed. No
// travel scaling, no trunk lean aim, no rate solve: a block may be played faster instead
// (BlockOrder::max_rate) to be in place before the fist.
#include <algorithm>
#include <cmath>

#include "behaviour_internal.hpp"
#include "kumite/content/behaviour.hpp"
#include "kumite/content/canonical.hpp"

namespace kumite::content {

using namespace behaviour_detail;
using CJ = CanonicalJoint;
using Eigen::Vector3d;

namespace {
/// s the forearm stays across the path after the fist's predicted arrival (its prediction is
/// a straight line at constant speed).
constexpr double kHoldPast_s = 0.12;
/// s: the forearm is planned in place this long before the fist (one display frame at 60 Hz).
constexpr double kInPlaceMargin_s = 1.0 / 60;
/// m/s: a re-aim (reaim_block) moves the wrist's target at most this fast at its peak (a
/// minimum-jerk shift peaks at 1.875 x its mean speed), as a parry's move from the guard.
constexpr double kMostReaimSpeed_mps = 6.0;

/// Segment s a block holds its forearm across the path after it is in place: until the fist,
/// aimed at `aim_s` from now, has passed (kHoldPast_s), the forearm in place `in_place_wall_s`
/// from now, the clip played at `rate`; never past the clip's end.
double block_hold_s(double aim_s, double in_place_wall_s, double rate, double contact_s, double end_s) {
  const double hold_wall_s = std::max(0.0, aim_s - in_place_wall_s) + kHoldPast_s;
  return std::min(hold_wall_s * rate, std::max(0.0, end_s - contact_s));
}
}  // namespace

bool Behaviour::can_block() const {
  if (paused_ || !have_pose_ || db_->block_index.size == 0) return false;
  if (!(as<Idle>() || as<AwaitingPlan>() || as<Retaking>())) return false;
  return player_.blend_elapsed_s() >= tun_.blend_time_s;
}

bool Behaviour::block(const BlockOrder& b, Timestamp now) {
  if (!can_block() || !b.fist_m.allFinite() || !b.velocity_mps.allFinite() || !std::isfinite(b.arrival_s)) return false;
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  const GroundFrame g = ground();
  BlockRequest req;
  req.now = pose_;
  req.before = pose_before_;
  req.dt_s = last_dt_ > 0 ? last_dt_ : 1.0 / 60;
  req.fist_local_m = g.to_local(b.fist_m);
  req.fist_velocity_local_mps = g.rotation().inverse() * b.velocity_mps;
  req.character_leg_length_m = rig.morphology.leg_length_m;
  const BlockChoice c = block_planner_->plan_block(req);
  if (c.segment < 0) return false;
  const MotionSegment& bseg = db_->segments[static_cast<std::size_t>(c.segment)];
  const double lead_s = (c.intercept_frame - c.start_frame) * bseg.frame_time_s;
  // Where the forearm meets the fist: on its path where the fist will be once the block can be
  // in place (played at max_rate), at the guard (retrieve_block's intercept) if that is later,
  // but no later than the fist's arrival at the body. (The guard's crossing alone was often
  // already behind the fist: a punch is seen fast only 50-70 ms before it lands.)
  const double can_s = lead_s / std::max(1.0, b.max_rate) + kInPlaceMargin_s;
  const double aim_s = std::clamp(std::max(c.intercept.time_s, can_s), 0.0, std::max(0.0, b.arrival_s));
  const Vector3d intercept = b.fist_m + b.velocity_mps * aim_s;

  // The strike order under way (waiting for its plan, or to be taken again) is dropped.
  if (const AwaitingPlan* w = as<AwaitingPlan>())
    emit(FighterEvent::Kind::order_ignored, now, w->strike.order, FighterEvent::Reason::blocking);
  if (const Retaking* r = as<Retaking>()) emit(FighterEvent::Kind::order_ignored, now, r->order.order, FighterEvent::Reason::blocking);

  StrikePlan plan;
  plan.segment = c.segment;
  plan.start_frame = c.start_frame;
  plan.contact_frame = c.intercept_frame;
  plan.choice = c.choice;
  strike_target_.reset();  // no travel scaling toward a target: the block stands where it is
  StrikeFit fit;
  Source s = strike_source(plan, fit);
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(plan.segment)];
  // A block stands where it is: the clip's floor travel is taken out (kata blocks step 0.5 m
  // and more; played as captured, the fighter stepped into the visitor and off its area).
  s.travel = Source::Travel{};
  s.travel.scale = 0;
  s.travel.from_s = s.time_s;
  s.travel.contact_s = (seg.frame_count() - 1) * seg.frame_time_s;
  s.travel.release_s = seg.frame_time_s;

  player_.play(s);
  if (fit.landing_support >= 0) feet_.land(fit.landing_support);
  if (fit.redirect_support >= 0) feet_.redirect(fit.redirect_support, fit.redirect_to_m, kRedirectPeakSpeed_mps);
  // In place before the fist: as fast as that needs, up to max_rate (a block's lead over the
  // fist's arrival at the guard, or at the body when that is sooner).
  const double until_s = aim_s - kInPlaceMargin_s;
  const double rate = std::clamp(until_s > 1e-3 ? lead_s / until_s : b.max_rate, 1.0, std::max(1.0, b.max_rate));
  player_.set_rate(rate);
  const double dt = last_dt_ > 0 ? last_dt_ : 1.0 / 60;

  strike_ = StrikeInfo{};
  strike_.block = true;
  strike_.block_limb = b.limb;
  strike_.block_recognised = b.recognised;
  strike_.fist_speed_mps = b.velocity_mps.norm();
  strike_.fist_arrival_t = now + aim_s;
  strike_.intercept_m = intercept;
  strike_.plan = plan;
  strike_.effector = *seg.effector();  // the forearm's arm
  strike_.start_time_s = plan.start_frame * seg.frame_time_s;
  strike_.clip_contact_time_s = plan.contact_frame * seg.frame_time_s;
  strike_.contact_time_s = contact_frame_time(player_.current().time_s, strike_.clip_contact_time_s, dt * player_.current().rate);
  strike_.end_time_s = (seg.frame_count() - 1) * seg.frame_time_s;
  // Held across the path until the fist has passed (segment seconds), within the clip.
  const double in_place_wall_s = (strike_.contact_time_s - player_.current().time_s) / rate;
  strike_.hold_s = block_hold_s(strike_.fist_arrival_t - now, in_place_wall_s, rate, strike_.contact_time_s, strike_.end_time_s);
  strike_.release_end_s = release_end_s(strike_.contact_time_s);
  strike_.start_update = updates_;
  strike_.rate = rate;
  enter(Striking{});
  strike_.plan_feet = feet_through_contact(player_.current(), strike_.contact_time_s);
  aim_block_at(intercept);
  if (!strike_.target_room_m.allFinite() || !strike_.error_m.allFinite()) {
    // (never seen: a pose that cannot be decoded) no d(t): the block plays as captured
    strike_.target_room_m = intercept;
    strike_.error_m.setZero();
    strike_.turn = Eigen::Quaterniond::Identity();
    strike_.stretch = 1;
  }
  return true;
}

void Behaviour::aim_block_at(const Vector3d& intercept) {
  // d(t) brings the wrist where it puts the forearm's middle on the intercept: the wrist
  // target is the intercept plus the half forearm (elbow -> wrist) as the clip holds it there.
  strike_.target_room_m = intercept;
  compute_reach_error(strike_.contact_time_s, false);
  // (the pose at the intercept, decoded without d(t), is in scratch_pose_)
  const Vector3d wrist = at(scratch_pose_, strike_.effector.joint());
  const Vector3d elbow = at(scratch_pose_, strike_.effector.side == kLeft ? CJ::l_elbow : CJ::r_elbow);
  strike_.target_room_m = intercept + (1 - kForearmContactFraction) * (wrist - elbow);
  compute_reach_error(strike_.contact_time_s, false);
}

bool Behaviour::reaim_block(const BlockOrder& b, Timestamp now) {
  // The dual-buffer boxer's action switching for a block clip: the clip plays on (no restart,
  // no new clip), only d(t)'s aim moves, from the correction it has now to the one that puts
  // the forearm's middle on the limb's path as it is now, over the time left to the intercept.
  if (!striking() || !strike_.block || strike_.contact_done || strike_.aborted || b.limb != strike_.block_limb) return false;
  if (!b.fist_m.allFinite() || !b.velocity_mps.allFinite() || !std::isfinite(b.arrival_s)) return false;
  const Source& cur = player_.current();
  if (cur.segment != strike_.plan.segment || !(cur.rate > 0)) return false;
  const double t = cur.time_s;
  const double dt = last_dt_ > 0 ? last_dt_ : 1.0 / 60;
  const double left_s = strike_.contact_time_s - t;  // segment seconds to the intercept
  if (left_s < 2 * dt * cur.rate) return false;      // in place within two frames: too late to turn
  const double in_place_wall_s = left_s / cur.rate;
  // Where the fist will be as the forearm comes into place (or where it reaches the body, if
  // sooner: a late block is aimed there).
  const double aim_s = std::clamp(in_place_wall_s + kInPlaceMargin_s, 0.0, std::max(0.0, b.arrival_s));
  const Vector3d intercept = b.fist_m + b.velocity_mps * aim_s;

  // The correction drawn now (mid-way through an earlier re-aim: where that one has got to).
  Eigen::Quaterniond from_turn;
  double from_stretch = 1;
  correction_at(t, from_turn, from_stretch);
  // (kept to put back where the new aim cannot be taken)
  const Vector3d old_target = strike_.target_room_m, old_error = strike_.error_m;
  const Eigen::Quaterniond old_turn = strike_.turn;
  const double old_stretch = strike_.stretch;
  const bool old_out_of_reach = strike_.out_of_reach;
  const Vector3d old_shoulder = contact_shoulder_m_, old_head = contact_head_m_, old_elbow = contact_elbow_m_;
  aim_block_at(intercept);
  const double shift_m = (strike_.target_room_m - old_target).norm();
  if (!strike_.target_room_m.allFinite() || !strike_.error_m.allFinite() || 1.875 * shift_m / in_place_wall_s > kMostReaimSpeed_mps) {
    strike_.target_room_m = old_target;
    strike_.error_m = old_error;
    strike_.turn = old_turn;
    strike_.stretch = old_stretch;
    strike_.out_of_reach = old_out_of_reach;
    contact_shoulder_m_ = old_shoulder;
    contact_head_m_ = old_head;
    contact_elbow_m_ = old_elbow;
    return false;
  }
  strike_.reaim_turn_from = from_turn;
  strike_.reaim_stretch_from = from_stretch;
  strike_.reaim_from_s = t;
  strike_.reaim_to_s = strike_.contact_time_s;
  strike_.intercept_m = intercept;
  strike_.fist_arrival_t = now + aim_s;
  strike_.fist_speed_mps = b.velocity_mps.norm();
  strike_.block_recognised = strike_.block_recognised || b.recognised;
  strike_.hold_s = block_hold_s(aim_s, in_place_wall_s, cur.rate, strike_.contact_time_s, strike_.end_time_s);
  strike_.release_end_s = release_end_s(strike_.contact_time_s);
  return true;
}

void Behaviour::judge_block_in_place(Timestamp now) {
  strike_.contact_done = true;
  strike_.contact_update = updates_;
  strike_.in_place_t = now;
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  const Vector3d wrist = rig_positions_[static_cast<std::size_t>(rig.skeleton.index(strike_.effector.joint()))];
  strike_.contact_distance_m = (wrist - strike_.target_room_m).norm();
  strike_.contact_reached = report_.reached;
  FighterEvent& e = emit(FighterEvent::Kind::block, now, strike_.order, FighterEvent::Reason::none);
  describe_contact(strike_, e);
  e.target = strike_.intercept_m;
  e.limb = strike_.block_limb;
  e.side = strike_.effector.side;
  e.margin_s = strike_.fist_arrival_t - now;
  e.speed_mps = strike_.fist_speed_mps;
  e.recognised = strike_.block_recognised;
}

}  // namespace kumite::content
