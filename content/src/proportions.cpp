#include "kumite/content/proportions.hpp"

#include <fmt/format.h>

#include "kumite/common/error.hpp"

namespace kumite::content {

std::vector<Eigen::Vector3d> rest_positions(const Skeleton& s) {
  std::vector<Eigen::Vector3d> p(s.names.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    const int parent = s.parents[i];
    p[i] = parent < 0 ? s.offsets[i] : Eigen::Vector3d(p[static_cast<std::size_t>(parent)] + s.offsets[i]);
  }
  return p;
}

double chain_length(const Skeleton& s, int ancestor, int descendant) {
  double len = 0;
  for (int i = descendant; i >= 0; i = s.parents[static_cast<std::size_t>(i)]) {
    if (i == ancestor) return len;
    len += s.offsets[static_cast<std::size_t>(i)].norm();
  }
  const auto p = rest_positions(s);
  return (p[static_cast<std::size_t>(ancestor)] - p[static_cast<std::size_t>(descendant)]).norm();
}

Proportions measure_proportions(const Skeleton& s) {
  using CJ = CanonicalJoint;
  for (CJ c : {CJ::pelvis, CJ::l_shoulder, CJ::l_elbow, CJ::l_wrist, CJ::r_shoulder, CJ::r_elbow, CJ::r_wrist,
               CJ::l_hip, CJ::l_knee, CJ::l_ankle, CJ::r_hip, CJ::r_knee, CJ::r_ankle}) {
    if (s.index(c) < 0 || s.index(c) >= s.joint_count()) {
      throw Error("skeleton", "canonical",
                  fmt::format("measure_proportions: canonical joint {} is not mapped (call map_canonical)", to_string(c)));
    }
  }
  auto len = [&](CJ a, CJ b) { return chain_length(s, s.index(a), s.index(b)); };
  const auto rest = rest_positions(s);
  auto at = [&](CJ c) { return rest[static_cast<std::size_t>(s.index(c))]; };
  Proportions p;
  double lo = 1e300, hi = -1e300;
  for (const auto& q : rest) {
    lo = std::min(lo, q.y());
    hi = std::max(hi, q.y());
  }
  p.stature_m = hi - lo;
  p.upper_arm_m = 0.5 * (len(CJ::l_shoulder, CJ::l_elbow) + len(CJ::r_shoulder, CJ::r_elbow));
  p.forearm_m = 0.5 * (len(CJ::l_elbow, CJ::l_wrist) + len(CJ::r_elbow, CJ::r_wrist));
  p.arm_m = p.upper_arm_m + p.forearm_m;
  p.thigh_m = 0.5 * (len(CJ::l_hip, CJ::l_knee) + len(CJ::r_hip, CJ::r_knee));
  p.shin_m = 0.5 * (len(CJ::l_knee, CJ::l_ankle) + len(CJ::r_knee, CJ::r_ankle));
  p.leg_m = p.thigh_m + p.shin_m;
  const CJ top = s.index(CJ::neck) >= 0 ? CJ::neck : CJ::head;
  if (s.index(top) >= 0) p.torso_m = len(CJ::pelvis, top);
  p.shoulder_width_m = (at(CJ::l_shoulder) - at(CJ::r_shoulder)).norm();
  p.hip_width_m = (at(CJ::l_hip) - at(CJ::r_hip)).norm();
  p.pelvis_height_m = at(CJ::pelvis).y() - lo;
  // Standing straight: head top = the highest joint in the head's subtree (or the head).
  const int head = s.index(CJ::head) >= 0 ? s.index(CJ::head) : s.index(top);
  int head_top = head;
  for (int j = head + 1; head >= 0 && j < s.joint_count(); ++j) {
    for (int a = j; a >= 0; a = s.parents[static_cast<std::size_t>(a)]) {
      if (a == head) {
        if (rest[static_cast<std::size_t>(j)].y() > rest[static_cast<std::size_t>(head_top)].y()) head_top = j;
        break;
      }
    }
  }
  const double upper = head >= 0 ? chain_length(s, s.index(CJ::pelvis), head_top) : 0;
  const double hip_drop = 0.5 * ((at(CJ::pelvis) - at(CJ::l_hip)).y() + (at(CJ::pelvis) - at(CJ::r_hip)).y());
  const double ankle_height = 0.5 * (at(CJ::l_ankle).y() + at(CJ::r_ankle).y()) - lo;
  p.standing_height_m = upper + hip_drop + p.leg_m + ankle_height;
  return p;
}

}  // namespace kumite::content
