#pragma once
// SYNTHETIC test data for the fighter tests (no mocap needed): CMU-like and assimp-like
// skeletons with adjustable proportions, and a procedural right-hand punch clip whose local
// rotations are written by hand (not produced by the code under test).
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "kumite/content/skeleton.hpp"

namespace kumite::content::synthetic {

struct Proportions {
  double scale = 1.0;  ///< overall (1 = a ~1.75 m adult)
  double arm = 1.0;    ///< arm bones relative to `scale`
  double leg = 1.0;    ///< leg bones relative to `scale`
  double torso = 1.0;  ///< spine/neck bones relative to `scale`
  bool assimp_names = false;  ///< "LeftArm"... instead of CMU "lhumerus"...
  bool extra_roll_joint = false;  ///< a non-canonical joint inside the upper arm
};

inline Skeleton make_skeleton(const Proportions& p) {
  Skeleton s;
  auto add = [&](const std::string& name, int parent, Eigen::Vector3d off, bool end = false) {
    s.names.push_back(name);
    s.parents.push_back(parent);
    s.offsets.push_back(off);
    s.end_site.push_back(end);
    return static_cast<int>(s.names.size()) - 1;
  };
  auto set = [&](CanonicalJoint j, int i) { s.canonical[static_cast<std::size_t>(j)] = i; };
  s.canonical.fill(-1);
  const double k = p.scale, a = p.scale * p.arm, l = p.scale * p.leg, t = p.scale * p.torso;
  const bool A = p.assimp_names;
  const int hips = add(A ? "Hips" : "hips", -1, {0, 0, 0});
  set(CanonicalJoint::pelvis, hips);
  const int spine = add(A ? "Spine" : "lowerback", hips, {0, 0.03 * t, 0});
  set(CanonicalJoint::spine, spine);
  const int upper = add(A ? "Spine1" : "upperback", spine, {0, 0.12 * t, -0.01 * t});
  const int chest = add(A ? "Spine2" : "thorax", upper, {0, 0.12 * t, 0.0});
  set(CanonicalJoint::chest, chest);
  const int neck = add(A ? "Neck" : "lowerneck", chest, {0, 0.16 * t, 0.01 * t});
  set(CanonicalJoint::neck, neck);
  const int head = add(A ? "Head" : "head", neck, {0, 0.10 * t, 0.01 * t});
  set(CanonicalJoint::head, head);
  add(A ? "Head_end" : "head_end", head, {0, 0.15 * k, 0}, true);
  for (int side = 0; side < 2; ++side) {
    const double sx = side == 0 ? 1.0 : -1.0;
    const std::string L = side == 0 ? "l" : "r";
    const std::string Side = side == 0 ? "Left" : "Right";
    const int clav = add(A ? Side + "Shoulder" : L + "clavicle", chest, {sx * 0.02 * k, 0.12 * t, 0});
    const int sh = add(A ? Side + "Arm" : L + "humerus", clav, {sx * 0.16 * k, 0.02 * k, 0});
    int elbow_parent = sh;
    if (p.extra_roll_joint) elbow_parent = add(Side + "ArmRoll", sh, {sx * 0.14 * a, 0, 0});
    const int el = add(A ? Side + "ForeArm" : L + "radius", elbow_parent,
                       {sx * (p.extra_roll_joint ? 0.14 : 0.28) * a, 0, 0});
    const int wr = add(A ? Side + "Hand" : L + "wrist", el, {sx * 0.25 * a, 0, 0});
    add(A ? Side + "Hand_end" : L + "hand_end", wr, {sx * 0.09 * a, 0, 0}, true);
    const int hipj = add(A ? Side + "HipJoint" : L + "hipjoint", hips, {0, 0, 0});
    const int hip = add(A ? Side + "UpLeg" : L + "femur", hipj, {sx * 0.09 * k, -0.07 * k, 0});
    const int knee = add(A ? Side + "Leg" : L + "tibia", hip, {0, -0.43 * l, 0});
    const int ankle = add(A ? Side + "Foot" : L + "foot", knee, {0, -0.41 * l, 0});
    const int toe = add(A ? Side + "ToeBase" : L + "toes", ankle, {0, -0.05 * k, 0.13 * k});
    add(A ? Side + "Toe_end" : L + "toe_end", toe, {0, 0, 0.05 * k}, true);
    using CJ = CanonicalJoint;
    set(side == 0 ? CJ::l_clavicle : CJ::r_clavicle, clav);
    set(side == 0 ? CJ::l_shoulder : CJ::r_shoulder, sh);
    set(side == 0 ? CJ::l_elbow : CJ::r_elbow, el);
    set(side == 0 ? CJ::l_wrist : CJ::r_wrist, wr);
    set(side == 0 ? CJ::l_hip : CJ::r_hip, hip);
    set(side == 0 ? CJ::l_knee : CJ::r_knee, knee);
    set(side == 0 ? CJ::l_ankle : CJ::r_ankle, ankle);
    set(side == 0 ? CJ::l_toe : CJ::r_toe, toe);
  }
  return s;
}

inline Eigen::Quaterniond aa(double angle, const Eigen::Vector3d& axis) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis.normalized()));
}

