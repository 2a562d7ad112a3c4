// Playing sources (the motion now and the one it fades from): sampling a segment at a time,
// placing it in the room, a strike's scaled floor travel and pelvis rise (Playback, and the
// MotionPlayer that owns Behaviour's sources); Behaviour's side: the rest motion started where
// the body is. A strike's clip placed on its support foot, its travel fitted: strike_placement.cpp.
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

}  // namespace kumite::content
