#include "kumite/content/mkm.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "kumite/common/error.hpp"
#include "kumite/content/ik.hpp"

namespace kumite::content {

using CJ = CanonicalJoint;
using Eigen::Quaterniond;
using Eigen::Vector3d;

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

constexpr std::array<CJ, 2> kShoulder{CJ::l_shoulder, CJ::r_shoulder};
constexpr std::array<CJ, 2> kElbow{CJ::l_elbow, CJ::r_elbow};
constexpr std::array<CJ, 2> kWrist{CJ::l_wrist, CJ::r_wrist};
constexpr std::array<CJ, 2> kClavicle{CJ::l_clavicle, CJ::r_clavicle};
constexpr std::array<CJ, 2> kHip{CJ::l_hip, CJ::r_hip};
constexpr std::array<CJ, 2> kKnee{CJ::l_knee, CJ::r_knee};
constexpr std::array<CJ, 2> kAnkle{CJ::l_ankle, CJ::r_ankle};
constexpr std::array<CJ, 2> kToe{CJ::l_toe, CJ::r_toe};

bool valid(const Vector3d& v) { return v.allFinite(); }

// Right-handed frame from a lateral (toward the left) and an up vector.
Quaterniond frame_from(const Vector3d& lateral, const Vector3d& up) {
  Vector3d x = lateral.normalized();
  Vector3d y = up - up.dot(x) * x;
  if (y.norm() < 1e-9) y = Vector3d::UnitY() - x.y() * x;
  y.normalize();
  Eigen::Matrix3d m;
  m.col(0) = x;
  m.col(1) = y;
  m.col(2) = x.cross(y);
  return Quaterniond(m).normalized();
}

Vector3d normalized_or(const Vector3d& v, const Vector3d& fallback) {
  const double n = v.norm();
  return n > 1e-9 ? Vector3d(v / n) : fallback;
}

double wrap_angle(double a) {
  return std::remainder(a, 2 * std::numbers::pi);
}
}  // namespace

Vector3d GroundFrame::to_world(const Vector3d& local) const {
  return rotation() * local + Vector3d(origin_xz.x(), 0, origin_xz.y());
}
Vector3d GroundFrame::to_local(const Vector3d& world) const {
  return rotation().conjugate() * (world - Vector3d(origin_xz.x(), 0, origin_xz.y()));
}
GroundFrame GroundFrame::compose(const GroundFrame& other) const {
  GroundFrame r;
  const Vector3d o = to_world(Vector3d(other.origin_xz.x(), 0, other.origin_xz.y()));
  r.origin_xz = {o.x(), o.z()};
  r.yaw_rad = wrap_angle(yaw_rad + other.yaw_rad);
  return r;
}
GroundFrame GroundFrame::inverse() const {
  GroundFrame r;
  r.yaw_rad = wrap_angle(-yaw_rad);
  const Vector3d o = r.rotation() * Vector3d(-origin_xz.x(), 0, -origin_xz.y());
  r.origin_xz = {o.x(), o.z()};
  return r;
}

double yaw_of(const Vector3d& forward) { return std::atan2(forward.x(), forward.z()); }

void canonical_positions(const Skeleton& skeleton, std::span<const Vector3d> global_positions,
                         CanonicalPose& out) {
  for (std::size_t j = 0; j < kCanonicalJointCount; ++j) {
    const int i = skeleton.canonical[j];
    out[j] = i >= 0 ? global_positions[static_cast<std::size_t>(i)] : Vector3d::Constant(kNaN);
  }
}

void require_canonical_joints(const Skeleton& skeleton, std::string_view what) {
  static constexpr std::array<CJ, 16> kRequired{
      CJ::pelvis,     CJ::chest,   CJ::neck,    CJ::head,    CJ::l_shoulder, CJ::l_elbow,
      CJ::l_wrist,    CJ::r_shoulder, CJ::r_elbow, CJ::r_wrist, CJ::l_hip,      CJ::l_knee,
      CJ::l_ankle,    CJ::r_hip,   CJ::r_knee,  CJ::r_ankle};
  for (CJ j : kRequired) {
    if (skeleton.index(j) < 0) {
      throw Error("content", "skeleton",
                  fmt::format("{}: skeleton lacks the canonical joint '{}' that the fighter needs",
                              what, to_string(j)));
    }
  }
}

