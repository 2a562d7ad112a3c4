// The feet (feet.hpp): what the motion now playing says of each foot (contact, lift, landing
// and the way to it, its own step this update), handed to the FootPlanter (foot_planting.cpp);
// the held feet and the bounds on the pelvis drop for the update's decode.
#include "kumite/content/feet.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include "behaviour_internal.hpp"
#include "held_feet_drop.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/bvh.hpp"
#include "kumite/content/canonical.hpp"

namespace kumite::content {

using namespace behaviour_detail;
using CJ = CanonicalJoint;
using Eigen::Vector2d;
using Eigen::Vector3d;

namespace {
/// The share of the source's path left when a stance step's stepping foot is over its landing
/// (FootSample::landing_lead).
constexpr double kStanceStepLandingLead = 0.05;
/// s: a held foot the motion would lift for less than this (it puts it down again sooner) stays held.
constexpr double kShortestLift_s = 0.1;

/// The source's ankle on its way from now (`now_y_m`, m) to its landing at segment frame `land`
/// stays within `height_m` above the lower of its heights now and there: a glide along the
/// floor, not a step.
bool stays_low(const MotionPlayer& player, const MotionSegment& seg, const PlaybackSource& src, int land, const Rig& rig,
               int side, const Vector3d& hip_local, double now_y_m, double height_m) {
  const Eigen::Quaterniond turn = src.placement.rotation();
  const int first = static_cast<int>(std::floor(src.time_s / seg.frame_time_s)) + 1;
  const double land_y = player.frame_ankle(src, turn, land, rig, side, hip_local).y();
  const double floor_y = std::min(now_y_m, land_y);
  for (int k = first; k < land; ++k)
    if (player.frame_ankle(src, turn, k, rig, side, hip_local).y() > floor_y + height_m) return false;
  return true;
}
}  // namespace

Feet::Feet(std::shared_ptr<const Database> db, const BehaviourTunables& tunables)
    : db_(std::move(db)), blend_time_s_(tunables.blend_time_s), max_root_drop_m_(tunables.max_root_drop_m),
      max_drop_rate_mps_(tunables.max_drop_rate_mps), max_drop_accel_mps2_(tunables.max_drop_accel_mps2),
      planter_(tunables.feet) {}

double Feet::swing_left_s(const FeetInput& in, int side) const {
  // Time until the motion now playing puts this foot down again.
  const PlaybackSource& cur = in.player->current();
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(cur.segment)];
  if (cur.loop) return 0;  // the rest motion: nothing to follow (the shortest swing applies)
  const int n = seg.frame_count();
  const int first = std::clamp(static_cast<int>(std::ceil(cur.time_s / seg.frame_time_s - 1e-9)), 0, n);
  for (int k = first; k < n; ++k)
    if (clip_planted(seg, k, side)) return (k * seg.frame_time_s - cur.time_s) / cur.rate;
  return ((n - 1) * seg.frame_time_s - cur.time_s) / cur.rate + blend_time_s_;  // the rest motion after it
}

int Feet::hold_frame(const FeetInput& in, int side, int land) const {
  // The clip puts a foot down at `land` and keeps it down to the strike's contact: where a
  // lunge's hip travels farther than the mocap's (Source::Travel) or the mocap's own back foot
  // slides on the floor (135_06's lunges: 10-12 cm), a foot held where the clip lands it is
  // out of the leg's reach by contact and steps while the front foot swings (mei's opening
  // lunge, 135_06_punch_right_2:mirror from frame 0: both feet off for 12 frames). Held where
  // the clip has it at contact, the leg reaches it there, as the clip's own does.
  if (!in.before_contact || in.player->current().loop) return land;
  if (in.effector.leg && in.effector.side == side) return land;
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(in.player->current().segment)];
  const int contact = std::clamp(static_cast<int>(std::lround(in.clip_contact_time_s / seg.frame_time_s)), 0, seg.frame_count() - 1);
  if (contact <= land) return land;
  for (int k = land; k <= contact; ++k)
    if (!clip_planted(seg, k, side)) return land;
  return contact;
}

