// Behaviour: what the motion now playing says of each foot (contact, lift, landing and the
// way to it, its own step this update), handed to the FootPlanter (foot_planting.cpp).
#include "kumite/content/behaviour.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "behaviour_internal.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/bvh.hpp"
#include "kumite/content/canonical.hpp"

namespace kumite::content {

using namespace behaviour_detail;
using CJ = CanonicalJoint;
using Eigen::Vector2d;
using Eigen::Vector3d;

std::array<bool, 2> Behaviour::feet_locked() const { return {feet_.held(kLeft), feet_.held(kRight)}; }

double Behaviour::swing_left_s(int side) const {
  // Time until the motion now playing puts this foot down again.
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(player_.current().segment)];
  if (player_.current().loop) return 0;  // the rest motion: nothing to follow (the shortest swing applies)
  const int n = seg.frame_count();
  const int first = std::clamp(static_cast<int>(std::ceil(player_.current().time_s / seg.frame_time_s - 1e-9)), 0, n);
  for (int k = first; k < n; ++k)
    if (clip_planted(seg, k, side)) return (k * seg.frame_time_s - player_.current().time_s) / player_.current().rate;
  return ((n - 1) * seg.frame_time_s - player_.current().time_s) / player_.current().rate + tun_.blend_time_s;  // the rest motion after it
}

int Behaviour::strike_hold_frame(int side, int land) const {
  // The clip puts a foot down at `land` and keeps it down to the strike's contact: where a
  // lunge's hip travels farther than the mocap's (Source::Travel) or the mocap's own back foot
  // slides on the floor (135_06's lunges: 10-12 cm), a foot held where the clip lands it is
  // out of the leg's reach by contact and steps while the front foot swings (mei's opening
  // lunge, 135_06_punch_right_2:mirror from frame 0: both feet off for 12 frames). Held where
  // the clip has it at contact, the leg reaches it there, as the clip's own does.
  if (!striking() || strike_.contact_done || player_.current().loop) return land;
  if (strike_.effector.leg && strike_.effector.side == side) return land;
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(player_.current().segment)];
  const int contact = std::clamp(static_cast<int>(std::lround(strike_.clip_contact_time_s / seg.frame_time_s)), 0, seg.frame_count() - 1);
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

