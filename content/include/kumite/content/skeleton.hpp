#pragma once
// Skeletons, canonical joints and clips: the vocabulary of content/.
//
// Units: every length past the BVH reader is in METRES (the reader records the file's unit
// in Clip::unit_m so writers can go back to it); angles in radians; time in seconds.
// Frames: Y up. A clip keeps the orientation of its source (CMU actors face +Z at rest).
#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace kumite::content {

/// The joints every dialect maps onto (CMU `lhumerus` -> l_shoulder, assimp `LeftShoulder`
/// -> l_shoulder, ...). A joint is a point where a bone starts.
enum class CanonicalJoint : std::uint8_t {
  pelvis, spine, chest, neck, head,
  l_clavicle, l_shoulder, l_elbow, l_wrist,
  r_clavicle, r_shoulder, r_elbow, r_wrist,
  l_hip, l_knee, l_ankle, l_toe,
  r_hip, r_knee, r_ankle, r_toe,
  count
};
inline constexpr std::size_t kCanonicalJointCount = static_cast<std::size_t>(CanonicalJoint::count);
std::string_view to_string(CanonicalJoint j);
std::optional<CanonicalJoint> canonical_joint_from_string(std::string_view name);

/// A joint hierarchy. Joints are stored parents-first (parents[i] < i; the root is 0 with
/// parent -1), so forward kinematics is one pass.
struct Skeleton {
  std::vector<std::string> names;
  std::vector<int> parents;
  std::vector<Eigen::Vector3d> offsets;  ///< m, joint origin in its parent's frame at rest
  std::vector<bool> end_site;            ///< BVH "End Site" leaves (no rotation of their own)
  /// BVH channels per joint in file order, one letter each: 'X','Y','Z' = position (file
  /// units on disk, metres in memory), 'x','y','z' = rotation about that axis (degrees on
  /// disk). E.g. CMU root "XYZzyx", CMU joint "zyx", boxer "zxy", end site "". Kept so a
  /// written file has the source's channel order; empty vector = writer defaults.
  std::vector<std::string> channels;
  /// Skeleton joint index of each canonical joint, or -1 when the dialect lacks it.
  std::array<int, kCanonicalJointCount> canonical{};
  /// Name of the dialect map that filled `canonical` ("cmu", "assimp_boxer", a TOML map's
  /// name, "structural"), or "" when not mapped. See canonical.hpp.
  std::string dialect;

  int joint_count() const { return static_cast<int>(names.size()); }
  int find(std::string_view name) const;  ///< index or -1
  int index(CanonicalJoint j) const { return canonical[static_cast<std::size_t>(j)]; }
};

/// A motion on a skeleton: per frame the root position and every joint's local rotation.
/// Flat arrays (frame-major) so runtime code can take spans without copying.
struct Clip {
  std::string name;                 ///< e.g. "135_04"
  Skeleton skeleton;
  double frame_time_s = 1.0 / 120;  ///< s per frame
  double unit_m = 0.01;             ///< metres per unit in the source file (BVH cm -> 0.01)
  int frame_count = 0;
  std::vector<Eigen::Vector3d> root_positions;     ///< m, [frame]
  std::vector<Eigen::Quaterniond> local_rotations; ///< [frame * joint_count + joint]
  /// m, [frame * joint_count + joint]: per-frame local translation of every joint. EMPTY
  /// unless a non-root joint has position channels whose values change over the clip (they
  /// replace the offset). When empty, skeleton.offsets are the translations (constant
  /// position channels are folded into the offsets by the reader).
  std::vector<Eigen::Vector3d> local_translations;

  double frame_rate_hz() const { return 1.0 / frame_time_s; }
  double duration_s() const { return frame_count * frame_time_s; }

  std::span<const Eigen::Quaterniond> rotations(int frame) const {
    const auto n = static_cast<std::size_t>(skeleton.joint_count());
    return {local_rotations.data() + static_cast<std::size_t>(frame) * n, n};
  }
};

/// Forward kinematics of one frame of `clip`: global joint positions (m) and rotations.
/// Output spans must hold skeleton.joint_count() entries (the caller owns the buffers).
void forward_kinematics(const Skeleton& skeleton, const Eigen::Vector3d& root_position,
                        std::span<const Eigen::Quaterniond> local_rotations,
                        std::span<Eigen::Vector3d> global_positions,
                        std::span<Eigen::Quaterniond> global_rotations);

/// Forward kinematics of frame `frame` of `clip`, honouring clip.local_translations when
/// present. Output spans must hold clip.skeleton.joint_count() entries.
void forward_kinematics(const Clip& clip, int frame, std::span<Eigen::Vector3d> global_positions,
                        std::span<Eigen::Quaterniond> global_rotations);

/// Global joint positions (m) of every frame: [frame * joint_count + joint]. Offline use.
std::vector<Eigen::Vector3d> all_joint_positions(const Clip& clip);

/// The clip sampled every `frame_time_s` seconds from its first frame to its last (the last
/// new frame at or before the source's last; 1e-9 s of rounding allowed): each sample between
/// source frames i and i + 1 at u = (t - i dt) / dt, local rotations by slerp (shortest arc),
/// root positions and per-joint translations by lerp. A sample on a source frame is that
/// frame's values exactly. What a studio delivering at another frame rate gives (the tests
/// resample the 120 fps development mocap to 30 and 60 fps: `kumite-motion resample`).
/// Throws kumite::Error when frame_time_s is not finite and > 0 or the clip has no frames.
Clip resample_clip(const Clip& clip, double frame_time_s);

}  // namespace kumite::content
