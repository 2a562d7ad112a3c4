// A character switch's easing (switch_easing.hpp).
#include "kumite/content/switch_easing.hpp"

#include "behaviour_internal.hpp"
#include "kumite/content/canonical.hpp"
#include "kumite/content/mkm.hpp"

namespace kumite::content {

using behaviour_detail::smoothstep;
using Eigen::Vector3d;

SwitchEasing::SwitchEasing(std::size_t max_joints, double blend_time_s)
    : blend_time_s_(blend_time_s), offset_m_(max_joints, Vector3d::Zero()), old_drawn_m_(max_joints, Vector3d::Zero()) {}

void SwitchEasing::keep_drawn(const Rig& rig, std::span<const Vector3d> drawn_m) {
  const auto n = static_cast<std::size_t>(rig.joint_count());
  std::copy(drawn_m.begin(), drawn_m.begin() + static_cast<std::ptrdiff_t>(n), old_drawn_m_.begin());
  old_rig_ = &rig;
}

void SwitchEasing::ease(const Rig& rig, std::span<const Vector3d> rig_m, std::span<Vector3d> out_m) {
  const auto n = static_cast<std::size_t>(rig.joint_count());
  if (due_) {
    due_ = false;
    elapsed_s_ = 0;
    CanonicalPose old_c, new_c;
    if (old_rig_) {
      canonical_positions(old_rig_->skeleton,
                          std::span<const Vector3d>(old_drawn_m_).first(static_cast<std::size_t>(old_rig_->joint_count())), old_c);
    } else {
      canonical_positions(rig.skeleton, rig_m, old_c);
    }
    canonical_positions(rig.skeleton, rig_m, new_c);
    for (std::size_t i = 0; i < n; ++i) {
      // The nearest canonical joint at or above i carries its offset.
      int j = static_cast<int>(i);
      int cj = -1;
      while (j >= 0 && cj < 0) {
        for (std::size_t c = 0; c < kCanonicalJointCount; ++c)
          if (rig.skeleton.canonical[c] == j && old_c[c].allFinite()) { cj = static_cast<int>(c); break; }
        if (cj < 0) j = rig.skeleton.parents[static_cast<std::size_t>(j)];
      }
      offset_m_[i] = cj >= 0 ? Vector3d(old_c[static_cast<std::size_t>(cj)] - new_c[static_cast<std::size_t>(cj)]) : Vector3d::Zero();
    }
  }
  old_rig_ = nullptr;  // kept for this update's switch only
  const double fade = elapsed_s_ < blend_time_s_ ? 1 - smoothstep(elapsed_s_ / blend_time_s_) : 0.0;
  for (std::size_t i = 0; i < n; ++i) out_m[i] = rig_m[i] + offset_m_[i] * fade;
}

}  // namespace kumite::content
