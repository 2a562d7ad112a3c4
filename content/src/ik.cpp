#include "kumite/content/ik.hpp"

#include <algorithm>
#include <cmath>

namespace kumite::content {

TwoBoneResult solve_two_bone(const Eigen::Vector3d& root, const Eigen::Vector3d& target, double l1,
                             double l2, const Eigen::Vector3d& pole_unit) {
  TwoBoneResult r;
  Eigen::Vector3d axis = target - root;
  double d = axis.norm();
  if (d < 1e-12) {
    // Degenerate: target on the root. Fold the limb along the pole.
    axis = pole_unit.unitOrthogonal();
    d = 0;
  } else {
    axis /= d;
  }
  // Keep a hair short of full extension so the middle joint stays defined (1e-9 m).
  const double d_max = l1 + l2 - 1e-9;
  const double d_min = std::abs(l1 - l2) + 1e-9;
  const double dc = std::clamp(d, d_min, d_max);
  r.reached = (d <= l1 + l2 + 1e-9) && (d >= std::abs(l1 - l2) - 1e-9);
  const TwoBoneBend bend = two_bone_bend(l1, l2, dc);
  r.middle = root + axis * bend.along_m + pole_unit * bend.off_m;
  r.end = r.reached ? target : Eigen::Vector3d(root + axis * dc);
  return r;
}

TwoBoneResult solve_two_bone_soft(const Eigen::Vector3d& root, const Eigen::Vector3d& target, double l1,
                                  double l2, const Eigen::Vector3d& pole_unit, double softness_m) {
  const double full = l1 + l2;
  const double s = std::clamp(softness_m, 0.0, 0.5 * full);
  const Eigen::Vector3d v = target - root;
  const double d = v.norm();
  if (s <= 0 || d <= full - s || d < 1e-12) return solve_two_bone(root, target, l1, l2, pole_unit);
  const double soft = full - s + s * (1 - std::exp(-(d - (full - s)) / s));
  TwoBoneResult r = solve_two_bone(root, root + v * (soft / d), l1, l2, pole_unit);
  r.reached = d <= full + 1e-9;
  return r;
}

Eigen::Quaterniond swing_between(const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
  return Eigen::Quaterniond::FromTwoVectors(from, to);
}

double rotation_angle_rad(const Eigen::Quaterniond& q) { return 2 * std::acos(std::min(1.0, std::abs(q.w()))); }

Eigen::Quaterniond clamp_angle(const Eigen::Quaterniond& q_in, double max_angle_rad) {
  Eigen::Quaterniond q = q_in.w() < 0 ? Eigen::Quaterniond(-q_in.coeffs()) : q_in;
  const double angle = rotation_angle_rad(q);
  if (angle <= max_angle_rad || angle < 1e-12) return q;
  const Eigen::Vector3d axis = q.vec().normalized();
  return Eigen::Quaterniond(Eigen::AngleAxisd(max_angle_rad, axis));
}

namespace {
// Position of x after the pivots [first, last) rotate it, innermost (last) first.
Eigen::Vector3d apply_pivots(const CcdChain& c, const std::array<Eigen::Quaterniond, 4>& d, int first,
                             int last, Eigen::Vector3d x) {
  for (int k = last - 1; k >= first; --k) x = c.pivots[k] + d[k] * (x - c.pivots[k]);
  return x;
}
}  // namespace

bool solve_ccd_reach(const CcdChain& chain, const Eigen::Vector3d& target, double reach_m,
                     int iterations, std::array<Eigen::Quaterniond, 4>& deltas) {
  for (auto& q : deltas) q.setIdentity();
  for (int it = 0; it < iterations; ++it) {
    for (int k = chain.count - 1; k >= 0; --k) {
      const Eigen::Vector3d s = apply_pivots(chain, deltas, 0, chain.count, chain.limb_root);
      const Eigen::Vector3d to_s = s - target;
      const double dist = to_s.norm();
      if (dist <= reach_m) return true;
      // Aim a little inside the reach ball (0.2 %) so CCD does not crawl toward its surface.
      const Eigen::Vector3d goal = target + to_s * (0.998 * reach_m / dist);
      const Eigen::Vector3d pk = apply_pivots(chain, deltas, 0, k, chain.pivots[k]);
      const Eigen::Quaterniond q = swing_between(s - pk, goal - pk);
      // Express q (about the moved pivot, in current coordinates) in the original
      // coordinates of pivot k: conjugate by the parents' rotation.
      Eigen::Quaterniond parents = Eigen::Quaterniond::Identity();
      for (int j = 0; j < k; ++j) parents = parents * deltas[j];
      const Eigen::Quaterniond local = parents.conjugate() * q * parents;
      deltas[k] = clamp_angle((local * deltas[k]).normalized(), chain.limit_rad[k]);
    }
  }
  const Eigen::Vector3d s = apply_pivots(chain, deltas, 0, chain.count, chain.limb_root);
  return (s - target).norm() <= reach_m + 1e-9;
}

}  // namespace kumite::content
