#pragma once
// Real-time adaptation: decodes an MKM pose (mkm.hpp) onto a character's skeleton, every
// frame. Trunk joints take their geometric frames and directions; each limb is rebuilt with
// analytic two-bone IK from the character's own shoulder/hip, keeping the swivel angle; the
// hit point can be pulled by an offset d(t) toward a target (reach); planted feet can be held
// at fixed ankle positions. When the arm alone cannot reach, CCD over spine/chest/clavicle
// brings the shoulder closer first.
//
// Style (ozz-animation): a Rig is immutable runtime data built once per character; AdaptJob
// is a small struct over caller-owned spans with Validate()/Run(); Run() never allocates.
#include <array>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "kumite/content/mkm.hpp"
#include "kumite/content/skeleton.hpp"

namespace kumite::content {

/// A character (or the actor) prepared for adaptation.
struct Rig {
  enum class Role : std::uint8_t {
    none, pelvis, spine, chest, neck, clavicle, shoulder, elbow, hip, knee, ankle
  };
  std::string name;
  Skeleton skeleton;
  std::vector<Eigen::Quaterniond> rest_local;  ///< rest local rotation per joint
  CanonicalPose rest_pose;                     ///< m, canonical positions at rest
  Morphology morphology;
  std::vector<Role> role;            ///< what the solver does at each joint
  std::vector<std::int8_t> side;     ///< kLeft / kRight for limb roles, -1 otherwise
  std::vector<Eigen::Vector3d> aim_local;  ///< unit, toward the role's child joint, joint frame at rest
  /// unit [side]: the thumb's side of the forearm, across it, in the elbow joint's frame at rest
  /// (from a joint named "thumb" below the wrist, else the rest pose's forward); zero where
  /// neither gives a direction. AdaptJob::fist_neutral turns the forearm by it.
  std::array<Eigen::Vector3d, 2> thumb_local{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  Eigen::Quaterniond pelvis_frame_local = Eigen::Quaterniond::Identity();  ///< geometric frame in pelvis joint frame
  Eigen::Quaterniond chest_frame_local = Eigen::Quaterniond::Identity();   ///< geometric frame in chest joint frame
  Eigen::Vector3d root_to_pelvis_local{0, 0, 0};  ///< m, pelvis from the root joint, root frame at rest
  std::vector<float> joint_radii_m;  ///< suggested capsule radius of the bone ending at each joint
  double unit_m = 1.0;               ///< metres per unit of the file it came from (for writing back)

  int joint_count() const { return skeleton.joint_count(); }
};

/// Builds a rig from a skeleton and its rest local rotations (empty = identity, i.e. the
/// BVH offsets' pose). Throws kumite::Error naming `name` when canonical joints are missing.
Rig make_rig(const Skeleton& skeleton, std::span<const Eigen::Quaterniond> rest_local, std::string name);

/// Which limb carries the hit point (the end joint of the limb: wrist or ankle).
struct Effector {
  int side = kRight;
  bool leg = false;
  CanonicalJoint joint() const;
};

/// The trunk's rotations toward a punch's target (room-frame rotations about the spine, the
/// chest and the striking side's clavicle, as AdaptJob's trunk fallback applies them).
/// Identity: upright as the motion has it.
struct TrunkLean {
  Eigen::Quaterniond spine = Eigen::Quaterniond::Identity();
  Eigen::Quaterniond chest = Eigen::Quaterniond::Identity();
  Eigen::Quaterniond clavicle = Eigen::Quaterniond::Identity();
  /// This lean at `w` of its rotations (0: none, 1: whole).
  TrunkLean scaled(double w) const {
    return {Eigen::Quaterniond::Identity().slerp(w, spine), Eigen::Quaterniond::Identity().slerp(w, chest),
            Eigen::Quaterniond::Identity().slerp(w, clavicle)};
  }
  bool identity() const {
    return spine.isApprox(Eigen::Quaterniond::Identity(), 0) && chest.isApprox(Eigen::Quaterniond::Identity(), 0) &&
           clavicle.isApprox(Eigen::Quaterniond::Identity(), 0);
  }
};

/// d(t): how the effector's limb is moved toward a target this frame. The limb vector (limb
/// root -> decoded effector) is turned by `turn` and scaled by `stretch` about the limb's root
/// (the whole limb aims, a folded limb stays folded), then `offset_m` is added.
struct ReachGoal {
  Effector effector;
  Eigen::Quaterniond turn = Eigen::Quaterniond::Identity();  ///< room frame
  double stretch = 1;                ///< limb vector length factor
  Eigen::Vector3d offset_m{0, 0, 0};  ///< m, room frame
  /// 0..1: how firmly the goal stays put when held feet lower the pelvis. 1 (contact): the
  /// effector keeps its goal; 0: it moves down with the body like every other joint. The
  /// fighter sets d(t)'s ramp here, so the effector rejoins the body as d(t) is released.
  double pin = 1;
  /// m: the most of the pelvis drop the goal is kept against; beyond it the goal goes down with
  /// the body (by `pin` of the excess). A punch's plan checked its arm at the drop it planned
  /// (its elbow under the head): held against a deeper drop, the arm rose steeper than planned.
  double pin_drop_max_m = std::numeric_limits<double>::infinity();
  /// A punch's planned trunk lean at this frame (the lean its contact needs, eased in and out
  /// with d(t) by the caller): applied before the arm is solved, so the body leans into the
  /// punch over its whole way instead of the trunk fallback snapping in at full stretch.
  TrunkLean lean;
};

/// Planted feet: per side a weight in [0, 1] pulling the decoded ankle onto `ankle_m`.
struct FootLocks {
  std::array<double, 2> weight{0, 0};
  std::array<Eigen::Vector3d, 2> ankle_m{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};  ///< m, room
  /// m: the range the pelvis drop is kept in. The drop asked for (held feet within the legs'
  /// reach) is clamped into it: the caller keeps it a knee bend (max) and makes it change at
  /// a bounded rate from frame to frame (both ends around the last frame's drop). A foot still
  /// out of reach then is reported (AdaptReport::foot_reached).
  double min_root_drop_m = 0;
  double max_root_drop_m = 0.20;
  /// [side] the foot bears weight (held on the floor): only such feet lower the pelvis; a
  /// foot in the air goes as far toward its goal as the leg reaches.
  std::array<bool, 2> supporting{true, true};
  /// [side] a held foot keeps its heading on the floor: the ankle's aim (toward the toes) is
  /// turned about +Y toward `heading_xz` (a unit room-frame x/z direction) by
  /// `heading_weight` in [0, 1] (the motion's own tilt is kept: a heel rises about the toes,
  /// the foot does not spin). The caller eases the weight out when the foot is lifted.
  std::array<double, 2> heading_weight{0, 0};
  /// [side] 0..1: how much of a held foot's soft leg extension applies (times its weight): the
  /// caller eases it in where a hold is taken from nothing (a straight leg's knee moves
  /// centimetres as its soft zone comes in).
  std::array<double, 2> softness{1, 1};
  std::array<Eigen::Vector2d, 2> heading_xz{Eigen::Vector2d(0, 1), Eigen::Vector2d(0, 1)};
  /// [side] m, room: a held foot's toe joint goes no higher than this, by `toe_floor_weight`
  /// (0..1, times `weight`): the foot pitches down about its ankle to put it there. An ankle
  /// held above the floor (a leg that does not reach down to it flat) stands on its toes; the
  /// motion's flat foot held at that height floated 6 cm over the floor.
  std::array<double, 2> toe_floor_y_m{0, 0};
  std::array<double, 2> toe_floor_weight{0, 0};
  /// [side] m, room: ...and no lower than this, by `toe_lowest_weight` (the foot pitched up
  /// about its ankle): a foot on the floor or coming down onto it does not put its toes through
  /// it (a held foot whose motion rolls it onto its toes to lift it, held on while the other
  /// foot lands, pushed them 1.8 cm under).
  std::array<double, 2> toe_lowest_y_m{0, 0};
  std::array<double, 2> toe_lowest_weight{0, 0};
};

/// What one Run() did (optional output).
struct AdaptReport {
  Eigen::Vector3d effector_goal{0, 0, 0};     ///< m, where the effector was asked to be
  Eigen::Vector3d effector_reached{0, 0, 0};  ///< m, where it is after FK
  double reach_error_m = 0;                   ///< |goal - reached|
  bool reached = true;                        ///< goal within the limb's reach (after CCD)
  bool trunk_used = false;                    ///< the CCD fallback bent the trunk
  TrunkLean trunk;                            ///< the trunk rotations applied (lean and fallback)
  double trunk_weight = 0;                    ///< the trunk fallback's weight used (0..1)
  TrunkLean trunk_fallback;                   ///< the fallback's own rotations (on top of the lean)
  std::array<bool, 2> foot_reached{true, true};  ///< locked ankle within the leg's reach
  double root_drop_m = 0;                     ///< m the pelvis was lowered for held feet
  /// rad [side]: a held foot's heading (FootLocks::heading_xz) less the motion's, about +Y, as
  /// the decode took it (heading_weight of it turned the foot); NaN where no heading was held.
  /// A caller drawing frames in sequence hands it back (AdaptJob::previous_heading_delta_rad).
  std::array<double, 2> heading_delta_rad{std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
};

/// Tunables of the trunk fallback (rad). Larger limits reach further but look contorted.
struct TrunkLimits {
  double spine_rad = 0.45;     ///< ~26 deg: a lean from the lower back
  double chest_rad = 0.35;     ///< ~20 deg
  double clavicle_rad = 0.35;  ///< ~20 deg: shoulder thrust
  int iterations = 12;         ///< CCD sweeps; converges in 2-4 for reachable targets
};

struct AdaptJob {
  const Rig* rig = nullptr;
  const MkmFrame* pose = nullptr;       ///< placed in the room frame (place_mkm)
  const ReachGoal* reach = nullptr;     ///< optional
  const FootLocks* feet = nullptr;      ///< optional
  TrunkLimits trunk{};
  /// At most this weight of the trunk fallback (0..1). A caller drawing frames in sequence
  /// passes the last frame's weight plus what may come in over one frame: the fallback's need
  /// jumps where the arm goes from within its reach to full stretch in one frame.
  double max_trunk_weight = 1;
  /// The share of the arm's length the trunk fallback brings the goal within (its weight rises
  /// from 0 at this share to 1 at the full length). A punch's planned lean is found with a
  /// smaller share than the frames' fallback, so the frames rarely need the fallback at all.
  double trunk_target_share = 0.95;
  /// Optional: the least trunk fallback to apply (rotations on top of the planned lean, e.g.
  /// the last frame's eased toward none). A caller drawing frames in sequence passes it so the
  /// fallback goes out over frames: the frame after a full-stretch contact the goal is back
  /// within reach, the fallback's need drops to nothing and the body sprang up in one frame.
  const TrunkLean* min_trunk_fallback = nullptr;
  /// The arm (kLeft / kRight) whose strike the min_trunk_fallback comes from: with a leg's
  /// reach (a kick started while a punch's fallback still goes out) it is applied too, its
  /// clavicle turn on this arm's side (-1: applied only with an arm's reach, on that arm).
  int min_trunk_fallback_side = -1;
  /// Optional: the last drawn frame's global positions of this rig (m, room frame, joint_count;
  /// empty: none). A caller drawing frames in sequence passes them with max_knee_swivel_rad:
  /// each knee then turns about its leg's hip->ankle axis by at most that much from where it
  /// was drawn. Where a held foot keeps the ankle far from the motion's (a kick aborted as its
  /// foot rose), the motion's knee direction can pass through the leg's axis, and the knee
  /// flipped to the other side in one frame (0.6 m: the spar demo with stance steps on).
  std::span<const Eigen::Vector3d> previous_positions;
  double max_knee_swivel_rad = 0;  ///< rad, per frame; 0: no limit
  /// 0..1 [side]: how far each forearm turns about its own length from the twist its aim gives
  /// (the shortest swing from the rest, carried down the arm: MKM has arm directions and
  /// elbow poles, no hand) toward a fist held up: the thumb toward the shoulder's side of the
  /// forearm, the palm toward the body's middle. The guard passes its weight: swung alone, its
  /// upright forearms turned their palms to the visitor, fingers curled toward them.
  std::array<double, 2> fist_neutral{0, 0};
  /// rad [side], optional (NaN: none): the last frame's AdaptReport::heading_delta_rad. The
  /// heading difference is then taken on the turn nearest it, not always within +-pi: where the
  /// motion's foot turned through the opposite of its held heading while the hold eased out
  /// (a kick lifting the foot), the share turned changed sign and the toe swung round 26 cm in
  /// one frame.
  std::array<double, 2> previous_heading_delta_rad{std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
  std::span<Eigen::Quaterniond> local_rotations;   ///< out, joint_count
  std::span<Eigen::Vector3d> global_positions;     ///< out, m, room frame, joint_count
  std::span<Eigen::Quaterniond> global_rotations;  ///< out, joint_count
  Eigen::Vector3d* root_position = nullptr;        ///< out, m, root joint position
  AdaptReport* report = nullptr;                   ///< optional out

  bool Validate() const;
  bool Run() const;  ///< false when Validate() fails
};

/// Convenience for offline code and queries (allocates): decode `pose` on `rig` and return
/// the canonical positions (m).
void decode_canonical(const Rig& rig, const MkmFrame& pose, CanonicalPose& out);

}  // namespace kumite::content