double standing_foot_pitch(const CanonicalPose& p, int side) {
  const Vector3d& toe = at(p, kToe[static_cast<std::size_t>(side)]);
  const Vector3d d = toe - at(p, kAnkle[static_cast<std::size_t>(side)]);
  // No toe: encode_mkm's fallback direction (forward and down, 26.6 deg) is the standing one.
  if (!valid(toe) || d.norm() < 1e-9) return std::atan2(0.5, 1.0);
  return std::atan2(-d.y(), std::hypot(d.x(), d.z()));
}

namespace {
/// The pitch (rad) counted from a foot's standing pitch `standing_rad`: the standing pitch
/// subtracted over the usual range (within kPitchKnee_rad of the horizontal), fading to
/// nothing at straight down and straight up (piecewise linear, increasing): a foot turning
/// through the vertical turns its heading over, and mapped to the same vertical it stays
/// continuous (a constant offset jumped 45 deg there on kicks with pointed toes).
constexpr double kQuarter = std::numbers::pi / 2;
constexpr double kPitchKnee_rad = 40 * std::numbers::pi / 180;
double pitch_from_standing(double pitch, double standing_rad) {
  const double lo = -kPitchKnee_rad - standing_rad, hi = kPitchKnee_rad - standing_rad;
  if (pitch >= kPitchKnee_rad) return hi + (pitch - kPitchKnee_rad) * (kQuarter - hi) / (kQuarter - kPitchKnee_rad);
  if (pitch <= -kPitchKnee_rad) return lo + (pitch + kPitchKnee_rad) * (lo + kQuarter) / (kQuarter - kPitchKnee_rad);
  return pitch - standing_rad;
}
double pitch_to_standing(double c, double standing_rad) {
  const double lo = -kPitchKnee_rad - standing_rad, hi = kPitchKnee_rad - standing_rad;
  if (c >= hi) return kPitchKnee_rad + (c - hi) * (kQuarter - kPitchKnee_rad) / (kQuarter - hi);
  if (c <= lo) return -kPitchKnee_rad + (c - lo) * (kQuarter - kPitchKnee_rad) / (lo + kQuarter);
  return c + standing_rad;
}
}  // namespace

Vector3d repitch(const Vector3d& dir, double from_rad, double to_rad) {
  const double h = std::hypot(dir.x(), dir.z());
  if (h < 1e-9 || from_rad == to_rad) return dir;
  // Standing pitches beyond 45 deg would fold the map over: none is (HDM05's reach 43 deg).
  constexpr double kMost = 45 * std::numbers::pi / 180;
  from_rad = std::clamp(from_rad, -kMost, kMost);
  to_rad = std::clamp(to_rad, -kMost, kMost);
  const double q = pitch_to_standing(pitch_from_standing(std::atan2(-dir.y(), h), from_rad), to_rad);
  return Vector3d(std::cos(q) * dir.x() / h, -std::sin(q), std::cos(q) * dir.z() / h);
}

