// Playing sources (the motion now and the one it fades from): sampling a segment at a time,
// placing it in the room, a strike's scaled floor travel and pelvis rise (Playback, and the
// MotionPlayer that owns Behaviour's sources); Behaviour's side: a strike's clip moved onto its
// support foot and its travel fitted, the rest motion started where the body is.
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

double Behaviour::stride_scale() const {
  return characters_[static_cast<std::size_t>(character_)].morphology.leg_length_m / db_->actor.leg_length_m;
}

GroundFrame Behaviour::ground() const { return ground_frame_of(pose_); }

Vector2d Playback::scaled_travel(const PlaybackSource& s, const MotionSegment& seg, double t) const {
  // The part of the clip's root travel that Source::Travel scales, at segment time t: all of it
  // from `from_s` to contact, then weighted by 1 - smoothstep over `release_s` (the extra
  // travel stops smoothly, with the clip's own motion, not at once). The root is linear within
  // a frame, so the weighted travel is exact per frame; its running sums at contact and at each
  // frame after it are kept for the strike being played (one pass per strike, O(1) per call).
  const PlaybackSource::Travel& tr = s.travel;
  if (t <= tr.from_s) return Vector2d::Zero();
  const double tc = std::max(tr.from_s, tr.contact_s);
  Vector2d g = root_at(seg, std::min(t, tc)) - root_at(seg, tr.from_s);
  if (t <= tc || tr.release_s <= 0) return g;
  const double h = seg.frame_time_s, end = tc + tr.release_s;
  const double first = std::ceil(tc / h - 1e-9) * h;  // the first frame at or after contact
  // Knots: contact, then every frame time before the end of the release, then its end.
  const auto knot = [&](std::size_t i) { return i == 0 ? tc : std::min(end, first + static_cast<double>(i - 1) * h); };
  const auto part = [&](double a, double b) {  // weighted travel over [a, b] within one frame
    if (b <= a) return Vector2d(Vector2d::Zero());
    const Vector2d v = (root_at(seg, b) - root_at(seg, a)) / (b - a);
    return Vector2d(v * tr.release_s * (eased_integral((b - tc) / tr.release_s) - eased_integral((a - tc) / tr.release_s)));
  };
  if (eased.segment != s.segment || !(eased.travel == tr)) {
    eased.segment = s.segment;
    eased.travel = tr;
    eased.cum.clear();
    eased.cum.push_back(Vector2d::Zero());
    for (std::size_t i = 1; knot(i - 1) < end; ++i) eased.cum.push_back(eased.cum.back() + part(knot(i - 1), knot(i)));
  }
  if (t >= end) return g + eased.cum.back();
  const std::size_t i = t < first ? 0 : std::min(eased.cum.size() - 1, 1 + static_cast<std::size_t>((t - first) / h));
  return g + eased.cum[i] + part(knot(i), t);
}

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
/// (align_to_support_foot): a step's length.
constexpr double kMostRedirect_m = 0.35;
// The pelvis rise (/ leg length) a strike's Travel adds at segment time t: eased in from the
// strike's start to contact, out over the release.
double travel_rise_n(const PlaybackSource::Travel& tr, double t) {
  const double w = t <= tr.contact_s ? smoothstep((t - tr.from_s) / std::max(1e-6, tr.contact_s - tr.from_s))
                                     : 1 - smoothstep((t - tr.contact_s) / std::max(1e-6, tr.release_s));
  return w * tr.rise_n;
}
}  // namespace

void Playback::sample(const PlaybackSource& s, MkmFrame& out) const {
  const MotionSegment& seg = db.segments[static_cast<std::size_t>(s.segment)];
  const double period = (seg.frame_count() - 1) * seg.frame_time_s;
  double t = s.time_s;
  if (s.loop && seg.kind != SegmentKind::rest) t = 0;  // no rest clip: hold the first frame
  if (s.loop && period > 0) {
    t = std::fmod(std::max(0.0, t), 2 * period);  // ping-pong: no seam to blend over
    if (t > period) t = 2 * period - t;
  }
  const auto [i0, a] = frame_pair(seg, t);
  MkmFrame mixed;
  blend_mkm(seg.frames[i0], seg.frames[i0 + 1], a, mixed);
  place_sample(s, seg, t, mixed, out);
}

void Playback::place_sample(const PlaybackSource& s, const MotionSegment& seg, double t, MkmFrame& mixed,
                            MkmFrame& out) const {
  if (!s.loop && s.travel.scale != 1) mixed.root_xz_m += (s.travel.scale - 1) * scaled_travel(s, seg, t);
  if (!s.loop && s.travel.rise_n != 0) mixed.root_height_n += travel_rise_n(s.travel, t);
  place_mkm(mixed, s.placement, s.anchor_xz_m, stride_scale, out);
}

