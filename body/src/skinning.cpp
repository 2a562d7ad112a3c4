// Rest transforms and linear blend skinning on the CPU (the reference the GPU path is checked
// against).
#include <cassert>

#include "kumite/body/model.hpp"

namespace kumite::body {

void rest_globals(const ModelSkeleton& s, std::span<Eigen::Matrix4d> out) {
  const std::size_t n = s.names.size();
  assert(out.size() >= n);
  for (std::size_t j = 0; j < n; ++j) {
    Eigen::Matrix4d l = Eigen::Matrix4d::Identity();
    l.topLeftCorner<3, 3>() = s.rest_rotations[j].toRotationMatrix() * s.rest_scales[j].asDiagonal();
    l.topRightCorner<3, 1>() = s.rest_translations[j];
    const int p = s.parents[j];
    out[j] = (p < 0 ? s.top_parent_globals[j] : out[static_cast<std::size_t>(p)]) * l;
  }
}

void rest_palette(const SkinnedModel& model, std::span<Eigen::Matrix4f> palette) {
  const auto& s = model.skeleton;
  const std::size_t n = s.names.size();
  assert(palette.size() >= n && n <= static_cast<std::size_t>(kMaxJoints));
  std::array<Eigen::Matrix4d, kMaxJoints> g;
  rest_globals(s, std::span<Eigen::Matrix4d>(g.data(), n));
  for (std::size_t j = 0; j < n; ++j) palette[j] = (g[j] * s.inverse_bind[j]).cast<float>();
}

void skin_cpu(const SkinnedModel& model, std::span<const Eigen::Matrix4f> palette,
              std::span<Eigen::Vector3f> positions, std::span<Eigen::Vector3f> normals) {
  const std::size_t n = model.vertex_count();
  assert(positions.size() >= n && normals.size() >= n);
  for (std::size_t v = 0; v < n; ++v) {
    Eigen::Matrix4f m = Eigen::Matrix4f::Zero();
    for (std::size_t i = 0; i < 4; ++i) {
      const float w = model.weights[v][i];
      if (w != 0.f) m += w * palette[model.joints[v][i]];
    }
    positions[v] = m.topLeftCorner<3, 3>() * model.positions[v] + m.topRightCorner<3, 1>();
    Eigen::Vector3f nv = m.topLeftCorner<3, 3>() * model.normals[v];
    const float len = nv.norm();
    normals[v] = len > 1e-12f ? Eigen::Vector3f(nv / len) : nv;
  }
}

}  // namespace kumite::body