Morphology measure_morphology(const CanonicalPose& rest, std::string_view what) {
  for (std::size_t j = 0; j < kCanonicalJointCount; ++j) {
    const auto cj = static_cast<CJ>(j);
    const bool optional = cj == CJ::spine || cj == CJ::l_clavicle || cj == CJ::r_clavicle ||
                          cj == CJ::l_toe || cj == CJ::r_toe;
    if (!optional && !valid(rest[j])) {
      throw Error("content", "skeleton",
                  fmt::format("{}: skeleton lacks the canonical joint '{}' that the fighter needs",
                              what, to_string(cj)));
    }
  }
  Morphology m;
  for (int s = 0; s < 2; ++s) {
    m.upper_arm_m[s] = (at(rest, kElbow[s]) - at(rest, kShoulder[s])).norm();
    m.forearm_m[s] = (at(rest, kWrist[s]) - at(rest, kElbow[s])).norm();
    m.thigh_m[s] = (at(rest, kKnee[s]) - at(rest, kHip[s])).norm();
    m.shin_m[s] = (at(rest, kAnkle[s]) - at(rest, kKnee[s])).norm();
    if (m.upper_arm_m[s] < 1e-3 || m.forearm_m[s] < 1e-3 || m.thigh_m[s] < 1e-3 ||
        m.shin_m[s] < 1e-3) {
      throw Error("content", "skeleton",
                  fmt::format("{}: a limb bone of the {} side is shorter than 1 mm", what,
                              s == kLeft ? "left" : "right"));
    }
  }
  // Pelvis height when standing straight: the pelvis->hips drop along the pelvis' up axis
  // plus thigh and shin (independent of the rest pose's leg angles).
  const Quaterniond pf = pelvis_frame(rest);
  const Vector3d mid_hips = 0.5 * (at(rest, CJ::l_hip) + at(rest, CJ::r_hip));
  const double drop = std::max(0.0, (at(rest, CJ::pelvis) - mid_hips).dot(pf * Vector3d::UnitY()));
  m.leg_length_m = drop + 0.5 * (m.limb_leg_length(kLeft) + m.limb_leg_length(kRight));
  const double lowest_ankle = std::min(at(rest, CJ::l_ankle).y(), at(rest, CJ::r_ankle).y());
  double lowest = lowest_ankle;
  for (CJ t : kToe) {
    if (valid(at(rest, t))) lowest = std::min(lowest, at(rest, t).y());
  }
  m.height_m = at(rest, CJ::head).y() - lowest;
  m.standing_ankle_m = lowest_ankle - lowest;
  for (int s = 0; s < 2; ++s) m.standing_foot_pitch_rad[s] = standing_foot_pitch(rest, s);
  return m;
}

// The pelvis frame is built from points rigid with the pelvis (pelvis and hips) so that
// encode -> decode on the same skeleton is exact; rigs whose hips sit level with the pelvis
// fall back to the chest for "up".
Quaterniond pelvis_frame(const CanonicalPose& p) {
  const Vector3d lateral = at(p, CJ::l_hip) - at(p, CJ::r_hip);
  Vector3d up = at(p, CJ::pelvis) - 0.5 * (at(p, CJ::l_hip) + at(p, CJ::r_hip));
  const Vector3d lat_unit = lateral.normalized();
  if ((up - up.dot(lat_unit) * lat_unit).norm() < 0.02) up = at(p, CJ::chest) - at(p, CJ::pelvis);
  return frame_from(lateral, up);
}
// Clavicle origins are rigid with the chest (shoulders move with the clavicles): use them
// when the skeleton has both.
Quaterniond chest_frame(const CanonicalPose& p) {
  const bool clav = valid(at(p, CJ::l_clavicle)) && valid(at(p, CJ::r_clavicle)) &&
                    (at(p, CJ::l_clavicle) - at(p, CJ::r_clavicle)).norm() > 0.02;
  const Vector3d lateral = clav ? Vector3d(at(p, CJ::l_clavicle) - at(p, CJ::r_clavicle))
                                : Vector3d(at(p, CJ::l_shoulder) - at(p, CJ::r_shoulder));
  return frame_from(lateral, at(p, CJ::neck) - at(p, CJ::chest));
}

GroundFrame ground_frame_of(const CanonicalPose& p) {
  GroundFrame g;
  g.origin_xz = {at(p, CJ::pelvis).x(), at(p, CJ::pelvis).z()};
  g.yaw_rad = yaw_of(pelvis_frame(p) * Vector3d::UnitZ());
  return g;
}
GroundFrame ground_frame_of(const MkmFrame& f) {
  GroundFrame g;
  g.origin_xz = f.root_xz_m;
  g.yaw_rad = yaw_of(f.pelvis * Vector3d::UnitZ());
  return g;
}