Vector3d Playback::frame_ankle(const PlaybackSource& s, const Eigen::Quaterniond& placement_rotation, int frame, const Rig& rig,
                               int side, const Vector3d& hip_local) const {
  // sample_frame + place_sample + place_mkm + mkm_ankle, on the fields mkm_ankle reads.
  const MotionSegment& seg = db.segments[static_cast<std::size_t>(s.segment)];
  const MkmFrame& f = seg.frames[static_cast<std::size_t>(std::clamp(frame, 0, seg.frame_count() - 1))];
  const double t = frame * seg.frame_time_s;
  MkmFrame placed;
  placed.root_xz_m = f.root_xz_m;
  placed.root_height_n = f.root_height_n;
  if (!s.loop && s.travel.scale != 1) placed.root_xz_m += (s.travel.scale - 1) * scaled_travel(s, seg, t);
  if (!s.loop && s.travel.rise_n != 0) placed.root_height_n += travel_rise_n(s.travel, t);
  // (place_mkm's placement of the root and its turn of the pelvis and the leg)
  placed.root_xz_m = place_root_xz(placed.root_xz_m, s.placement, placement_rotation, s.anchor_xz_m, stride_scale);
  placed.pelvis = placement_rotation * f.pelvis;
  placed.leg_n[static_cast<std::size_t>(side)] = placement_rotation * f.leg_n[static_cast<std::size_t>(side)];
  return mkm_ankle(rig, placed, side, hip_local);
}

void Playback::compose(const PlaybackSource& cur, const PlaybackSource& prev, double blend_elapsed_s,
                       double blend_time_s, MkmFrame& cur_pose, MkmFrame& out, PoleTurns* turns) const {
  sample(cur, cur_pose);
  if (prev.segment >= 0 && blend_elapsed_s < blend_time_s) {
    MkmFrame prev_pose;
    sample(prev, prev_pose);
    const double w = smoothstep(blend_elapsed_s / blend_time_s);
    // Turns of another cross-fade (other segments, or more time into it than this) start afresh.
    if (turns != nullptr && (turns->from_segment != prev.segment || turns->to_segment != cur.segment ||
                             turns->elapsed_s < 0 || blend_elapsed_s < turns->elapsed_s))
      *turns = PoleTurns{prev.segment, cur.segment};
    blend_mkm(prev_pose, cur_pose, w, out, turns);
    if (turns != nullptr) turns->elapsed_s = blend_elapsed_s;
  } else {
    out = cur_pose;
  }
}

// ---- MotionPlayer: the sources on Behaviour's update thread, with their own cache ----------

MotionPlayer::MotionPlayer(std::shared_ptr<const Database> db, double stride_scale)
    : db_(std::move(db)), stride_scale_(stride_scale) {
  eased_.cum.reserve(256);  // a release of 0.25 s holds ~32 frames: no allocation while playing
}

void MotionPlayer::play(const Source& next) {
  previous_ = current_;
  blend_elapsed_s_ = 0;
  current_ = next;
}

void MotionPlayer::place(const Vector2d& origin_xz, double yaw_rad) {
  current_.placement.origin_xz = origin_xz;
  current_.placement.yaw_rad = yaw_rad;
}

void MotionPlayer::advance(double dt) {
  current_.time_s += dt * current_.rate;
  previous_.time_s += dt * previous_.rate;
  blend_elapsed_s_ += dt;
}

void MotionPlayer::rescale(double stride_scale) {
  const double old_scale = stride_scale_;
  stride_scale_ = stride_scale;
  const double new_scale = stride_scale_;
  for (Source* s : {&current_, &previous_}) {
    if (s->segment < 0) continue;
    MkmFrame f;
    sample(*s, f);  // with the new scale
    const Vector2d d_new = f.root_xz_m;
    // Root under the old scale: origin + R (old * (root - anchor)) == what was shown.
    const Vector2d rel = (d_new - s->placement.origin_xz) / new_scale;
    const Vector2d d_old = s->placement.origin_xz + rel * old_scale;
    s->placement.origin_xz += d_old - d_new;
  }
  for (auto& a : arm_poles_) a.drawn_radius_m = 0;  // measured on the old body
}

void MotionPlayer::sample(const Source& s, MkmFrame& out) const { Playback{*db_, stride_scale_, eased_}.sample(s, out); }

void MotionPlayer::sample_frame(const Source& s, int frame, MkmFrame& out) const {
  // A strike source at one of its own frames: the frame itself, no blend (s.loop is false).
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(s.segment)];
  MkmFrame f = seg.frames[static_cast<std::size_t>(std::clamp(frame, 0, seg.frame_count() - 1))];
  Playback{*db_, stride_scale_, eased_}.place_sample(s, seg, frame * seg.frame_time_s, f, out);
}

