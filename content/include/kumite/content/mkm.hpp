#pragma once
// A morphology-independent pose representation, after Kulpa & Multon's MKM ("Morphology-
// independent representation of motions for interactive human-like animation", 2005):
// limbs are stored as the vector root->end of the limb divided by the limb's length plus the
// direction of the middle joint across that vector (MKM's swivel, kept as a direction: see
// MkmFrame::arm_pole); the trunk as geometric frames and unit
// directions; the pelvis height as a fraction of the leg length. A pose encoded from one
// skeleton (the actor) decodes onto any other (a character) whose canonical joints are known:
// the decoder (adaptation.hpp) rebuilds each limb with analytic two-bone IK.
//
// Frames: every direction and quaternion of an MkmFrame is expressed in the frame's ground
// frame (Y up). Geometric frames: x toward the body's LEFT, y up, z forward (right-handed;
// a body at rest facing +Z has the identity frame).
#include <array>
#include <limits>
#include <span>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "kumite/content/skeleton.hpp"

namespace kumite::content {

enum Side : int { kLeft = 0, kRight = 1 };

/// Global positions of the canonical joints of one pose (m); joints a skeleton lacks are NaN.
using CanonicalPose = std::array<Eigen::Vector3d, kCanonicalJointCount>;

inline const Eigen::Vector3d& at(const CanonicalPose& p, CanonicalJoint j) {
  return p[static_cast<std::size_t>(j)];
}
inline Eigen::Vector3d& at(CanonicalPose& p, CanonicalJoint j) {
  return p[static_cast<std::size_t>(j)];
}

/// A rigid motion on the floor: world = R_y(yaw) * local + (x, 0, z).
struct GroundFrame {
  Eigen::Vector2d origin_xz{0, 0};  ///< m, (x, z) of the origin on the floor
  double yaw_rad = 0;               ///< rotation about +Y; 0 = facing +Z

  Eigen::Quaterniond rotation() const {
    return Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitY()));
  }
  Eigen::Vector3d to_world(const Eigen::Vector3d& local) const;
  Eigen::Vector3d to_local(const Eigen::Vector3d& world) const;
  /// this ∘ other (apply `other` first).
  GroundFrame compose(const GroundFrame& other) const;
  GroundFrame inverse() const;
};

/// Yaw (rad) of a forward vector projected on the floor: atan2(x, z), 0 for +Z.
double yaw_of(const Eigen::Vector3d& forward);

/// One pose in MKM form. Lengths are normalised (dimensionless) except root_xz_m.
struct MkmFrame {
  Eigen::Vector2d root_xz_m{0, 0};  ///< m, pelvis on the floor (x, z): the only metric field,
                                    ///< because locomotion must keep its metres when blended
  double root_height_n = 1;         ///< pelvis height above the standing ankle (floor + Morphology::standing_ankle_m) / leg length
  Eigen::Quaterniond pelvis = Eigen::Quaterniond::Identity();  ///< geometric frame (hips, up)
  Eigen::Quaterniond chest = Eigen::Quaterniond::Identity();   ///< geometric frame (shoulders, neck)
  Eigen::Vector3d spine_dir{0, 1, 0};  ///< unit, spine -> chest
  Eigen::Vector3d head_dir{0, 1, 0};   ///< unit, neck -> head
  std::array<Eigen::Vector3d, 2> clavicle_dir{};  ///< unit, clavicle -> shoulder [side]
  std::array<Eigen::Vector3d, 2> arm_n{};   ///< (wrist - shoulder) / arm length [side]
  /// unit, from the shoulder->wrist axis toward the elbow, across the axis [side] (the frame of
  /// arm_n). A direction, not an angle about a fixed reference: every fixed reference has two
  /// limb directions where the angle turns fast (a guard arm across the body, a long stance's
  /// front leg pointed nearly opposite it), and any blend or sub-frame sample there swung the
  /// elbow or knee (a 25 cm elbow jump in a frame out of 135_10_step_6).
  std::array<Eigen::Vector3d, 2> arm_pole{};
  std::array<Eigen::Vector3d, 2> leg_n{};   ///< (ankle - hip) / leg length [side]
  std::array<Eigen::Vector3d, 2> leg_pole{};  ///< unit, from the hip->ankle axis toward the knee [side] (as arm_pole)
  std::array<Eigen::Vector3d, 2> foot_dir{};  ///< unit, ankle -> toe [side], its pitch relative to the body's standing foot (Morphology::standing_foot_pitch_rad; drawn_foot_dir)
  std::array<double, 2> planted{};  ///< 1 = foot planted on the floor, 0 = free [side]
  /// The source's own ankle above its lowest in the segment / the source's leg length [side]:
  /// a heel raised onto the toes, measured on the mocap itself (the ankle decoded on another
  /// body's proportions is no measure: it stood 6-7 cm up on a straight support leg).
  std::array<double, 2> ankle_lift_n{};
};