Vector3d arm_swivel_reference(int side) {
  return Vector3d(side == kLeft ? 1.0 : -1.0, 1.0, -1.0).normalized();
}
Vector3d leg_swivel_reference(int side) {
  return Vector3d(side == kLeft ? 0.3 : -0.3, 1.0, -1.0).normalized();
}

Vector3d across(const Vector3d& v, const Vector3d& axis, const Vector3d& otherwise) {
  Vector3d p = v - v.dot(axis) * axis;
  if (p.norm() > 1e-9) return p.normalized();
  p = otherwise - otherwise.dot(axis) * axis;
  return p.norm() > 1e-9 ? Vector3d(p.normalized()) : axis.unitOrthogonal();
}

Vector3d limb_pole(const Vector3d& root, const Vector3d& middle, const Vector3d& end, const Vector3d& fallback) {
  const Vector3d axis = end - root;
  const double len = axis.norm();
  if (len < 1e-9) return fallback.norm() > 1e-9 ? Vector3d(fallback.normalized()) : Vector3d::UnitX();
  const Vector3d a = axis / len;
  const Vector3d e = (middle - root) - (middle - root).dot(a) * a;
  if (e.norm() < 1e-6) return across(fallback, a, a.unitOrthogonal());
  return e.normalized();
}

Vector3d blend_pole(const Vector3d& a, const Vector3d& b, const Vector3d& axis, double w, double* turn_rad) {
  // Both made across the axis and turned from one to the other about it at an even pace. Within
  // 30 deg their nlerp does that to 7 % (mid-way against the ends; a few dot products: sampling
  // between frames runs this per limb for every sample); farther apart its pace is uneven (at
  // 150 deg 15x as fast mid-way: a guard arm's elbow snapped in a blend at the start of two of
  // bruno's kicks on the grid), so the angle is turned instead.
  const Vector3d pa = a - a.dot(axis) * axis, pb = b - b.dot(axis) * axis;
  const double na = pa.norm(), nb = pb.norm();
  const bool near = na > 0.1 && nb > 0.1 && pa.dot(pb) > 0.866 * na * nb;
  if (near && turn_rad == nullptr) return ((1 - w) / na * pa + w / nb * pb).normalized();
  const Vector3d ua = across(a, axis, b), ub = across(b, axis, ua);
  double angle = std::atan2(axis.dot(ua.cross(ub)), ua.dot(ub));
  if (turn_rad != nullptr) {
    // The whole turns that bring the shorter angle nearest the last update's (|change| <= pi).
    const double turns = std::isfinite(*turn_rad) ? std::round((*turn_rad - angle) / (2 * std::numbers::pi)) : 0.0;
    *turn_rad = angle += turns * 2 * std::numbers::pi;
    if (near && turns == 0) return ((1 - w) / na * pa + w / nb * pb).normalized();
  }
  return Eigen::AngleAxisd(w * angle, axis) * ua;
}

