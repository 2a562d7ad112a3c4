#pragma once
// Threats: the visitor's fists and feet seen coming at the fighter, from the tracked bodies
// alone (no recognised class needed: on boxers the recogniser never saw it found 8 of 19
// punches), or from a recognised strike's predicted impact point.
//
// Per limb the watch keeps the last measured positions (their own timestamps, each measurement
// once). A limb threatens when, over the last `velocity_window_s` of measurements, it moves at
// least `min_speed_mps` relative to the visitor's head (a walk carries the hands with the head:
// not a threat), and its straight path from where it is now (extrapolated from its measurement
// to `now`) comes within `aim_radius_m` of the fighter's head-to-pelvis segment within
// `horizon_s`, closing on it at least `min_closing_mps`; with `min_extension`, a fist also only
// while it moves away from the visitor's shoulders (the arm extends, as in a straight punch). Recognised strike
// begins add the limb's path toward the predicted impact point (the recogniser's early word,
// before the fist is fast). Everything in the room frame: metres, seconds.
#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include <Eigen/Core>

#include "kumite/common/time.hpp"
#include "kumite/recognition/recognition.hpp"

namespace kumite::content {

struct VisitorBody;        // fighter.hpp
struct VisitorStrikeSeen;  // planner.hpp

/// [fighter.planner] threat_* keys (units in the names).
struct ThreatTunables {
  double min_speed_mps = 3.0;      ///< m/s: a fist or foot slower than this (relative to the head) is no threat
  double min_closing_mps = 1.5;    ///< m/s: its speed toward the fighter's body
  double horizon_s = 0.4;          ///< s: it arrives within this
  double aim_radius_m = 0.25;     ///< m: its path passes within this of the fighter's head-pelvis line
  double velocity_window_s = 0.05; ///< s of measurements its velocity is fitted over (at least two)
  /// A fist threatens only while it moves away from the middle of the visitor's shoulders (0.22 m
  /// under the tracked head) at least this share of its speed relative to the head: a straight
  /// punch extends the arm; a hand swung round the shoulder (arm circles, a throw's wind-up)
  /// keeps its distance -- and so does a bent arm's rising or hooking fist (the kata's), which
  /// is why it is off by default. 0: any direction. Feet are not held to it.
  double min_extension = 0.0;
  /// Both hands fast (relative to the head) and the one's velocity the other's mirror image in
  /// the vertical plane between them and the fighter, to within this share of the faster's
  /// speed: a two-handed motion (arm circles, a throw, a push), and neither hand threatens
  /// unless recognition says it strikes. A punch moves one hand (the other keeps its guard or
  /// pulls back). 0: off (a two-handed strike is then met too).
  double two_hand_mirror = 0.5;
  bool operator==(const ThreatTunables&) const = default;
};
/// "" when finite and in range, else "key: message".
std::string validate(const ThreatTunables& t);

/// A fist or foot coming at the fighter.
struct Threat {
  recognition::Role limb = recognition::Role::right_hand;
  Eigen::Vector3d point_m{0, 0, 0};       ///< m, room: the limb now (extrapolated to `now`)
  Eigen::Vector3d velocity_mps{0, 0, 0};  ///< m/s, room
  double arrival_s = 0;                   ///< s from now until its path is within aim_radius_m of the body
  double miss_m = 0;                      ///< m: the path's nearest distance to the head-pelvis line (within the horizon)
  Eigen::Vector3d aim_m{0, 0, 0};         ///< m, room: the point of the head-pelvis line it comes nearest
  Timestamp measured_t = 0;               ///< s: the newest measurement it is made from
  bool recognised = false;                ///< from a recognised strike's begin (its impact point), not seen alone
};

class ThreatWatch {
 public:
  explicit ThreatWatch(ThreatTunables t = {}) : tun_(t) {}
  void set_tunables(const ThreatTunables& t) { tun_ = t; }
  const ThreatTunables& tunables() const { return tun_; }
  /// Takes this update's bodies (a measurement already seen, by its time, is not taken twice; a
  /// lost body ends its limb's history) and recognised strikes.
  void observe(std::span<const VisitorBody> bodies, std::span<const VisitorStrikeSeen> strikes);
  /// The threat arriving soonest at the segment `top_m`..`bottom_m` (the fighter's head and
  /// pelvis as drawn) at time `now`, if any; with `only`, that limb's alone.
  std::optional<Threat> soonest(const Eigen::Vector3d& top_m, const Eigen::Vector3d& bottom_m, Timestamp now,
                                std::optional<recognition::Role> only = std::nullopt) const;
  /// The limb's fitted velocity (m/s, room) over the window, if it has two measurements.
  std::optional<Eigen::Vector3d> velocity(recognition::Role role) const;
  void reset();

 private:
  static constexpr int kKeep = 16;
  struct Sample {
    Eigen::Vector3d p{0, 0, 0};
    Timestamp t = 0;
  };
  struct History {
    std::array<Sample, kKeep> ring{};
    int count = 0, next = 0;
    const Sample& newest(int back = 0) const { return ring[static_cast<std::size_t>((next - 1 - back + 2 * kKeep) % kKeep)]; }
  };
  std::optional<Threat> path_threat(const Eigen::Vector3d& p, const Eigen::Vector3d& v, const Eigen::Vector3d& top,
                                    const Eigen::Vector3d& bottom) const;
  /// A fist moving away from the head by min_extension of its relative velocity `rel` (feet,
  /// and a fist with no head measured, always).
  bool extends(recognition::Role role, const Eigen::Vector3d& rel) const;
  /// The mean of the limb's measurements over the velocity window (the fitted line's point at
  /// their mean time), if it has one.
  std::optional<Eigen::Vector3d> window_mean(recognition::Role role) const;
  ThreatTunables tun_;
  std::array<History, recognition::kRoleCount> hist_{};
  /// A recognised strike's begin per limb (cleared by its end or cancel): its impact point.
  std::array<std::optional<Eigen::Vector3d>, recognition::kRoleCount> recognised_{};
};

}  // namespace kumite::content
