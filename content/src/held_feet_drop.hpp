#pragma once
// The pelvis drop the held feet ask for (internal to content): AdaptJob lowers the pelvis by it
// (adaptation.cpp), Feet::bound_drop estimates it before the decode (feet.cpp).
#include <algorithm>
#include <cmath>
#include <cstddef>

#include <Eigen/Core>

#include "kumite/content/adaptation.hpp"

namespace kumite::content {

/// m: how far the pelvis must come down for each supporting held foot of `locks` to be within
/// `leg_share` of its leg's length from its hip (`hip_of(side)`, m, room): held feet the legs
/// cannot reach ask for a knee bend rather than slide. Each foot asks for its drop times its
/// hold weight, so the drop is continuous in the inputs (a foot being released lets the pelvis
/// up smoothly); a foot further out than the leg reaches asks for the whole hip height (the
/// need grows continuously to it; the caller's cap keeps it a knee bend).
template <class HipOf>
double held_feet_drop(const FootLocks& locks, const Morphology& m, double leg_share, const HipOf& hip_of) {
  double drop = 0;
  for (int s = 0; s < 2; ++s) {
    const auto us = static_cast<std::size_t>(s);
    const double w = std::clamp(locks.weight[us], 0.0, 1.0);
    if (w <= 0 || !locks.supporting[us]) continue;
    const Eigen::Vector3d d = locks.ankle_m[us] - hip_of(s);
    const double l = m.limb_leg_length(s) * leg_share;
    const double h2 = d.x() * d.x() + d.z() * d.z();
    if (d.squaredNorm() <= l * l) continue;
    const double need = -d.y() - std::sqrt(std::max(0.0, l * l - h2));
    drop = std::max(drop, w * need);
  }
  return drop;
}

}  // namespace kumite::content
