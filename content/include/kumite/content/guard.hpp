#pragma once
// The fighter's guard and parries (spar with blocks on): arm directions laid on the composed
// pose before the decode (behaviour_guard.cpp). The Guard is the only owner of the guard's
// progress, the arms as it drew them and the parries under way; Behaviour tells it whether
// the guard may be up and hands it the pose, the drawn joints and the time step.
#include <algorithm>
#include <array>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "kumite/common/time.hpp"
#include "kumite/content/adaptation.hpp"
#include "kumite/content/fighter.hpp"
#include "kumite/content/mkm.hpp"

namespace kumite::content {

/// A block against a fist seen coming (the Fighter's defence, spar mode): Behaviour::block
/// plays a block clip for it, Behaviour::parry (Guard::parry) moves a forearm from the guard.
struct BlockOrder {
  recognition::Role limb = recognition::Role::right_hand;
  Eigen::Vector3d fist_m{0, 0, 0};         ///< m, room: the fist now
  Eigen::Vector3d velocity_mps{0, 0, 0};   ///< m/s, room
  double arrival_s = 0;                    ///< s from now until it reaches the body (ThreatWatch)
  bool recognised = false;
  double max_rate = 2.0;                   ///< segment s per s the block may be played at to be in place in time
};

/// The guard (both forearms raised before the face and chest, eased in over 0.4 s and out over
/// 0.15 s) and a parry per arm (a minimum-jerk move of the wrist across the fist's path, held
/// until the fist has passed, eased back to the guard).
class Guard {
 public:
  /// Wanted: spar with blocks on (the Fighter sets it every update).
  void want(bool on) { wanted_ = on; }
  /// The guard's weight at the last update (0: the motion's own arms, 1: the guard).
  double weight() const { return weight_; }
  /// Drawn, and up far enough to parry from.
  bool up() const;
  /// An arm is free (not moving to a parry or holding one).
  bool arm_free() const;
  /// A parry is moving to its place or held there.
  bool parrying() const;
  /// A parry against `order`: the free forearm that can be across the fist's path soonest is
  /// sent there. `drawn`: the joints drawn at the last update on `rig` (m, room); `chest`: the
  /// composed pose's chest frame. False: no free arm reaches the path, or the order is not finite.
  bool parry(const BlockOrder& order, Timestamp now, const Rig& rig, std::span<const Eigen::Vector3d> drawn,
             const Eigen::Quaterniond& chest);
  /// The parry of the arm answering `order.limb` (moving to its place or held there) re-aimed
  /// at `order`'s path: the wrist's and elbow's targets move to the new crossing by a
  /// minimum-jerk shift laid on the way under way (no restart: the drawn arm keeps its place
  /// and speed at that moment); the forearm is in place, and the hold ends, from the new
  /// crossing's timing. False: no such parry, or no place on the new path within the arm's reach.
  bool reaim(const BlockOrder& order, Timestamp now, const Rig& rig, std::span<const Eigen::Vector3d> drawn,
             const Eigen::Quaterniond& chest);
  /// Advances the guard and the parries by dt and lays them on `pose`'s arms. `allowed`: the
  /// guard may be up (not paused, no strike of its own); `drawn_before`: a pose was drawn
  /// before this update (`drawn` holds its joints). A parry whose forearm comes in place
  /// appends its block event to `events`.
  void lay(double dt, Timestamp now, bool allowed, bool drawn_before, const Rig& rig, std::span<const Eigen::Vector3d> drawn,
           MkmFrame& pose, std::vector<FighterEvent>& events);

 private:
  /// A parry of one arm.
  struct Parry {
    bool on = false;
    double t_s = 0;           ///< s since it began
    double move_s = 0;        ///< s the wrist takes to its place
    double hold_end_s = 0;    ///< s (since it began) it starts back to the guard
    double back_s = 0.3;      ///< s back to the guard (timed along its way as it starts)
    bool back_timed = false;  ///< back_s taken for the way back (Guard::lay, at hold_end_s)
    Eigen::Vector3d from_arm_n{0, 0, 0}, from_pole{0, 0, 0};  ///< the arm as drawn when it began
    Eigen::Vector3d wrist_m{0, 0, 0};   ///< m, room: the wrist in place
    Eigen::Vector3d elbow_m{0, 0, 0};   ///< m, room: where the elbow is wanted in place
    Eigen::Vector3d cross_m{0, 0, 0};   ///< m, room: where the fist's path crosses the forearm
    /// A re-aim: the targets (m, room) shift from these to wrist_m / elbow_m over reaim_s from
    /// reaim_t_s (s since the parry began; negative: never re-aimed).
    Eigen::Vector3d wrist_from_m{0, 0, 0}, elbow_from_m{0, 0, 0};
    double reaim_t_s = -1, reaim_s = 0;
    bool said = false;        ///< its block event emitted
    Timestamp meet_t = 0;     ///< s: when the fist is due at the forearm
    /// From when the fist is due, the place is held with the body, not the room: these (m, from
    /// the shoulder) are the wrist's and elbow's targets as they stood then (carried: taken).
    bool carried = false;
    Eigen::Vector3d wrist_carried_m{0, 0, 0}, elbow_carried_m{0, 0, 0};
    /// The phase the last update drew (0 to its place, 1 held, 2 back; -1: none yet).
    int turn_phase = -1;
    /// rad: the elbow's pole's turn about the wrist's direction over that phase's way as drawn
    /// at the last update; the next update in the same phase takes the turn nearest it.
    double pole_turn_rad = 0;
    recognition::Role limb = recognition::Role::right_hand;
    bool recognised = false;
    double fist_speed_mps = 0;
    /// Moving to its place or held there (not going back).
    bool busy() const { return on && t_s < hold_end_s; }
    /// s since it began when the forearm is in place (its move done, and any re-aim's shift).
    double in_place_s() const { return reaim_t_s >= 0 ? std::max(move_s, reaim_t_s + reaim_s) : move_s; }
    /// m, room: the wrist's and elbow's targets at t_s (shifting during a re-aim).
    Eigen::Vector3d wrist_target() const;
    Eigen::Vector3d elbow_target() const;
  };
  bool wanted_ = false;
  double up_ = 0;       ///< 0..1 the guard's progress (its weight is smoothstep(up_))
  double weight_ = 0;   ///< the weight drawn at the last update
  std::array<Eigen::Vector3d, 2> last_arm_n_{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};  ///< [side] as drawn last
  std::array<Eigen::Vector3d, 2> last_arm_pole_{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  bool have_last_ = false;
  std::array<Parry, 2> parry_{};
};

}  // namespace kumite::content
