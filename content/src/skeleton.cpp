#include "kumite/content/skeleton.hpp"

#include <cassert>
#include <cmath>

#include <fmt/format.h>

#include "kumite/common/error.hpp"

namespace kumite::content {

namespace {
constexpr std::array<std::string_view, kCanonicalJointCount> kNames = {
    "pelvis",     "spine",      "chest",   "neck",    "head",
    "l_clavicle", "l_shoulder", "l_elbow", "l_wrist",
    "r_clavicle", "r_shoulder", "r_elbow", "r_wrist",
    "l_hip",      "l_knee",     "l_ankle", "l_toe",
    "r_hip",      "r_knee",     "r_ankle", "r_toe"};
}  // namespace

std::string_view to_string(CanonicalJoint j) {
  const auto i = static_cast<std::size_t>(j);
  return i < kNames.size() ? kNames[i] : "?";
}

std::optional<CanonicalJoint> canonical_joint_from_string(std::string_view name) {
  for (std::size_t i = 0; i < kNames.size(); ++i) {
    if (kNames[i] == name) return static_cast<CanonicalJoint>(i);
  }
  return std::nullopt;
}

int Skeleton::find(std::string_view name) const {
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) return static_cast<int>(i);
  }
  return -1;
}

void forward_kinematics(const Skeleton& skeleton, const Eigen::Vector3d& root_position,
                        std::span<const Eigen::Quaterniond> local_rotations,
                        std::span<Eigen::Vector3d> global_positions,
                        std::span<Eigen::Quaterniond> global_rotations) {
  const std::size_t n = skeleton.names.size();
  assert(local_rotations.size() >= n && global_positions.size() >= n && global_rotations.size() >= n);
  for (std::size_t i = 0; i < n; ++i) {
    const int p = skeleton.parents[i];
    if (p < 0) {
      global_positions[i] = root_position;
      global_rotations[i] = local_rotations[i];
    } else {
      global_positions[i] = global_positions[p] + global_rotations[p] * skeleton.offsets[i];
      global_rotations[i] = global_rotations[p] * local_rotations[i];
    }
  }
}

void forward_kinematics(const Clip& clip, int frame, std::span<Eigen::Vector3d> global_positions,
                        std::span<Eigen::Quaterniond> global_rotations) {
  const Skeleton& s = clip.skeleton;
  const auto n = static_cast<std::size_t>(s.joint_count());
  assert(frame >= 0 && frame < clip.frame_count);
  const auto local = clip.rotations(frame);
  if (clip.local_translations.empty()) {
    forward_kinematics(s, clip.root_positions[static_cast<std::size_t>(frame)], local,
                       global_positions, global_rotations);
    return;
  }
  const Eigen::Vector3d* t = clip.local_translations.data() + static_cast<std::size_t>(frame) * n;
  for (std::size_t i = 0; i < n; ++i) {
    const int p = s.parents[i];
    if (p < 0) {
      global_positions[i] = clip.root_positions[static_cast<std::size_t>(frame)];
      global_rotations[i] = local[i];
    } else {
      global_positions[i] = global_positions[p] + global_rotations[p] * t[i];
      global_rotations[i] = global_rotations[p] * local[i];
    }
  }
}

std::vector<Eigen::Vector3d> all_joint_positions(const Clip& clip) {
  const auto n = static_cast<std::size_t>(clip.skeleton.joint_count());
  std::vector<Eigen::Vector3d> out(n * static_cast<std::size_t>(clip.frame_count));
  std::vector<Eigen::Quaterniond> rot(n);
  for (int f = 0; f < clip.frame_count; ++f) {
    forward_kinematics(clip, f, std::span(out.data() + static_cast<std::size_t>(f) * n, n), rot);
  }
  return out;
}

Clip resample_clip(const Clip& clip, double frame_time_s) {
  if (!std::isfinite(frame_time_s) || !(frame_time_s > 0) || !(frame_time_s <= 10)) {
    throw Error("skeleton", "resample", fmt::format("frame time {} s must be finite, > 0 and at most 10 s", frame_time_s));
  }
  if (clip.frame_count < 1) throw Error("skeleton", "resample", fmt::format("clip '{}' has no frames", clip.name));
  const auto n = static_cast<std::size_t>(clip.skeleton.joint_count());
  const double duration = (clip.frame_count - 1) * clip.frame_time_s;
  const auto frames = static_cast<int>(std::floor(duration / frame_time_s + 1e-9 / frame_time_s)) + 1;
  Clip out = clip;
  out.frame_time_s = frame_time_s;
  out.frame_count = frames;
  out.root_positions.assign(static_cast<std::size_t>(frames), Eigen::Vector3d::Zero());
  out.local_rotations.assign(static_cast<std::size_t>(frames) * n, Eigen::Quaterniond::Identity());
  if (!clip.local_translations.empty()) out.local_translations.assign(static_cast<std::size_t>(frames) * n, Eigen::Vector3d::Zero());
  for (int k = 0; k < frames; ++k) {
    const double s = k * frame_time_s / clip.frame_time_s;  // in source frames
    int i = static_cast<int>(std::floor(s + 1e-9));
    double u = s - i;
    if (i >= clip.frame_count - 1) {
      i = clip.frame_count - 1;
      u = 0;
    }
    if (std::abs(u) < 1e-9) u = 0;
    const int j = u > 0 ? i + 1 : i;
    const auto fi = static_cast<std::size_t>(i), fj = static_cast<std::size_t>(j), fk = static_cast<std::size_t>(k);
    out.root_positions[fk] = (1 - u) * clip.root_positions[fi] + u * clip.root_positions[fj];
    for (std::size_t b = 0; b < n; ++b) {
      const Eigen::Quaterniond& qa = clip.local_rotations[fi * n + b];
      const Eigen::Quaterniond& qb = clip.local_rotations[fj * n + b];
      out.local_rotations[fk * n + b] = u > 0 ? qa.slerp(u, qb).normalized() : qa;
      if (!clip.local_translations.empty()) {
        out.local_translations[fk * n + b] =
            (1 - u) * clip.local_translations[fi * n + b] + u * clip.local_translations[fj * n + b];
      }
    }
  }
  return out;
}

}  // namespace kumite::content
