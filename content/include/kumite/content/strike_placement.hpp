#pragma once
// Placing a strike's clip in the room (strike_placement.cpp): free functions over explicit
// inputs, run when a strike (or a block) is about to start. The clip is moved on the floor
// onto the foot it stands on (align_to_support_foot) and its floor travel scaled so that the
// limb lands on the target as extended as captured (place_strike_travel); they write only the
// source they are given and the caller's scratch pose.
#include <array>

#include <Eigen/Core>

#include "kumite/content/adaptation.hpp"
#include "kumite/content/canonical.hpp"
#include "kumite/content/database.hpp"
#include "kumite/content/mkm.hpp"
#include "kumite/content/motion_player.hpp"
#include "kumite/content/tunables.hpp"

namespace kumite::content {

/// The feet a strike is placed on: which are held, and where their ankles stand (m, room).
struct HeldFeet {
  std::array<bool, 2> held{};
  std::array<bool, 2> stepping{};  ///< in a procedural step (not held): it may be cut short
  std::array<Eigen::Vector3d, 2> ankle_m{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  std::array<Eigen::Vector3d, 2> step_end_m{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};  ///< m, room: where it puts it down
};

/// How a strike placed by place_strike_travel lands on its target.
struct StrikeFit {
  double shortfall_m = 0;  ///< m the fighter would have to step in for the limb to reach the target as extended as captured
  double too_near_m = 0;   ///< m the limb's root is nearer the target than the clip has it from its own hit point
  double extension = 1;    ///< limb root to target over the limb's length at contact (1: straight)
  /// The foot the strike is aligned on while it is in a procedural step (the clip stands on
  /// it from its start, or puts it down on the way and keeps it down to contact:
  /// align_to_support_foot), -1 for none: the step ends where the foot is
  /// when the strike starts (FootPlanter::land), and it stands there.
  int landing_support = -1;
  /// The foot the strike is aligned on while it is in a procedural step too far from where the
  /// clip has it to carry the clip there (max_support_shift_m): its step goes on to where the
  /// clip, carried as far as it goes, stands on it (FootPlanter::redirect), -1 for none.
  int redirect_support = -1;
  Eigen::Vector3d redirect_to_m{0, 0, 0};  ///< m, room: where that step then ends
};

/// What placing a strike reads.
struct StrikePlacement {
  const Database* db = nullptr;
  const MotionPlayer* player = nullptr;  ///< samples the source (its stride scale, its travel)
  const Rig* rig = nullptr;              ///< the character
  const BehaviourTunables* tunables = nullptr;
  /// m, room: the strike's target (nullptr: none; the clip is then placed by its pelvis and
  /// its travel left as captured).
  const Eigen::Vector3d* target_m = nullptr;
  const HeldFeet* feet = nullptr;
  /// A decoded pose to work in (its room kept: placing a strike allocates nothing once warm).
  CanonicalPose* scratch = nullptr;
};

/// The clip, placed by its pelvis, shifted on the floor (s.placement.origin_xz) so that its
/// support foot (planted at the start and staying down longest) lands where that foot is held
/// now. Returns the foot aligned that is in a procedural step now (to be put down where it
/// is), else -1. With `redirect`: a stepping foot the clip stands on too far away to carry the
/// clip to may be aligned on with its step sent on to the clip (StrikeFit::redirect_support, _to_m).
int align_to_support_foot(const StrikePlacement& in, PlaybackSource& s, double contact_time_s, StrikeFit* redirect = nullptr);

/// The floor travel (m, room) of a strike source's root from its time to contact_time_s, as
/// placed with its travel as it is; `contact_pose`: the pose at contact.
Eigen::Vector2d strike_travel(const MotionPlayer& player, const PlaybackSource& s, double contact_time_s, MkmFrame& contact_pose);

/// The clip's floor travel up to contact scaled (s.travel: a shorter or longer lunge) so that
/// at contact the limb's root is as far from the target as the clip has it from its own hit
/// point; a punch's pelvis raised toward a high target. Returns how the limb then lands.
StrikeFit place_strike_travel(const StrikePlacement& in, PlaybackSource& s, double contact_time_s);

}  // namespace kumite::content