Vector3d behaviour_detail::hip_in_pelvis_frame(const Rig& rig, int side) {
  const CanonicalPose& rest = rig.rest_pose;
  return pelvis_frame(rest).conjugate() * (at(rest, side == kLeft ? CJ::l_hip : CJ::r_hip) - at(rest, CJ::pelvis));
}

Vector3d behaviour_detail::mkm_ankle(const Rig& rig, const MkmFrame& f, int side, const Vector3d& hip_local) {
  const Vector3d pelvis(f.root_xz_m.x(), f.root_height_n * rig.morphology.leg_length_m + rig.morphology.standing_ankle_m, f.root_xz_m.y());
  return pelvis + f.pelvis * hip_local + f.leg_n[static_cast<std::size_t>(side)] * rig.morphology.limb_leg_length(side);
}

Vector3d behaviour_detail::mkm_ankle(const Rig& rig, const MkmFrame& f, int side) {
  return mkm_ankle(rig, f, side, hip_in_pelvis_frame(rig, side));
}

void Feet::update(const FeetInput& in) {
  plant(in);
  bound_drop(in);
}

void Feet::plant(const FeetInput& in) {
  if (!in.have_pose) {
    locks_ = FootLocks{};
    return;
  }
  const double dt = in.dt_s;
  const MkmFrame& cur = *in.motion;
  const MkmFrame& pose = *in.pose;
  const MotionPlayer& player = *in.player;
  const std::array<double, 2>& planted = cur.planted;
  const Rig& rig = *in.rig;
  // The motion being played, one update earlier: how far it moved each foot since.
  MkmFrame before, before2;
  PlaybackSource earlier = player.current();
  earlier.time_s -= dt * player.current().rate;
  player.sample(earlier, before);
  // ...and one before that, sampled only for a lifted foot (its swing reads how fast the
  // source's foot gathers speed): not on every update a fighter stands.
  bool have_before2 = false;

  constexpr double kLiftDeadband_m = 0.01;
  constexpr double kHeelRiseSlack_m = 0.02;  // m: a heel's rise beyond its foot's pitch (the ball flexing)
  std::array<FootSample, 2> samples;
  for (int s = 0; s < 2; ++s) {
    const auto us = static_cast<std::size_t>(s);
    const auto ankle = static_cast<std::size_t>(rig.skeleton.index(s == kLeft ? CJ::l_ankle : CJ::r_ankle));
    const auto hip = static_cast<std::size_t>(rig.skeleton.index(s == kLeft ? CJ::l_hip : CJ::r_hip));
    FootSample& f = samples[us];
    const Vector3d hip_local = hip_in_pelvis_frame(rig, s);  // for every mkm_ankle of this foot
    // Contacts of the motion being blended TO: a cross-fade moves feet the new motion has
    // down elsewhere, and following the fade would slide them there along the floor.
    f.planted = planted[us] >= 0.5;
    // A stance step stands on its support foot throughout: where the mocap turns on it (a
    // heel raised, the foot pivoting) it stays held, not stepped to the clip's next contact.
    if (in.stance_support == s) {
      f.planted = true;
      f.pivot = true;
    }
    // ...and its stepping foot is over its landing before the source's glides in (landing_lead).
    if (in.stance_support >= 0 && in.stance_support != s) f.landing_lead = kStanceStepLandingLead;
    f.swing_left_s = swing_left_s(in, s);
    // Where the motion alone would put the ankle now (last hip + this frame's leg vector). On
    // a character switch's update the hip drawn last is the old body's: the new leg hung from
    // it put viktor's free ankle 10 cm under the floor after mei (1.52 m -> 1.84 m), and a kick
    // started on that update carried the gap into its swing (the foot 14.5 cm up in the next
    // frame, the knee 14 cm: the scripted bout with stance steps on at 15.25 s). There the new
    // body's own hip, as its pose places it.
    const Vector3d hip_now = in.switched ? Vector3d(mkm_ankle(rig, pose, s, hip_local) -
                                                    pose.leg_n[us] * rig.morphology.limb_leg_length(s))
                                         : in.drawn_m[hip];
    f.free_ankle_m = hip_now + pose.leg_n[us] * rig.morphology.limb_leg_length(s);
    f.source_step_m = mkm_ankle(rig, cur, s, hip_local) - mkm_ankle(rig, before, s, hip_local);
    if (!f.planted) {
      if (!have_before2) {
        PlaybackSource earlier2 = earlier;
        earlier2.time_s -= dt * player.current().rate;
        player.sample(earlier2, before2);
        have_before2 = true;
      }
      f.source_step_before_m = mkm_ankle(rig, before, s, hip_local) - mkm_ankle(rig, before2, s, hip_local);
    }
    if (!f.planted && !player.current().loop && std::isfinite(f.swing_left_s) && f.swing_left_s > 0) {
      // Where the motion puts this foot down next, and the horizontal way its ankle still goes.
      const PlaybackSource& src = player.current();
      const double land_t = src.time_s + f.swing_left_s * src.rate;
      const MotionSegment& seg = db_->segments[static_cast<std::size_t>(src.segment)];
      const int land = std::min(static_cast<int>(std::lround(land_t / seg.frame_time_s)), seg.frame_count() - 1);
      const int hold = hold_frame(in, s, land);
      const Vector3d now_m = mkm_ankle(rig, cur, s, hip_local);
      SwingPath& sp = swing_paths_[us];
      // The walk depends on the landing frame only (a strike's rate entering mid-swing moves
      // the landing time of a foot that stays up past the clip's end, not its frame).
      const bool same = sp.segment == src.segment && sp.character == in.character && sp.land_frame == land && sp.hold_frame == hold &&
                        sp.placement.origin_xz == src.placement.origin_xz && sp.placement.yaw_rad == src.placement.yaw_rad &&
                        sp.anchor_xz_m == src.anchor_xz_m && sp.travel == src.travel;
      if (same) {
        sp.way_left_m = std::max(0.0, sp.way_left_m - Eigen::Vector2d(now_m.x() - sp.last_m.x(), now_m.z() - sp.last_m.z()).norm());
      } else {
        // The source's own frames from now to the landing (swing_left_s ends on a frame).
        const Eigen::Quaterniond turn = src.placement.rotation();
        Vector3d last = now_m;
        double path = 0;
        for (int k = static_cast<int>(std::floor(src.time_s / seg.frame_time_s)) + 1; k <= land; ++k) {
          const Vector3d p = player.frame_ankle(src, turn, k, rig, s, hip_local);
          path += Eigen::Vector2d(p.x() - last.x(), p.z() - last.z()).norm();
          last = p;
        }
        // A strike's foot put down before contact and kept down through it lands where the
        // clip has it at contact (hold_frame), its way walked to the landing as the source's.
        const Vector3d at = hold == land ? last : player.frame_ankle(src, turn, hold, rig, s, hip_local);
        sp = SwingPath{src.segment, in.character, land, hold, src.placement, src.anchor_xz_m, src.travel, at, now_m, path};
      }
      sp.last_m = now_m;
      f.has_landing = true;
      f.landing_ankle_m = sp.landing_m;
      f.source_path_left_m = sp.way_left_m;
      // A held foot the source "lifts" only to glide a few centimetres along the floor is not
      // stepped: the mocap's own foot sliding (135_06's lunges, whose back foot glides at 1-2
      // m/s over their first frames) read as off the floor by its contacts. A strike retrieved
      // from such a frame (135_06_punch_right_2 from frame 8, after a stance step) dragged the
      // planted foot 3.4 cm along the floor in two frames (1.0 m/s) before putting it down.
      const double glide_way_m = sp.way_left_m + Vector2d(f.source_step_m.x(), f.source_step_m.z()).norm();
      if (planter_.held(s) && in.kick_side != s && glide_way_m < planter_.tunables().min_swing_path_m &&
          stays_low(player, seg, src, land, rig, s, hip_local, now_m.y(), planter_.tunables().landing_height_m)) {
        f.planted = true;
        f.has_landing = false;
      }
      // Nor one the source puts down again within kShortestLift_s (the time left of its lift,
      // however long the source's lift was: a strike begun as the source's foot comes down from a
      // step of its own, or a foot that waited for the other to land): a swing that short is a
      // lift and a stop. Lifted, bruno's held foot went 2.9 cm (2.3 up) in its one 30 Hz update
      // of swing and was put down in the next, the nearly straight knee 5.5 cm in that frame (the
      // studio grid's left punches from Boxing_Toes_30fps frame 184).
      if (planter_.held(s) && in.kick_side != s && f.swing_left_s < kShortestLift_s) {
        f.planted = true;
        f.has_landing = false;
      }
    }
    f.drawn_ankle_m = in.drawn_m[ankle];
    const Vector3d drawn_dir = drawn_foot_dir(pose, rig.morphology, s);  // the foot as adaptation aims it
    {
      const Vector3d toe = in.drawn_m[static_cast<std::size_t>(rig.skeleton.index(s == kLeft ? CJ::l_toe : CJ::r_toe))];
      const Vector2d h(toe.x() - f.drawn_ankle_m.x(), toe.z() - f.drawn_ankle_m.z());
      if (h.norm() > 1e-6) f.drawn_heading_xz = h.normalized();
      const Vector2d m(drawn_dir.x(), drawn_dir.z());
      f.motion_heading_xz = m.norm() > 1e-6 ? Vector2d(m.normalized()) : f.drawn_heading_xz;
    }
    f.hip_m = hip_now;
    f.leg_length_m = rig.morphology.limb_leg_length(s);
    {
      // Each foot's floor where it stands flat on its own toes (the rest pose's straight legs
      // hold a shorter leg's foot that much up: the left foot stood 1.6 cm above the floor).
      const Vector3d rest_ankle = at(rig.rest_pose, s == kLeft ? CJ::l_ankle : CJ::r_ankle);
      const Vector3d rest_toe = at(rig.rest_pose, s == kLeft ? CJ::l_toe : CJ::r_toe);
      const double own_floor = rest_toe.allFinite() ? std::min(rest_ankle.y(), rest_toe.y()) : rest_ankle.y();
      constexpr double kMostShortLeg_m = 0.05;  // m: a foot standing higher at rest is a rig's, not a leg's
      f.standing_ankle_y_m = rest_ankle.y() - std::min(own_floor, rest_floor_y(rig) + kMostShortLeg_m);
      if (rest_toe.allFinite()) f.standing_toe_y_m = rest_toe.y() - std::min(own_floor, rest_floor_y(rig) + kMostShortLeg_m);
      f.short_leg_m = rest_ankle.y() - rest_floor_y(rig) - f.standing_ankle_y_m;
    }
    f.reached = in.report->foot_reached[us];
    // A heel the source raises, as the mocap itself has it (its ankle above its own lowest, in
    // leg lengths): the ankle decoded on this body stood 6-7 cm up on a kick's straight support
    // leg where the actor stands flat (bruno's HDM_mm_024 kick: the held foot floated flat for 0.7 s).
    // And at least as high as keeps the toes on the floor with the foot pitched as the motion
    // has it (drawn that way: adaptation aims the foot along foot_dir): a blend can pitch the
    // foot onto its toes while its ankle stays low (aiko's recovery in the scripted bout: the
    // toes 6 cm through the floor). Both of the pose as drawn (the cross-fade's), not of the
    // motion faded to.
    if (f.planted) {
      const Vector3d rest_foot = at(rig.rest_pose, s == kLeft ? CJ::l_toe : CJ::r_toe) - at(rig.rest_pose, s == kLeft ? CJ::l_ankle : CJ::r_ankle);
      const double toes_down_m = rest_foot.y() - drawn_dir.y() * rest_foot.norm();
      // Only as far as a heel rises with the toes still down (the pitch's own rise and a little):
      // a blend out of a kick whose segment ends with the foot still up says "planted" (the
      // rest faded to) while the pose has the ankle 20 cm above its lowest, and that foot was
      // held in the air (viktor's HDM_dg_017 kick: the other foot then stepped, both feet off).
      const double heel_m = std::min(pose.ankle_lift_n[us] * rig.morphology.leg_length_m, std::max(0.0, toes_down_m) + kHeelRiseSlack_m);
      f.source_lift_m = std::max(0.0, std::max(heel_m, toes_down_m) - kLiftDeadband_m);
    }
    f.effector = in.kick_side == s && in.kick_striking;
  }
  planter_.update(dt, samples, in.may_step, in.spot_velocity_mps, locks_);
}