Vector3d limit_folded_pole_turn(DrawnPole& mem, const Vector3d& src, const Vector3d& limb_n, double upper_m, double lower_m,
                                double dt) {
  const double ext = limb_n.norm();
  if (!(ext > 1e-9) || !src.allFinite() || !limb_n.allFinite()) {
    mem.valid = false;
    return src;
  }
  const Vector3d axis = limb_n / ext;
  // The source's middle joint's distance from its axis, on these bones.
  const double src_radius = two_bone_bend(upper_m, lower_m, std::max(1e-6, ext * (upper_m + lower_m))).off_m;
  Vector3d pole = src;
  if (mem.valid && mem.drawn_radius_m > 0 && dt > 0) {
    const Vector3d last_drawn = carried_pole(mem.drawn, mem.axis, axis, src);
    const Vector3d last_src = carried_pole(mem.source, mem.axis, axis, src);
    const auto angle = [&](const Vector3d& a, const Vector3d& b) { return std::atan2(axis.dot(a.cross(b)), a.dot(b)); };
    // The drawn elbow swings (m, about the axis) as far as the source's did, plus the catch-up;
    // both radii of the last update.
    const double swing_m = mem.source_radius_m * std::abs(angle(last_src, src)) + kFoldedPoleCatchUp_mps * dt;
    const double allowed = swing_m / mem.drawn_radius_m;
    const double want = angle(last_drawn, src);
    if (std::abs(want) > allowed) pole = Eigen::AngleAxisd(std::copysign(allowed, want), axis) * last_drawn;
  }
  mem.valid = true;
  mem.drawn = pole;
  mem.source = src;
  mem.axis = axis;
  mem.source_radius_m = src_radius;
  return pole;
}

void encode_mkm(const CanonicalPose& p, const Morphology& m, double floor_y_m,
                const MkmFrame* previous, MkmFrame& out) {
  const Vector3d& pelvis = at(p, CJ::pelvis);
  out.root_xz_m = {pelvis.x(), pelvis.z()};
  out.root_height_n = (pelvis.y() - floor_y_m - m.standing_ankle_m) / m.leg_length_m;
  out.pelvis = pelvis_frame(p);
  out.chest = chest_frame(p);
  const Vector3d up_chest = out.chest * Vector3d::UnitY();
  const Vector3d spine_root = valid(at(p, CJ::spine)) ? at(p, CJ::spine) : pelvis;
  out.spine_dir = normalized_or(at(p, CJ::chest) - spine_root, out.pelvis * Vector3d::UnitY());
  out.head_dir = normalized_or(at(p, CJ::head) - at(p, CJ::neck), up_chest);
  for (int s = 0; s < 2; ++s) {
    const Vector3d outward = out.chest * Vector3d(s == kLeft ? 1 : -1, 0, 0);
    const Vector3d& clav = at(p, kClavicle[s]);
    out.clavicle_dir[s] = valid(clav) ? normalized_or(at(p, kShoulder[s]) - clav, outward) : outward;

    const Vector3d& sh = at(p, kShoulder[s]);
    const Vector3d& wr = at(p, kWrist[s]);
    out.arm_n[s] = (wr - sh) / m.arm_length(s);
    out.arm_pole[s] = limb_pole(sh, at(p, kElbow[s]), wr, previous ? previous->arm_pole[s] : Vector3d(out.chest * arm_swivel_reference(s)));
    const Vector3d& hip = at(p, kHip[s]);
    const Vector3d& an = at(p, kAnkle[s]);
    out.leg_n[s] = (an - hip) / m.limb_leg_length(s);
    out.leg_pole[s] = limb_pole(hip, at(p, kKnee[s]), an, previous ? previous->leg_pole[s] : Vector3d(out.pelvis * leg_swivel_reference(s)));
    const Vector3d fwd_down = out.pelvis * Vector3d(0, -0.5, 1).normalized();
    out.foot_dir[s] = repitch(valid(at(p, kToe[s])) ? normalized_or(at(p, kToe[s]) - an, fwd_down) : fwd_down, m.standing_foot_pitch_rad[s], 0.0);
  }
}