Vector3d MotionPlayer::frame_ankle(const Source& s, const Eigen::Quaterniond& placement_rotation, int frame, const Rig& rig, int side,
                                   const Vector3d& hip_local) const {
  return Playback{*db_, stride_scale_, eased_}.frame_ankle(s, placement_rotation, frame, rig, side, hip_local);
}

void MotionPlayer::compose(const Source& cur, const Source& prev, double blend_elapsed_s, double blend_time_s, MkmFrame& cur_pose,
                           MkmFrame& out) const {
  Playback{*db_, stride_scale_, eased_}.compose(cur, prev, blend_elapsed_s, blend_time_s, cur_pose, out);
}

void MotionPlayer::compose_update(double dt, double blend_time_s, const Morphology& m, MkmFrame& cur_pose, MkmFrame& out) {
  Playback{*db_, stride_scale_, eased_}.compose(current_, previous_, blend_elapsed_s_, blend_time_s, cur_pose, out, &pole_turns_);
  // A folded arm's elbow swings no farther than the source's (limit_folded_pole_turn).
  for (int side = 0; side < 2; ++side)
    out.arm_pole[side] = limit_folded_pole_turn(arm_poles_[static_cast<std::size_t>(side)], out.arm_pole[side], out.arm_n[side],
                                                m.upper_arm_m[side], m.forearm_m[side], dt);
}

void MotionPlayer::note_drawn_arms(const Rig& rig, std::span<const Vector3d> drawn) {
  for (int side = 0; side < 2; ++side) {
    const auto idx = [&](CJ j) { return drawn[static_cast<std::size_t>(rig.skeleton.index(j))]; };
    const Vector3d sh = idx(side == kLeft ? CJ::l_shoulder : CJ::r_shoulder);
    const Vector3d el = idx(side == kLeft ? CJ::l_elbow : CJ::r_elbow);
    const Vector3d wr = idx(side == kLeft ? CJ::l_wrist : CJ::r_wrist);
    const Vector3d axis = wr - sh;
    arm_poles_[static_cast<std::size_t>(side)].drawn_radius_m = axis.norm() > 1e-9 ? (el - sh).cross(axis).norm() / axis.norm() : 0.0;
  }
}

// ---- Behaviour's sources ---------------------------------------------------------------

void Behaviour::start_rest(Timestamp, int segment) {
  if (segment < 0) segment = rest_segment_;
  const MotionSegment& rest = db_->segments[static_cast<std::size_t>(segment)];
  if (have_pose_) spot_xz_m_ = pose_.root_xz_m;
  Source next;
  next.segment = segment;
  next.loop = true;
  next.anchor_xz_m = rest.frames[0].root_xz_m;
  next.placement.origin_xz = spot_xz_m_;
  rest_yaw_rad_ = 0;
  next.placement.yaw_rad = wrap(facing_rad_ - ground_frame_of(rest.frames[0]).yaw_rad);
  player_.play(next);
}

