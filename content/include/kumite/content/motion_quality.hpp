#pragma once
// Motion quality as the eye sees it: figures computed from the joint positions that are DRAWN
// (a BVH read back with read_bvh + forward_kinematics), never from the solver's internals.
// Free functions over plain data; every input is explicit.
//
// Units: positions in metres, room frame (+Y up, floor y = 0); speeds in m/s; time in s;
// angles in degrees where a name says _deg. A track is frames x joints at a fixed frame time.
//
// Definitions (content/README.md, "Motion quality"):
// - joint speed: |p(f) - p(f-1)| / frame_time for every non-end-site joint and frame step.
// - snap (one-frame jump) at step f (p(f-1) -> p(f)), any of:
//     (a) speed above SnapOptions::max_speed_mps (20 m/s);
//     (b) step above min_step_m (5 cm) and above ratio (3) x both neighbouring steps
//         (a missing neighbour at the range's edge does not count against it);
//     (c) a there-and-back spike: steps f and f+1 both above min_step_m, pointing opposite
//         ways (cosine < -0.5), each above ratio x the steps f-1 and f+2.
// - foot contact (geometric): a foot (ankle + toe canonical joints) is in contact at frame f
//   when the ankle and the toe are both within height_tolerance_m (1.5 cm) of their own lowest
//   level (over the whole track unless a level range is given), and the foot point's horizontal speed (below) is under
//   ContactOptions::max_speed_mps (2 m/s: a foot sweeping low across the floor in a step is
//   not standing; a standing foot that slides faster than 2 m/s is counted in
//   low_fast_frames so it is never hidden).
// - foot point: midpoint of ankle and toe. Foot speed at frame f: displacement of the foot
//   point from f-h to f+h over 2h frame times, h = max(1, round(window_s / 2 / frame_time)),
//   window_s = 1/30 s (~33 ms: h = 2 at 120 Hz, h = 1 at 60 Hz).
// - support-foot slide: max horizontal foot speed over the frames where the foot is in
//   contact at every frame of the window [f-h, f+h] (contact flags given by the caller: the
//   source clip's own contacts mapped onto the output, or the geometric detector).
// - stepping-foot peak: max 3-D foot speed over the frames where the foot is not in contact.
// - limb at contact: extension = |root -> end| / (upper + lower bone length) (1 = straight);
//   end_ahead = (end - middle) . u, u = unit vector from the limb root (shoulder / hip) to
//   the target; negative = a fold (wrist / ankle behind its elbow / knee toward the target);
//   for arms also a fold when the elbow is above the head joint (elbow.y > head.y).
//   approach elevation = atan2(vy, |vxz|) of the end joint's velocity over the window ending
//   at contact (a fist hooking upward has a large positive elevation).
// - limb flip: bend-plane normal n = (middle - root) x (end - middle), unit; a flip at frame f
//   when the angle between n(f) and n(f-k), k = 1..K (K = max(1, round(window_s / frame
//   time)), window_s = 1/30 s: "within a frame or two" of a 60 Hz display), exceeds
//   max_turn_deg (90 deg) while the limb is bent at least min_bend_deg (20 deg) in both frames
//   (a straight limb has no bend plane). One flip per limb is reported per K frames.
#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "kumite/common/wire.hpp"
#include "kumite/content/adaptation.hpp"
#include "kumite/content/behaviour.hpp"
#include "kumite/content/skeleton.hpp"

namespace kumite::content {

/// A joint-position sequence: what a viewer sees. Non-owning view.
struct JointTrack {
  const Skeleton* skeleton = nullptr;
  std::span<const Eigen::Vector3d> positions;  ///< m, room frame, [frame * joint_count + joint]
  int frame_count = 0;
  double frame_time_s = 1.0 / 120;             ///< s per frame (fixed)