void Behaviour::update_feet(double dt, const ReachGoal* reach, const MkmFrame& cur) {
  if (!have_pose_) {
    locks_ = FootLocks{};
    return;
  }
  const std::array<double, 2>& planted = cur.planted;
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  // The motion being played, one update earlier: how far it moved each foot since.
  MkmFrame before, before2;
  Source earlier = player_.current();
  earlier.time_s -= dt * player_.current().rate;
  player_.sample(earlier, before);
  // ...and one before that, sampled only for a lifted foot (its swing reads how fast the
  // source's foot gathers speed): not on every update a fighter stands.
  bool have_before2 = false;

  constexpr double kLiftDeadband_m = 0.01;
  constexpr double kHeelRiseSlack_m = 0.02;  // m: a heel's rise beyond its foot's pitch (the ball flexing)
  std::array<FootSample, 2> in;
  for (int s = 0; s < 2; ++s) {
    const auto us = static_cast<std::size_t>(s);
    const auto ankle = static_cast<std::size_t>(rig.skeleton.index(s == kLeft ? CJ::l_ankle : CJ::r_ankle));
    const auto hip = static_cast<std::size_t>(rig.skeleton.index(s == kLeft ? CJ::l_hip : CJ::r_hip));
    FootSample& f = in[us];
    const Vector3d hip_local = hip_in_pelvis_frame(rig, s);  // for every mkm_ankle of this foot
    // Contacts of the motion being blended TO: a cross-fade moves feet the new motion has
    // down elsewhere, and following the fade would slide them there along the floor.
    f.planted = planted[us] >= 0.5;
    // A stance step stands on its support foot throughout: where the mocap turns on it (a
    // heel raised, the foot pivoting) it stays held, not stepped to the clip's next contact.
    if (stance_step() && stance_step()->support == s) {
      f.planted = true;
      f.pivot = true;
    }
    f.swing_left_s = swing_left_s(s);
    // Where the motion alone would put the ankle now (last hip + this frame's leg vector). On
    // a character switch's update the hip drawn last is the old body's: the new leg hung from
    // it put viktor's free ankle 10 cm under the floor after mei (1.52 m -> 1.84 m), and a kick
    // started on that update carried the gap into its swing (the foot 14.5 cm up in the next
    // frame, the knee 14 cm: the scripted bout with stance steps on at 15.25 s). There the new
    // body's own hip, as its pose places it.
    const Vector3d hip_now = switch_offsets_due_ ? Vector3d(mkm_ankle(rig, pose_, s, hip_local) -
                                                            pose_.leg_n[us] * rig.morphology.limb_leg_length(s))
                                                 : rig_positions_[hip];
    f.free_ankle_m = hip_now + pose_.leg_n[us] * rig.morphology.limb_leg_length(s);
    f.source_step_m = mkm_ankle(rig, cur, s, hip_local) - mkm_ankle(rig, before, s, hip_local);
    if (!f.planted) {
      if (!have_before2) {
        Source earlier2 = earlier;
        earlier2.time_s -= dt * player_.current().rate;
        player_.sample(earlier2, before2);
        have_before2 = true;
      }
      f.source_step_before_m = mkm_ankle(rig, before, s, hip_local) - mkm_ankle(rig, before2, s, hip_local);
    }
    if (!f.planted && !player_.current().loop && std::isfinite(f.swing_left_s) && f.swing_left_s > 0) {
      // Where the motion puts this foot down next, and the horizontal way its ankle still goes.
      const double land_t = player_.current().time_s + f.swing_left_s * player_.current().rate;
      const MotionSegment& seg = db_->segments[static_cast<std::size_t>(player_.current().segment)];
      const int land = std::min(static_cast<int>(std::lround(land_t / seg.frame_time_s)), seg.frame_count() - 1);
      const int hold = strike_hold_frame(s, land);
      const Vector3d now_m = mkm_ankle(rig, cur, s, hip_local);
      SwingPath& sp = swing_paths_[us];
      // The walk depends on the landing frame only (a strike's rate entering mid-swing moves
      // the landing time of a foot that stays up past the clip's end, not its frame).
      const bool same = sp.segment == player_.current().segment && sp.character == character_ && sp.land_frame == land && sp.hold_frame == hold &&
                        sp.placement.origin_xz == player_.current().placement.origin_xz && sp.placement.yaw_rad == player_.current().placement.yaw_rad &&
                        sp.anchor_xz_m == player_.current().anchor_xz_m && sp.travel == player_.current().travel;
      if (same) {
        sp.way_left_m = std::max(0.0, sp.way_left_m - Eigen::Vector2d(now_m.x() - sp.last_m.x(), now_m.z() - sp.last_m.z()).norm());
      } else {
        // The source's own frames from now to the landing (swing_left_s ends on a frame).
        const Eigen::Quaterniond turn = player_.current().placement.rotation();
        Vector3d last = now_m;
        double path = 0;
        for (int k = static_cast<int>(std::floor(player_.current().time_s / seg.frame_time_s)) + 1; k <= land; ++k) {
          const Vector3d p = player_.frame_ankle(player_.current(), turn, k, rig, s, hip_local);
          path += Eigen::Vector2d(p.x() - last.x(), p.z() - last.z()).norm();
          last = p;
        }
        // A strike's foot put down before contact and kept down through it lands where the
        // clip has it at contact (strike_hold_frame), its way walked to the landing as the source's.
        const Vector3d at = hold == land ? last : player_.frame_ankle(player_.current(), turn, hold, rig, s, hip_local);
        sp = SwingPath{player_.current().segment, character_, land, hold, player_.current().placement, player_.current().anchor_xz_m, player_.current().travel, at, now_m, path};
      }
      sp.last_m = now_m;
      f.has_landing = true;
      f.landing_ankle_m = sp.landing_m;
      f.source_path_left_m = sp.way_left_m;
    }
    f.drawn_ankle_m = rig_positions_[ankle];
    const Vector3d drawn_dir = drawn_foot_dir(pose_, rig.morphology, s);  // the foot as adaptation aims it
    {
      const Vector3d toe = rig_positions_[static_cast<std::size_t>(rig.skeleton.index(s == kLeft ? CJ::l_toe : CJ::r_toe))];
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
      f.short_leg_m = rest_ankle.y() - rest_floor_y(rig) - f.standing_ankle_y_m;
    }
    f.reached = report_.foot_reached[us];
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
      const double heel_m = std::min(pose_.ankle_lift_n[us] * rig.morphology.leg_length_m, std::max(0.0, toes_down_m) + kHeelRiseSlack_m);
      f.source_lift_m = std::max(0.0, std::max(heel_m, toes_down_m) - kLiftDeadband_m);
    }
    f.effector = reach && strike_.effector.leg && strike_.effector.side == s && striking();
  }
  // Steps also while recovering: a strike that ends in a long stance steps back under the
  // body instead of squatting into the rest motion's narrower one.
  // Not while d(t) still acts: the strike holds its stance until it has been taken back.
  // Nor while a kick's support foot is set (its step and the kick it waits for): the other foot
  // stands, and the set foot stays where the kick will turn on it.
  const bool support_set = support_step() || (pending() && pending()->support_stepped) || (retaking() && retaking()->support_stepped);
  // Nor while a stance step plays: the clip steps the feet.
  // Nor while a strike is being planned (its plan in flight, or an order taken again after
  // stepping in): it is planned around the feet as they stand. A step begun between a
  // step-in's arrival and the plan left the back foot of kenji's lunge punch on the grid
  // 13 cm ahead of where the lunge holds it: out of reach, it stepped back and forth in the air.
  const bool planning = pending() || (retaking() && retaking()->stepped_first);
  const bool may_step = !striking() && ramp_ <= 0 && !support_set && !stance_step() && !planning;
  feet_.update(dt, in, may_step, spot_velocity_, locks_);
}

}  // namespace kumite::content
