#include "kumite/content/adaptation.hpp"

#include <algorithm>
#include <limits>
#include <cmath>
#include <numbers>
#include <string>

#include "kumite/common/error.hpp"
#include "held_feet_drop.hpp"
#include "kumite/content/ik.hpp"
#include "text.hpp"

namespace kumite::content {

using CJ = CanonicalJoint;
using Role = Rig::Role;
using Eigen::Quaterniond;
using Eigen::Vector3d;

CanonicalJoint Effector::joint() const {
  if (leg) return side == kLeft ? CJ::l_ankle : CJ::r_ankle;
  return side == kLeft ? CJ::l_wrist : CJ::r_wrist;
}

namespace {

struct RoleSpec {
  CJ joint;
  CJ child;
  Role role;
  int side;
};
// Order: the role of a joint index is the first spec that names it.
constexpr std::array<RoleSpec, 17> kRoles{{
    {CJ::pelvis, CJ::pelvis, Role::pelvis, -1},
    {CJ::chest, CJ::neck, Role::chest, -1},
    {CJ::spine, CJ::chest, Role::spine, -1},
    {CJ::neck, CJ::head, Role::neck, -1},
    {CJ::l_clavicle, CJ::l_shoulder, Role::clavicle, kLeft},
    {CJ::r_clavicle, CJ::r_shoulder, Role::clavicle, kRight},
    {CJ::l_shoulder, CJ::l_elbow, Role::shoulder, kLeft},
    {CJ::r_shoulder, CJ::r_elbow, Role::shoulder, kRight},
    {CJ::l_elbow, CJ::l_wrist, Role::elbow, kLeft},
    {CJ::r_elbow, CJ::r_wrist, Role::elbow, kRight},
    {CJ::l_hip, CJ::l_knee, Role::hip, kLeft},
    {CJ::r_hip, CJ::r_knee, Role::hip, kRight},
    {CJ::l_knee, CJ::l_ankle, Role::knee, kLeft},
    {CJ::r_knee, CJ::r_ankle, Role::knee, kRight},
    {CJ::l_ankle, CJ::l_toe, Role::ankle, kLeft},
    {CJ::r_ankle, CJ::r_toe, Role::ankle, kRight},
    {CJ::head, CJ::head, Role::none, -1},
}};

constexpr std::array<CJ, 2> kShoulder{CJ::l_shoulder, CJ::r_shoulder};
constexpr std::array<CJ, 2> kClavicle{CJ::l_clavicle, CJ::r_clavicle};


/// Share of the leg's length over which a held foot's leg straightens its knee softly
/// (solve_two_bone_soft, scaled by the hold's weight so taking a hold is continuous): 1.5 %
/// is ~1.2 cm on a 1.75 m person. A held foot at full extension is then drawn up to 0.37 of
/// that (4 mm) short of its lock, instead of the knee popping straight in one frame.
constexpr double kLegSoftness = 0.015;

/// Share of the arm's length over which the striking arm straightens softly (see the
/// shoulder in decode_pass): 0.8 %, ~5 mm on a 0.6 m arm. A goal at full extension is then
/// drawn at most 0.37 of that short (under 2 mm on the longest arm); the trunk lean keeps
/// goals below the soft zone wherever its limits allow.
constexpr double kArmSoftness = 0.008;
/// A striking arm's wrist goal comes no nearer its shoulder than this share of the arm's length
/// (unless the motion's own wrist is nearer): min_strike_extension's default, the least a punch
/// is planned to land at.
constexpr double kStrikeWristFloorShare = 0.5;
constexpr double kKickSoftness = 0.008;  // the kicking leg's, as the arm's (m per m of leg)

/// m, a 1.75 m person's head drawn as a capsule (scaled with height like the bones).
constexpr double kHeadRadius_m = 0.075;

float bone_radius(Role role, double length_m, double height_m) {
  const double scale = height_m / 1.75;  // radii of a 1.75 m person, scaled
  switch (role) {
    case Role::pelvis: case Role::spine: case Role::chest: return static_cast<float>(0.11 * scale);
    case Role::neck: return static_cast<float>(0.05 * scale);
    case Role::hip: case Role::knee: return static_cast<float>(0.065 * scale);
    case Role::shoulder: case Role::elbow: return static_cast<float>(0.045 * scale);
    default: return static_cast<float>(std::clamp(0.2 * length_m, 0.02, 0.06) * scale);
  }
}

/// A foot's direction `dir` pitched about its ankle at `ankle` (its heading kept) so that the toe
/// joint `foot_m` along it is at height `y_m`, blended in by `w` (0..1): only where the toe lies
/// above it (`no_higher`) or below it (else); `dir` as it is otherwise.
Vector3d toe_kept(const Vector3d& dir, const Vector3d& ankle, double foot_m, double y_m, double w, bool no_higher) {
  const Vector3d d = dir.normalized();
  const Eigen::Vector2d h(d.x(), d.z());
  if (!(w > 0) || !std::isfinite(y_m) || !(foot_m > 1e-6) || h.norm() < 1e-6) return dir;
  const double toe = ankle.y() + d.y() * foot_m;
  if (no_higher ? toe <= y_m : toe >= y_m) return dir;
  const double y = std::clamp((y_m - ankle.y()) / foot_m, -1.0, 1.0);
  const Eigen::Vector2d hn = h.normalized() * std::sqrt(1 - y * y);
  return ((1 - w) * d + w * Vector3d(hn.x(), y, hn.y())).normalized();
}

// Trunk deltas from the CCD fallback (identity when unused): spine, chest, clavicle.
struct TrunkDeltas {
  Quaterniond spine = Quaterniond::Identity();
  Quaterniond chest = Quaterniond::Identity();
  Quaterniond clavicle = Quaterniond::Identity();
  int clavicle_side = -1;
  bool fixed_goal = false;  // later passes keep the effector goal of pass 1 (it must not move with the trunk)
  double pin = 1;           // how much of that goal they keep (the rest follows the lowered body)
  Vector3d goal{0, 0, 0};
  double root_drop_m = 0;   // m: pelvis lowered so held feet stay within the legs' reach
};

struct PassOut {
  std::array<double, 2> heading_delta_rad{std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
  std::array<bool, 2> arm_reached{true, true};
  std::array<bool, 2> leg_reached{true, true};
  Vector3d effector_goal{0, 0, 0};
};

// The motion's own bend direction (elbow/knee, `pole`: across `motion_limb`) carried onto a
// goal that an offset or a held foot has moved: re-projected onto the new axis. Equal to the
// motion's own pole when the goal is the motion's own. (A pole turned with a strongly turned
// axis can point the knee anywhere: a folded leg whose goal passes near the hip flipped its
// knee through the floor; the kept direction does not.)
Vector3d kept_pole(const Vector3d& motion_limb, const Vector3d& axis, const Vector3d& pole) {
  const Vector3d p = pole - pole.dot(axis) * axis;
  const double n = p.norm();
  // Where the kept direction degenerates (the goal turned toward where the joint pointed), ease
  // back to the plain pole: full kept at n >= 0.5, plain at n <= 0.2.
  const double w = std::clamp((n - 0.2) / 0.3, 0.0, 1.0);
  if (w >= 1) return p / n;
  // Plain: turned with the limb (the shortest rotation from its axis to the new one), always
  // across the new axis.
  const double len = motion_limb.norm();
  const Vector3d plain = len > 1e-9 ? carried_pole(pole, motion_limb / len, axis, axis.unitOrthogonal())
                                    : across(pole, axis, axis.unitOrthogonal());
  Vector3d q = (1 - w) * plain;
  if (n > 1e-9) q += w * (p / n);
  return q.norm() > 1e-9 ? Vector3d(q.normalized()) : plain;
}

/// `want` (unit, across `axis`) turned back toward `previous` (the last drawn knee's direction
/// from the hip, projected across `axis`) so that it is at most `max_rad` about the axis from it.
Vector3d swivel_limited(const Vector3d& previous, const Vector3d& axis, const Vector3d& want, double max_rad) {
  Vector3d p = previous - previous.dot(axis) * axis;
  const double n = p.norm();
  if (!(n > 1e-6) || !(max_rad > 0)) return want;
  p /= n;
  const double angle = std::atan2(p.cross(want).dot(axis), p.dot(want));
  if (std::abs(angle) <= max_rad) return want;
  return Eigen::AngleAxisd(std::copysign(max_rad, angle), axis) * p;
}

// One decode pass over the skeleton, parents first.
void decode_pass(const AdaptJob& job, const TrunkDeltas& td, PassOut& out) {
  const Rig& rig = *job.rig;
  const MkmFrame& f = *job.pose;
  const Morphology& m = rig.morphology;
  const Skeleton& sk = rig.skeleton;
  const int n = sk.joint_count();
  const Quaterniond trunk = td.spine * td.chest;
  const Quaterniond chest_world = trunk * f.chest;
  std::array<Vector3d, 2> wrist_goal{Vector3d::Zero(), Vector3d::Zero()};
  std::array<Vector3d, 2> ankle_goal{Vector3d::Zero(), Vector3d::Zero()};

  const Vector3d pelvis_pos(f.root_xz_m.x(), f.root_height_n * m.leg_length_m + m.standing_ankle_m - td.root_drop_m, f.root_xz_m.y());
  for (int i = 0; i < n; ++i) {
    const int p = sk.parents[static_cast<std::size_t>(i)];
    const auto ui = static_cast<std::size_t>(i);
    Vector3d pos;
    Quaterniond inh;
    if (p < 0) {
      inh = rig.rest_local[ui];
      pos = pelvis_pos - inh * rig.root_to_pelvis_local;
    } else {
      const auto up = static_cast<std::size_t>(p);
      pos = job.global_positions[up] + job.global_rotations[up] * sk.offsets[ui];
      inh = job.global_rotations[up] * rig.rest_local[ui];
    }
    const int s = rig.side[ui];
    auto aim = [&](const Vector3d& dir) { return swing_between(inh * rig.aim_local[ui], dir) * inh; };
    Quaterniond rot = inh;
    switch (rig.role[ui]) {
      case Role::pelvis: rot = f.pelvis * rig.pelvis_frame_local.conjugate(); break;
      case Role::spine: rot = aim(td.spine * f.spine_dir); break;
      case Role::chest: rot = chest_world * rig.chest_frame_local.conjugate(); break;
      case Role::neck: rot = aim(trunk * f.head_dir); break;
      case Role::clavicle: {
        const Quaterniond extra = s == td.clavicle_side ? td.clavicle : Quaterniond::Identity();
        rot = aim(trunk * (extra * f.clavicle_dir[s]));
        break;
      }
      case Role::shoulder: {
        const bool striking = job.reach && !job.reach->effector.leg && job.reach->effector.side == s;
        // The other arm leans with the trunk (a bent trunk carries both arms; held in the room
        // frame, the guard arm's elbow flipped as the lean eased out after contact).
        Quaterniond turn = striking ? Quaterniond::Identity() : trunk;
        Vector3d goal = pos + turn * f.arm_n[s] * m.arm_length(s);
        if (striking) {
          turn = job.reach->turn;
          const double own_m = (goal - pos).norm();
          goal = pos + job.reach->stretch * (turn * (goal - pos)) + job.reach->offset_m;
          if (td.fixed_goal) goal = td.pin * td.goal + (1 - td.pin) * goal;
          // A punch shortened onto a near target (stretch < 1) keeps its wrist at least
          // kStrikeWristFloorShare of the arm from the shoulder, or the motion's own distance
          // where that is nearer: shrunk about the shoulder, a lunge's chambered fist passed
          // by it, the arm folded flat and the elbow swung round it (14.7 m/s in the spar); at
          // 0.35 of the arm the elbow still swept round the shoulder at that radius (16.6 m/s:
          // spar demo seed 5, stance steps on, punches waiting for their support foot).
          const double floor_m = std::min(own_m, kStrikeWristFloorShare * m.arm_length(s));
          const Vector3d from_shoulder = goal - pos;
          const double d = from_shoulder.norm();
          if (d < floor_m && d > 1e-9) goal = pos + from_shoulder * (floor_m / d);
          out.effector_goal = goal;
        }
        const Vector3d axis = (goal - pos).normalized();
        // The pole turns with the trunk's rotations as the body carries the elbow (a guard arm's
        // `turn` is the trunk already; a striking arm's axis does not turn with it, its goal
        // stays in the room), and a striking arm's with d(t)'s turn too.
        const Quaterniond ref_turn = striking ? turn : Quaterniond::Identity();
        const Vector3d pole = kept_pole(turn * f.arm_n[s], axis, ref_turn * (trunk * f.arm_pole[s]));
        // The striking arm straightens softly (as a held foot's leg does): near full extension
        // two-bone IK moves the elbow centimetres for the last millimetres, and a goal that
        // comes back within reach the frame after contact popped the elbow (5.6 cm in a frame).
        // The trunk lean keeps a goal at contact within trunk_target_share of the arm, below the
        // soft zone, so the reach there is exact unless the trunk's limits stop it.
        const double softness = striking ? kArmSoftness * (m.upper_arm_m[s] + m.forearm_m[s]) : 0.0;
        const TwoBoneResult r = solve_two_bone_soft(pos, goal, m.upper_arm_m[s], m.forearm_m[s], pole, softness);
        wrist_goal[s] = r.end;
        out.arm_reached[s] = r.reached;
        rot = aim(r.middle - pos);
        break;
      }
      case Role::elbow: {
        rot = aim(wrist_goal[s] - pos);
        const double w = s >= 0 ? std::clamp(job.fist_neutral[static_cast<std::size_t>(s)], 0.0, 1.0) : 0.0;
        const Vector3d& thumb_local = rig.thumb_local[static_cast<std::size_t>(std::max(s, 0))];
        const int sh = s >= 0 ? sk.index(s == kLeft ? CJ::l_shoulder : CJ::r_shoulder) : -1;
        if (w > 0 && sh >= 0 && sh < i && thumb_local.squaredNorm() > 0) {
          // The thumb toward the shoulder's side of the forearm (the palm toward the body's
          // middle): a fist's neutral turn on a bent arm.
          const Vector3d fore = wrist_goal[s] - pos;
          const Vector3d to_shoulder = job.global_positions[static_cast<std::size_t>(sh)] - pos;
          if (fore.norm() > 1e-6) {
            const Vector3d a = fore.normalized();
            const Vector3d want = to_shoulder - to_shoulder.dot(a) * a;
            const Vector3d now = rot * thumb_local;
            if (want.norm() > 1e-3 * to_shoulder.norm()) {
              const double angle = std::atan2(a.dot(now.cross(want)), now.dot(want));
              rot = Quaterniond(Eigen::AngleAxisd(w * angle, a)) * rot;
            }
          }
        }
        break;
      }
      case Role::hip: {
        // d(t) moves the motion's foot; a hold then pulls the result onto the held ankle (a
        // kicking foot put down while d(t) is still being released stays where it is held).
        // A pelvis lowered for held feet is a knee bend: a foot in the air keeps its height
        // above the floor (lowered with the pelvis, a stepping foot skimmed the floor).
        Vector3d goal = pos + f.leg_n[s] * m.limb_leg_length(s) + Vector3d::UnitY() * td.root_drop_m;
        Quaterniond turn = Quaterniond::Identity();
        const bool effector = job.reach && job.reach->effector.leg && job.reach->effector.side == s;
        if (effector) {
          turn = job.reach->turn;
          goal = pos + job.reach->stretch * (turn * (goal - pos)) + job.reach->offset_m;
        }
        double softness = 0;  // m: only a held foot's leg straightens softly (the motion's own leg is exact)
        if (job.feet && job.feet->weight[s] > 0) {
          const double w = std::clamp(job.feet->weight[s], 0.0, 1.0);
          goal = (1 - w) * goal + w * job.feet->ankle_m[s];
          if (!effector) softness = w * std::clamp(job.feet->softness[s], 0.0, 1.0) * kLegSoftness * (m.thigh_m[s] + m.shin_m[s]);
        }
        if (effector) {
          if (td.fixed_goal) goal = td.pin * td.goal + (1 - td.pin) * goal;
          out.effector_goal = goal;
          // The kicking leg straightens softly, as the striking arm does: stretched by d(t)
          // beyond the motion's extension (a shorter character switched in mid-kick), it
          // reached full length a frame before the motion's leg would and stopped there, the
          // knee 9 cm in that frame and still in the next (the bout with stance steps on).
          // The soft zone begins above kKickLockOutShare's 0.99 of the leg: a kick's reach at
          // contact stays exact.
          softness = std::max(softness, kKickSoftness * (m.thigh_m[s] + m.shin_m[s]));
        }
        const Vector3d axis = (goal - pos).normalized();
        Vector3d pole = kept_pole(turn * f.leg_n[s], axis, turn * f.leg_pole[s]);
        if (job.max_knee_swivel_rad > 0 && !job.previous_positions.empty()) {
          const auto& prev = job.previous_positions;
          const Vector3d& hip = prev[static_cast<std::size_t>(sk.index(s == kLeft ? CJ::l_hip : CJ::r_hip))];
          const Vector3d& knee = prev[static_cast<std::size_t>(sk.index(s == kLeft ? CJ::l_knee : CJ::r_knee))];
          const Vector3d& ankle = prev[static_cast<std::size_t>(sk.index(s == kLeft ? CJ::l_ankle : CJ::r_ankle))];
          const Vector3d leg = ankle - hip;
          if (leg.allFinite() && (knee - hip).allFinite() && leg.norm() > 1e-6) {
            const Vector3d u = leg.normalized();
            pole = swivel_limited((knee - hip) - (knee - hip).dot(u) * u, axis, pole, job.max_knee_swivel_rad);
          }
        }
        const TwoBoneResult r = solve_two_bone_soft(pos, goal, m.thigh_m[s], m.shin_m[s], pole, softness);
        ankle_goal[s] = r.end;
        out.leg_reached[s] = r.reached;
        rot = aim(r.middle - pos);
        break;
      }
      case Role::knee: rot = aim(ankle_goal[s] - pos); break;
      case Role::ankle: {
        Vector3d dir = drawn_foot_dir(f, m, s);
        if (job.feet && job.feet->heading_weight[s] > 0) {
          const Eigen::Vector2d& h = job.feet->heading_xz[s];
          const double from = std::atan2(dir.x(), dir.z()), to = std::atan2(h.x(), h.y());
          if (std::hypot(dir.x(), dir.z()) > 1e-6 && h.squaredNorm() > 1e-12) {
            double delta = std::remainder(to - from, 2 * std::numbers::pi);
            const double prev = job.previous_heading_delta_rad[static_cast<std::size_t>(s)];
            if (std::isfinite(prev)) delta += 2 * std::numbers::pi * std::round((prev - delta) / (2 * std::numbers::pi));
            out.heading_delta_rad[static_cast<std::size_t>(s)] = delta;
            const double turn = delta * std::clamp(job.feet->heading_weight[s], 0.0, 1.0);
            dir = Eigen::AngleAxisd(turn, Vector3d::UnitY()) * dir;
          }
        }
        if (job.feet && job.feet->weight[s] > 0) {
          // Toes no higher than their floor (on its toes) and no lower than their lowest.
          const auto& rest = job.rig->rest_pose;
          const double foot = (rest[static_cast<std::size_t>(s == kLeft ? CJ::l_toe : CJ::r_toe)] -
                               rest[static_cast<std::size_t>(s == kLeft ? CJ::l_ankle : CJ::r_ankle)]).norm();
          const double w = std::clamp(job.feet->weight[s], 0.0, 1.0);
          dir = toe_kept(dir, pos, foot, job.feet->toe_floor_y_m[s], w * std::clamp(job.feet->toe_floor_weight[s], 0.0, 1.0), true);
          dir = toe_kept(dir, pos, foot, job.feet->toe_lowest_y_m[s], w * std::clamp(job.feet->toe_lowest_weight[s], 0.0, 1.0), false);
        }
        rot = aim(dir);
        break;
      }
      case Role::none: break;
    }
    rot.normalize();
    job.global_positions[ui] = pos;
    job.global_rotations[ui] = rot;
    job.local_rotations[ui] = p < 0 ? rot : job.global_rotations[static_cast<std::size_t>(p)].conjugate() * rot;
  }
  if (job.root_position) *job.root_position = job.global_positions[0];
}

Vector3d joint_pos(const AdaptJob& job, CJ j) {
  return job.global_positions[static_cast<std::size_t>(job.rig->skeleton.index(j))];
}

}  // namespace

Rig make_rig(const Skeleton& skeleton, std::span<const Quaterniond> rest_local, std::string name) {
  require_canonical_joints(skeleton, name);
  Rig rig;
  rig.name = std::move(name);
  rig.skeleton = skeleton;
  const int n = skeleton.joint_count();
  const auto un = static_cast<std::size_t>(n);
  if (!rest_local.empty() && rest_local.size() != un) {
    throw Error("content", "skeleton", fmt::format("{}: rest pose has {} rotations for {} joints",
                                                   rig.name, rest_local.size(), n));
  }
  rig.rest_local.assign(un, Quaterniond::Identity());
  for (std::size_t i = 0; i < rest_local.size(); ++i) rig.rest_local[i] = rest_local[i].normalized();
  std::vector<Vector3d> gp(un);
  std::vector<Quaterniond> gr(un);
  forward_kinematics(skeleton, Vector3d::Zero(), rig.rest_local, gp, gr);
  canonical_positions(skeleton, gp, rig.rest_pose);
  rig.morphology = measure_morphology(rig.rest_pose, rig.name);

  rig.role.assign(un, Role::none);
  rig.side.assign(un, -1);
  rig.aim_local.assign(un, Vector3d::UnitY());
  for (const RoleSpec& spec : kRoles) {
    const int i = skeleton.index(spec.joint);
    if (i < 0 || rig.role[static_cast<std::size_t>(i)] != Role::none || spec.role == Role::none) continue;
    const auto ui = static_cast<std::size_t>(i);
    if (spec.role != Role::pelvis && spec.role != Role::chest) {
      const int c = skeleton.index(spec.child);
      if (c < 0) continue;
      const Vector3d v = gp[static_cast<std::size_t>(c)] - gp[ui];
      if (v.norm() < 1e-3) continue;  // zero-length bone: nothing to aim
      rig.aim_local[ui] = (gr[ui].conjugate() * v).normalized();
    }
    rig.role[ui] = spec.role;
    rig.side[ui] = static_cast<std::int8_t>(spec.side);
  }
  const auto pelvis = static_cast<std::size_t>(skeleton.index(CJ::pelvis));
  const auto chest = static_cast<std::size_t>(skeleton.index(CJ::chest));
  // Each forearm's thumb side at rest: a "thumb" joint below the wrist toward its child (CMU's
  // lthumb toward its end, forward in its T-pose: palms down), else the chest's forward.
  for (int s = 0; s < 2; ++s) {
    const int el = skeleton.index(s == kLeft ? CJ::l_elbow : CJ::r_elbow);
    const int wr = skeleton.index(s == kLeft ? CJ::l_wrist : CJ::r_wrist);
    if (el < 0 || wr < 0) continue;
    const Vector3d fore = gp[static_cast<std::size_t>(wr)] - gp[static_cast<std::size_t>(el)];
    if (fore.norm() < 1e-6) continue;
    Vector3d thumb = chest_frame(rig.rest_pose) * Vector3d::UnitZ();
    for (int j = wr + 1; j < n; ++j) {
      if (detail::lower(skeleton.names[static_cast<std::size_t>(j)]).find("thumb") == std::string::npos) continue;
      bool below = false;
      for (int a = skeleton.parents[static_cast<std::size_t>(j)]; a >= 0 && !below; a = skeleton.parents[static_cast<std::size_t>(a)]) below = a == wr;
      if (!below) continue;
      for (int c = j + 1; c < n; ++c) {
        if (skeleton.parents[static_cast<std::size_t>(c)] != j) continue;
        const Vector3d d = gp[static_cast<std::size_t>(c)] - gp[static_cast<std::size_t>(j)];
        if (d.norm() > 1e-6) thumb = d;
        break;
      }
      break;
    }
    const Vector3d f = fore.normalized();
    const Vector3d across = thumb - thumb.dot(f) * f;
    if (across.norm() > 1e-3 * thumb.norm())
      rig.thumb_local[static_cast<std::size_t>(s)] = gr[static_cast<std::size_t>(el)].conjugate() * across.normalized();
  }
  rig.pelvis_frame_local = gr[pelvis].conjugate() * pelvis_frame(rig.rest_pose);
  rig.chest_frame_local = gr[chest].conjugate() * chest_frame(rig.rest_pose);
  // The root keeps its rest rotation when it is not the pelvis (e.g. a floor "Root" joint).
  rig.root_to_pelvis_local = gr[0].conjugate() * (gp[pelvis] - gp[0]);

  rig.joint_radii_m.assign(un, 0.03f);
  for (std::size_t i = 1; i < un; ++i) {
    const auto p = static_cast<std::size_t>(skeleton.parents[i]);
    rig.joint_radii_m[i] = bone_radius(rig.role[p], skeleton.offsets[i].norm(), rig.morphology.height_m);
  }
  // The head has no role of its own; by its bone's length alone it was drawn as a thin stick
  // on the shoulders. The bones to its end sites get a head's radius instead.
  const int head = skeleton.index(CJ::head);
  for (std::size_t i = 1; i < un; ++i)
    if (head >= 0 && skeleton.parents[i] == head) rig.joint_radii_m[i] = static_cast<float>(kHeadRadius_m * rig.morphology.height_m / 1.75);
  return rig;
}

bool AdaptJob::Validate() const {
  if (!rig || !pose) return false;
  const auto n = static_cast<std::size_t>(rig->joint_count());
  return local_rotations.size() >= n && global_positions.size() >= n && global_rotations.size() >= n &&
         (previous_positions.empty() || previous_positions.size() >= n) && std::isfinite(max_knee_swivel_rad) &&
         max_knee_swivel_rad >= 0 && !std::isinf(previous_heading_delta_rad[0]) && !std::isinf(previous_heading_delta_rad[1]) && fist_neutral[0] >= 0 && fist_neutral[0] <= 1 && fist_neutral[1] >= 0 && fist_neutral[1] <= 1;
}

bool AdaptJob::Run() const {
  if (!Validate()) return false;
  TrunkDeltas td;
  PassOut out;
  decode_pass(*this, td, out);
  if (reach && !reach->effector.leg && !reach->lean.identity()) {
    // The planned lean: the body leans, the goal stays where the plain pose put it (pinned as
    // d(t) pins it: at contact the target itself).
    td.spine = reach->lean.spine;
    td.chest = reach->lean.chest;
    td.clavicle = reach->lean.clavicle;
    td.clavicle_side = reach->effector.side;
    td.fixed_goal = true;
    td.pin = std::clamp(reach->pin, 0.0, 1.0);
    td.goal = out.effector_goal;
    out = PassOut{};
    decode_pass(*this, td, out);
  }
  if (feet) {
    // Held feet the legs cannot reach: lower the pelvis just enough (held_feet_drop), kept a
    // hair short of the straight leg.
    double drop = held_feet_drop(*feet, rig->morphology, 1 - 1e-6,
                                 [&](int s) { return joint_pos(*this, s == kLeft ? CJ::l_hip : CJ::r_hip); });
    drop = std::clamp(drop, std::max(0.0, feet->min_root_drop_m), std::max(feet->min_root_drop_m, feet->max_root_drop_m));
    if (drop > 0) {
      td.root_drop_m = drop;
      if (!td.fixed_goal) {
        td.fixed_goal = reach != nullptr;
        td.pin = reach ? std::clamp(reach->pin, 0.0, 1.0) : 0.0;
        td.goal = out.effector_goal;
      }
      if (td.fixed_goal && reach->pin_drop_max_m < drop) td.goal.y() -= drop - std::max(0.0, reach->pin_drop_max_m);
      out = PassOut{};
      decode_pass(*this, td, out);
    }
  }
  const bool arm_reach = reach && !reach->effector.leg;
  bool trunk_used = false;
  TrunkLean fallback;  // the fallback's rotations this frame (identity: none)
  // Pins the effector goal for the passes that bend the trunk (it must not move with it).
  const auto pin_goal = [&] {
    if (!td.fixed_goal || td.pin < 1) {
      td.fixed_goal = true;
      td.pin = 1;
      td.goal = out.effector_goal;
    }
  };
  const auto bend = [&](const TrunkLean& by, int s) {
    td.spine = by.spine * td.spine;
    td.chest = by.chest * td.chest;
    td.clavicle = by.clavicle * (td.clavicle_side == s ? td.clavicle : Quaterniond::Identity());
    td.clavicle_side = s;
    fallback.spine = by.spine * fallback.spine;
    fallback.chest = by.chest * fallback.chest;
    fallback.clavicle = by.clavicle * fallback.clavicle;
  };
  if (min_trunk_fallback && !min_trunk_fallback->identity() && (arm_reach || (reach && min_trunk_fallback_side >= 0))) {
    // The least fallback the caller asks for (the last frame's, going out over frames) first;
    // the CCD below adds only what the goal needs beyond it. (With a leg's reach: a punch's
    // fallback going on out under a kick; dropped there, the trunk sprang up in one frame.)
    bend(*min_trunk_fallback, arm_reach ? reach->effector.side : min_trunk_fallback_side);
    pin_goal();
    out = PassOut{};
    decode_pass(*this, td, out);
    trunk_used = true;
  }
  // The trunk joins in over the arm's last (1 - trunk_target_share) of reach (weight 0 -> 1 as
  // the goal goes from that share to 1 x the arm's length from the shoulder), not only once the
  // arm falls short: a nearly straight arm leans the body in a little instead of raising its
  // elbow (strike grid: punches with the elbow above the head at contact 15 -> 4 of 120). In
  // time it is smooth only as the caller bounds it (max_trunk_weight, min_trunk_fallback).
  const double share = std::clamp(trunk_target_share, 0.5, 0.999);
  double trunk_w = 0;
  if (arm_reach) {
    const int s = reach->effector.side;
    const double arm = rig->morphology.arm_length(s);
    const double d = (out.effector_goal - joint_pos(*this, kShoulder[s])).norm();
    const double x = std::clamp((d - share * arm) / ((1 - share) * arm), 0.0, 1.0);
    trunk_w = std::min(out.arm_reached[s] ? x * x * (3 - 2 * x) : 1.0, std::clamp(max_trunk_weight, 0.0, 1.0));
  }
  if (trunk_w > 0) {
    // Bend spine/chest/clavicle (CCD) to bring the shoulder within `share` of the arm's
    // length, that much of it by trunk_w, then decode again with those rotations.
    const int s = reach->effector.side;
    CcdChain chain;
    const CJ pivots[3] = {CJ::spine, CJ::chest, kClavicle[s]};
    // The limits are the trunk's whole turn: what the planned lean and the least fallback
    // already turn at a pivot is taken off its limit (added on top with limits of its own, a
    // far punch's trunk turned twice as far as the limits allow: the head dipped 21 cm, under
    // the raised elbow, where the plan had it dip 11).
    const auto left = [](double limit, const Quaterniond& used) { return std::max(0.0, limit - rotation_angle_rad(used)); };
    const Quaterniond clavicle_used = td.clavicle_side == s ? td.clavicle : Quaterniond::Identity();
    const double limits[3] = {left(trunk.spine_rad, td.spine), left(trunk.chest_rad, td.chest),
                              left(trunk.clavicle_rad, clavicle_used)};
    int slot[3] = {-1, -1, -1};
    for (int k = 0; k < 3; ++k) {
      if (rig->skeleton.index(pivots[k]) < 0) continue;
      slot[k] = chain.count;
      chain.pivots[chain.count] = joint_pos(*this, pivots[k]);
      chain.limit_rad[chain.count] = limits[k];
      ++chain.count;
    }
    chain.limb_root = joint_pos(*this, kShoulder[s]);
    std::array<Quaterniond, 4> deltas;
    const double reach_m = rig->morphology.arm_length(s) * share;
    solve_ccd_reach(chain, out.effector_goal, reach_m, trunk.iterations, deltas);
    for (auto& q : deltas) q = Quaterniond::Identity().slerp(trunk_w, q);
    // On top of a planned lean and the caller's least fallback (solved from that pose):
    // composed, not replaced. The spine delta rotates about the spine joint, the chest delta
    // about the chest: that is what the decode pass does when it applies them to the aimed
    // directions/frames.
    TrunkLean by;
    if (slot[0] >= 0) by.spine = deltas[slot[0]];
    if (slot[1] >= 0) by.chest = deltas[slot[1]];
    if (slot[2] >= 0) by.clavicle = deltas[slot[2]];
    bend(by, s);
    pin_goal();
    out = PassOut{};
    decode_pass(*this, td, out);
    trunk_used = true;
  }
  if (report) {
    report->trunk_used = trunk_used;
    report->trunk_weight = trunk_used ? trunk_w : 0.0;
    report->trunk_fallback = fallback;
    report->trunk.spine = td.spine;
    report->trunk.chest = td.chest;
    report->trunk.clavicle = td.clavicle_side >= 0 ? td.clavicle : Quaterniond::Identity();
    report->foot_reached = out.leg_reached;
    report->root_drop_m = td.root_drop_m;
    report->heading_delta_rad = out.heading_delta_rad;
    if (reach) {
      report->effector_goal = out.effector_goal;
      report->effector_reached = joint_pos(*this, reach->effector.joint());
      report->reach_error_m = (report->effector_goal - report->effector_reached).norm();
      report->reached = reach->effector.leg ? out.leg_reached[reach->effector.side]
                                            : out.arm_reached[reach->effector.side];
    } else {
      report->reached = true;
      report->reach_error_m = 0;
    }
  }
  return true;
}

void decode_canonical(const Rig& rig, const MkmFrame& pose, CanonicalPose& out) {
  const auto n = static_cast<std::size_t>(rig.joint_count());
  // Per thread, their room kept: the fighter decodes on the frame thread (a strike's start),
  // the planner on its worker; neither allocates once warm.
  thread_local std::vector<Quaterniond> local, global;
  thread_local std::vector<Vector3d> pos;
  local.resize(n);
  global.resize(n);
  pos.resize(n);
  AdaptJob job;
  job.rig = &rig;
  job.pose = &pose;
  job.local_rotations = local;
  job.global_positions = pos;
  job.global_rotations = global;
  job.Run();
  canonical_positions(rig.skeleton, pos, out);
}

}  // namespace kumite::content
