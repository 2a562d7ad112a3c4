#pragma once
// The fighter's skeleton (a character's BVH skeleton, content::Skeleton) retargeted onto a
// model's. Both sides are matched through content's canonical joints: the source's from its
// dialect (CMU ASF names, MotionBuilder names, ...), the model's from a bone map per rig
// family (Quaternius, Rigify, UE mannequin, Mixamo).
//
// Set-up, once per (character skeleton, model): the model is turned to face the way the
// character faces, scaled by the ratio of leg lengths (hip height) and its pelvis put on the
// character's; each mapped bone gets an alignment A_j, the swing that turns its rest direction
// (to its mapped child) onto the character's rest direction (the retarget pose).
// Per frame: G_t = S · G_s · G_s,rest⁻¹ · A_j · G_t,rest (global rotations; S a swing that
// corrects a source bone spanning several source joints, identity for a one-joint bone), each
// mapped joint placed on the character's joint and its bone stretched along its length to the
// character's (girth keeps the hip-height scale), unmapped joints riding rigidly on their
// parent (their rest), fingers curled into a loose fist.
#include <array>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "kumite/body/model.hpp"
#include "kumite/content/skeleton.hpp"

namespace kumite::body {

/// Model joint name per canonical joint for one rig family ("" = the family has none).
struct BoneMap {
  std::string family;  ///< "quaternius", "rigify", "ue_mannequin", "mixamo"
  std::array<std::string, content::kCanonicalJointCount> joints{};
  const std::string& joint(content::CanonicalJoint j) const { return joints[static_cast<std::size_t>(j)]; }
};
const std::vector<BoneMap>& builtin_bone_maps();
/// Joint index of `name` in `names`: case-insensitive, a "prefix:" namespace ignored. -1: none.
int find_joint(std::span<const std::string> names, std::string_view name);
/// The built-in map naming most of the skeleton's joints, with every core joint (pelvis, head,
/// shoulders, elbows, wrists, hips, knees, ankles) present; nullptr when none fits.
const BoneMap* detect_bone_map(std::span<const std::string> names);

/// A retarget target: a skeleton (parents first) at rest, its canonical joints and, per
/// joint, the source joint it follows.
struct TargetRig {
  std::string source_name;  ///< for messages (the model's file)
  std::vector<std::string> names;
  std::vector<int> parents;
  std::vector<Eigen::Matrix4d> rest_globals;  ///< in the target's own world
  std::vector<Eigen::Matrix4d> top_parent_globals;  ///< per joint (identity unless a top joint under a node)
  std::vector<Eigen::Matrix4d> bind;           ///< per joint G_rest · IBM (identity: no mesh)
  std::vector<int> source;                     ///< per joint: source skeleton joint, -1 unmapped
  std::vector<bool> finger;                    ///< per joint: curled into the fist
  std::array<int, content::kCanonicalJointCount> canonical{};  ///< target joint per canonical joint, -1
  /// Per side (left, right): the rest positions (target world) of the mesh's vertices that the
  /// ankle or a joint under it moves most (the shoe): where the sole lies under the ankle.
  /// Empty without a mesh (then the foot is not fitted).
  std::array<std::vector<Eigen::Vector3d>, 2> foot_points;
  int joint_count() const { return static_cast<int>(names.size()); }
};

/// A model's rig onto `source` (canonical joints mapped), through `map`. Throws kumite::Error
/// naming the model when the map finds no pelvis or the source has none.
TargetRig model_rig(const SkinnedModel& model, const content::Skeleton& source, const BoneMap& map);
/// A content skeleton as a target, every joint following the source joint of the same name
/// (the identity retarget when the source is the same skeleton).
TargetRig skeleton_rig(const content::Skeleton& target, const content::Skeleton& source);

struct RetargetOptions {
  bool proportions = true;  ///< stretch mapped bones to the character's lengths
  double fist_deg = 80;     ///< curl per finger joint (thumb: half)
  /// The torso (spine, chest, neck, head, clavicles) keeps the model's own shape (the
  /// hip-height scale), turned as the character's: only the limbs are put on the character's
  /// joints. Skeletons disagree where those joints sit (the CMU lowerneck 20 cm under the
  /// bodies' neck, its clavicles starting at the sternum): stretched onto them, the neck grew
  /// threefold and the shoulders rose into a V.
  bool model_torso = true;
};

/// What is computed once per (source skeleton, target). Immutable once built.
struct RetargetSetup {
  static RetargetSetup build(const content::Skeleton& source, const Eigen::Vector3d& source_rest_root,
                             TargetRig target, const RetargetOptions& options = {});