void steady_straight_limb_poles(std::span<MkmFrame> frames, double frame_time_s) {
  const int n = static_cast<int>(frames.size());
  if (n == 0 || !(frame_time_s > 0)) return;
  const double sigma = kSteadySigma_s / frame_time_s;  // frames
  // (at most the segment: a BVH's frame time has no lower bound, and 3 sigma of a 1e-9 s frame
  // is more frames than memory holds)
  const int reach = static_cast<int>(std::min(std::ceil(3 * sigma), static_cast<double>(n)));
  std::vector<double> gauss(static_cast<std::size_t>(reach + 1));
  for (int k = 0; k <= reach; ++k) gauss[static_cast<std::size_t>(k)] = std::exp(-0.5 * k * k / (sigma * sigma));
  double total = 0;  // the window's weight (its ends repeat the segment's first and last frames)
  for (int k = -reach; k <= reach; ++k) total += gauss[static_cast<std::size_t>(std::abs(k))];
  std::vector<Vector3d> steadied(frames.size());
  std::vector<double> straight(frames.size()), weight(frames.size());
  const auto limb_pass = [&](auto limb, auto pole) {
    // How straight each frame is (0 at kSteadyFrom, 1 from kSteadyFull), then that smoothed
    // over the same window: a kick straightens its leg in two frames, and a blend weight
    // following the extension alone swapped the measured pole for the steadied one at once.
    for (int t = 0; t < n; ++t) {
      const double x = std::clamp((limb(frames[static_cast<std::size_t>(t)]).norm() - kSteadyFrom) / (kSteadyFull - kSteadyFrom), 0.0, 1.0);
      straight[static_cast<std::size_t>(t)] = x * x * (3 - 2 * x);
    }
    for (int t = 0; t < n; ++t) {
      double sum = 0;
      for (int k = -reach; k <= reach; ++k) {
        const int u = std::clamp(t + k, 0, n - 1);
        sum += gauss[static_cast<std::size_t>(std::abs(k))] * straight[static_cast<std::size_t>(u)];
      }
      weight[static_cast<std::size_t>(t)] = sum / total;
    }
    for (int t = 0; t < n; ++t) {
      const Vector3d& l = limb(frames[static_cast<std::size_t>(t)]);
      const Vector3d& own = pole(frames[static_cast<std::size_t>(t)]);
      steadied[static_cast<std::size_t>(t)] = own;
      const double ext = l.norm();
      const double w = weight[static_cast<std::size_t>(t)];
      if (w <= 0 || ext < 1e-9) continue;
      const Vector3d axis = l / ext;
      Vector3d sum = Vector3d::Zero();
      for (int k = -reach; k <= reach; ++k) {
        const int u = t + k;
        if (u < 0 || u >= n) continue;
        const MkmFrame& f = frames[static_cast<std::size_t>(u)];
        const double len = limb(f).norm();
        if (len < 1e-9) continue;
        const double bent = std::max(1 - len, 0.002);
        // Carried with its limb onto this frame's axis (a kicking leg turns 90 deg in 0.1 s:
        // a neighbour's pole taken across this axis as it is can point anywhere).
        sum += gauss[static_cast<std::size_t>(std::abs(k))] * bent * carried_pole(pole(f), limb(f) / len, axis, own);
      }
      steadied[static_cast<std::size_t>(t)] = blend_pole(own, across(sum, axis, own), axis, w);
    }
    for (int t = 0; t < n; ++t) pole(frames[static_cast<std::size_t>(t)]) = steadied[static_cast<std::size_t>(t)];
  };
  for (std::size_t s = 0; s < 2; ++s) {
    limb_pass([s](const MkmFrame& f) -> const Vector3d& { return f.arm_n[s]; },
              [s](auto& f) -> auto& { return f.arm_pole[s]; });
    limb_pass([s](const MkmFrame& f) -> const Vector3d& { return f.leg_n[s]; },
              [s](auto& f) -> auto& { return f.leg_pole[s]; });
  }
}

void mirror_pose(const CanonicalPose& in, const GroundFrame& g, CanonicalPose& out) {
  auto mirror = [&](const Vector3d& v) {
    if (!valid(v)) return v;
    Vector3d l = g.to_local(v);
    l.x() = -l.x();
    return g.to_world(l);
  };
  for (std::size_t j = 0; j < kCanonicalJointCount; ++j) {
    const auto name = to_string(static_cast<CJ>(j));
    std::size_t src = j;
    if (name.starts_with("l_") || name.starts_with("r_")) {
      std::string other(name);
      other[0] = name[0] == 'l' ? 'r' : 'l';
      src = static_cast<std::size_t>(*canonical_joint_from_string(other));
    }
    out[j] = mirror(in[src]);
  }
}

