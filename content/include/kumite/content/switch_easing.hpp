#pragma once
// A character switch's easing (switch_easing.cpp): the new body's joints start from the old
// drawn pose, an offset per joint fading to zero over the blend time. The only owner of the
// offsets and their clock; Behaviour keeps the old drawn joints before a switch, starts the
// easing on the switch and has the drawn joints eased after each decode.
#include <cstddef>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "kumite/content/adaptation.hpp"

namespace kumite::content {

class SwitchEasing {
 public:
  /// Room for `max_joints` joints (the most any character has); `blend_time_s`: the fade.
  SwitchEasing(std::size_t max_joints, double blend_time_s);
  /// The joints drawn at the last update on `rig` (m, room), kept before a switch this update:
  /// the offsets are taken from them (copied into room kept: nothing allocated).
  void keep_drawn(const Rig& rig, std::span<const Eigen::Vector3d> drawn_m);
  /// A switch on this update: the offsets are taken after its decode (ease()).
  void begin() { due_ = true; }
  /// A switch on this update whose offsets are not taken yet.
  bool due() const { return due_; }
  /// The fade's clock advanced by dt (s; not on the switch's own update).
  void advance(double dt_s) {
    if (!due_) elapsed_s_ += dt_s;
  }
  /// After the decode: on a switch's update the offsets from the kept joints (or, none kept,
  /// from `rig_m` itself) to `rig_m`, per joint of `rig` the nearest canonical joint at or above
  /// it carrying one; then out_m = rig_m + offset * the fade's weight, for `rig`'s joints.
  void ease(const Rig& rig, std::span<const Eigen::Vector3d> rig_m, std::span<Eigen::Vector3d> out_m);

 private:
  double blend_time_s_ = 0;
  std::vector<Eigen::Vector3d> offset_m_;     ///< m, per joint of the current rig
  std::vector<Eigen::Vector3d> old_drawn_m_;  ///< m, room: keep_drawn's joints
  const Rig* old_rig_ = nullptr;              ///< their rig (nullptr: none kept this update)
  double elapsed_s_ = 1e9;  ///< s since the offsets were taken (long ago: no easing)
  bool due_ = false;
};

}  // namespace kumite::content
