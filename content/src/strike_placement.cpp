// Placing a strike's clip in the room (strike_placement.hpp): onto the foot it stands on, and
// its floor travel fitted to its target.
#include "kumite/content/strike_placement.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "behaviour_internal.hpp"
#include "kumite/content/foot_planting.hpp"

namespace kumite::content {

using namespace behaviour_detail;
using CJ = CanonicalJoint;
using Eigen::Vector2d;
using Eigen::Vector3d;

namespace {
/// m: a foot in a procedural step is put down as the clip's support (FootPlanter::land) where
/// the clip would have to be carried up to this much farther than max_support_shift_m to land
/// it there: the clip is carried max_support_shift_m and the foot stands that much from where
/// the clip has it (the leg takes it up). Not put down, the step went on to its old target
/// while the clip stood on the foot and lifted the other: viktor's opening lunge (135_06 from
/// its frame 24, 4.65 s) wanted 0.375 m and had 13 frames with both feet off in each of the
/// 24 bouts he opens.
constexpr double kLandingSupportSlack_m = 0.10;
/// m: the farthest a procedural step is redirected to where a strike's clip stands on its foot
/// from its start (align_to_support_foot): a step's length.
constexpr double kMostRedirect_m = 0.35;
/// m: ...and to where the clip puts the foot down a few frames in: a long step's length (at
/// 0.35 m, a lunge of the 120-order sweep's scripted bout at 19.3 s wanted its stepping back foot
/// 0.37 m on). (0.45 m for the first kind too moved sparring bouts and gained the sweep nothing.)
constexpr double kMostRedirectOnTheWay_m = 0.45;
}  // namespace

int align_to_support_foot(const StrikePlacement& in, PlaybackSource& s, double contact_time_s, StrikeFit* redirect) {
  // The clip is placed by its pelvis; shift it on the floor so that its support foot (planted
  // at the start and staying down longest) lands where that foot is held now: the motion then
  // swings its other foot and moves its body around a foot that does not have to move, as in
  // the mocap, instead of dragging a held foot the clip has elsewhere out of the leg's reach.
  const HeldFeet& feet = *in.feet;
  const MotionSegment& seg = in.db->segments[static_cast<std::size_t>(s.segment)];
  const int n = seg.frame_count();
  const int first = std::clamp(static_cast<int>(std::lround(s.time_s / seg.frame_time_s)), 0, n - 1);
  const int contact = std::clamp(static_cast<int>(std::lround(contact_time_s / seg.frame_time_s)), first, n - 1);
  const auto run_from_start = [&](int side) { return planted_run(seg, side, first, n - 1); };
  const Rig& rig = *in.rig;
  // How far (m, x/z) the clip must move for `side`'s ankle at clip frame `frame` to stand where
  // that foot is drawn now.
  const auto wanted = [&](int side, int frame) {
    PlaybackSource at_frame = s;
    at_frame.time_s = frame * seg.frame_time_s;
    MkmFrame placed;
    in.player->sample(at_frame, placed);
    CanonicalPose& c = *in.scratch;  // its room kept: a strike's start allocates nothing
    decode_canonical(rig, placed, c);
    const Vector3d& a = at(c, side == kLeft ? CJ::l_ankle : CJ::r_ankle);
    const Vector3d& held = feet.ankle_m[static_cast<std::size_t>(side)];
    return Vector2d(held.x() - a.x(), held.z() - a.z());
  };
  const double limit = in.tunables->max_support_shift_m;
  // The way along the floor from where the clip is placed to the target (none without a target,
  // or with the target straight above).
  Vector2d to_target = Vector2d::Zero();
  if (in.target_m) {
    to_target = Vector2d(in.target_m->x() - s.placement.origin_xz.x(), in.target_m->z() - s.placement.origin_xz.y());
    to_target = to_target.norm() > 1e-6 ? Vector2d(to_target.normalized()) : Vector2d::Zero();
  }
  int best = -1, landing_support = -1;
  Vector2d shift = Vector2d::Zero();
  // The foot the clip stands on from its start, among those held or in a procedural step. A
  // stepping one (the last strike's recovery stepping it back while the clip stands on it) is
  // cut short where it is (FootPlanter::land), if the clip can be carried there (max_support_shift_m,
  // or within kLandingSupportSlack_m of it).
  int best_any = -1, best_any_run = 0, best_held = -1, best_held_run = 0;
  for (int side = 0; side < 2; ++side) {
    const auto us = static_cast<std::size_t>(side);
    if (!feet.held[us] && !feet.stepping[us]) continue;
    const int run = run_from_start(side);
    if (run > best_any_run) { best_any = side; best_any_run = run; }
    if (feet.held[us] && run > best_held_run) { best_held = side; best_held_run = run; }
  }
  if (best_any >= 0 && !feet.held[static_cast<std::size_t>(best_any)]) {
    const Vector2d want = wanted(best_any, first);
    if (want.norm() <= limit + kLandingSupportSlack_m) {
      best = best_any;
      landing_support = best_any;
      shift = want;
    } else if (redirect != nullptr && (best_held < 0 || first + best_held_run <= contact) && clip_planted(seg, contact, best_any)) {
      // Too far to carry the clip there, and no held foot it stands on to contact: carried as
      // far as it goes toward the foot, and the foot's step goes on to where the clip then
      // has it, if that is within a step's length (slowed to a step's pace where it must be:
      // FootPlanter::redirect). Placed by its pelvis
      // instead, the clip stood on that foot 47 cm from where its step put it down, the foot
      // stepped again under the lunge while the other swung, both feet off the floor for 0.4 s
      // (kenji's 135_06_punch_left_3 from frame 24 at 11.58 s of the scripted bout).
      const auto us = static_cast<std::size_t>(best_any);
      const Vector2d carry = want * (limit / want.norm());
      const Vector3d& end = feet.step_end_m[us];
      Vector3d to = feet.ankle_m[us];
      to.x() += carry.x() - want.x();
      to.z() += carry.y() - want.y();
      to.y() = end.y();
      const double way = Vector2d(to.x() - feet.ankle_m[us].x(), to.z() - feet.ankle_m[us].z()).norm();
      if (way <= kMostRedirect_m) {
        best = best_any;
        shift = carry;
        redirect->redirect_support = best_any;
        redirect->redirect_to_m = to;
      }
    }
  }
  bool redirected = redirect != nullptr && redirect->redirect_support >= 0;
  if (best < 0) best = best_held;  // its shift is found below, once it is the one kept
  // The foot it is aligned on, if held, may be one the clip lifts before contact (a held front
  // foot that the lunge steps): then a stepping foot that the clip stands on at contact is the
  // better support, as where no foot is down from the start (mei's opening lunge, 135_06 from
  // its frame 0: aligned on the left foot the clip lifts at once, the right foot's step ended
  // 60 cm from where the clip puts it, and it stepped again and again under the lunge while the
  // left swung: 27 frames with both feet off, now 12).
  const int best_run = best == best_held ? best_held_run : best_any_run;
  const bool lifted_before_contact = best >= 0 && landing_support < 0 && !redirected && first + best_run <= contact;
  if ((best < 0 && best_any < 0) || lifted_before_contact) {
    // No foot held or stepping that the clip has down from its start: a foot in a procedural
    // step that the clip puts down on the way and keeps down to contact is the support (135_06's
    // lunges from frame 8 lift one foot at once and put the other down a few frames on). Placed
    // by its pelvis, the clip landed that foot 40 cm from where it was drawn while the step went
    // on to its old target: the foot swung back and forth in the air while the mocap stood on it
    // (kenji at 4.70 s in every bout he opens, 27 frames). Now the step ends where the foot is
    // and the clip is carried so that it lands the foot there, if that is within
    // max_support_shift_m (session 34 also took a held foot, and any carry: a 85 cm carry held to
    // 30 cm landed the foot 55 cm off and the pelvis sank under a head-height punch).
    for (int side = 0; side < 2 && landing_support < 0 && !redirected; ++side) {
      const auto us = static_cast<std::size_t>(side);
      if (!feet.stepping[us] || !clip_planted(seg, contact, side)) continue;
      const Vector2d want = wanted(side, planted_since(seg, side, first, contact));
      if (want.norm() <= limit + kLandingSupportSlack_m) {
        best = side;
        landing_support = side;
        shift = want;
      } else if (redirect != nullptr) {
        // Too far to carry the clip there: carried as far as it goes, and the step sent on to
        // where the clip then has the foot, as above (a stepping foot the clip stands on from
        // its start). Left to its old target, the foot landed there, out of the leg's reach
        // from where the lunge stands on it, and stepped again while the front foot swung:
        // both feet off 20 frames where the source stands (kenji's and mei's 135_06 right lunge
        // from frames 0-4 at 19.3-19.5 s of the scripted bout: 562 frames in 46 of the 120 orders).
        // Never carried toward the target for it: the foot's step takes that part (carried
        // forward, the spar demo's lunges began up to 0.3 m nearer a visitor walking in: over
        // planner seeds 1-40 its torso came within 0.1 m of the visitor's body axis in 558
        // frames against 377). The way the step is then sent on is still kMostRedirectOnTheWay_m at most.
        Vector2d carry = want * (limit / want.norm());
        carry -= std::max(0.0, carry.dot(to_target)) * to_target;
        Vector3d to = feet.ankle_m[us];
        to.x() += carry.x() - want.x();
        to.z() += carry.y() - want.y();
        to.y() = feet.step_end_m[us].y();
        if (Vector2d(to.x() - feet.ankle_m[us].x(), to.z() - feet.ankle_m[us].z()).norm() <= kMostRedirectOnTheWay_m) {
          best = side;
          shift = carry;
          redirect->redirect_support = side;
          redirect->redirect_to_m = to;
          redirected = true;
        }
      }
    }
    // None within reach of a carry: the held foot's alignment, as before.
  }
  if (best < 0) return -1;
  if (landing_support < 0 && !redirected) shift = wanted(best, first);  // the held foot, down from the start
  // Along the line to the target: never back away for it (the held foot then steps up to where
  // the clip has it, rather than the whole strike landing short) -- except for a lunge (a clip
  // whose body travels to contact): its support foot is the back foot the lunge pushes off,
  // and the stance is only the captured one when that foot stands where the clip has it (a
  // strike that then lands short steps in first: place_strike_travel). A foot put down where
  // it is (landing_support) is aligned whole: it will stand there.
  MkmFrame contact_pose;
  const bool lunge = strike_travel(*in.player, s, contact_time_s, contact_pose).norm() >= in.tunables->min_scaled_travel_m;
  if (in.target_m && !lunge && landing_support < 0 && !redirected) {
    shift -= std::min(shift.dot(to_target), 0.0) * to_target;
  }
  if (shift.norm() > limit) shift *= limit / shift.norm();
  s.placement.origin_xz += shift;
  return landing_support;
}

Vector2d strike_travel(const MotionPlayer& player, const PlaybackSource& s, double contact_time_s, MkmFrame& contact_pose) {
  PlaybackSource at_contact = s;
  at_contact.time_s = contact_time_s;
  MkmFrame start_pose;
  player.sample(s, start_pose);
  player.sample(at_contact, contact_pose);
  return contact_pose.root_xz_m - start_pose.root_xz_m;
}

StrikeFit place_strike_travel(const StrikePlacement& in, PlaybackSource& s, double contact_time_s) {
  // A lunge travels a fixed distance in the clip; the target is nearer or farther. Scale the
  // clip's floor travel up to contact (a shorter or longer lunge: Source::Travel) so that at
  // contact the limb's root (shoulder / hip) is as far from the target as the clip has it from
  // its own hit point: the limb arrives as extended as captured and d(t) only turns it,
  // instead of folding a straight punch up onto a near head or stretching it to a far one.
  // Clips that hardly travel keep their travel; the pelvis always stays min_contact_distance_m
  // short of the target at contact.
  // Returns how the limb then lands: how much farther (m) its root would have to be carried
  // toward the target for the limb, as extended as captured, to reach it (0 when it does), or
  // how much nearer the target than captured it is, and its extension.
  const HeldFeet& feet = *in.feet;
  const BehaviourTunables& tun = *in.tunables;
  s.travel = PlaybackSource::Travel{};
  if (!in.target_m) return {};
  Vector2d dir(in.target_m->x() - s.placement.origin_xz.x(), in.target_m->z() - s.placement.origin_xz.y());
  if (dir.norm() < 1e-6) return {};
  dir.normalize();
  s.travel.from_s = s.time_s;
  s.travel.contact_s = contact_time_s;
  s.travel.release_s = tun.release_time_s;
  const MotionSegment& seg = in.db->segments[static_cast<std::size_t>(s.segment)];
  const auto eff = seg.effector();
  if (!eff) return {};
  const Rig& rig = *in.rig;
  MkmFrame contact_pose;
  const Vector2d travel2 = strike_travel(*in.player, s, contact_time_s, contact_pose);
  const Vector3d target = *in.target_m;
  double k = 0;  // scale - 1
  const double leg = rig.morphology.leg_length_m;
  CanonicalPose& c = *in.scratch;  // its room kept: a strike's start allocates nothing
  decode_canonical(rig, contact_pose, c);
  const CJ root = eff->leg ? (eff->side == kLeft ? CJ::l_hip : CJ::r_hip) : (eff->side == kLeft ? CJ::l_shoulder : CJ::r_shoulder);
  Vector3d limb_root = at(c, root);
  const double reach = (at(c, eff->joint()) - limb_root).norm();
  if (!eff->leg) {
    // A target above what the arm reaches at max_punch_elevation_deg: raise the pelvis toward
    // its standing height (a higher stance), at most max_strike_rise_m.
    // The rest pose is decoded about its pelvis (y = 0 there): heights count from its feet.
    const double standing_n = (at(rig.rest_pose, CJ::pelvis).y() - rest_floor_y(rig) - rig.morphology.standing_ankle_m) / leg;
    const double room = std::max(0.0, standing_n - contact_pose.root_height_n) * leg;
    const double above = target.y() - limb_root.y() - reach * std::sin(tun.max_punch_elevation_deg * std::numbers::pi / 180);
    const double rise = std::clamp(above, 0.0, std::min(room, tun.max_strike_rise_m));
    s.travel.rise_n = rise / leg;
    limb_root.y() += rise;
  }
  if (travel2.norm() >= tun.min_scaled_travel_m) {
    const Vector3d T(travel2.x(), 0, travel2.y());
    const Vector3d u = target - limb_root;
    // |u - k T| = reach, the root approaching from behind (the smaller k); when no k reaches
    // (a target far above or below), the k that comes closest.
    const double tt = T.squaredNorm(), ut = u.dot(T);
    const double disc = ut * ut - tt * (u.squaredNorm() - reach * reach);
    k = disc >= 0 ? (ut - std::sqrt(disc)) / tt : ut / tt;
    k = std::clamp(k, tun.min_travel_scale - 1, tun.max_travel_scale - 1);
    const double td = T.x() * dir.x() + T.z() * dir.y();
    if (td > 1e-6) {
      const double ahead = (Vector2d(target.x(), target.z()) - contact_pose.root_xz_m).dot(dir);
      k = std::min(k, (ahead - tun.min_contact_distance_m) / td);
    }
    // A foot the clip keeps down from now through contact (the back foot of a lunge) is held
    // where it stands: at contact the hip stays within the leg's reach of it. A longer lunge
    // would drag the foot along the floor, or sink the pelvis to keep it (and a punch at head
    // height then goes up, its elbow above the head): the fighter steps in first instead
    // (the distance returned), or the arm reaches on as far as it goes.
    const int from = std::clamp(static_cast<int>(std::floor(s.time_s / seg.frame_time_s)), 0, seg.frame_count() - 1);
    // (down up to the frame before contact: a back foot the clip lifts at contact, to step
    // after the hit, still holds the stance until then)
    const int to = std::clamp(static_cast<int>(std::floor(contact_time_s / seg.frame_time_s)) - 1, from, seg.frame_count() - 1);
    for (int side = 0; side < 2; ++side) {
      if (!feet.held[static_cast<std::size_t>(side)] || (eff->leg && eff->side == side)) continue;
      bool down = true;
      for (int f = from; f <= to && down; ++f) down = clip_planted(seg, f, side);
      if (!down) continue;
      const CJ ankle = side == kLeft ? CJ::l_ankle : CJ::r_ankle;
      Vector3d a = feet.ankle_m[static_cast<std::size_t>(side)];
      a.y() = std::max(a.y(), at(c, ankle).y());  // a heel the clip raises by contact
      Vector3d h0 = at(c, side == kLeft ? CJ::l_hip : CJ::r_hip);
      h0.y() += s.travel.rise_n * leg;
      const Vector3d d0 = h0 - a;
      // As far as max_leg_stretch, or as the clip's own leg at contact where the clip holds
      // it straighter (a lunge's straight back leg), as the foot planter allows.
      const double leg_length = rig.morphology.limb_leg_length(side);
      const double clip_stretch = (at(c, side == kLeft ? CJ::l_hip : CJ::r_hip) - at(c, ankle)).norm() / std::max(1e-6, leg_length);
      const double r = allowed_leg_stretch(tun.feet.max_leg_stretch, clip_stretch) * leg_length;
      const double b = T.dot(d0), cc = d0.squaredNorm() - r * r;
      const double disc2 = b * b - tt * cc;
      k = std::min(k, disc2 >= 0 ? (-b + std::sqrt(disc2)) / tt : -b / tt);
    }
    k = std::max(k, tun.min_travel_scale - 1);
    limb_root += k * T;
  } else {
    // No travel to scale: keep the pelvis short of the target by moving the clip back, at most
    // max_support_shift_m (as far as any placement shift goes: a target behind the fighter is
    // not a reason to slide the whole strike away from it).
    const double ahead = (Vector2d(target.x(), target.z()) - contact_pose.root_xz_m).dot(dir);
    if (ahead < tun.min_contact_distance_m) {
      const double back = std::min(tun.min_contact_distance_m - ahead, tun.max_support_shift_m);
      s.placement.origin_xz -= back * dir;
      limb_root -= back * Vector3d(dir.x(), 0, dir.y());
    }
  }
  s.travel.scale = 1 + k;
  const double u = (target - limb_root).norm();
  const double limb = eff->leg ? rig.morphology.limb_leg_length(eff->side) : rig.morphology.arm_length(eff->side);
  return StrikeFit{std::max(0.0, u - reach), std::max(0.0, reach - u), u / std::max(1e-6, limb)};
}

}  // namespace kumite::content
