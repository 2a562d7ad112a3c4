// The guard and parries (Guard, guard.hpp; issue 53, item 3). Sparring with blocks on, the fighter
// keeps both forearms raised before its face and chest whenever it is not striking (the
// karate stance's hands hang at the hips: a block from there needs 0.2-0.4 s of clip, and a
// punch is seen coming 50-170 ms before it lands). A fist seen coming is parried from the
// guard: the forearm nearer its path is brought across it, where the fist will be once the
// forearm can be there, by a minimum-jerk move of the wrist (peak speed bounded: no whip),
// held until the fist has passed, and eased back to the guard.
//
// Both are laid on the composed pose (MkmFrame: each arm's shoulder -> wrist direction and
// elbow pole, room frame) before the decode, so the arm IK, the reel of a blow and the feet
// act on top as on any pose; the legs and trunk are the motion's own.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "kumite/content/guard.hpp"

#include "behaviour_internal.hpp"
#include "kumite/content/behaviour.hpp"
#include "kumite/content/canonical.hpp"
#include "kumite/content/hit_reel.hpp"
#include "kumite/content/ik.hpp"

namespace kumite::content {

using namespace behaviour_detail;
using CJ = CanonicalJoint;
using Eigen::Vector3d;

namespace {
/// s: the guard comes up over this (smoothstep) and goes down over kGuardOut_s as a strike starts.
constexpr double kGuardIn_s = 0.4;
constexpr double kGuardOut_s = 0.15;
/// The guard's weight from which the fighter parries (below it a block clip answers).
constexpr double kGuardUp = 0.9;
/// The guard's wrist and elbow from the shoulder, in arm lengths, in the chest's frame (x
/// toward the fighter's left, y up along the neck, z forward), for the left arm (x mirrored
/// for the right): the fist before the chin, a little inside the shoulder, the elbow below
/// it in front of the ribs.
const Vector3d kGuardWrist(-0.22, 0.30, 0.32);
const Vector3d kGuardElbow(-0.05, -0.45, 0.20);
/// m/s: a parry's wrist and elbow move at most this fast on the straight way (a minimum-jerk move peaks at 1.875 x its mean speed).
constexpr double kParryPeak_mps = 6.0;
/// s: the shortest parry move; from an arm still in a parry, four display frames at 60 Hz.
constexpr double kParryMin_s = 0.05;
constexpr double kParryFromParry_s = 4.0 / 60;
/// Updates a parry's move takes at the least where an update is kParryFloorFrom_s or longer
/// (Guard::lay): under 55 a second, so 60 Hz keeps kParryMin_s (three updates).
constexpr double kParryMinUpdates = 4;
constexpr double kParryFloorFrom_s = 1.0 / 55;
/// s: the forearm is planned in place at least this before the fist (one display frame at 60 Hz).
constexpr double kParryMargin_s = 1.0 / 60;
/// s it stays across the path after the fist's predicted arrival at it.
constexpr double kParryHoldPast_s = 0.15;
/// s back to the guard: at least, and at most however its way is.
constexpr double kParryBack_s = 0.3;
constexpr double kParryBackMost_s = 0.8;
/// The wrist stays within this share of the arm's length from the shoulder (a straight arm
/// parries nothing and its elbow flips) and beyond kParryFold of it (an arm folded onto its
/// shoulder swings its elbow round on a small move of the wrist, and shields nothing).
constexpr double kParryReach = 0.92;
constexpr double kParryFold = 0.35;
/// Samples along a parry's move to find how fast the drawn elbow goes (it turns on an arc).
constexpr int kParryPathSamples = 24;
/// m: the hand's length beyond the wrist (fingers' ends; CMU hands 0.15-0.2 m) and the thumb's
/// reach across the forearm: the forearm's turn and twist swing them faster than the wrist.
constexpr double kHand_m = 0.2;
constexpr double kThumb_m = 0.1;
/// A slip's lean: the trunk's turn at its peak (rad: 0.25 moves a head 0.6 m above the pelvis
/// ~15 cm) and the share of its way that goes back along the fist's way.
constexpr double kSlipTrunk_rad = 0.25;
constexpr double kSlipBack = 0.5;
/// rad/s: a slip's lean is driven critically damped at this (from rest: 0.8 of its way by
/// 0.1 s; at most 0.25 x 30 / e = 2.8 rad/s, a head 0.6 m up ~1.7 m/s), held, then let back.
/// 40 moved a parrying hand's end 2.0 m/s faster in one frame, 25 left the head 1.5 cm nearer
/// a kick's line.
constexpr double kSlipStiffness_rad_s = 30;
/// s: intercepts are tried this far apart along the fist's path.
constexpr double kParryStep_s = 1.0 / 240;

Vector3d mirrored(const Vector3d& v, int side) { return side == kLeft ? v : Vector3d(-v.x(), v.y(), v.z()); }

/// `pole` made unit and across `axis` (the elbow's direction off the shoulder -> wrist line);
/// `fallback` where it lies along it.
Vector3d unit_across(const Vector3d& pole, const Vector3d& axis, const Vector3d& fallback) {
  const double n = axis.norm();
  if (n < 1e-9) return fallback;
  const Vector3d a = axis / n;
  const Vector3d p = pole - pole.dot(a) * a;
  return p.norm() > 1e-6 ? Vector3d(p.normalized()) : fallback;
}
/// The unit direction of `from` turned the share x of the way to `to`'s (slerp; x = 0: from's).
Vector3d turned_toward(const Vector3d& from, const Vector3d& to, double x) {
  if (from.norm() < 1e-9 || to.norm() < 1e-9) return from.norm() < 1e-9 ? Vector3d(to.normalized()) : Vector3d(from.normalized());
  const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(from.normalized(), to.normalized());
  return Eigen::Quaterniond::Identity().slerp(x, q) * from.normalized();
}
/// `v` turned as the direction `from` turns onto `to` (the shortest turn; v itself where either is zero).
Vector3d carried(const Vector3d& v, const Vector3d& from, const Vector3d& to) {
  if (from.norm() < 1e-9 || to.norm() < 1e-9) return v;
  return Eigen::Quaterniond::FromTwoVectors(from, to) * v;
}
/// The elbow, from the shoulder, of an arm whose wrist lies at `wrist` from the shoulder, bent
/// toward `pole` (unit, across): where the decode's two-bone IK puts it.
Vector3d elbow_of(const Vector3d& wrist, const Vector3d& pole, double upper_m, double fore_m) {
  const double d = std::clamp(wrist.norm(), std::abs(upper_m - fore_m) + 1e-6, upper_m + fore_m);
  const TwoBoneBend b = two_bone_bend(upper_m, fore_m, d);
  const Vector3d axis = wrist.norm() > 1e-9 ? Vector3d(wrist.normalized()) : Vector3d::UnitY();
  return axis * b.along_m + pole * b.off_m;
}

/// A parry's arm (from the shoulder) at the share x of a way from (w0, e0) to (w1, e1): the
/// wrist along a straight line, the elbow's pole turned from e0's to e1's, the arm drawn
/// through them. Guard::lay draws every phase of a parry with it, and parry_move_s times a
/// move by it.
struct ArmAt {
  Vector3d wrist, elbow;  ///< m from the shoulder; `elbow` where the two-bone IK draws it
  Vector3d pole;          ///< unit: the arm's pole (toward the wanted elbow, across the wrist's line)
  Vector3d hand;          ///< m from the shoulder: kHand_m on along the forearm
  Vector3d thumb;         ///< m from the shoulder: kThumb_m from the wrist toward the elbow's pole
};
ArmAt parry_arm_at(double x, const Vector3d& w0, const Vector3d& e0, const Vector3d& w1, const Vector3d& e1, const Vector3d& pole0,
                   double upper_m, double fore_m, const double* turn_near = nullptr, double* turn_out = nullptr) {
  Vector3d wp = (1 - x) * w0 + x * w1;
  // No nearer the shoulder than kParryFold of the arm on the way either: a way between two
  // places on either side of the shoulder (a parry's place and the guard) passed 0.13 m from it,
  // the arm folded shut, its elbow on the shoulder -> wrist line, where the elbow's pole (and the
  // drawn elbow, 7 cm in a frame) flips.
  const double fold = kParryFold * (upper_m + fore_m), r = wp.norm();
  if (r < fold && r > 1e-9) wp *= fold / r;
  // The elbow's pole: the start's and the end's, each carried with its arm onto the wrist's
  // direction now (turned as that direction turns, so across it), then turned the short way
  // from one to the other. Taken from the straight line between the two elbows, it swung round
  // the long way where that line passed by the shoulder -> wrist line (a right parry from the
  // guard, its elbow 29 cm in a frame: spar demo seed 1 at 27.73 s); turned without the
  // carrying, a pole across a wrist ahead lay along the wrist as it came down, and the drawn
  // elbow went 20 cm in a frame there.
  // The turn is taken nearest the last frame's (turn_near: its angle about the wrist's
  // direction), not the short way afresh: on a way back from a place behind and beside the
  // shoulder to a guard coming back up ahead of it, the wrist's direction came near the
  // opposite of the place's, the start's pole carried onto it turned up to 2 rad a frame, the
  // turn between the two passed pi and the short way changed side from one frame to the next:
  // the drawn elbow 11 cm in a frame, the hand 14 (spar demo seed 6, stance steps on, at 16.18 s).
  const Vector3d p0 = unit_across(e0, w0, pole0), p1 = unit_across(e1, w1, p0);
  const Vector3d c0 = carried(p0, w0, wp), c1 = carried(p1, w1, wp);
  Vector3d pole = turned_toward(c0, c1, x);
  if (wp.norm() > 1e-9) {
    const Vector3d axis = wp.normalized();
    double turn = std::atan2(c0.cross(c1).dot(axis), c0.dot(c1));  // rad about the wrist's direction, (-pi, pi]
    if (turn_near != nullptr && std::isfinite(*turn_near) && std::isfinite(turn)) {
      const double k = std::round((*turn_near - turn) / (2 * std::numbers::pi));
      if (k != 0) {
        turn += 2 * std::numbers::pi * k;
        pole = Eigen::AngleAxisd(x * turn, axis) * c0;
      }
    }
    if (turn_out != nullptr) *turn_out = turn;
  }
  pole = unit_across(pole, wp, pole0);
  const Vector3d el = elbow_of(wp, pole, upper_m, fore_m);
  const Vector3d fore = wp - el;
  return {wp, el, pole, fore.norm() > 1e-9 ? Vector3d(wp + fore.normalized() * kHand_m) : wp, wp + pole * kThumb_m};
}

/// s: the shortest minimum-jerk move from (w0, e0) to (w1, e1) in which neither the wrist,
/// the elbow as drawn nor the hand's end or thumb goes faster than kParryPeak_mps. The drawn elbow turns about the
/// shoulder -> wrist line as the wanted elbow moves past it, so its way is sampled rather than
/// taken as the straight line between its ends.
double parry_move_s(const Vector3d& w0, const Vector3d& e0, const Vector3d& w1, const Vector3d& e1, const Vector3d& pole0,
                    double upper_m, double fore_m) {
  double most = 0;  // m per unit of the move's share of time: the fastest part of the way
  // (Each sample's pole turn taken nearest the last sample's, as Guard::lay draws it.)
  double turn = 0;
  ArmAt prev = parry_arm_at(0, w0, e0, w1, e1, pole0, upper_m, fore_m, nullptr, &turn);
  for (int k = 1; k <= kParryPathSamples; ++k) {
    const double ds = 1.0 / kParryPathSamples;
    const double near = turn;
    const ArmAt now = parry_arm_at(min_jerk(k * ds), w0, e0, w1, e1, pole0, upper_m, fore_m, &near, &turn);
    most = std::max({most, (now.wrist - prev.wrist).norm() / ds, (now.elbow - prev.elbow).norm() / ds,
                     (now.hand - prev.hand).norm() / ds, (now.thumb - prev.thumb).norm() / ds});
    prev = now;
  }
  return std::max(kParryMin_s, most / kParryPeak_mps);
}
}  // namespace

// ---- Guard ---------------------------------------------------------------------------

bool Guard::up() const { return have_last_ && weight_ >= kGuardUp; }

bool Guard::arm_free() const { return !parry_[0].busy() || !parry_[1].busy(); }

bool Guard::parrying() const { return parry_[0].busy() || parry_[1].busy(); }

namespace {
/// A parry's place: the arm, the time along the fist's path at which the forearm meets it,
/// the move's time and how late it is (negative: in time, with that margin).
struct ParryPick {
  int side = -1;
  double t_s = 0, move_s = 0, late_s = 1e9;
  Vector3d wrist, elbow, cross;
};

/// The place for a parry against `b` by an arm for which `may(side)` holds: the intercept
/// needing the shortest move among those the forearm can be in place for in time; where none
/// can, the one it is least late for. `drawn`: the joints drawn last on `rig` (m, room).
template <class May>
ParryPick pick_parry(const BlockOrder& b, const Rig& rig, std::span<const Vector3d> drawn, const Eigen::Quaterniond& chest,
                     const May& may) {
  ParryPick best;
  const double speed = b.velocity_mps.norm();
  if (!(speed > 1e-3)) return best;
  const Morphology& m = rig.morphology;
  const auto joint = [&](CJ j) { return drawn[static_cast<std::size_t>(rig.skeleton.index(j))]; };
  const Vector3d v_unit = b.velocity_mps / speed;
  const double horizon = std::max(0.0, b.arrival_s);
  for (int side = 0; side < 2; ++side) {
    if (!may(side)) continue;
    const Vector3d sh = joint(side == kLeft ? CJ::l_shoulder : CJ::r_shoulder);
    const Vector3d wr = joint(side == kLeft ? CJ::l_wrist : CJ::r_wrist);
    const Vector3d el = joint(side == kLeft ? CJ::l_elbow : CJ::r_elbow);
    const double arm = m.arm_length(side), half = 0.5 * m.forearm_m[side];
    // The forearm lies across the path, its middle on it: turned from the guard's forearm (its
    // part along the fist's way taken out), or pointing from where the elbow is now to the
    // path (the elbow then hardly moves); the one needing the shorter move.
    std::array<Vector3d, 2> dirs{chest * mirrored(kGuardWrist - kGuardElbow, side), Vector3d::Zero()};
    for (double t = 0; t <= horizon + 1e-9; t += kParryStep_s) {
      const Vector3d cross = b.fist_m + b.velocity_mps * t;
      dirs[1] = cross - el;
      for (Vector3d f : dirs) {
        f -= f.dot(v_unit) * v_unit;
        if (f.norm() < 1e-6) continue;
        f.normalize();
        const Vector3d wrist = cross + f * half, elbow = cross - f * half;
        const double reach = (wrist - sh).norm();
        if (reach > kParryReach * arm || reach < kParryFold * arm) continue;
        // The move's length: the wrist's way or the elbow's (where the IK draws it, bent
        // toward the wanted elbow), the longer; the chosen one's time is then taken along
        // its drawn path (parry_move_s).
        const Vector3d drawn_elbow = sh + elbow_of(wrist - sh, unit_across(elbow - sh, wrist - sh, el - sh), m.upper_arm_m[side],
                                                   m.forearm_m[side]);
        const double d = std::max((wrist - wr).norm(), (drawn_elbow - el).norm());
        const double move = std::max(kParryMin_s, 1.875 * d / kParryPeak_mps);
        const double late = move + kParryMargin_s - t;
        const bool in_time = late <= 0;
        // The intercept needing the shortest move among those the forearm can be in place for
        // in time; where none can, the one it is least late for.
        const bool better = best.side < 0 || (in_time && (best.late_s > 0 || move < best.move_s)) ||
                            (!in_time && best.late_s > 0 && late < best.late_s);
        if (better) best = ParryPick{side, t, move, late, wrist, elbow, cross};
      }
    }
  }
  return best;
}
}  // namespace

bool Guard::parry(const BlockOrder& b, Timestamp now, const Rig& rig, std::span<const Vector3d> drawn, const Eigen::Quaterniond& chest) {
  if (!b.fist_m.allFinite() || !b.velocity_mps.allFinite() || !std::isfinite(b.arrival_s)) return false;
  const double speed = b.velocity_mps.norm();
  const Morphology& m = rig.morphology;
  const auto joint = [&](CJ j) { return drawn[static_cast<std::size_t>(rig.skeleton.index(j))]; };
  ParryPick best = pick_parry(b, rig, drawn, chest, [&](int side) { return !parry_[static_cast<std::size_t>(side)].busy(); });
  if (best.side < 0) return false;  // nowhere on its path within a free arm's reach
  const auto bs = static_cast<std::size_t>(best.side);
  Guard::Parry& g = parry_[bs];
  {
    // The move's time along the way Guard::lay draws it, from the arm as it was drawn last.
    const Vector3d sh = joint(best.side == kLeft ? CJ::l_shoulder : CJ::r_shoulder);
    const double arm = m.arm_length(best.side), up = m.upper_arm_m[bs], fore = m.forearm_m[bs];
    const Vector3d w0 = last_arm_n_[bs] * arm, e0 = elbow_of(w0, last_arm_pole_[bs], up, fore);
    best.move_s = std::max(best.move_s, parry_move_s(w0, e0, best.wrist - sh, best.elbow - sh, last_arm_pole_[bs], up, fore));
    // From an arm still in a parry (held or going back), at least kParryFromParry_s: in 0.05 s
    // a short move from there (7 cm) put half its way into one frame, the wrist 5.6 cm between
    // neighbours of 1-2 cm (spar demo seed 4, stance steps off, at 52.1 s).
    if (g.on) best.move_s = std::max(best.move_s, kParryFromParry_s);
  }
  g.on = true;
  g.t_s = 0;
  g.move_s = best.move_s;
  g.hold_end_s = std::max(best.move_s, best.t_s) + kParryHoldPast_s;
  g.back_s = kParryBack_s;
  g.back_timed = false;
  g.turn_phase = -1;
  g.from_arm_n = last_arm_n_[static_cast<std::size_t>(best.side)];
  g.from_pole = last_arm_pole_[static_cast<std::size_t>(best.side)];
  g.wrist_m = best.wrist;
  g.elbow_m = best.elbow;
  g.cross_m = best.cross;
  g.said = false;
  g.reaim_t_s = -1;
  g.reaim_s = 0;
  g.meet_t = now + best.t_s;
  g.carried = false;
  g.limb = b.limb;
  g.recognised = b.recognised;
  g.fist_speed_mps = speed;
  return true;
}

Vector3d Guard::Parry::wrist_target() const {
  if (reaim_t_s < 0) return wrist_m;
  return wrist_from_m + min_jerk((t_s - reaim_t_s) / std::max(reaim_s, 1e-6)) * (wrist_m - wrist_from_m);
}

Vector3d Guard::Parry::elbow_target() const {
  if (reaim_t_s < 0) return elbow_m;
  return elbow_from_m + min_jerk((t_s - reaim_t_s) / std::max(reaim_s, 1e-6)) * (elbow_m - elbow_from_m);
}

bool Guard::reaim(const BlockOrder& b, Timestamp now, const Rig& rig, std::span<const Vector3d> drawn, const Eigen::Quaterniond& chest) {
  if (!b.fist_m.allFinite() || !b.velocity_mps.allFinite() || !std::isfinite(b.arrival_s)) return false;
  int side = -1;
  for (int s = 0; s < 2; ++s)
    if (parry_[static_cast<std::size_t>(s)].busy() && parry_[static_cast<std::size_t>(s)].limb == b.limb) side = s;
  if (side < 0) return false;
  const ParryPick p = pick_parry(b, rig, drawn, chest, [&](int s) { return s == side; });
  if (p.side < 0) return false;  // the new path is beyond this arm: it keeps its aim
  Parry& g = parry_[static_cast<std::size_t>(side)];
  // The targets shift from where they are now (mid-shift if re-aimed before) to the new
  // place; the shift starts at rest, so the drawn arm keeps its place and speed.
  const Morphology& m = rig.morphology;
  const auto s = static_cast<std::size_t>(side);
  const Vector3d sh = drawn[static_cast<std::size_t>(rig.skeleton.index(side == kLeft ? CJ::l_shoulder : CJ::r_shoulder))];
  const Vector3d wrist_now = g.carried ? Vector3d(sh + g.wrist_carried_m) : g.wrist_target();
  const Vector3d elbow_now = g.carried ? Vector3d(sh + g.elbow_carried_m) : g.elbow_target();
  g.carried = false;
  g.back_timed = false;
  g.wrist_from_m = wrist_now;
  g.elbow_from_m = elbow_now;
  g.wrist_m = p.wrist;
  g.elbow_m = p.elbow;
  g.cross_m = p.cross;
  g.reaim_t_s = g.t_s;
  g.reaim_s = parry_move_s(wrist_now - sh, elbow_now - sh, p.wrist - sh, p.elbow - sh, last_arm_pole_[s], m.upper_arm_m[s],
                           m.forearm_m[s]);
  g.meet_t = now + p.t_s;
  g.hold_end_s = std::max(g.in_place_s(), g.t_s + p.t_s) + kParryHoldPast_s;
  g.recognised = b.recognised;
  g.fist_speed_mps = b.velocity_mps.norm();
  return true;
}

void Guard::lay(double dt, Timestamp now, bool allowed, bool drawn_before, const Rig& rig, std::span<const Vector3d> drawn,
                MkmFrame& pose, std::vector<FighterEvent>& events) {
  const bool want = wanted_ && allowed;
  up_ = std::clamp(up_ + (want ? dt / kGuardIn_s : -dt / kGuardOut_s), 0.0, 1.0);
  const double w = up_ > 0 ? smoothstep(up_) : 0.0;
  weight_ = w;
  const Morphology& m = rig.morphology;
  for (int side = 0; side < 2; ++side) {
    const auto s = static_cast<std::size_t>(side);
    Parry& pr = parry_[s];
    if (!wanted_ && up_ <= 0) pr.on = false;
    if (pr.on) pr.t_s += dt;
    // Updated under 55 times a second (kParryFloorFrom_s), a parry's move, and a re-aim's shift,
    // take at least kParryMinUpdates updates, timed from their first (the hold lengthened to
    // follow): at 30 Hz a move timed at its shortest (kParryMin_s) put 79 % of its way into one
    // frame (the spar demo on a 30 Hz loop, every seed at 5.47 s: the elbow 7.8 cm between 1.9
    // and 3.9), at 50 Hz most of it (the hand 7.4 cm between 0.7 and 2.2; three updates there
    // still left an elbow 7.0 cm between 2.3 and 2.1). Not at 60 Hz and faster: four updates
    // (67 ms) are longer than kParryMin_s there, and the shipped frames keep their parries'
    // timing. (pick_parry still plans with the unfloored move, so a parry it finds in time may
    // be late where the floor acts.)
    if (pr.on && dt >= kParryFloorFrom_s) {
      const double least = kParryMinUpdates * dt;
      if (pr.turn_phase == -1 && pr.move_s < least) {  // the parry's first update (parry() set -1)
        pr.move_s = least;
        pr.hold_end_s = std::max(pr.hold_end_s, pr.move_s + kParryHoldPast_s);
      }
      if (pr.reaim_t_s >= 0 && pr.t_s - pr.reaim_t_s < 1.5 * dt && pr.reaim_s < least) {  // a re-aim's first update
        pr.reaim_s = least;
        pr.hold_end_s = std::max(pr.hold_end_s, pr.in_place_s() + kParryHoldPast_s);
      }
    }
    if (pr.on && pr.t_s >= pr.hold_end_s + pr.back_s) pr.on = false;
    Vector3d a = pose.arm_n[s], p = pose.arm_pole[s];
    if (w > 0 && drawn_before) {
      const Vector3d ag = pose.chest * mirrored(kGuardWrist, side);
      const Vector3d pg = unit_across(pose.chest * mirrored(kGuardElbow, side), ag, p);
      // The motion's arm and the guard's, each as a wrist and an elbow from the shoulder,
      // turned into each other about the shoulder (slerped directions, lerped distances): a
      // straight blend of the arm vectors and poles swung the drawn elbow round the short
      // shoulder -> wrist line as a strike began from the guard (18.8 m/s for 0.15 s in the
      // spar bout with stance steps, the wrist at 6 m/s); this way it turns with the wrist.
      const double arm = m.arm_length(side), up = m.upper_arm_m[s], fore = m.forearm_m[s];
      const Vector3d wa = a * arm, wb = ag * arm;
      const Vector3d ea = elbow_of(wa, p, up, fore), eb = elbow_of(wb, pg, up, fore);
      const Vector3d wp = turned_toward(wa, wb, w) * ((1 - w) * wa.norm() + w * wb.norm());
      const Vector3d ep = turned_toward(ea, eb, w) * ((1 - w) * ea.norm() + w * eb.norm());
      a = wp / arm;
      p = unit_across(ep, wp, p);
    }
    if (pr.on && drawn_before) {
      // The wrist and the elbow (from the shoulder) each moved along a straight line, the arm
      // drawn through them (its direction to the wrist, its pole toward the elbow): parry_arm_at.
      const double arm = m.arm_length(side), up = m.upper_arm_m[s], fore = m.forearm_m[s];
      const Vector3d sh = drawn[static_cast<std::size_t>(rig.skeleton.index(side == kLeft ? CJ::l_shoulder : CJ::r_shoulder))];
      Vector3d w1 = pr.wrist_target() - sh;
      if (w1.norm() > kParryReach * arm) w1 *= kParryReach * arm / w1.norm();
      Vector3d e1 = pr.elbow_target() - sh;
      // Once the fist is due, the place goes with the body: held in the room, a place the
      // shoulder walked onto (the fighter following through its hold) had the wrist pushed out
      // of the fold the other way from one frame to the next, 16 cm (the elbow 41 m/s: spar
      // demo seed 8 at 15.95 s).
      if (now >= pr.meet_t) {
        if (!pr.carried) {
          pr.carried = true;
          pr.wrist_carried_m = w1;
          pr.elbow_carried_m = e1;
        }
        w1 = pr.wrist_carried_m;
        e1 = pr.elbow_carried_m;
      }
      // The way of this phase: from the arm as drawn when the parry began to its place; held
      // there; from there back to the guard (or the motion's arm).
      Vector3d wa = w1, ea = e1, wb = w1, eb = e1;
      double x = 1;
      int phase = 1;  // 0 to its place, 1 held, 2 back
      if (pr.t_s < pr.move_s) {
        phase = 0;
        wa = pr.from_arm_n * arm;
        ea = elbow_of(wa, pr.from_pole, up, fore);
        x = min_jerk(pr.t_s / pr.move_s);
      } else if (pr.t_s >= pr.hold_end_s) {
        phase = 2;
        wb = a * arm;
        eb = elbow_of(wb, p, up, fore);
        // Timed along its way as it starts, as a move to a place is (parry_move_s), at least
        // kParryBack_s: a way back from a place beside the shoulder to the guard swept round
        // it at the fold's radius in 0.3 s, the wrist 13 cm and the elbow 26 cm in a frame
        // (spar demo seed 8, stance steps off, at 16.07 s).
        if (!pr.back_timed) {
          pr.back_timed = true;
          pr.back_s = std::clamp(parry_move_s(wa, ea, wb, eb, p, up, fore), kParryBack_s, kParryBackMost_s);
        }
        x = min_jerk((pr.t_s - pr.hold_end_s) / pr.back_s);
      }
      double turn = 0;
      const ArmAt at = parry_arm_at(x, wa, ea, wb, eb, p, up, fore, pr.turn_phase == phase ? &pr.pole_turn_rad : nullptr, &turn);
      pr.turn_phase = phase;
      pr.pole_turn_rad = turn;
      a = at.wrist / arm;
      p = at.pole;
      if (!pr.said && pr.t_s >= pr.in_place_s()) {
        pr.said = true;
        FighterEvent& e = events.emplace_back();  // as Behaviour::emit makes it
        e.time = now;
        e.kind = FighterEvent::Kind::block;
        e.order = Order{};
        e.reason = FighterEvent::Reason::none;
        e.distance_m = 0;
        e.segment = -1;  // a parry from the guard, no clip
        e.target = pr.cross_m;
        e.limb = pr.limb;
        e.side = side;
        e.margin_s = pr.meet_t - now;
        e.speed_mps = pr.fist_speed_mps;
        e.recognised = pr.recognised;
      }
    }
    if (w > 0 || pr.on) {
      pose.arm_n[s] = a;
      pose.arm_pole[s] = p;
    }
    last_arm_n_[s] = pose.arm_n[s];
    last_arm_pole_[s] = pose.arm_pole[s];
  }
  have_last_ = drawn_before || have_last_;
}

// ---- Behaviour's guard: what the Guard may do now ------------------------------------

double Behaviour::guard_weight() const { return guard_.weight(); }

bool Behaviour::guarding() const { return !paused_ && have_pose_ && !(striking() && !strike_.block) && guard_.up(); }

bool Behaviour::can_parry() const { return guarding() && guard_.arm_free(); }

bool Behaviour::parry(const BlockOrder& b, Timestamp now) {
  if (!can_parry()) return false;
  return guard_.parry(b, now, characters_[static_cast<std::size_t>(character_)], rig_positions_, pose_.chest);
}

bool Behaviour::parrying() const { return guard_.parrying(); }

bool Behaviour::slip(const BlockOrder& b, Timestamp /*now*/) {
  if (paused_ || !have_pose_ || striking() || !b.fist_m.allFinite() || !b.velocity_mps.allFinite()) return false;
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  const Vector3d head = rig_positions_[static_cast<std::size_t>(rig.skeleton.index(CJ::head))];
  // Horizontal: the way the fist comes, and the head's side of its path (a path through the
  // head: the side away from the striking limb's own side of the visitor).
  Vector3d along(b.velocity_mps.x(), 0, b.velocity_mps.z());
  if (along.norm() < 1e-6) return false;
  along.normalize();
  Vector3d off = head - b.fist_m;
  off.y() = 0;
  off -= off.dot(along) * along;
  if (off.norm() < 0.03) {
    const Vector3d left_of_path = Vector3d::UnitY().cross(along);  // the path's left, seen along it
    const bool right_limb = b.limb == recognition::Role::right_hand || b.limb == recognition::Role::right_foot;
    off = right_limb ? left_of_path : Vector3d(-left_of_path);
  }
  HitOrder h;
  h.point_m = head;
  h.velocity_mps = (off.normalized() + kSlipBack * along).normalized() * b.velocity_mps.norm();
  h.head = false;  // the trunk leans, carrying the head
  h.share = 1;
  h.trunk_max_rad = kSlipTrunk_rad;
  // Leaned, not pushed: from rest, held until the fist has passed, then back.
  h.driven = true;
  h.stiffness_rad_s = kSlipStiffness_rad_s;
  h.hold_s = std::max(0.0, b.arrival_s) + kParryHoldPast_s;
  return reel_.take(h, rig, rig_positions_);
}

bool Behaviour::reaim_parry(const BlockOrder& b, Timestamp now) {
  if (!have_pose_) return false;
  return guard_.reaim(b, now, characters_[static_cast<std::size_t>(character_)], rig_positions_, pose_.chest);
}

}  // namespace kumite::content
