#pragma once
// The fighter's reel under a blow it took (spar mode; behaviour_hit.cpp): per chain (trunk,
// head, each shoulder) a damped spring on a rotation vector, laid on the composed pose before
// the decode, and the spot a large blow steps the fighter back to. The HitReel is the only
// owner of the springs, the reeled pose and that spot; Behaviour hands it the blow, the drawn
// joints, the time step and the pose, and decides what else a blow does (a strike aborted).
#include <array>
#include <optional>
#include <span>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "kumite/common/time.hpp"
#include "kumite/content/adaptation.hpp"
#include "kumite/content/mkm.hpp"

namespace kumite::content {

/// A blow the fighter took (the Fighter's contact judgement, spar mode): the visitor's fist or
/// foot entered its drawn head or torso.
struct HitOrder {
  Eigen::Vector3d point_m{0, 0, 0};        ///< m, room: where the fist entered the body
  Eigen::Vector3d velocity_mps{0, 0, 0};   ///< m/s, room: the fist's
  bool head = false;                       ///< the head was struck (else the torso)
  double share = 0;                        ///< 0..1: the blow's size (0: nothing happens)
  double head_max_rad = 0.26, trunk_max_rad = 0.14, shoulder_max_rad = 0.21;  ///< rad, each chain's reel at share 1
  double stiffness_rad_s = 10;             ///< rad/s, the spring's undamped angular frequency
  double damping_ratio = 0.8;              ///< 0.4..1
  double step_back_m = 0;                  ///< m stepped back (0: none)
  /// A lean the fighter makes itself (a slip), not a blow: each chain is driven from where it
  /// is toward its angle at share 1 (critically damped at stiffness_rad_s), held there for
  /// hold_s, then let back. It starts from rest, where a blow's push starts at its full speed
  /// (a slip pushed so jumped a parrying hand 6 cm in one frame: the spar demo, seeds 3 and 5).
  bool driven = false;
  double hold_s = 0;                       ///< s: a driven lean is held this long from its start
};

/// The reel under way: the head, trunk and shoulders' rotation vectors (rad, room frame: axis
/// times angle) at the last update; all zero when none is.
struct ReelState {
  bool active = false;
  Eigen::Vector3d trunk{0, 0, 0}, head{0, 0, 0};
  std::array<Eigen::Vector3d, 2> shoulder{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
};

class HitReel {
 public:
  /// A blow: each struck chain pushed so that the struck point first moves along the blow
  /// (the head about the neck, the trunk about the pelvis, the struck side's shoulder when a
  /// torso blow lands off the midline). `drawn`: the joints drawn at the last update on `rig`
  /// (m, room). False (nothing changed): a share of 0, or a value not finite.
  bool take(const HitOrder& order, const Rig& rig, std::span<const Eigen::Vector3d> drawn);
  /// The springs advanced by dt (stepped exactly: the same numbers at any frame rate's steps);
  /// a reel that has died down ends.
  void advance(double dt);
  /// `pose` with the reel laid on (the trunk, head and shoulder girdles turned, the arms with
  /// their shoulders), kept here until the next update; nullptr when no reel is under way.
  const MkmFrame* lay(const MkmFrame& pose);
  ReelState state() const;

  /// The spot (m, room) a large blow steps the fighter back to; none once arrived or given up.
  const std::optional<Eigen::Vector2d>& step_back() const { return step_back_; }
  void step_back_to(const Eigen::Vector2d& goal_xz, Timestamp until);
  /// Given up once `now` is past the time step_back_to set.
  void give_up_step_back(Timestamp now) {
    if (step_back_ && now > step_back_until_) step_back_.reset();
  }
  void end_step_back() { step_back_.reset(); }

 private:
  struct Springs {
    bool active = false;
    std::array<Eigen::Vector3d, 4> theta{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
    std::array<Eigen::Vector3d, 4> rate{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
    /// A driven lean's angles (rad, room; zero: none, or let back) and how long they are held.
    std::array<Eigen::Vector3d, 4> target{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
    double hold_s = 0;
    double stiffness_rad_s = 10, damping_ratio = 0.8;
    double since_s = 0;  ///< s since the last blow (or driven lean)
  } springs_;  ///< per chain (trunk, head, left shoulder, right shoulder) a rotation vector (rad, room) and its rate
  MkmFrame reeled_;  ///< the pose with the reel laid on (lay())
  std::optional<Eigen::Vector2d> step_back_;
  Timestamp step_back_until_ = 0;  ///< s: given up then
};

}  // namespace kumite::content