int Behaviour::align_to_support_foot(Source& s, double contact_time_s, const HeldFeet& feet, StrikeFit* redirect) const {
  // The clip is placed by its pelvis; shift it on the floor so that its support foot (planted
  // at the start and staying down longest) lands where that foot is held now: the motion then
  // swings its other foot and moves its body around a foot that does not have to move, as in
  // the mocap, instead of dragging a held foot the clip has elsewhere out of the leg's reach.
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(s.segment)];
  const int n = seg.frame_count();
  const int first = std::clamp(static_cast<int>(std::lround(s.time_s / seg.frame_time_s)), 0, n - 1);
  const int contact = std::clamp(static_cast<int>(std::lround(contact_time_s / seg.frame_time_s)), first, n - 1);
  const auto run_from_start = [&](int side) {
    int run = 0;
    for (int k = first; k < n && clip_planted(seg, k, side); ++k) ++run;
    return run;
  };
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  // How far (m, x/z) the clip must move for `side`'s ankle at clip frame `frame` to stand where
  // that foot is drawn now.
  const auto wanted = [&](int side, int frame) {
    Source at_frame = s;
    at_frame.time_s = frame * seg.frame_time_s;
    MkmFrame placed;
    player_.sample(at_frame, placed);
    CanonicalPose& c = scratch_pose_;  // its room kept: a strike's start allocates nothing
    decode_canonical(rig, placed, c);
    const Vector3d& a = at(c, side == kLeft ? CJ::l_ankle : CJ::r_ankle);
    const Vector3d& held = feet.ankle_m[static_cast<std::size_t>(side)];
    return Vector2d(held.x() - a.x(), held.z() - a.z());
  };
  const double limit = tun_.max_support_shift_m;
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
  const bool redirected = redirect != nullptr && redirect->redirect_support >= 0;
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
    for (int side = 0; side < 2 && landing_support < 0; ++side) {
      if (!feet.stepping[static_cast<std::size_t>(side)] || !clip_planted(seg, contact, side)) continue;
      const Vector2d want = wanted(side, planted_since(seg, side, first, contact));
      if (want.norm() <= limit + kLandingSupportSlack_m) {
        best = side;
        landing_support = side;
        shift = want;
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
  const bool lunge = strike_travel(s, contact_time_s, contact_pose).norm() >= tun_.min_scaled_travel_m;
  if (strike_target_ && !lunge && landing_support < 0 && !redirected) {
    Vector2d dir(strike_target_->x() - s.placement.origin_xz.x(), strike_target_->z() - s.placement.origin_xz.y());
    if (dir.norm() > 1e-6) {
      dir.normalize();
      const double along = shift.dot(dir);
      shift -= std::min(along, 0.0) * dir;
    }
  }
  if (shift.norm() > limit) shift *= limit / shift.norm();
  s.placement.origin_xz += shift;
  return landing_support;
}

Vector2d Behaviour::strike_travel(const Source& s, double contact_time_s, MkmFrame& contact_pose) const {
  Source at_contact = s;
  at_contact.time_s = contact_time_s;
  MkmFrame start_pose;
  player_.sample(s, start_pose);
  player_.sample(at_contact, contact_pose);
  return contact_pose.root_xz_m - start_pose.root_xz_m;
}

Behaviour::StrikeFit Behaviour::place_strike_travel(Source& s, double contact_time_s, const HeldFeet& feet) const {
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
  s.travel = Source::Travel{};
  if (!strike_target_) return {};
  Vector2d dir(strike_target_->x() - s.placement.origin_xz.x(), strike_target_->z() - s.placement.origin_xz.y());
  if (dir.norm() < 1e-6) return {};
  dir.normalize();
  s.travel.from_s = s.time_s;
  s.travel.contact_s = contact_time_s;
  s.travel.release_s = tun_.release_time_s;
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(s.segment)];
  const auto eff = seg.effector();
  if (!eff) return {};
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  MkmFrame contact_pose;
  const Vector2d travel2 = strike_travel(s, contact_time_s, contact_pose);
  const Vector3d target = *strike_target_;
  double k = 0;  // scale - 1
  const double leg = rig.morphology.leg_length_m;
  CanonicalPose& c = scratch_pose_;  // its room kept: a strike's start allocates nothing
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
    const double above = target.y() - limb_root.y() - reach * std::sin(tun_.max_punch_elevation_deg * std::numbers::pi / 180);
    const double rise = std::clamp(above, 0.0, std::min(room, tun_.max_strike_rise_m));
    s.travel.rise_n = rise / leg;
    limb_root.y() += rise;
  }
  if (travel2.norm() >= tun_.min_scaled_travel_m) {
    const Vector3d T(travel2.x(), 0, travel2.y());
    const Vector3d u = target - limb_root;
    // |u - k T| = reach, the root approaching from behind (the smaller k); when no k reaches
    // (a target far above or below), the k that comes closest.
    const double tt = T.squaredNorm(), ut = u.dot(T);
    const double disc = ut * ut - tt * (u.squaredNorm() - reach * reach);
    k = disc >= 0 ? (ut - std::sqrt(disc)) / tt : ut / tt;
    k = std::clamp(k, tun_.min_travel_scale - 1, tun_.max_travel_scale - 1);
    const double td = T.x() * dir.x() + T.z() * dir.y();
    if (td > 1e-6) {
      const double ahead = (Vector2d(target.x(), target.z()) - contact_pose.root_xz_m).dot(dir);
      k = std::min(k, (ahead - tun_.min_contact_distance_m) / td);
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
      const double r = allowed_leg_stretch(feet_.tunables().max_leg_stretch, clip_stretch) * leg_length;
      const double b = T.dot(d0), cc = d0.squaredNorm() - r * r;
      const double disc2 = b * b - tt * cc;
      k = std::min(k, disc2 >= 0 ? (-b + std::sqrt(disc2)) / tt : -b / tt);
    }
    k = std::max(k, tun_.min_travel_scale - 1);
    limb_root += k * T;
  } else {
    // No travel to scale: keep the pelvis short of the target by moving the clip back, at most
    // max_support_shift_m (as far as any placement shift goes: a target behind the fighter is
    // not a reason to slide the whole strike away from it).
    const double ahead = (Vector2d(target.x(), target.z()) - contact_pose.root_xz_m).dot(dir);
    if (ahead < tun_.min_contact_distance_m) {
      const double back = std::min(tun_.min_contact_distance_m - ahead, tun_.max_support_shift_m);
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