  int joint_count() const { return skeleton->joint_count(); }
  const Eigen::Vector3d& at(int frame, int joint) const {
    return positions[static_cast<std::size_t>(frame) * static_cast<std::size_t>(joint_count()) +
                     static_cast<std::size_t>(joint)];
  }
};

/// Frames [first, last], inclusive.
struct FrameRange {
  int first = 0;
  int last = -1;
  int count() const { return last - first + 1; }
};

/// Window half-width h in frames for a speed window of `window_s` (h >= 1).
int speed_half_window(double frame_time_s, double window_s = 1.0 / 30);

struct SpeedStats {
  double p50_mps = 0, p99_mps = 0, max_mps = 0;  ///< over every joint-step sample in the range
  int max_joint = -1;                            ///< skeleton joint of the max
  int max_frame = -1;                            ///< frame f of the step f-1 -> f
  int samples = 0;
  std::vector<double> joint_max_mps;             ///< per skeleton joint (0 for end sites)
};
/// Joint speeds over the steps inside `range` (f in [first+1, last]), multiplied by `scale`
/// (1, or character leg / actor leg to compare a source clip with a character).
SpeedStats joint_speeds(const JointTrack& track, FrameRange range, double scale = 1);

struct SnapOptions {
  double max_speed_mps = 20;  ///< (a)
  double min_step_m = 0.05;   ///< (b), (c)
  double ratio = 3;           ///< (b), (c)
};
struct Snap {
  int frame = -1;   ///< step frame-1 -> frame
  int joint = -1;
  double step_m = 0;
  char rule = 'a';  ///< 'a' speed, 'b' isolated step, 'c' spike
};
std::vector<Snap> find_snaps(const JointTrack& track, FrameRange range, const SnapOptions& options = {});

struct ContactOptions {
  double height_tolerance_m = 0.015;
  /// m: compare_strike counts an output foot as down (standing, so a horizontal speed is a
  /// skate) while its ankle or its toe is within this of the output's own lowest level.
  double down_tolerance_m = 0.03;
  double max_speed_mps = 2.0;
  double window_s = 1.0 / 30;
};
struct FootContacts {
  std::array<std::vector<std::uint8_t>, 2> contact;  ///< [side][frame] 1 = in contact (kLeft, kRight)
  std::array<double, 2> ankle_floor_m{0, 0}, toe_floor_m{0, 0};  ///< lowest levels (m)
  std::array<int, 2> low_fast_frames{0, 0};  ///< flat and low but faster than the speed gate
};
/// Geometric contacts for every frame of the track (needs the ankle and toe canonical joints).
/// The lowest levels are taken over `level_range` (default: the whole track).
FootContacts detect_foot_contacts(const JointTrack& track, const ContactOptions& options = {},
                                  FrameRange level_range = {0, -1});

/// Spans of frames in `range` with both feet off the floor: the ankle and the toe of each foot
/// more than `tolerance_m` above their own lowest level (`levels`' ankle_floor_m / toe_floor_m:
/// detect_foot_contacts over the same track) — a hop, or a jump; a fighter following the
/// visitor never has one. Each span [first, last].
std::vector<FrameRange> both_feet_off(const JointTrack& track, FrameRange range, const FootContacts& levels,
                                      double tolerance_m = 0.03);

/// The frames of `off` (spans of a track's frames: both_feet_off) at which the motion played
/// had a foot down by its own contacts: off the floor where the source is not. Track frame k
/// is frame `first_frame` + k of `source_planted`, the motion's contacts per frame ([side] >=
/// 0.5: down; Behaviour::motion_planted(), the clip blended to, as the database stores them
/// from the mocap). A frame counts as the source's own when the source has both feet up at
/// any frame within `slack` of it (the drawn joints' and the mocap's detections differ by a
/// frame or two; the window is cut at the ends of `source_planted`).
std::vector<int> both_feet_off_source_down(std::span<const FrameRange> off, int first_frame,
                                           std::span<const std::array<double, 2>> source_planted, int slack);

/// Midpoint of ankle and toe of `side` at `frame` (m).
Eigen::Vector3d foot_point(const JointTrack& track, int side, int frame);
/// Foot point speed (m/s) at frame f over [f-h, f+h]; horizontal only when `horizontal`.
/// NaN when the window leaves the track.
double foot_speed(const JointTrack& track, int side, int frame, int half_window, bool horizontal);

struct FootFigure {
  double max_mps = 0;  ///< NaN when no frame qualified
  int frame = -1;      ///< frame of the max
  int frames = 0;      ///< frames that qualified
  double p50_mps = 0, p95_mps = 0;  ///< over the qualified frames (NaN when none)
};
/// Support-foot slide of `side` over `range`: contact[f] is the flag of track frame f (size
/// frame_count). Multiplied by `scale`.
FootFigure support_foot_slide(const JointTrack& track, int side, std::span<const std::uint8_t> contact,
                              FrameRange range, int half_window, double scale = 1);
/// Stepping-foot peak speed of `side` over the frames of `range` where contact[f] == 0.
FootFigure stepping_foot_peak(const JointTrack& track, int side, std::span<const std::uint8_t> contact,
                              FrameRange range, int half_window, double scale = 1);

struct LimbAtContact {
  double extension = 0;         ///< |root->end| / (upper + lower), 1 = straight
  double end_ahead_m = 0;       ///< (end - middle) . unit(target - root); < 0: folded behind
  bool folded = false;          ///< end_ahead_m < 0, or (arms) elbow above the head
  bool elbow_above_head = false;
  double approach_elevation_deg = 0;  ///< of the end joint's velocity over the window before contact
  /// The same minus the elevation of the limb's line (root -> end) at contact: how far the
  /// end's last approach rises across the line it strikes along (0: it travels along the arm,
  /// a straight punch; a punch aimed higher has a steeper line, not a larger figure here).
  double approach_above_line_deg = 0;
  /// Largest elevation of the end joint's velocity (over the speed window) at any frame of
  /// the 0.1 s before contact while it moves faster than 1 m/s: a hook shows here even when
  /// the last window is level. 0 when it never moves that fast.
  double approach_max_elevation_deg = 0;
  double end_to_target_m = 0;   ///< |end joint - target|
};
/// The limb of `effector` at `frame` toward `target_m` (room frame). half_window frames back
/// for the approach velocity (clamped at frame 0).
LimbAtContact limb_at_contact(const JointTrack& track, const Effector& effector, int frame,
                              const Eigen::Vector3d& target_m, int half_window);

struct FlipOptions {
  double max_turn_deg = 90;
  double window_s = 1.0 / 30;  ///< compare with the frames up to this far back (4 at 120 Hz, 2 at 60 Hz)
  double min_bend_deg = 20;
};
struct LimbFlip {
  int frame = -1;
  int side = 0;
  bool leg = false;  ///< false: elbow, true: knee
  double turn_deg = 0;
};
std::vector<LimbFlip> find_limb_flips(const JointTrack& track, FrameRange range, const FlipOptions& options = {});
/// The largest bend-plane turn within the window (deg) over `range`: [0] elbows, [1] knees
/// (0 when a limb is never bent enough to have a plane).
std::array<double, 2> max_limb_turn_deg(const JointTrack& track, FrameRange range, const FlipOptions& options = {});

/// Every figure above for one range of one track (contacts given per frame and side).
struct TrackFigures {
  SpeedStats speed;
  std::vector<Snap> snaps;
  std::array<FootFigure, 2> slide{}, stepping{};  ///< [side]
  /// compare_strike's output only: horizontal speed of a foot the source has standing flat
  /// while the output has it off the floor (a step or a late landing the source does not
  /// make: not a skate, but the foot is not where the source has it). `slide` then counts the
  /// frames where the output foot is down too; `slide_source_contacts` every source-contact
  /// frame (both together: lifted or skating), as the figure was first defined.
  std::array<FootFigure, 2> lifted{}, slide_source_contacts{};
  std::vector<LimbFlip> flips;
  std::array<double, 2> max_turn_deg{0, 0};  ///< [0] elbows, [1] knees (max_limb_turn_deg)
  int knee_flips() const;
  int elbow_flips() const;
  double max_slide_mps() const;     ///< max over both feet (NaN when neither qualified)
  double max_lifted_mps() const;    ///< the same of `lifted`
  double max_slide_source_contacts_mps() const;  ///< the same of `slide_source_contacts`
  double max_stepping_mps() const;  ///< max over the given feet (NaN when none qualified)
};
struct FigureOptions {
  SnapOptions snaps;
  FlipOptions flips;
  double window_s = 1.0 / 30;
  std::array<bool, 2> stepping_feet{true, true};  ///< feet whose stepping peak counts
};
TrackFigures track_figures(const JointTrack& track, FrameRange range, const FootContacts& contacts, double scale,
                           const FigureOptions& options = {});

// ---- strikes --------------------------------------------------------------------------------

/// The measurement grid: characters x the four strike orders x targets. Targets are in the
/// character ground frame of record_strike (root on the floor at the origin, facing +Z).
struct StrikeCase {
  int character = 0;  ///< index into the rigs given to quality_grid
  OrderKind order = OrderKind::punch_right;
  Eigen::Vector3d target_m{0, 0, 0};
};
/// Punches at the character's rest head-joint height (Rig::rest_pose, feet on y = 0), kicks at head height - 0.45 m (the torso, as
/// BehaviourTunables::kick_target_drop_m); distance in front (z) spread evenly over
/// 0.45..0.65 x stature, lateral offset (x) from -0.10 to +0.10 x stature in a fixed
/// low-discrepancy order (i * 0.618... mod 1). Stature = Rig::morphology.height_m.
std::vector<StrikeCase> quality_grid(std::span<const Rig> characters, int targets_per_order);

/// One strike compared with its source. Output = the read-back BVH; source = the source clip
/// (mirrored when the segment is) over the same frames. Mapping: output frame k shows source
/// frame source_first + round(rate * (k - output_first)) (same frame rate, checked). The output frames
/// before output_first are the rest pose; the blend-in (FighterConfig::blend_time_s after
/// output_first) cross-fades rest into the strike, and the blend-out into the rest clip
/// happens over the segment's last blend_time_s, so every compared frame has a source frame.
struct StrikeComparisonInput {
  const JointTrack* output = nullptr;
  const JointTrack* source = nullptr;
  int output_first = 0, output_last = 0;  ///< output frames compared
  int source_first = 0;                   ///< source frame of output_first
  /// Source frames per output frame (a strike played slower: StrikeRateSolver), after the
  /// first `rate_lead` frames played at the clip's own rate (kStrikeRateDelayUpdates). Output
  /// frame k = output_first + j shows source frame source_first + j for j <= rate_lead, then
  /// source_first + rate_lead + round(rate * (j - rate_lead)).
  double rate = 1;
  int rate_lead = 0;
  int contact_frame = 0;                  ///< output frame of contact
  Effector effector;
  Eigen::Vector3d target_m{0, 0, 0};      ///< room frame of the output
  double speed_scale = 1;                 ///< output leg length / source leg length
};
struct StrikeQuality {
  /// Compared frames. The source's foot figures are scaled by speed_scale; its joint speeds
  /// are measured on the source laid on the output's bones (lay_on_bones) when the two
  /// skeletons have the same joints, else scaled by speed_scale (`source_speed_on_output_bones`).
  TrackFigures output, source;
  /// The source's joint speeds over the compared frames scaled by speed_scale alone (leg
  /// length): the baseline before 28 Nov, kept beside the other. It misjudges a character whose
  /// arms are longer for its legs than the source actor's (bruno: arm / leg 0.75 against 0.58;
  /// his fists move 14 % faster than the leg scale says on the same joint angles).
  SpeedStats source_speed_leg_scaled;
  bool source_speed_on_output_bones = false;
  /// The whole output clip [0, frames - 1] (rest frames, strike, and the tail after it) with
  /// the output's own geometric contacts: what a viewer of the whole BVH sees.
  TrackFigures whole;
  /// The output frames after the compared ones (record_strike keeps going until the fighter
  /// rests: recovery, then following back to its spot with procedural steps), geometric
  /// contacts. Empty range (and default figures) when there is none.
  TrackFigures tail;
  LimbAtContact output_contact, source_contact;
  /// s with both feet off the floor (both_feet_off, 3 cm): the output over the compared frames
  /// against its floor levels over the whole BVH (it starts standing in the rest pose), the
  /// source over its compared frames against its own levels there. A hop the source makes,
  /// played at `rate`, lasts 1/rate as long; anything beyond is a foot held off the floor
  /// where the source stands (a float).
  double output_both_feet_off_s = 0, source_both_feet_off_s = 0;
  /// output_both_feet_off_s - source_both_feet_off_s / rate: the time the output holds both
  /// feet off that the source (at the rate played) does not.
  double both_feet_off_excess_s = 0;
  /// m: how far the output's toes go below where they stand at frame 0 (the rest pose, feet
  /// flat) over the compared frames, the deeper foot: a foot pitched onto its toes while its
  /// ankle is held low pushes them through the floor.
  double toe_below_standing_m = 0;
  FrameRange output_range, source_range, tail_range;
  double speed_scale = 1;
};
/// The source's joint positions over frames [range] as they would be on `bones`' body: every
/// bone of `source` laid along its own direction in the room, at the length of the same bone
/// of `bones` (|offset|), the root's way scaled by `root_scale` (leg length: a stride). The
/// source's joint speeds as the same motion would move the output character's joints, found by
/// a path of its own (no retargeting or decode of the content library). Empty when the two
/// skeletons' joints differ (joint count, parents or end sites); frames outside `range` are
/// left at zero. For bones whose rest directions agree this is the source's local rotations on
/// `bones`' offsets (checked: CMU 135 on bruno, p99 identical to 0.01 m/s).
std::vector<Eigen::Vector3d> lay_on_bones(const JointTrack& source, const Skeleton& bones, double root_scale,
                                          FrameRange range);

/// Support and stepping feet are judged from the SOURCE clip's geometric contacts (floor levels
/// over the compared source frames) mapped onto the output frames; the effector leg of a kick does
/// not count as a stepping foot. Source contact limb: at the source frame of contact, toward
/// the source's own hit point direction (its end joint's position there: folded is judged
/// against where the source actually struck).
StrikeQuality compare_strike(const StrikeComparisonInput& in, const FigureOptions& options = {});

/// The source clip of a database segment as a viewer would see the raw mocap:
/// <motions_dir>/<clip_name>.bvh, mirrored with mirror_clip when the segment is a mirrored
/// copy. Throws kumite::Error naming the file when it is missing.
Clip load_source_clip(const std::string& clip_name, bool mirrored, const std::filesystem::path& motions_dir);

/// The comparison of a strike recorded by record_strike (`rec`, database `db`), drawn as
/// `output` (its BVH read back) with its source clip `source` (load_source_clip). Mapping:
/// record_strike's frame 0 is the rest pose, the request is sent at frame 1 and the strike
/// source starts on the next update, so output frame k shows source frame
/// rec.source_start_frame + (k - first) with first = contact_frame - (plan.contact_frame -
/// plan.start_frame) (= 1); compared frames end at the segment's last frame or the output's.
/// speed_scale = output_leg_m / source_leg_m (hip -> ankle along the bones, measure_proportions).
/// Throws kumite::Error when no strike happened (rec.contact_frame < 0).
StrikeComparisonInput strike_comparison_input(const Database& db, const StrikeRecording& rec, OrderKind order,
                                              const JointTrack& output, const JointTrack& source,
                                              double output_leg_m, double source_leg_m);
Effector effector_of_order(OrderKind order);  ///< punch_left -> left arm, ..., kick_right -> right leg

}  // namespace kumite::content
