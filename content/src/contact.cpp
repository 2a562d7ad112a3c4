// Judging a strike's contact (contact.hpp).
#include "kumite/content/contact.hpp"

#include <algorithm>

#include "kumite/content/fighter.hpp"

namespace kumite::content {

using Eigen::Vector3d;

namespace {
double distance_to_segment(const Vector3d& p, const Vector3d& a, const Vector3d& b) {
  const Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double u = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (p - (a + u * ab)).norm();
}
}  // namespace

VisitorShape VisitorShape::of(const FighterConfig& config, const Vector3d& head_m) {
  VisitorShape v;
  v.head_m = head_m;
  v.head_radius_m = config.visitor_head_radius_m;
  v.body_radius_m = config.visitor_body_radius_m;
  v.neck_m = config.visitor_neck_m;
  v.capsule_bottom_m = config.visitor_capsule_bottom_m;
  return v;
}

ContactJudgement judge_strike_contact(const ContactInput& in) {
  ContactJudgement j;
  j.target_distance_m = (in.hit_point_m - in.target_m).norm();
  j.target_reached = j.target_distance_m <= in.hit_radius_m;
  const VisitorShape& v = in.visitor;
  const Vector3d top = v.head_m - Vector3d::UnitY() * v.neck_m;
  const Vector3d bottom(v.head_m.x(), std::min(top.y(), v.capsule_bottom_m), v.head_m.z());
  j.body_distance_m = std::min((in.hit_point_m - v.head_m).norm() - v.head_radius_m,
                               distance_to_segment(in.hit_point_m, top, bottom) - v.body_radius_m);
  j.hit = j.body_distance_m <= 0;
  return j;
}

}  // namespace kumite::content
