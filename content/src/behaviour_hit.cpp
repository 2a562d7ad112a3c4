// Hit reactions (HitReel, hit_reel.hpp; issue 53, item 4). A blow the Fighter judged (the visitor's fist
// or foot entering the drawn head or torso fast) gives each struck chain a push: a rotation
// rate about the axis r x v (r from the chain's pivot to where the fist entered, v the fist's
// velocity), so the struck point first moves along the blow. Each chain is a damped spring
// (stepped exactly, not integrated: the same numbers at any frame rate's steps) whose peak is
// the chain's largest reel times the blow's share; it is laid on the pose composed from the
// motion (pose_) before the decode (the arms turned with their shoulders), so it rides on whatever plays (rest, following, strikes,
// blocks), and d(t) and the held feet act on top of it as on any pose. The legs are not
// touched: held feet stay held.
#include <algorithm>
#include <cmath>

#include "kumite/content/hit_reel.hpp"

#include "behaviour_internal.hpp"
#include "kumite/content/behaviour.hpp"
#include "kumite/content/canonical.hpp"

namespace kumite::content {

using namespace behaviour_detail;
using CJ = CanonicalJoint;
using Eigen::Quaterniond;
using Eigen::Vector2d;
using Eigen::Vector3d;

namespace {
enum Chain : std::size_t { kTrunk = 0, kHead = 1, kShoulderL = 2, kShoulderR = 3 };
/// s: a strike of its own is aborted when it is under way within this after the blow (one
/// whose plan was awaited then starts and is aborted as soon as its cross-fade in is done).
constexpr double kAbortWindow_s = 0.3;
/// m: a torso blow this far or farther from the midline (along the shoulders) reels that side's shoulder.
constexpr double kOffCentre_m = 0.08;
/// A head blow reels the trunk this share of a full torso blow's (the neck carries it down).
constexpr double kHeadBlowTrunkShare = 0.4;
/// A torso blow turns the head back against the trunk by this share of the trunk's angle (the
/// head lags: Source 2's "whip", sparring-opponent.md section 2).
constexpr double kTorsoBlowHeadLag = 0.3;
/// s after a blow before a reel that has died down ends (exactly zero from then).
constexpr double kReelMin_s = 0.1;
constexpr double kReelRestRad = 1e-4, kReelRestRadPerS = 1e-3;
/// s a large blow's step back is tried for.
constexpr double kStepBackFor_s = 1.0;

/// The peak of x(t) for x(0) = 0, x'(0) = 1 under x'' + 2 z w x' + w^2 x = 0 (z <= 1).
double unit_peak(double w, double z) {
  if (z >= 0.999) return 1 / (w * std::exp(1.0));
  const double wd = w * std::sqrt(1 - z * z);
  const double t = std::atan2(wd, z * w) / wd;
  return std::exp(-z * w * t) * std::sin(wd * t) / wd;
}

/// The spring's exact step over dt (each component is independent: linear).
void spring_step(Vector3d& x, Vector3d& v, double w, double z, double dt) {
  const double e = std::exp(-z * w * dt);
  if (z >= 0.999) {
    const Vector3d c = v + w * x;
    x = e * (x + c * dt);
    v = e * (v - w * c * dt);
    return;
  }
  const double wd = w * std::sqrt(1 - z * z);
  const double a = z * w, c = std::cos(wd * dt), s = std::sin(wd * dt);
  const Vector3d x0 = x, v0 = v;
  x = e * (x0 * c + (v0 + a * x0) / wd * s);
  v = e * (v0 * c - (a * v0 + w * w * x0) / wd * s);
}

Quaterniond rotation_of(const Vector3d& theta) {
  const double a = theta.norm();
  return a > 1e-12 ? Quaterniond(Eigen::AngleAxisd(a, theta / a)) : Quaterniond::Identity();
}
}  // namespace

// ---- HitReel --------------------------------------------------------------------------

bool HitReel::take(const HitOrder& h, const Rig& rig, std::span<const Vector3d> drawn) {
  if (!(h.share > 0) || !h.point_m.allFinite() || !h.velocity_mps.allFinite()) return false;
  if (!(h.stiffness_rad_s > 0) || !(h.damping_ratio > 0) || !std::isfinite(h.head_max_rad) || !std::isfinite(h.trunk_max_rad) ||
      !std::isfinite(h.shoulder_max_rad))
    return false;
  const double share = std::min(1.0, h.share);
  const auto joint = [&](CJ j) { return drawn[static_cast<std::size_t>(rig.skeleton.index(j))]; };
  const Vector3d& v = h.velocity_mps;
  // The unit rotation axis a push along v at the fist gives a chain turning about `pivot`.
  const auto axis = [&](const Vector3d& pivot) -> Vector3d {
    Vector3d a = (h.point_m - pivot).cross(v);
    if (a.norm() < 1e-6 * std::max(1.0, v.norm())) a = Vector3d::UnitY().cross(Vector3d(v.x(), 0, v.z()));
    return a.norm() > 1e-9 ? Vector3d(a.normalized()) : Vector3d::Zero();
  };
  const double w = h.stiffness_rad_s, z = h.driven ? 1.0 : std::min(1.0, h.damping_ratio);
  const double peak = unit_peak(w, z);
  springs_.target.fill(Vector3d::Zero());  // a driven lean's angles are set below; a blow's push has none
  // A chain's rate for `angle` at its peak, added to what it has, and no more than its full
  // reel; a driven lean's angle instead (the spring from where it is toward it).
  const auto push = [&](Chain c, const Vector3d& dir, double angle, double most) {
    if (h.driven) {
      springs_.target[c] = dir * std::min(angle, std::abs(most));
      return;
    }
    Vector3d& r = springs_.rate[c];
    r += dir * (angle / peak);
    const double cap = std::abs(most) / peak;
    if (r.norm() > cap) r *= cap / r.norm();
  };
  const Vector3d pelvis = joint(CJ::pelvis), chest = joint(CJ::chest), neck = joint(CJ::neck);
  const Vector3d trunk_axis = axis(pelvis);
  if (h.head) {
    push(kHead, axis(neck), share * h.head_max_rad, h.head_max_rad);
    push(kTrunk, trunk_axis, kHeadBlowTrunkShare * share * h.trunk_max_rad, h.trunk_max_rad);
  } else {
    push(kTrunk, trunk_axis, share * h.trunk_max_rad, h.trunk_max_rad);
    push(kHead, -trunk_axis, kTorsoBlowHeadLag * share * h.trunk_max_rad, h.head_max_rad);
    const Vector3d across = joint(CJ::l_shoulder) - joint(CJ::r_shoulder);
    if (across.norm() > 1e-6) {
      const double off = (h.point_m - chest).dot(across.normalized());
      if (std::abs(off) >= kOffCentre_m) {
        const int side = off > 0 ? kLeft : kRight;
        push(side == kLeft ? kShoulderL : kShoulderR, axis(chest), share * h.shoulder_max_rad, h.shoulder_max_rad);
      }
    }
  }
  springs_.active = true;
  springs_.stiffness_rad_s = w;
  springs_.damping_ratio = z;
  springs_.since_s = 0;
  springs_.hold_s = h.driven && std::isfinite(h.hold_s) ? std::max(0.0, h.hold_s) : 0.0;
  return true;
}

void HitReel::step_back_to(const Vector2d& goal_xz, Timestamp until) {
  step_back_ = goal_xz;
  step_back_until_ = until;
}

ReelState HitReel::state() const {
  ReelState r;
  r.active = springs_.active;
  r.trunk = springs_.theta[kTrunk];
  r.head = springs_.theta[kHead];
  r.shoulder = {springs_.theta[kShoulderL], springs_.theta[kShoulderR]};
  return r;
}

void HitReel::advance(double dt) {
  if (!springs_.active) return;
  // A driven lean held its time is let back: its spring then returns to none from where it is.
  if (springs_.since_s >= springs_.hold_s) springs_.target.fill(Vector3d::Zero());
  springs_.since_s += dt;
  bool rest = springs_.since_s >= std::max(kReelMin_s, springs_.hold_s);
  for (std::size_t c = 0; c < springs_.theta.size(); ++c) {
    // Stepped about its equilibrium (the driven angle, or none): linear, so exactly.
    Vector3d x = springs_.theta[c] - springs_.target[c];
    spring_step(x, springs_.rate[c], springs_.stiffness_rad_s, springs_.damping_ratio, dt);
    springs_.theta[c] = x + springs_.target[c];
    rest = rest && springs_.target[c].isZero() && springs_.theta[c].norm() < kReelRestRad && springs_.rate[c].norm() < kReelRestRadPerS;
  }
  if (rest) springs_ = Springs{};
}

const MkmFrame* HitReel::lay(const MkmFrame& pose) {
  if (!springs_.active) return nullptr;
  reeled_ = pose;
  MkmFrame& f = reeled_;
  const Quaterniond rt = rotation_of(springs_.theta[kTrunk]);
  const Quaterniond rh = rotation_of(springs_.theta[kHead]);
  f.spine_dir = rt * f.spine_dir;
  f.chest = (rt * f.chest).normalized();
  f.head_dir = rh * (rt * f.head_dir);
  for (int s = 0; s < 2; ++s) {
    // The arm rides with its shoulder girdle: its direction and pole turn with it (held in the
    // room while the shoulder moved, the elbow swung 67 mm a frame under two full blows).
    const auto us = static_cast<std::size_t>(s);
    const Quaterniond r = rotation_of(springs_.theta[s == kLeft ? kShoulderL : kShoulderR]) * rt;
    f.clavicle_dir[us] = r * f.clavicle_dir[us];
    f.arm_n[us] = r * f.arm_n[us];
    f.arm_pole[us] = r * f.arm_pole[us];
  }
  return &reeled_;
}

// ---- Behaviour's side of a blow: the reel, a strike aborted, a step back ------------------

bool Behaviour::hit(const HitOrder& h, Timestamp now) {
  if (!have_pose_ || !reel_.take(h, characters_[static_cast<std::size_t>(character_)], rig_positions_)) return false;
  abort_until_ = now + kAbortWindow_s;
  const Vector2d along(h.velocity_mps.x(), h.velocity_mps.z());
  if (h.step_back_m > 0 && along.norm() > 1e-6)
    reel_.step_back_to(clamp_to_area(config_, spot_xz_m_ + along.normalized() * h.step_back_m), now + kStepBackFor_s);
  return true;
}

Behaviour::ReelState Behaviour::reel() const { return reel_.state(); }

bool Behaviour::attacking() const { return striking() && !strike_.block && !strike_.contact_done && !strike_.aborted; }

void Behaviour::abort_strike(Timestamp now) {
  if (attacking()) abort_until_ = std::max(abort_until_, now + kAbortWindow_s);
}

void Behaviour::abort_strike_for_blow(Timestamp now) {
  if (!(now <= abort_until_) || !striking() || strike_.block || strike_.contact_done) return;
  // Not before its own cross-fade in is done: leaving mid-blend drops the motion it blends
  // from in one frame (a block leaving so jumped the body 25 cm). The reel shows the blow
  // meanwhile.
  if (player_.blend_elapsed_s() < tun_.blend_time_s) return;
  const double t = player_.current().time_s;
  strike_.aborted = true;
  strike_.abort_s = t;
  strike_.abort_ramp = ramp_in(t);
  strike_.release_end_s = t + tun_.release_time_s * player_.current().rate;
  abort_until_ = -1;
  ++strikes_aborted_;
  start_rest(now);
  enter(Recovering{});
}

}  // namespace kumite::content