  content::Skeleton source;
  TargetRig target;
  RetargetOptions options;
  Eigen::Matrix4d normalise = Eigen::Matrix4d::Identity();  ///< target world -> source world (rest)
  double scale = 1;                  ///< hip-height (leg-length) ratio, source / target
  int pelvis = -1;                   ///< target joint
  std::vector<Eigen::Vector3d> source_rest_positions;
  std::vector<Eigen::Quaterniond> source_rest_rotations;
  std::vector<Eigen::Vector3d> rest_positions;      ///< target joints, source world
  std::vector<Eigen::Quaterniond> rest_rotations;   ///< target joints' global rotations, source world
  std::vector<Eigen::Quaterniond> top_parent_rotations;  ///< per joint, source world
  std::vector<Eigen::Quaterniond> align;            ///< A_j (mapped joints)
  std::vector<int> direction_child;                 ///< target joint whose position the bone points at, -1
  std::vector<Eigen::Vector3d> rest_direction;      ///< unit, target rest bone direction (source world)
  std::vector<double> rest_length;                  ///< m, target rest bone length (source world)
  std::vector<Eigen::Quaterniond> curl;             ///< fingers' fist rotation (world, about the joint)
  std::vector<Eigen::Matrix4f> bind;                ///< normalise · G_rest · IBM per joint
  /// The foot fit, per side (left, right): the model's sole depth under its ankle at rest (m,
  /// after the leg-length scale), the character's standing ankle height (its rest ankle above
  /// its toe joint, the floor content plants it on) and their ratio, by which the ankle's joints
  /// are scaled vertically (rest frame) so that the sole meets the floor where the character's
  /// foot stands (1: not fitted: no mesh, no toe joint, or a ratio outside 0.5..1.5).
  std::array<double, 2> sole_depth{0, 0}, ankle_height{0, 0}, foot_fit{1, 1};
  std::vector<int> foot_side;                       ///< per target joint: 0/1 the ankle's subtree, -1
  /// Per side: the shoe's vertices (TargetRig::foot_points) at rest in the source world, the
  /// ankle joint they ride on (-1: not fitted) and the source's toe joint. A posed shoe whose
  /// lowest of these lies under the floor (y = 0) is lifted onto it with its ankle's subtree,
  /// or only up to the character's own toe where that is under the floor, by at most 2.5 cm:
  /// the mocap's planted feet sink a toe up to 1 cm through the floor, and a pitched shoe's
  /// sole went 1 cm deeper.
  std::array<std::vector<Eigen::Vector3d>, 2> shoe_points;
  std::array<int, 2> shoe_ankle{-1, -1}, shoe_toe{-1, -1};
  std::vector<bool> rigid;     ///< per target joint: placed by its parent (model_torso), not on the character's
  /// Per target joint: its bone keeps its length (it points at a rigid joint, or a clavicle
  /// with model_torso).
  std::vector<bool> unstretched;
  /// The rigid torso's offsets scaled by the character's rest pelvis-to-head length over the
  /// model's (0.7..1.3): its head lands on the character's at rest.
  double torso_scale = 1;
  /// Per target joint: an ankle without a toe joint of its own follows the source's toe joint
  /// (its rest_direction: the character's rest ankle -> toe), -1.
  std::vector<int> foot_toe;
};

/// One frame's retarget, ozz-style: inputs and caller-owned outputs in spans; Run() allocates
/// nothing. Spans sized by the source / target joint counts.
struct RetargetJob {
  const RetargetSetup* setup = nullptr;
  std::span<const Eigen::Quaterniond> local_rotations;  ///< source, per joint (FighterFrame.local_rotations)
  Eigen::Vector3d root_position{0, 0, 0};               ///< m, the source root joint (FighterFrame.root_joint)
  /// Optional (empty: forward kinematics' positions): the source joints as drawn, which may
  /// differ from forward kinematics of local_rotations (a character switch eases the drawn
  /// joints from the old character's pose: FighterFrame.joints). The body is placed on these
  /// and its bones point along them; the rotations about the bones stay forward kinematics'.
  std::span<const Eigen::Vector3d> drawn_positions;
  std::span<Eigen::Vector3d> source_positions;          ///< scratch, source joints
  std::span<Eigen::Quaterniond> source_rotations;       ///< scratch, source joints
  std::span<Eigen::Matrix4d> deltas;           ///< out, target: rest world -> posed world (D_j)
  std::span<Eigen::Quaterniond> rotations;     ///< out, target global rotations G_t (source world)
  std::span<Eigen::Vector3d> positions;        ///< out, target joint positions (m)
  std::span<Eigen::Quaterniond> locals;        ///< out, optional (empty: skipped): G_parent⁻¹ · G_t
  std::span<Eigen::Matrix4f> palette;          ///< out, optional: D_j · bind_j, for skin_cpu / the GPU

  bool Validate() const;
  bool Run() const;  ///< false (nothing written) when !Validate()
};

}  // namespace kumite::body