/// Guard stance at phase 0, right lunge punch forward at phase `hit` (0..1), back at 1.
/// `frames` frames at 120 fps. Rotations are hand-written; the body stands on y = 0.
inline Clip make_punch_clip(const Skeleton& s, int frames = 96, double hit = 0.5, double wobble = 0.0,
                            std::string name = "synthetic_punch", double reach_scale = 1.0) {
  Clip c;
  c.name = std::move(name);
  c.skeleton = s;
  c.frame_time_s = 1.0 / 120;
  c.unit_m = 1.0;
  c.frame_count = frames;
  const int n = s.joint_count();
  const double pi = std::numbers::pi;
  const Eigen::Vector3d X = Eigen::Vector3d::UnitX(), Y = Eigen::Vector3d::UnitY(), Z = Eigen::Vector3d::UnitZ();
  // Pelvis height: hip drop + thigh + shin + ankle-to-sole (the toe offset's drop).
  const auto off = [&](const char* cmu, const char* as) {
    const int i = s.find(cmu) >= 0 ? s.find(cmu) : s.find(as);
    return s.offsets[static_cast<std::size_t>(i)];
  };
  const double stand = -off("lfemur", "LeftUpLeg").y() - off("ltibia", "LeftLeg").y() -
                       off("lfoot", "LeftFoot").y() - off("ltoes", "LeftToeBase").y();
  for (int f = 0; f < frames; ++f) {
    const double ph = static_cast<double>(f) / (frames - 1);
    // e: extension 0 (guard) -> 1 (hit) -> 0.
    double e = ph < hit ? std::sin(0.5 * pi * ph / hit) : std::cos(0.5 * pi * (ph - hit) / (1 - hit));
    e *= reach_scale;
    const double w = wobble * std::sin(2 * pi * ph * 3);
    c.root_positions.emplace_back(0.02 * w, stand - 0.03 - 0.02 * e, 0.10 * e);
    std::vector<Eigen::Quaterniond> r(static_cast<std::size_t>(n), Eigen::Quaterniond::Identity());
    auto set = [&](const char* cmu, const char* as, const Eigen::Quaterniond& q) {
      const int i = s.find(cmu) >= 0 ? s.find(cmu) : s.find(as);
      if (i >= 0) r[static_cast<std::size_t>(i)] = q;
    };
    set("hips", "Hips", aa(-0.3 + 0.5 * e + 0.05 * w, Y));  // hips turn into the punch
    set("lowerback", "Spine", aa(0.05 + 0.1 * e, X));
    set("thorax", "Spine2", aa(0.2 * e, Y));
    set("lowerneck", "Neck", aa(-0.1 * e, X));
    // Arms: T-pose along +-X. Left (guard): down-forward with the elbow bent.
    set("lhumerus", "LeftArm", aa(-0.9, Y) * aa(-1.1, Z));
    set("lradius", "LeftForeArm", aa(-2.0, Y));
    // Right: from guard (like the left, mirrored) to straight forward.
    const Eigen::Quaterniond guard = aa(0.9, Y) * aa(1.1, Z);
    const Eigen::Quaterniond forward = aa(pi / 2, Y);
    set("rhumerus", "RightArm", guard.slerp(e, forward));
    set("rradius", "RightForeArm", aa(2.0 * (1 - e) + 0.02, Y));
    // Legs: knees bent a little, left foot forward.
    set("lfemur", "LeftUpLeg", aa(-0.35, X));
    set("ltibia", "LeftLeg", aa(0.45, X));
    set("lfoot", "LeftFoot", aa(-0.1, X));
    set("rfemur", "RightUpLeg", aa(0.1, X));
    set("rtibia", "RightLeg", aa(0.3, X));
    set("rfoot", "RightFoot", aa(-0.4, X));
    c.local_rotations.insert(c.local_rotations.end(), r.begin(), r.end());
  }
  return c;
}

}  // namespace kumite::content::synthetic
