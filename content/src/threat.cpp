#include "kumite/content/threat.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "kumite/content/fighter.hpp"
#include "kumite/content/planner.hpp"

namespace kumite::content {

using Eigen::Vector3d;

std::string validate(const ThreatTunables& t) {
  const auto bad = [](double x, double lo, double hi) { return !std::isfinite(x) || x < lo || x > hi; };
  if (bad(t.min_speed_mps, 0.1, 50)) return fmt::format("threat_min_speed_mps: {} is not in [0.1, 50] m/s", t.min_speed_mps);
  if (bad(t.min_closing_mps, 0, 50)) return fmt::format("threat_min_closing_mps: {} is not in [0, 50] m/s", t.min_closing_mps);
  if (bad(t.horizon_s, 0.05, 2)) return fmt::format("threat_horizon_s: {} is not in [0.05, 2] s", t.horizon_s);
  if (bad(t.aim_radius_m, 0.05, 1)) return fmt::format("threat_aim_radius_m: {} is not in [0.05, 1] m", t.aim_radius_m);
  if (bad(t.velocity_window_s, 0.005, 0.5))
    return fmt::format("threat_velocity_window_s: {} is not in [0.005, 0.5] s", t.velocity_window_s);
  if (bad(t.min_extension, 0, 1)) return fmt::format("threat_min_extension: {} is not in [0, 1]", t.min_extension);
  if (bad(t.two_hand_mirror, 0, 1)) return fmt::format("threat_two_hand_mirror: {} is not in [0, 1]", t.two_hand_mirror);
  return {};
}

namespace {

double segment_distance(const Vector3d& p, const Vector3d& a, const Vector3d& b, Vector3d* nearest) {
  const Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double s = len2 > 1e-12 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  const Vector3d q = a + s * ab;
  if (nearest) *nearest = q;
  return (p - q).norm();
}

/// Both hands moving as mirror images of each other: their velocities relative to the head
/// (`left_v`, `right_v`), one mirrored in the vertical plane through the hands' middle and
/// `body_mid` (the fighter's), differ by at most `share` of the faster's speed, which is at
/// least `min_speed_mps` (ThreatTunables::two_hand_mirror).
bool mirrored_hands(const Vector3d& left_p, const Vector3d& right_p, const Vector3d& left_v, const Vector3d& right_v,
                    const Vector3d& body_mid, double share, double min_speed_mps) {
  Vector3d toward = body_mid - (left_p + right_p) / 2;
  toward.y() = 0;
  if (toward.norm() < 1e-6) return false;
  const Vector3d n = Vector3d::UnitY().cross(toward).normalized();
  const Vector3d left_mirrored = left_v - 2 * left_v.dot(n) * n;
  const double faster = std::max(left_v.norm(), right_v.norm());
  return faster >= min_speed_mps && (right_v - left_mirrored).norm() <= share * faster;
}

}  // namespace

void ThreatWatch::reset() {
  hist_ = {};
  recognised_ = {};
}

void ThreatWatch::observe(std::span<const VisitorBody> bodies, std::span<const VisitorStrikeSeen> strikes) {
  for (const VisitorBody& b : bodies) {
    const auto r = static_cast<std::size_t>(b.role);
    if (r >= hist_.size()) continue;
    History& h = hist_[r];
    if (!b.tracked || !b.position_m.allFinite() || !std::isfinite(b.t)) {
      h.count = 0;  // lost: its history ends (a velocity across the gap would be made up)
      continue;
    }
    if (h.count > 0 && !(b.t > h.newest().t)) continue;  // the same measurement again (or older)
    h.ring[static_cast<std::size_t>(h.next)] = Sample{b.position_m, b.t};
    h.next = (h.next + 1) % kKeep;
    h.count = std::min(h.count + 1, kKeep);
  }
  for (const VisitorStrikeSeen& s : strikes) {
    const auto r = static_cast<std::size_t>(s.limb);
    if (r >= recognised_.size()) continue;
    if (s.type == recognition::EventType::begin || s.type == recognition::EventType::switch_) {
      if (s.impact_m.allFinite()) recognised_[r] = s.impact_m;
    } else {
      recognised_[r].reset();
    }
  }
}

std::optional<Vector3d> ThreatWatch::velocity(recognition::Role role) const {
  const History& h = hist_[static_cast<std::size_t>(role)];
  if (h.count < 2) return std::nullopt;
  const Timestamp t_new = h.newest().t;
  // Least-squares slope over the window's measurements (at least the newest two).
  double st = 0, stt = 0;
  Vector3d sp = Vector3d::Zero(), stp = Vector3d::Zero();
  int n = 0;
  for (int k = 0; k < h.count; ++k) {
    const Sample& s = h.newest(k);
    if (k >= 2 && t_new - s.t > tun_.velocity_window_s) break;
    const double t = s.t - t_new;
    st += t;
    stt += t * t;
    sp += s.p;
    stp += t * s.p;
    ++n;
  }
  const double den = n * stt - st * st;
  if (!(den > 1e-12)) return std::nullopt;
  return Vector3d((n * stp - st * sp) / den);
}

std::optional<Threat> ThreatWatch::path_threat(const Vector3d& p, const Vector3d& v, const Vector3d& top,
                                               const Vector3d& bottom) const {
  constexpr double kStep_s = 0.005;
  const int steps = static_cast<int>(std::ceil(tun_.horizon_s / kStep_s));
  Threat t;
  t.miss_m = std::numeric_limits<double>::infinity();
  double arrival = -1;
  for (int i = 0; i <= steps; ++i) {
    const double tau = i * kStep_s;
    Vector3d q;
    const double d = segment_distance(p + v * tau, top, bottom, &q);
    if (d < t.miss_m) {
      t.miss_m = d;
      t.aim_m = q;
    }
    if (d <= tun_.aim_radius_m) {
      arrival = tau;
      break;
    }
  }
  if (arrival < 0) return std::nullopt;
  Vector3d q0;
  const double d0 = segment_distance(p, top, bottom, &q0);
  const double closing = d0 > 1e-9 ? -v.dot(p - q0) / d0 : v.norm();
  if (closing < tun_.min_closing_mps) return std::nullopt;
  t.point_m = p;
  t.velocity_mps = v;
  t.arrival_s = arrival;
  return t;
}

std::optional<Vector3d> ThreatWatch::window_mean(recognition::Role role) const {
  const History& h = hist_[static_cast<std::size_t>(role)];
  if (h.count < 1) return std::nullopt;
  const Timestamp t_new = h.newest().t;
  Vector3d sum = Vector3d::Zero();
  int n = 0;
  for (int k = 0; k < h.count; ++k) {
    const Sample& s = h.newest(k);
    if (k >= 2 && t_new - s.t > tun_.velocity_window_s) break;
    sum += s.p;
    ++n;
  }
  return Vector3d(sum / n);
}

bool ThreatWatch::extends(recognition::Role role, const Vector3d& rel) const {
  if (tun_.min_extension <= 0) return true;
  if (role != recognition::Role::left_hand && role != recognition::Role::right_hand) return true;
  // The fist and the head where the fitted velocity holds: at the window's mean time (the fist
  // now would lag a curved path's velocity by half the window: a hand on a circle would seem
  // to move outward). Measured from the middle of the shoulders, taken kShouldersBelowHead_m under the tracked head
  // (the glasses, at eye level): a punch from the hip (karate's chambered fist) keeps its
  // distance from the head but extends from the shoulder; an arm circled round a shoulder keeps
  // its distance from that point too (its circle lies beside it).
  constexpr double kShouldersBelowHead_m = 0.22;
  const std::optional<Vector3d> fist = window_mean(role), head = window_mean(recognition::Role::head);
  if (!fist || !head) return true;  // no head to measure from: the path alone decides
  const Vector3d out = *fist - (*head - Vector3d(0, kShouldersBelowHead_m, 0));
  const double r = out.norm(), speed = rel.norm();
  if (r < 1e-6 || speed < 1e-9) return true;
  return rel.dot(out) / (r * speed) >= tun_.min_extension;
}

std::optional<Threat> ThreatWatch::soonest(const Vector3d& top, const Vector3d& bottom, Timestamp now,
                                           std::optional<recognition::Role> only) const {
  if (!top.allFinite() || !bottom.allFinite() || !std::isfinite(now)) return std::nullopt;
  const Vector3d head_v = velocity(recognition::Role::head).value_or(Vector3d::Zero());
  std::array<std::optional<Vector3d>, recognition::kRoleCount> vel{};
  for (int r = 1; r < recognition::kRoleCount; ++r) vel[static_cast<std::size_t>(r)] = velocity(static_cast<recognition::Role>(r));
  const auto left = static_cast<std::size_t>(recognition::Role::left_hand);
  const auto right = static_cast<std::size_t>(recognition::Role::right_hand);
  // Both hands swung as mirror images (a velocity fitted means two measurements or more).
  const bool two_handed = tun_.two_hand_mirror > 0 && vel[left] && vel[right] &&
                          mirrored_hands(hist_[left].newest().p, hist_[right].newest().p, *vel[left] - head_v,
                                         *vel[right] - head_v, (top + bottom) / 2, tun_.two_hand_mirror, tun_.min_speed_mps);
  std::optional<Threat> best;
  for (int r = 1; r < recognition::kRoleCount; ++r) {
    const auto role = static_cast<recognition::Role>(r);
    if (only && role != *only) continue;
    const History& h = hist_[static_cast<std::size_t>(r)];
    if (h.count < 1) continue;
    const Sample& s = h.newest();
    const double ahead = std::clamp(now - s.t, 0.0, 0.1);  // a measurement from the future is taken as now
    std::optional<Threat> t;
    const std::optional<Vector3d>& v = vel[static_cast<std::size_t>(r)];
    if (v) {
      const Vector3d rel = *v - head_v;
      const bool hand = role == recognition::Role::left_hand || role == recognition::Role::right_hand;
      if (rel.norm() >= tun_.min_speed_mps && extends(role, rel) && !(hand && two_handed))
        t = path_threat(s.p + *v * ahead, *v, top, bottom);
    }
    if (!t && recognised_[static_cast<std::size_t>(r)]) {
      // Recognised: the path toward the predicted impact point, at the limb's speed or at
      // least a punch's (4 m/s), carried on past it.
      const Vector3d to = *recognised_[static_cast<std::size_t>(r)] - s.p;
      if (to.norm() > 1e-3) {
        const double speed = std::max(4.0, v ? v->norm() : 0.0);
        t = path_threat(s.p, to.normalized() * speed, top, bottom);
        if (t) t->recognised = true;
      }
    }
    if (!t) continue;
    t->limb = role;
    t->measured_t = s.t;
    if (!best || t->arrival_s < best->arrival_s) best = t;
  }
  return best;
}

}  // namespace kumite::content