/// Lengths of a body, measured on its rest pose (m). Limb lengths are bone lengths, so they
/// do not depend on the rest pose's angles.
struct Morphology {
  std::array<double, 2> upper_arm_m{}, forearm_m{}, thigh_m{}, shin_m{};  ///< [side]
  double leg_length_m = 1;  ///< pelvis height when standing straight: the size used for
                            ///< root normalisation and for scaling targets actor <-> character
  double height_m = 1.7;    ///< rest head height above the lowest foot joint (reporting)
  /// m: the ankle joint above the floor (the lowest foot joint) when the body stands. Root
  /// heights count from it (MkmFrame::root_height_n), so a body whose ankle joint sits higher
  /// in its foot does not stand its pelvis that much higher on another: HDM05's skeletons
  /// stand their ankles ~9 cm above the toe joint, CMU's ~4 cm, the characters' ~2.5 cm (an
  /// HDM05 kick's pelvis on aiko stood 6-7 cm above what her legs reach: her support foot hung
  /// in the air after the kick's hop).
  double standing_ankle_m = 0;
  /// [side] rad: the foot's pitch (ankle -> toe joint, below the horizontal) when it stands
  /// flat. Foot directions are stored relative to it (MkmFrame::foot_dir): where the toe
  /// joint sits in the foot differs by skeleton (HDM05's stands 27-43 deg below its ankle,
  /// CMU's 10-20, the characters' 11), and the source's own pitch drawn on a character put
  /// its toes through the floor or its heel in the air.
  std::array<double, 2> standing_foot_pitch_rad{};
  double arm_length(int side) const { return upper_arm_m[side] + forearm_m[side]; }
  double limb_leg_length(int side) const { return thigh_m[side] + shin_m[side]; }
};

/// Canonical global positions of a skeleton pose (NaN where the skeleton lacks a joint).
void canonical_positions(const Skeleton& skeleton, std::span<const Eigen::Vector3d> global_positions,
                         CanonicalPose& out);

/// Morphology from a rest pose's canonical positions. Throws kumite::Error("content",
/// "skeleton", ...) naming `what` and the missing canonical joint when the pose lacks one
/// that the fighter needs (pelvis, chest, neck, head, shoulders, elbows, wrists, hips, knees,
/// ankles).
Morphology measure_morphology(const CanonicalPose& rest, std::string_view what);
/// rad: the pitch of a pose's foot (ankle -> toe joint below the horizontal; forward and down,
/// 26.6 deg, where the pose has no toe joint).
double standing_foot_pitch(const CanonicalPose& pose, int side);
/// The canonical joints every fighter skeleton must have.
void require_canonical_joints(const Skeleton& skeleton, std::string_view what);

/// Geometric frames (x left, y up, z forward) of the pelvis and chest of a pose.
Eigen::Quaterniond pelvis_frame(const CanonicalPose& p);
Eigen::Quaterniond chest_frame(const CanonicalPose& p);
/// The pose's ground frame: pelvis projected on the floor, heading of the pelvis frame.
GroundFrame ground_frame_of(const CanonicalPose& p);
GroundFrame ground_frame_of(const MkmFrame& f);

/// Swivel reference (unit, in the pelvis/chest geometric frame) for a side's arm or leg
/// (up-outward-back for arms, up-back for legs): the pole of a straight limb the encoder meets
/// first (no earlier frame to carry its pole from).
Eigen::Vector3d arm_swivel_reference(int side);
Eigen::Vector3d leg_swivel_reference(int side);