void blend_mkm(const MkmFrame& a, const MkmFrame& b, double w, MkmFrame& out, PoleTurns* turns) {
  const double u = 1 - w;
  auto nlerp = [&](const Vector3d& x, const Vector3d& y) { return normalized_or(u * x + w * y, x); };
  out.root_xz_m = u * a.root_xz_m + w * b.root_xz_m;
  out.root_height_n = u * a.root_height_n + w * b.root_height_n;
  out.pelvis = a.pelvis.slerp(w, b.pelvis);
  out.chest = a.chest.slerp(w, b.chest);
  out.spine_dir = nlerp(a.spine_dir, b.spine_dir);
  out.head_dir = nlerp(a.head_dir, b.head_dir);
  for (int s = 0; s < 2; ++s) {
    out.clavicle_dir[s] = nlerp(a.clavicle_dir[s], b.clavicle_dir[s]);
    out.arm_n[s] = u * a.arm_n[s] + w * b.arm_n[s];
    double* arm_turn = turns ? &turns->arm_rad[s] : nullptr;
    double* leg_turn = turns ? &turns->leg_rad[s] : nullptr;
    out.arm_pole[s] = blend_pole(a.arm_pole[s], b.arm_pole[s], normalized_or(out.arm_n[s], normalized_or(a.arm_n[s], Vector3d::UnitY())), w, arm_turn);
    out.leg_n[s] = u * a.leg_n[s] + w * b.leg_n[s];
    out.leg_pole[s] = blend_pole(a.leg_pole[s], b.leg_pole[s], normalized_or(out.leg_n[s], normalized_or(a.leg_n[s], -Vector3d::UnitY())), w, leg_turn);
    out.foot_dir[s] = nlerp(a.foot_dir[s], b.foot_dir[s]);
    out.planted[s] = u * a.planted[s] + w * b.planted[s];
    out.ankle_lift_n[s] = u * a.ankle_lift_n[s] + w * b.ankle_lift_n[s];
  }
}

Eigen::Vector2d place_root_xz(const Eigen::Vector2d& root_xz_m, const GroundFrame& placement, const Quaterniond& rotation,
                              const Eigen::Vector2d& anchor_xz_m, double stride_scale) {
  const Eigen::Vector2d d = (root_xz_m - anchor_xz_m) * stride_scale;
  // (to_world with the rotation given: sin and cos of the yaw once per frame placed, or fewer)
  const Vector3d root = rotation * Vector3d(d.x(), 0, d.y()) + Vector3d(placement.origin_xz.x(), 0, placement.origin_xz.y());
  return {root.x(), root.z()};
}

void place_mkm(const MkmFrame& in, const GroundFrame& placement, const Eigen::Vector2d& anchor_xz_m,
               double stride_scale, MkmFrame& out) {
  const Quaterniond r = placement.rotation();
  out.root_xz_m = place_root_xz(in.root_xz_m, placement, r, anchor_xz_m, stride_scale);
  out.root_height_n = in.root_height_n;
  out.pelvis = r * in.pelvis;
  out.chest = r * in.chest;
  out.spine_dir = r * in.spine_dir;
  out.head_dir = r * in.head_dir;
  for (int s = 0; s < 2; ++s) {
    out.clavicle_dir[s] = r * in.clavicle_dir[s];
    out.arm_n[s] = r * in.arm_n[s];
    out.arm_pole[s] = r * in.arm_pole[s];
    out.leg_n[s] = r * in.leg_n[s];
    out.leg_pole[s] = r * in.leg_pole[s];
    out.foot_dir[s] = r * in.foot_dir[s];
    out.planted[s] = in.planted[s];
    out.ankle_lift_n[s] = in.ankle_lift_n[s];
  }
}

}  // namespace kumite::content