void Feet::bound_drop(const FeetInput& in) {
  const double dt = in.dt_s;
  if (in.kick_side >= 0 && !planter_.held(in.kick_side)) {
    // The kicking foot leaves its hold on the same ramp as d(t): fully free at contact, so the
    // goal there is exactly the motion's own foot turned by d(t) (what compute_reach_error
    // assumed), and back under the hold as d(t) is released. Once put down it is held.
    locks_.weight[static_cast<std::size_t>(in.kick_side)] *= std::clamp(1 - in.reach_ramp, 0.0, 1.0);
  }
  // The pelvis drop for held feet changes at a bounded rate and a bounded acceleration: a foot
  // lifted or put down never moves the whole body in one frame, and a foot held for a single
  // update (landing, lifted again) does not flick the pelvis down and up (the knees popped).
  const double last_drop = in.have_pose ? in.report->root_drop_m : 0.0;
  const double v = in.have_pose ? drop_rate_mps_ : 0.0;
  last_drop_m_ = last_drop;
  // The rate changes by max_drop_accel_mps2 * dt, but the step (rate * dt) by no more than
  // kMostDropStepGain_m an update: at 30 Hz (30 fps clips played at their rate) 60 m/s^2 let a
  // foot's hold lift the whole body 5.9 cm in one update after 0.4 cm in the one before (the
  // motion-quality check's one-frame jump); 120 and 60 Hz stay under the bound (0.4 and 1.7 cm;
  // foot_planting.cpp's kMostStepGain_m, the same 3 cm). A tighter bound (1 cm) also kept a
  // nearly straight leg's knee, which moves 2-3x what the pelvis does, from jumping at 30 and
  // 60 Hz, but at 60 Hz the shipped sweep's pelvis then lagged its feet: both feet off in 8899
  // frames instead of 6757, 3 snaps instead of 0.
  constexpr double kMostDropStepGain_m = 0.03;
  const double dv = dt > 0 ? std::min(max_drop_accel_mps2_ * dt, kMostDropStepGain_m / dt) : 0.0;
  double v_lo = std::max(-max_drop_rate_mps_, v - dv);
  double v_hi = std::min(max_drop_rate_mps_, v + dv);
  if (dt >= kCoarseUpdate_s) {
    // Updated coarsely (kCoarseUpdate_s), the pelvis rising out of its drop starts and stops
    // gently: its step up grows by no more than the last update's step and 5 mm (a foot lifted
    // from a leg the drop stretched let the pelvis up 2 cm in one update after none, the nearly
    // straight knee 5 cm: the studio grid's 30 fps strikes), and it slows as it nears the drop
    // its held feet still need (held_feet_drop; none where the legs reach them), rising by at most
    // half the way left and 5 mm an update. It went on speeding up and stopped dead: at no
    // drop, 6 cm in one update, then none, a knee 11 cm in that frame; at the drop a held
    // foot needs, 1.6 then 3.7 cm, then 0.7, the held leg's knee 8.3 cm as it straightened
    // (aiko's steps before two punches of the studio grid).
    constexpr double kCoarseDropStepGain_m = 0.005;
    v_lo = std::max(v_lo, v - (std::abs(v) + kCoarseDropStepGain_m / dt));
    // The drop the held feet need (what AdaptJob will ask for), from the last drawn hips raised
    // by the drop they were drawn with.
    double need = 0;
    if (in.have_pose)
      need = held_feet_drop(locks_, in.rig->morphology, 1.0, [&](int s) {
        const auto hip = static_cast<std::size_t>(in.rig->skeleton.index(s == kLeft ? CJ::l_hip : CJ::r_hip));
        return hip < in.drawn_m.size() ? Vector3d(in.drawn_m[hip] + Vector3d::UnitY() * last_drop) : locks_.ankle_m[static_cast<std::size_t>(s)];
      });
    v_lo = std::max(v_lo, -(0.5 * std::max(0.0, last_drop - need) + kCoarseDropStepGain_m) / dt);
    // Going down, its step grows by no more than the last update's step and 1.5 cm: from none to
    // 2.6 cm in one update (a step landing out of the leg's reach) moved the other, nearly
    // straight, leg's knee 6 cm. Bounded as rising is (5 mm), the spar demo run at 30 Hz left a
    // foot 70 cm behind the fighter stepping in, then swept it 39 cm in a frame (a knee 13 m/s).
    constexpr double kCoarseDropFallGain_m = 0.015;
    v_hi = std::min(v_hi, v + std::abs(v) + kCoarseDropFallGain_m / dt);
  }
  // A punch's pelvis goes no lower than keeps its target within the arm's reach at
  // max_punch_aim_deg from the shoulder: a lunge's back foot held out of the legs' reach sank
  // the pelvis 0.29 m and a head-height punch went up with the elbow above the head. The foot
  // steps instead (a foot the leg cannot reach steps at once: FootPlanter).
  double most_drop = max_root_drop_m_;
  if (in.punch_side >= 0 && in.have_pose) {
    const CJ shoulder = in.punch_side == kLeft ? CJ::l_shoulder : CJ::r_shoulder;
    const double shoulder_undropped = in.drawn_m[static_cast<std::size_t>(in.rig->skeleton.index(shoulder))].y() + last_drop;
    most_drop = std::clamp(shoulder_undropped - in.lowest_shoulder_y_m, 0.0, most_drop);
  }
  locks_.min_root_drop_m = std::clamp(last_drop + v_lo * dt, 0.0, max_root_drop_m_);
  locks_.max_root_drop_m = std::clamp(std::min(last_drop + v_hi * dt, most_drop), locks_.min_root_drop_m, max_root_drop_m_);
  // A character switch's update: the drop goes where the new body needs it at once, its rate
  // restarting from none; the switch's easing (SwitchEasing) takes the difference out over its
  // fade with every other joint's. Bounded from the old body's drop and rate, the new body's
  // pelvis went on rising 2.4 cm an update after the switch and a bent knee moved 5 cm in one.
  switched_ = in.switched && in.have_pose;
  if (switched_) {
    locks_.min_root_drop_m = 0;
    locks_.max_root_drop_m = std::clamp(most_drop, 0.0, max_root_drop_m_);
  }
}

void Feet::drew(bool had_pose, double dt_s, double root_drop_m) {
  drop_rate_mps_ = had_pose && dt_s > 0 && !switched_ ? (root_drop_m - last_drop_m_) / dt_s : 0.0;
}

}  // namespace kumite::content
