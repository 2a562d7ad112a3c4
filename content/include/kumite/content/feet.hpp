#pragma once
// The fighter's feet (feet.cpp): the only writer of where each foot is held (its FootPlanter),
// of the held feet handed to the decode (FootLocks) and of the bounds on the pelvis drop.
// Each update it reads what the motion now playing says of each foot (contact, lift, the
// landing of a swing and the way left to it, its own step), walks a swing's way once when the
// swing begins, and keeps the pelvis drop changing at a bounded rate and acceleration.
// Behaviour gives it the update's inputs (FeetInput), asks it for a step or a landing where a
// strike or a step before one wants it, and hands its FootLocks to AdaptJob.
#include <array>
#include <limits>
#include <memory>
#include <span>

#include <Eigen/Core>

#include "kumite/content/adaptation.hpp"
#include "kumite/content/database.hpp"
#include "kumite/content/foot_planting.hpp"
#include "kumite/content/motion_player.hpp"
#include "kumite/content/tunables.hpp"

namespace kumite::content {

/// One update's inputs to the feet: the motion, the pose as drawn at the last update and as
/// composed now, what the strike under way asks of them, and whether a foot may step.
struct FeetInput {
  double dt_s = 0;
  bool have_pose = false;         ///< a pose was drawn before (false: nothing is held yet)
  const Rig* rig = nullptr;       ///< the current character
  int character = 0;              ///< its index (a swing's way is walked again on another)
  const MotionPlayer* player = nullptr;  ///< the motion playing (its current source)
  const MkmFrame* motion = nullptr;      ///< the current source alone at this update (its contacts)
  const MkmFrame* pose = nullptr;        ///< the pose composed at this update (the cross-fade, the guard)
  std::span<const Eigen::Vector3d> drawn_m;  ///< m, room: the joints the decode drew at the last update
  const AdaptReport* report = nullptr;   ///< the last update's decode
  /// A character switch on this update: the hip drawn last is the old body's, so each leg
  /// hangs from the new body's hip as `pose` places it.
  bool switched = false;
  /// The foot a stance step from the mocap stands on throughout (-1: none): held, pivoting.
  int stance_support = -1;
  /// A strike of its own on its way to contact: a foot its clip puts down and keeps down
  /// through contact is held where the clip has it at contact (`effector`'s leg excepted).
  bool before_contact = false;
  Effector effector;
  double clip_contact_time_s = 0;  ///< s, segment time of the clip's contact frame
  /// The kicking leg while d(t) acts on it (-1: none); `kick_striking`: its clip is the one
  /// playing (it is never held down anew then).
  int kick_side = -1;
  bool kick_striking = false;
  double reach_ramp = 0;  ///< d(t)'s weight at this update (the kicking foot's hold eases out with it)
  /// A punch under way with d(t): its arm (-1: none) and how low its shoulder may go for held
  /// feet (m, room: the target within the arm's reach at max_punch_aim_deg).
  int punch_side = -1;
  double lowest_shoulder_y_m = -std::numeric_limits<double>::infinity();
  bool may_step = false;                 ///< a foot may begin a procedural step
  Eigen::Vector2d spot_velocity_mps{0, 0};  ///< m/s of the rest spot (steps lead with it)
};

class Feet {
 public:
  Feet(std::shared_ptr<const Database> db, const BehaviourTunables& tunables);

  /// The update's feet: each foot's sample handed to the planter, the held feet and the
  /// bounds on the pelvis drop made for this update's decode (locks()).
  void update(const FeetInput& in);
  /// After the decode: the pelvis drop it drew (m), for the next update's bounds.
  void drew(bool had_pose, double dt_s, double root_drop_m);

  /// The held feet and the pelvis drop's bounds for this update's decode.
  const FootLocks& locks() const { return locks_; }
  const FootPlanter& planter() const { return planter_; }
  FootPlanter::Phase phase(int side) const { return planter_.phase(side); }
  bool held(int side) const { return planter_.held(side); }
  bool settled(int side) const { return planter_.settled(side); }
  const Eigen::Vector3d* step_end(int side) const { return planter_.step_end(side); }
  const FootPlantingTunables& tunables() const { return planter_.tunables(); }

  /// Commands (FootPlanter's): nothing held; only held feet kept (a character switch); a
  /// foot stepped to `to`, a step under way sent on to `to`, a step put down where it is.
  void reset() { planter_.reset(); }
  void keep_held_only() { planter_.keep_held_only(); }
  bool step_to(int side, const Eigen::Vector3d& to) { return planter_.step_to(side, to); }
  bool redirect(int side, const Eigen::Vector3d& to, double peak_speed_mps) { return planter_.redirect(side, to, peak_speed_mps); }
  void land(int side) { planter_.land(side); }

 private:
  /// s until the motion now playing puts this foot down again.
  double swing_left_s(const FeetInput& in, int side) const;
  /// The segment frame whose ankle a foot the motion puts down at its frame `land` is held at.
  int hold_frame(const FeetInput& in, int side, int land) const;
  /// Each foot's sample handed to the planter (locks_ made anew).
  void plant(const FeetInput& in);
  /// The kicking foot's hold eased out with d(t), and the pelvis drop's bounds.
  void bound_drop(const FeetInput& in);

  std::shared_ptr<const Database> db_;
  double blend_time_s_ = 0;       ///< s, the cross-fade into the rest after a clip
  double max_root_drop_m_ = 0;    ///< m (BehaviourTunables)
  double max_drop_rate_mps_ = 0;
  double max_drop_accel_mps2_ = 0;
  FootPlanter planter_;
  FootLocks locks_;
  double last_drop_m_ = 0;    ///< m: the pelvis drop drawn at the last update (as bound_drop read it)
  double drop_rate_mps_ = 0;  ///< m/s: how fast the pelvis drop changed at the last update
  bool switched_ = false;     ///< this update is a character switch's (bound_drop)
  /// Per foot, the landing of the swing under way and the source ankle's horizontal way left to
  /// it: walked once when a swing (or the motion that plays it) begins, then reduced by each
  /// update's own step, so a swing costs one pass over its frames rather than one per update.
  struct SwingPath {
    int segment = -1;        ///< -1: none
    int character = -1;
    /// The segment frame of the landing (its time clamped to the clip: a foot that stays up to
    /// the clip's end lands on its last frame, whatever the rate the rest after it is played at).
    int land_frame = 0;
    /// The segment frame whose ankle it is held at once down (hold_frame: land_frame, or a
    /// strike's contact frame).
    int hold_frame = 0;
    GroundFrame placement;
    Eigen::Vector2d anchor_xz_m{0, 0};
    PlaybackSource::Travel travel;
    Eigen::Vector3d landing_m{0, 0, 0};  ///< m, room: the ankle at the landing
    Eigen::Vector3d last_m{0, 0, 0};     ///< m, room: the source ankle at the last update
    double way_left_m = 0;               ///< m, horizontal path from last_m to the landing
  };
  std::array<SwingPath, 2> swing_paths_{};
};

}  // namespace kumite::content
