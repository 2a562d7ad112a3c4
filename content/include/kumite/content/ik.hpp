#pragma once
// Inverse kinematics used by adaptation: analytic two-bone IK with a pole (swivel) direction,
// and a CCD fallback over a short chain of trunk joints for when the limb alone cannot reach.
// Everything is allocation-free and works on caller-provided values (m, rad).
#include <algorithm>
#include <array>
#include <cmath>
#include <span>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace kumite::content {

struct TwoBoneResult {
  Eigen::Vector3d middle;  ///< m, elbow / knee
  Eigen::Vector3d end;     ///< m, wrist / ankle actually reached (== target when reachable)
  bool reached = true;     ///< false when the target lies beyond l1 + l2 (or inside |l1 - l2|)
};

/// Where the middle joint (elbow / knee) of a root(l1)-middle(l2)-end limb sits when its ends
/// are `d` apart (m, > 0; within [|l1 - l2|, l1 + l2], else `off_m` is 0 beyond full length):
/// `along_m` along the root->end line from the root, `off_m` off that line (the radius its
/// pole turns it round).
struct TwoBoneBend {
  double along_m = 0, off_m = 0;
};
inline TwoBoneBend two_bone_bend(double l1, double l2, double d) {
  const double a = (l1 * l1 - l2 * l2 + d * d) / (2 * d);
  return {a, std::sqrt(std::max(0.0, l1 * l1 - a * a))};
}

/// Places the middle joint of root(l1)-middle(l2)-end so that end == target when
/// |target - root| lies in [|l1 - l2|, l1 + l2]; otherwise end is the nearest reachable
/// point on the root->target line. `pole_unit` (perpendicular to root->target) says where
/// the middle joint bends.
TwoBoneResult solve_two_bone(const Eigen::Vector3d& root, const Eigen::Vector3d& target, double l1,
                             double l2, const Eigen::Vector3d& pole_unit);
/// The same with a soft end of reach (m, 0 = hard): a target within `softness_m` of full
/// extension or beyond is reached at root + axis * (L - s + s * (1 - exp(-(d - (L - s)) / s)))
/// (L = l1 + l2, s = softness_m), so the limb straightens smoothly as its target goes out of
/// reach instead of its middle joint moving centimetres for the last millimetres (the knee
/// "pop" of two-bone IK). The end then falls short of the target by at most s;
/// `reached` still says whether the target lies within l1 + l2.
TwoBoneResult solve_two_bone_soft(const Eigen::Vector3d& root, const Eigen::Vector3d& target, double l1,
                                  double l2, const Eigen::Vector3d& pole_unit, double softness_m);

/// The smallest rotation taking direction `from` onto `to` (neither need be unit).
Eigen::Quaterniond swing_between(const Eigen::Vector3d& from, const Eigen::Vector3d& to);

/// The angle (rad, 0..pi) a unit quaternion turns about its own axis, either sign of it.
double rotation_angle_rad(const Eigen::Quaterniond& q);
/// Limits a rotation to at most `max_angle_rad` about its own axis.
Eigen::Quaterniond clamp_angle(const Eigen::Quaterniond& q, double max_angle_rad);

/// CCD over a chain of up to 4 pivots that carry a limb root (e.g. spine, chest, clavicle ->
/// shoulder). Moves the limb root toward the ball of radius `reach_m` around `target`,
/// rotating each pivot (last first) by at most its limit in total. Outputs one world-frame
/// delta rotation per pivot (to apply about that pivot, parents first). Returns true when the
/// limb root ends within reach.
struct CcdChain {
  std::array<Eigen::Vector3d, 4> pivots;  ///< m, world positions, parents first
  std::array<double, 4> limit_rad{};      ///< total rotation allowed per pivot
  int count = 0;
  Eigen::Vector3d limb_root;              ///< m, e.g. shoulder
};
bool solve_ccd_reach(const CcdChain& chain, const Eigen::Vector3d& target, double reach_m,
                     int iterations, std::array<Eigen::Quaterniond, 4>& deltas);

}  // namespace kumite::content