/// `v` made perpendicular to the unit `axis`, unit; `otherwise` so made where `v` lies along
/// the axis, and any unit perpendicular where both do.
Eigen::Vector3d across(const Eigen::Vector3d& v, const Eigen::Vector3d& axis, const Eigen::Vector3d& otherwise);
/// A limb's pole carried with the limb from direction `from` (unit) onto `axis` (unit): turned
/// by the shortest rotation between them, then made across the axis (`otherwise` where it lies
/// along it: across()).
inline Eigen::Vector3d carried_pole(const Eigen::Vector3d& pole, const Eigen::Vector3d& from, const Eigen::Vector3d& axis,
                                    const Eigen::Vector3d& otherwise) {
  return across(Eigen::Quaterniond::FromTwoVectors(from, axis) * pole, axis, otherwise);
}
/// Unit direction from the axis root->end toward `middle`, across the axis. Where the limb is
/// straight (the middle within 1e-6 m of the axis: undefined) the fallback pole (unit, e.g. the
/// previous frame's), made perpendicular to the axis; where that is along the axis too, any
/// unit perpendicular.
Eigen::Vector3d limb_pole(const Eigen::Vector3d& root, const Eigen::Vector3d& middle, const Eigen::Vector3d& end,
                          const Eigen::Vector3d& fallback);
/// The pole `a` turned toward `b` by `w` (0..1) about `axis` (unit): both made perpendicular to
/// the axis, the shorter way round (a blend of two frames' poles about the blended limb).
/// `turn_rad` (a cross-fade carried over updates, PoleTurns): in, the angle (rad, about the
/// axis, a's pole to b's) the previous update turned by, NaN for none; the turn is then the one
/// of a's-to-b's angles (the shorter one plus any whole turn) nearest it, so a blend of two
/// nearly opposite poles keeps turning the way it began. Out: the angle turned by. Where that
/// is the shorter way the pole is the same as without it.
Eigen::Vector3d blend_pole(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& axis, double w,
                           double* turn_rad = nullptr);

/// A cross-fade's limb-pole turns, carried from update to update (blend_mkm, PlaybackSource's
/// compose). Turned the shorter way afresh at every update, two nearly opposite poles (a guard
/// arm's elbow against a kick's) swap sides whenever which way is shorter changes: the elbow
/// crossed the body and back, 27 cm in one frame. Plain data: the rate solver gets a copy
/// with the strike's start state. Belongs to the cross-fade from `from_segment` to
/// `to_segment`; a smaller `elapsed_s` than the last one, or other segments: a new cross-fade.
struct PoleTurns {
  static constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  int from_segment = -1, to_segment = -1;
  double elapsed_s = -1;  ///< s into the cross-fade at the update that last turned
  /// rad about each limb from the fading pose's pole to the other's: arm, leg per side (NaN:
  /// none yet, the shorter way)
  std::array<double, 2> arm_rad{kNone, kNone}, leg_rad{kNone, kNone};
};

/// A drawn limb's pole carried from update to update (limit_folded_pole_turn; Behaviour keeps
/// one per arm). Plain data, room frame.
struct DrawnPole {
  bool valid = false;                      ///< false: nothing drawn yet (the source's pole is taken as it is)
  Eigen::Vector3d drawn{0, 0, 1};          ///< unit: the pole drawn at the last update
  Eigen::Vector3d source{0, 0, 1};         ///< unit: the source's pole then
  Eigen::Vector3d axis{0, 1, 0};           ///< unit: the limb's root -> end axis then
  /// m: the drawn middle joint's (elbow's) distance from its root-end line at the last update;
  /// 0: unknown (a new body), the source's pole is taken as it is.
  double drawn_radius_m = 0;
  double source_radius_m = 0;  ///< m: the source's, on the same bones, at the last update
};
/// m/s: how fast the elbow of a drawn pole held back by limit_folded_pole_turn swings back to
/// where the source's pole has it (on top of the source's own swing).
inline constexpr double kFoldedPoleCatchUp_mps = 0.5;
/// The pole (unit, across `limb_n`'s axis) to draw for a two-bone limb whose source pole is
/// `source_pole` and whose source direction is `limb_n` ((end - root) / limb length, the
/// MkmFrame's arm_n or leg_n), bones `upper_m` and `lower_m` long, `dt` s after the last
/// update (`memory`, updated; its drawn_radius_m is the caller's to set after drawing). A
/// nearly straight source limb's pole swings with the mocap (its middle joint millimetres off
/// the axis: nothing to see on the source); where adaptation draws the limb more bent than the
/// source (a punch landing nearer than captured), the same turn swings the drawn elbow round a
/// radius several times the source's (aiko's right elbow 5.4 cm in one frame after a punch
/// landed at 0.55 of her arm, the source's at 0.99). So the drawn elbow swings about the axis
/// at most as far (m) as the source's did, both on the last update's radii, plus
/// kFoldedPoleCatchUp_mps * dt to come back to where the source's pole has it. Where the drawn limb is no more bent than the source's and has
/// not been held back, and where the drawn radius is unknown (0), the source's pole to the bit.
Eigen::Vector3d limit_folded_pole_turn(DrawnPole& memory, const Eigen::Vector3d& source_pole, const Eigen::Vector3d& limb_n,
                                       double upper_m, double lower_m, double dt);

