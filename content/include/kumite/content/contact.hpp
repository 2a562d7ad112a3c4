#pragma once
// Judging a strike's contact (contact.cpp): at the update that draws contact, whether the hit
// point touched the visitor's body as tracked then (a sphere round the head, a capsule below
// it) and whether it reached the target frozen at the order. A free function over explicit
// inputs: Behaviour hands it the drawn hit point, the target and the visitor's head, writes the
// judgement into its StrikeInfo and emits the event it names (hit, dodged or miss).
#include <Eigen/Core>

#include "kumite/content/event.hpp"

namespace kumite::content {

struct FighterConfig;

/// The visitor's body as tracked at contact: a sphere round the head point and a capsule from
/// below the neck down to a height above the floor (FighterConfig's visitor_* sizes).
struct VisitorShape {
  Eigen::Vector3d head_m{0, 0, 0};  ///< m, room: the tracked head
  double head_radius_m = 0.12;
  double body_radius_m = 0.20;
  double neck_m = 0.25;            ///< m, head point down to the capsule's top
  double capsule_bottom_m = 0.25;  ///< m above the floor: the capsule's bottom
  /// The sizes of `config`, about the tracked head `head_m`.
  static VisitorShape of(const FighterConfig& config, const Eigen::Vector3d& head_m);
};

struct ContactInput {
  Eigen::Vector3d hit_point_m{0, 0, 0};  ///< m, room: the striking limb's hit point as drawn
  Eigen::Vector3d target_m{0, 0, 0};     ///< m, room: the target frozen at the order
  double hit_radius_m = 0.10;            ///< m: the target counts as reached this close
  VisitorShape visitor;
};

struct ContactJudgement {
  double target_distance_m = 0;  ///< m, hit point to the frozen target
  bool target_reached = false;   ///< within hit_radius_m of it
  double body_distance_m = 0;    ///< m, hit point to the visitor's body surface (<= 0: touching)
  bool hit = false;              ///< the hit point touched the visitor's body
  /// The event: hit (touched), dodged (reached the target, the visitor had moved), else miss.
  EventKind kind() const { return hit ? EventKind::hit : target_reached ? EventKind::dodged : EventKind::miss; }
  /// The event's distance: 0 for a hit, else how far the hit point stayed from the body (m).
  double event_distance_m() const { return hit ? 0.0 : body_distance_m; }
};

/// Judged against the visitor as tracked at contact, not the target frozen at the order: a
/// visitor who ducked or stepped away since is not hit.
ContactJudgement judge_strike_contact(const ContactInput& in);

}  // namespace kumite::content
