#pragma once
// Behaviour's own helpers, shared by its three files (content/src, not installed):
//   behaviour.cpp        decisions: orders, the state machine, strikes, following, contact
//   motion_playback.cpp  playing sources: sampling, placement, a strike's scaled travel
//   behaviour_feet.cpp   what the motion says of each foot, for the FootPlanter
#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include <Eigen/Core>

#include "kumite/content/behaviour.hpp"

namespace kumite::content::behaviour_detail {

using Eigen::Vector2d;

inline double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
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


}  // namespace kumite::content::behaviour_detail
