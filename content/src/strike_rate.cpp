// StrikeRateSolver: how much slower a strike is played so that its correction (d(t), a scaled
// lunge, a raised pelvis) does not move its hit point faster than max_strike_speed_ratio times
// the source clip's own peak speed. Runs on the Fighter's retrieval worker (or between updates
// in the tools) over a copy of the strike's start state: nothing of Behaviour is shared but the
// database and the character, both immutable.
#include <algorithm>
#include <chrono>
#include <cmath>

#include "behaviour_internal.hpp"
#include "kumite/content/behaviour.hpp"

namespace kumite::content {

using namespace behaviour_detail;
using Eigen::Vector3d;

StrikeRateSolver::StrikeRateSolver(std::shared_ptr<const Database> db, const BehaviourTunables& tunables)
    : db_(std::move(db)), tun_(tunables) {
  eased_.cum.reserve(256);  // a release of 0.25 s holds ~32 frames
  speeds_.reserve(8192);    // ~40 joints x ~2 s of way at 60 Hz
}

StrikeRateResult StrikeRateSolver::solve(const StrikeRateJob& job) {
  // The hit point's way as it will be drawn (the blend out of the previous motion, the strike
  // with its scaled travel and d(t) ramped as Behaviour::update() ramps them, decoded on the
  // character) beside the source clip's own hit path scaled to the character, from the strike
  // start to the end of d(t)'s release, both sampled at 60 Hz. The strike plays job.lead_s at
  // the clip's own rate before the rate applies (kStrikeRateDelayUpdates). When the drawn peak
  // speed exceeds max_strike_speed_ratio times the source's, the strike is played slower
  // (refined twice: the blend runs in wall time, so the drawn speed is not quite proportional
  // to the rate).
  const auto t_start = std::chrono::steady_clock::now();
  StrikeRateResult result;
  result.id = job.id;
  const auto done = [&](double rate) {
    result.rate = rate;
    result.solve_us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t_start).count();
    return result;
  };
  if (tun_.min_strike_rate >= 1 || !job.rig || job.current.segment < 0 ||
      job.current.segment >= static_cast<int>(db_->segments.size()))
    return done(1);
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(job.current.segment)];
  if (seg.hit_path_m.size() != seg.frames.size() || seg.frame_count() < 2) return done(1);
  constexpr double h = 1.0 / 60;  // s between samples
  const int first = std::clamp(static_cast<int>(std::lround(job.start_time_s / seg.frame_time_s)), 0, seg.frame_count() - 1);
  const int last = std::clamp(static_cast<int>(std::lround(job.release_end_s / seg.frame_time_s)), first, seg.frame_count() - 1);
  const auto path_at = [&](double t) {
    const auto [i0, a] = frame_pair(seg, t);
    return Vector3d(((1 - a) * seg.hit_path_m[i0] + a * seg.hit_path_m[i0 + 1]).cast<double>());
  };
  double src_peak = 0;
  for (double t = first * seg.frame_time_s + h; t <= last * seg.frame_time_s + 1e-9; t += h)
    src_peak = std::max(src_peak, (path_at(t) - path_at(t - h)).norm() / h);
  src_peak *= job.stride_scale;
  if (!(src_peak > 1e-9)) return done(1);

  const Rig& rig = *job.rig;
  const auto n = static_cast<std::size_t>(rig.joint_count());
  if (local_.size() < n) {
    local_.resize(n);
    global_.resize(n);
    positions_.resize(n);
  }
  const auto effector = static_cast<std::size_t>(rig.skeleton.index(job.effector.joint()));
  if (last_positions_.size() < n) last_positions_.resize(n);
  // The striking limb's joints: the limb's root (shoulder or hip) and everything below it.
  const int limb_root = rig.skeleton.index(job.effector.leg ? (job.effector.side == kLeft ? CanonicalJoint::l_hip : CanonicalJoint::r_hip)
                                                            : (job.effector.side == kLeft ? CanonicalJoint::l_shoulder : CanonicalJoint::r_shoulder));
  in_limb_.assign(n, 0);
  for (std::size_t j = 0; j < n; ++j) {
    const int p = rig.skeleton.parents[j];
    in_limb_[j] = static_cast<int>(j) == limb_root || (p >= 0 && in_limb_[static_cast<std::size_t>(p)]);
  }
  const Playback play{*db_, job.stride_scale, eased_};
  // Peak speeds over the way, sampled every h: the hit point's, and the striking limb's fastest
  // joint's (a toe, a finger: the limb's end swings faster than the hit point when d(t) turns
  // the limb about its root). Negative: the decode failed.
  // And the p99 of every joint's speed over the way (the figure the motion-quality check holds
  // each strike to beside its source): a joint turned faster than its own source while the
  // limb's fastest stays within its bound (the knee of a kick aimed higher than captured).
  struct Peaks {
    double effector = 0, limb = 0, p99 = 0;  ///< m/s
  };
  const auto decode_peaks = [&](PlaybackSource cur, PlaybackSource prev, double rate, bool drawn) {
    cur.rate = rate;
    const double t0 = job.current.time_s, p0 = job.previous.time_s;
    Peaks peaks;
    MkmFrame b, pose;
    PoleTurns turns = job.pole_turns;  // carried through the way as the drawn updates carry them
    speeds_.clear();
    for (int k = 0;; ++k) {
      const double w = k * h;
      // The clip's own rate for the lead, then `rate`.
      cur.time_s = t0 + std::min(w, job.lead_s) + rate * std::max(0.0, w - job.lead_s);
      if (cur.time_s > job.release_end_s + 1e-9) break;
      prev.time_s = p0 + prev.rate * w;
      // The source alone (no blend from the motion before, no d(t)), or as it will be drawn.
      play.compose(cur, prev, drawn ? job.blend_elapsed_s + w : tun_.blend_time_s, tun_.blend_time_s, b, pose,
                   drawn ? &turns : nullptr);
      const double t = cur.time_s;
      const ReachGoal goal = reach_goal_at(job.effector, job.turn, job.stretch,
                                           t <= job.contact_time_s ? reach_ramp_in(job.start_time_s, job.contact_time_s, t)
                                                                   : reach_ramp_out(job.contact_time_s, job.release_end_s, t));
      AdaptJob adapt;
      adapt.rig = &rig;
      adapt.pose = &pose;
      adapt.reach = drawn ? &goal : nullptr;
      adapt.local_rotations = std::span(local_).first(n);
      adapt.global_rotations = std::span(global_).first(n);
      adapt.global_positions = std::span(positions_).first(n);
      if (!adapt.Run()) return Peaks{-1, -1};
      if (k > 0) {
        peaks.effector = std::max(peaks.effector, (positions_[effector] - last_positions_[effector]).norm() / h);
        for (std::size_t j = 0; j < n; ++j) {
          const double v = (positions_[j] - last_positions_[j]).norm() / h;
          if (in_limb_[j]) peaks.limb = std::max(peaks.limb, v);
          speeds_.push_back(v);
        }
      }
      std::copy_n(positions_.begin(), n, last_positions_.begin());
    }
    if (!speeds_.empty()) {
      const auto at = speeds_.begin() + static_cast<std::ptrdiff_t>(0.99 * static_cast<double>(speeds_.size() - 1));
      std::nth_element(speeds_.begin(), at, speeds_.end());
      peaks.p99 = *at;
    }
    return peaks;
  };
  // The source's own limb over the same segment frames at the clip's rate, decoded on the
  // character (its size), its travel as captured.
  PlaybackSource plain = job.current;
  plain.travel = {};
  const Peaks src = decode_peaks(plain, job.previous, 1.0, false);
  const double src_limb_peak = src.limb;
  if (src_limb_peak < 0) return done(1);
  double rate = 1;
  for (int refine = 0; refine < 2; ++refine) {
    const Peaks peaks = decode_peaks(job.current, job.previous, rate, true);
    if (peaks.effector < 0) return done(1);
    // The slowest of the rates that bring each peak within max_strike_speed_ratio.
    double want = 1;
    if (peaks.effector > tun_.max_strike_speed_ratio * src_peak) want = tun_.max_strike_speed_ratio * src_peak / peaks.effector;
    // The limb's fastest joint against the source limb's fastest (per joint, a joint turned
    // faster than its source's, e.g. the knee of a kick aimed higher, slowed most strikes of the
    // grid to min_strike_rate: played slower than their mocap, p99 joint speed / source p50 0.85).
    if (src_limb_peak > 1e-9 && peaks.limb > tun_.max_strike_speed_ratio * src_limb_peak)
      want = std::min(want, tun_.max_strike_speed_ratio * src_limb_peak / peaks.limb);
    if (src.p99 > 1e-9 && peaks.p99 > tun_.max_strike_speed_ratio * src.p99)
      want = std::min(want, tun_.max_strike_speed_ratio * src.p99 / peaks.p99);
    if (!(want < 1)) break;
    const double next = std::clamp(rate * want, tun_.min_strike_rate, 1.0);
    if (next >= rate) break;
    rate = next;
  }
  if (rate < 1) {
    // d(t) at contact at this rate, found as Behaviour::compute_reach_error() finds it on the
    // update the rate enters on (job.lead_s after the start at the clip's own rate), with the
    // same operations in the same order: the same numbers.
    PlaybackSource cur = job.current, prev = job.previous;
    cur.time_s += job.lead_s * 1.0;
    prev.time_s += job.lead_s * prev.rate;
    const double blend_elapsed_s = job.blend_elapsed_s + job.lead_s;
    cur.rate = rate;
    const double ahead = contact_frame_time(cur.time_s, job.clip_contact_time_s, job.frame_dt_s * rate) - cur.time_s;
    const double ahead_wall = ahead / cur.rate;
    cur.time_s += ahead;
    prev.time_s += ahead_wall * prev.rate;
    MkmFrame b, pose;
    play.compose(cur, prev, blend_elapsed_s + ahead_wall, tun_.blend_time_s, b, pose);
    const ReachCorrection r = reach_correction(rig, job.effector, job.target_room_m, pose, canonical_, true, &job.plan_feet,
                                               job.plan_lowest_shoulder_y_m);
    result.has_reach = true;
    result.error_m = r.error_m;
    result.turn = r.turn;
    result.stretch = r.stretch;
    result.lean = r.lean;
    result.root_drop_m = r.root_drop_m;
    result.elbow_under_head_m = r.elbow_under_head_m;
  }
  return done(rate);
}

}  // namespace kumite::content
