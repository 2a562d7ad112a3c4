#include "kumite/content/mirror.hpp"

#include <fmt/format.h>

#include "kumite/common/error.hpp"
#include "kumite/content/canonical.hpp"
#include "kumite/content/proportions.hpp"

namespace kumite::content {

int lateral_axis(const Skeleton& s) {
  using CJ = CanonicalJoint;
  const auto rest = rest_positions(s);
  Eigen::Vector3d d = Eigen::Vector3d::Zero();
  for (auto [l, r] : {std::pair{CJ::l_hip, CJ::r_hip}, {CJ::l_shoulder, CJ::r_shoulder}}) {
    const int li = s.index(l), ri = s.index(r);
    if (li >= 0 && ri >= 0 && li < s.joint_count() && ri < s.joint_count()) {
      d += rest[static_cast<std::size_t>(li)] - rest[static_cast<std::size_t>(ri)];
    }
  }
  if (d.norm() == 0) throw Error("skeleton", "canonical", "lateral_axis: no left/right hips or shoulders mapped");
  int axis = 0;
  d.cwiseAbs().maxCoeff(&axis);
  return axis;
}

std::vector<int> mirror_map(const Skeleton& s) {
  std::vector<int> m(s.names.size());
  for (int i = 0; i < s.joint_count(); ++i) m[static_cast<std::size_t>(i)] = mirror_partner(s, i);
  for (int i = 0; i < s.joint_count(); ++i) {
    const int p = m[static_cast<std::size_t>(i)];
    const int parent = s.parents[static_cast<std::size_t>(i)];
    const int parent_of_partner = s.parents[static_cast<std::size_t>(p)];
    const int partner_of_parent = parent < 0 ? -1 : m[static_cast<std::size_t>(parent)];
    if (m[static_cast<std::size_t>(p)] != i || parent_of_partner != partner_of_parent) {
      throw Error("skeleton", "mirror",
                  fmt::format("mirror: joints '{}' and '{}' are not a symmetric pair in the hierarchy",
                              s.names[static_cast<std::size_t>(i)], s.names[static_cast<std::size_t>(p)]));
    }
  }
  return m;
}

Clip mirror_clip(const Clip& clip) {
  const Skeleton& s = clip.skeleton;
  const int axis = lateral_axis(s);
  const std::vector<int> partner = mirror_map(s);
  Eigen::Vector3d flip = Eigen::Vector3d::Ones();
  flip[axis] = -1;
  auto reflect = [&](const Eigen::Vector3d& v) -> Eigen::Vector3d { return v.cwiseProduct(flip); };
  // M R M for the reflection M: a rotation about u by t becomes one about -M u by t, i.e. the
  // quaternion keeps w and its component along the axis and negates the other two.
  auto reflect_q = [&](const Eigen::Quaterniond& q) {
    Eigen::Vector3d v = -q.vec().cwiseProduct(flip);
    return Eigen::Quaterniond(q.w(), v.x(), v.y(), v.z());
  };
  Clip out = clip;
  out.name = clip.name + "_mirror";
  const auto n = static_cast<std::size_t>(s.joint_count());
  for (std::size_t j = 0; j < n; ++j) out.skeleton.offsets[j] = reflect(s.offsets[static_cast<std::size_t>(partner[j])]);
  for (std::size_t f = 0; f < static_cast<std::size_t>(clip.frame_count); ++f) {
    out.root_positions[f] = reflect(clip.root_positions[f]);
    for (std::size_t j = 0; j < n; ++j) {
      const std::size_t src = f * n + static_cast<std::size_t>(partner[j]);
      out.local_rotations[f * n + j] = reflect_q(clip.local_rotations[src]);
      if (!clip.local_translations.empty()) out.local_translations[f * n + j] = reflect(clip.local_translations[src]);
    }
  }
  return out;
}

}  // namespace kumite::content
