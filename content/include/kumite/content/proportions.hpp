#pragma once
// Body proportions measured from a skeleton's rest pose (its BVH offsets), in metres.
// Limb lengths are summed along the bones (pose-independent); widths and heights are taken
// in the rest pose. Needs Skeleton::canonical (see canonical.hpp).
#include "kumite/content/skeleton.hpp"

namespace kumite::content {

struct Proportions {
  double stature_m = 0;         ///< m, rest pose: highest minus lowest joint along +Y (incl. end sites)
  /// m, height if standing straight: spine chain pelvis -> head top + pelvis-to-hip drop +
  /// thigh + shin + ankle height (CMU rest poses splay the legs, so this exceeds stature_m
  /// by about 5 %).
  double standing_height_m = 0;
  double upper_arm_m = 0;       ///< m, shoulder -> elbow, mean of left and right
  double forearm_m = 0;         ///< m, elbow -> wrist, mean of left and right
  double arm_m = 0;             ///< m, shoulder -> wrist along the bones (upper arm + forearm)
  double thigh_m = 0;           ///< m, hip -> knee, mean of left and right
  double shin_m = 0;            ///< m, knee -> ankle, mean of left and right
  double leg_m = 0;             ///< m, hip -> ankle along the bones (thigh + shin)
  double torso_m = 0;           ///< m, pelvis -> neck (head when no neck) along the spine bones
  double shoulder_width_m = 0;  ///< m, left to right shoulder joint at rest
  double hip_width_m = 0;       ///< m, left to right hip joint at rest
  double pelvis_height_m = 0;   ///< m, pelvis above the lowest joint at rest

  double arm_ratio() const { return arm_m / stature_m; }      ///< arm / stature (1)
  double leg_ratio() const { return leg_m / stature_m; }      ///< leg / stature (1)
  double torso_ratio() const { return torso_m / stature_m; }  ///< torso / stature (1)
};

/// Throws kumite::Error (component "skeleton") when the canonical core joints are missing.
Proportions measure_proportions(const Skeleton& skeleton);

/// Rest-pose global joint positions (m): every rotation identity, root at the root offset.
std::vector<Eigen::Vector3d> rest_positions(const Skeleton& skeleton);

/// Length (m) along the bones from `ancestor` down to `descendant`; the straight rest-pose
/// distance when `ancestor` is not an ancestor of `descendant`.
double chain_length(const Skeleton& skeleton, int ancestor, int descendant);

}  // namespace kumite::content