/// `dir` (unit) pitched about the horizontal axis across it, its heading kept: a foot standing
/// at pitch `from_rad` (below the horizontal) re-drawn on a foot standing at `to_rad`. Within
/// 40 deg of the horizontal the pitch moves by to - from (a plantar flexion kept as it is);
/// beyond, the offset fades to nothing at straight down and straight up (so a foot turning
/// through the vertical stays continuous). Standing pitches are taken within +-45 deg. A
/// direction within 1e-9 of vertical is returned as it is.
Eigen::Vector3d repitch(const Eigen::Vector3d& dir, double from_rad, double to_rad);
/// The foot's direction (unit, ankle -> toe) drawn on a body of morphology `m`.
inline Eigen::Vector3d drawn_foot_dir(const MkmFrame& f, const Morphology& m, int side) {
  return repitch(f.foot_dir[static_cast<std::size_t>(side)], 0.0, m.standing_foot_pitch_rad[static_cast<std::size_t>(side)]);
}

/// Encodes canonical positions (m) into MKM. `floor_y_m` is the clip's floor height (the
/// root's height counts from floor_y_m + morphology.standing_ankle_m); where a limb is straight
/// its pole is the previous frame's: pass it so a straight arm keeps its last pole (previous may
/// be null: the swivel reference then).
void encode_mkm(const CanonicalPose& pose, const Morphology& morphology, double floor_y_m,
                const MkmFrame* previous, MkmFrame& out);

/// Offline (database build): a nearly straight limb's pole steadied over time. Where a limb is
/// nearly straight its elbow or knee sits millimetres off the root-end axis and the measured
/// pole swings with mocap noise (135_06's right arm at its hit: 21 deg in 1/60 s, the source
/// elbow 1 cm), which is nothing on the source but a limb that adaptation bends (d(t) folding
/// a straight punch onto a near head) swings its elbow by it (10 cm in a frame). A frame's
/// pole is blended toward the Gaussian average (sigma kSteadySigma_s) of its neighbours'
/// poles, each carried with its limb onto this frame's axis and weighted by how bent it is (a
/// bent frame's pole is well defined), by how straight the limb is (extension |arm_n|, |leg_n|:
/// none at kSteadyFrom, whole from kSteadyFull) smoothed over the same window: frames beside a
/// straight stretch take a little of it, frames far from one keep their measured pole. (A
/// knee that passes through straight in the mocap flips its pole 180 deg and back: HDM05's
/// kicks.) Unit poles across their limbs in, the same out; any frame time > 0.
inline constexpr double kSteadyFrom = 0.92, kSteadyFull = 0.98, kSteadySigma_s = 0.05;
void steady_straight_limb_poles(std::span<MkmFrame> frames, double frame_time_s);

/// Mirrors a canonical pose left <-> right through the plane x = 0 of its ground frame `g`.
void mirror_pose(const CanonicalPose& in, const GroundFrame& g, CanonicalPose& out);

/// out = a blended toward b by w in [0, 1] (0 = a). Quaternions slerp, unit directions
/// nlerp, limb vectors lerp (their length is the extension), poles turn about the blended limb
/// the shorter way (blend_pole).
/// `turns` (a cross-fade's, PoleTurns): each limb's pole turned by the angle nearest the one
/// there, which is then set to the angle used.
void blend_mkm(const MkmFrame& a, const MkmFrame& b, double w, MkmFrame& out, PoleTurns* turns = nullptr);

/// Expresses a frame given in ground frame `from`'s local coordinates in world coordinates,
/// i.e. applies `placement` (rotation about Y and translation on the floor). Root horizontal
/// displacement is scaled by `stride_scale` about placement's origin (actor -> character
/// legs) after removing `anchor_xz_m` (the clip's root at the alignment frame).
/// place_mkm's root alone: `root_xz_m` (m, the clip's pelvis on the floor) placed so, with
/// `rotation` = placement.rotation() found by the caller (once for many frames).
Eigen::Vector2d place_root_xz(const Eigen::Vector2d& root_xz_m, const GroundFrame& placement, const Eigen::Quaterniond& rotation,
                              const Eigen::Vector2d& anchor_xz_m, double stride_scale);
void place_mkm(const MkmFrame& in, const GroundFrame& placement, const Eigen::Vector2d& anchor_xz_m,
               double stride_scale, MkmFrame& out);

}  // namespace kumite::content
