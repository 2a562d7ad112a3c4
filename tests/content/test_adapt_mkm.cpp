// MKM encode/decode, two-bone IK, reach and foot locks on SYNTHETIC skeletons (synthetic_body.hpp).
#include <gtest/gtest.h>

#include <cstdio>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include <filesystem>

#include "kumite/content/adaptation.hpp"
#include "kumite/content/behaviour.hpp"
#include "kumite/content/ik.hpp"
#include "kumite/content/mkm.hpp"
#include "fighter_fixtures.hpp"
#include "kumite/content/database.hpp"
#include "synthetic_body.hpp"

using namespace kumite::content;
using CJ = CanonicalJoint;
using Eigen::Vector3d;

namespace {

CanonicalPose fk_canonical(const Clip& c, int f) {
  const auto n = static_cast<std::size_t>(c.skeleton.joint_count());
  std::vector<Vector3d> gp(n);
  std::vector<Eigen::Quaterniond> gr(n);
  forward_kinematics(c.skeleton, c.root_positions[static_cast<std::size_t>(f)], c.rotations(f), gp, gr);
  CanonicalPose p;
  canonical_positions(c.skeleton, gp, p);
  return p;
}

struct Buffers {
  explicit Buffers(const Rig& r)
      : local(static_cast<std::size_t>(r.joint_count())), global(local.size()), pos(local.size()) {}
  std::vector<Eigen::Quaterniond> local, global;
  std::vector<Vector3d> pos;
  AdaptJob job(const Rig& rig, const MkmFrame& f) {
    AdaptJob j;
    j.rig = &rig;
    j.pose = &f;
    j.local_rotations = local;
    j.global_rotations = global;
    j.global_positions = pos;
    return j;
  }
  Vector3d at_joint(const Rig& rig, CJ j) const { return pos[static_cast<std::size_t>(rig.skeleton.index(j))]; }
};

/// Frame `frame` of a SYNTHETIC 40-frame punch on skeleton `s`, encoded for `rig`.
MkmFrame punch_pose(const Skeleton& s, const Rig& rig, int frame) {
  const Clip clip = synthetic::make_punch_clip(s, 40);
  MkmFrame f;
  encode_mkm(fk_canonical(clip, frame), rig.morphology, 0.0, nullptr, f);
  return f;
}

/// The SYNTHETIC punch pose (frame 20) drawn plain, and wrist goals on the line straight out
/// from its right shoulder through its wrist, at k x the arm's length.
struct PunchLine {
  Skeleton s = synthetic::make_skeleton({});
  Rig rig = make_rig(s, {}, "c");
  Buffers b{rig};
  MkmFrame f = punch_pose(s, rig, 20);
  Vector3d shoulder0, wrist0, out;
  double arm = 0;
  PunchLine() {
    EXPECT_TRUE(b.job(rig, f).Run());
    shoulder0 = b.at_joint(rig, CJ::r_shoulder);
    wrist0 = b.at_joint(rig, CJ::r_wrist);
    out = (wrist0 - shoulder0).normalized();
    arm = rig.morphology.arm_length(kRight);
  }
  ReachGoal goal_at(double k) const {
    ReachGoal goal;
    goal.effector = {kRight, false};
    goal.offset_m = shoulder0 + out * (k * arm) - wrist0;  // added to the motion's own wrist
    return goal;
  }
};

}  // namespace

TEST(Mkm, EncodeDecodeOnTheSameSkeletonReproducesEveryCanonicalJoint) {
  const Skeleton s = synthetic::make_skeleton({});
  const Clip clip = synthetic::make_punch_clip(s, 60, 0.5, 1.0);
  const Rig rig = make_rig(s, {}, "synthetic");
  MkmFrame prev, f;
  for (int i = 0; i < clip.frame_count; ++i) {
    const CanonicalPose src = fk_canonical(clip, i);
    encode_mkm(src, rig.morphology, 0.0, i ? &prev : nullptr, f);
    CanonicalPose out;
    decode_canonical(rig, f, out);
    for (std::size_t j = 0; j < kCanonicalJointCount; ++j)
      EXPECT_LT((out[j] - src[j]).norm(), 1e-9) << "frame " << i << " joint " << to_string(static_cast<CJ>(j));
    prev = f;
  }
}

TEST(Mkm, RetargetKeepsNormalisedLimbsSwivelAndCharacterBones) {
  const Skeleton actor = synthetic::make_skeleton({});
  const Skeleton other = synthetic::make_skeleton({.scale = 0.86, .arm = 1.15, .leg = 0.9, .torso = 1.1,
                                                   .assimp_names = true, .extra_roll_joint = true});
  const Clip clip = synthetic::make_punch_clip(actor, 40);
  const Rig ra = make_rig(actor, {}, "actor");
  const Rig rc = make_rig(other, {}, "character");
  EXPECT_LT(rc.morphology.leg_length_m, ra.morphology.leg_length_m);
  Buffers b(rc);
  MkmFrame f, back;
  for (int i = 0; i < clip.frame_count; i += 3) {
    encode_mkm(fk_canonical(clip, i), ra.morphology, 0.0, nullptr, f);
    ASSERT_TRUE(b.job(rc, f).Run());
    CanonicalPose out;
    canonical_positions(rc.skeleton, b.pos, out);
    encode_mkm(out, rc.morphology, 0.0, nullptr, back);
    EXPECT_NEAR(back.root_height_n, f.root_height_n, 1e-9);
    for (int s = 0; s < 2; ++s) {
      EXPECT_LT((back.arm_n[s] - f.arm_n[s]).norm(), 1e-9);
      EXPECT_LT((back.leg_n[s] - f.leg_n[s]).norm(), 1e-9);
      EXPECT_LT((back.arm_pole[s] - f.arm_pole[s]).norm(), 1e-6);
      EXPECT_LT((back.leg_pole[s] - f.leg_pole[s]).norm(), 1e-6);
      EXPECT_LT((back.foot_dir[s] - f.foot_dir[s]).norm(), 1e-9);
    }
    EXPECT_TRUE(back.pelvis.isApprox(f.pelvis, 1e-9));
    EXPECT_TRUE(back.chest.isApprox(f.chest, 1e-9));
    // Bones keep the character's lengths (FK of its own offsets, whatever the rotations).
    EXPECT_NEAR((at(out, CJ::r_elbow) - at(out, CJ::r_shoulder)).norm(), rc.morphology.upper_arm_m[kRight], 1e-9);
  }
}

TEST(Ik, TwoBoneReachesEveryReachableTargetAndBendsTowardThePole) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 2000; ++i) {
    const Vector3d root(u(rng), u(rng), u(rng));
    const double l1 = 0.2 + 0.2 * (u(rng) + 1), l2 = 0.2 + 0.2 * (u(rng) + 1);
    const Vector3d dir = Vector3d(u(rng), u(rng), u(rng)).normalized();
    const double d = std::abs(l1 - l2) + 1e-6 + (l1 + l2 - std::abs(l1 - l2) - 2e-6) * 0.5 * (u(rng) + 1);
    const Vector3d target = root + dir * d;
    const Vector3d pole = (dir.unitOrthogonal());
    const TwoBoneResult r = solve_two_bone(root, target, l1, l2, pole);
    ASSERT_TRUE(r.reached);
    EXPECT_LT((r.end - target).norm(), 1e-9);
    EXPECT_NEAR((r.middle - root).norm(), l1, 1e-9);
    EXPECT_NEAR((target - r.middle).norm(), l2, 1e-6);
    EXPECT_GE((r.middle - root).dot(pole), -1e-9);
  }
  const TwoBoneResult far = solve_two_bone(Vector3d::Zero(), Vector3d(2, 0, 0), 0.3, 0.3, Vector3d::UnitY());
  EXPECT_FALSE(far.reached);
  EXPECT_NEAR(far.end.x(), 0.6, 1e-6);
}

TEST(Adapt, ReachOffsetLandsTheWristExactlyUsingTheTrunkWhenNeeded) {
  const Skeleton s = synthetic::make_skeleton({.scale = 0.9, .arm = 0.95});
  const Rig rig = make_rig(s, {}, "c");
  Buffers b(rig);
  const MkmFrame f = punch_pose(s, rig, 20);
  ASSERT_TRUE(b.job(rig, f).Run());
  const Vector3d wrist = b.at_joint(rig, CJ::r_wrist);
  const Vector3d shoulder = b.at_joint(rig, CJ::r_shoulder);
  const double arm = rig.morphology.arm_length(kRight);
  int trunk = 0, unreachable = 0;
  for (double dx : {-0.1, 0.0, 0.1}) {
    for (double dy : {-0.1, 0.0, 0.1}) {
      for (double dz : {-0.1, 0.0, 0.1, 0.2}) {
        ReachGoal goal;
        goal.effector = {kRight, false};
        goal.offset_m = Vector3d(dx, dy, dz);
        AdaptReport rep;
        AdaptJob job = b.job(rig, f);
        job.reach = &goal;
        job.report = &rep;
        ASSERT_TRUE(job.Run());
        const Vector3d target = wrist + goal.offset_m;
        EXPECT_LT((rep.effector_goal - target).norm(), 1e-12);
        if (rep.reached) {
          EXPECT_LT((b.at_joint(rig, CJ::r_wrist) - target).norm(), 1e-6) << dx << " " << dy << " " << dz;
          EXPECT_LT(rep.reach_error_m, 1e-6);
        } else {
          ++unreachable;
          std::printf("unreachable %g %g %g err %g\n", dx, dy, dz, rep.reach_error_m);
        }
        if (rep.trunk_used) {
          ++trunk;
          // Only where the arm is (nearly) straight: the trunk fades in over its last 5 %.
          EXPECT_GT((target - shoulder).norm(), 0.95 * arm);
        }
      }
    }
  }
  EXPECT_GT(trunk, 0);        // +20 cm forward of a full extension needs the trunk
  EXPECT_LT(unreachable, 6);  // and the trunk gets most of them
}

TEST(Adapt, FootLocksHoldTheAnkleAndValidateRejectsShortBuffers) {
  const Skeleton s = synthetic::make_skeleton({});
  const Rig rig = make_rig(s, {}, "c");
  Buffers b(rig);
  const MkmFrame f = punch_pose(s, rig, 0);
  ASSERT_TRUE(b.job(rig, f).Run());
  FootLocks locks;
  locks.weight = {1, 1};
  locks.ankle_m = {b.at_joint(rig, CJ::l_ankle) + Vector3d(0.03, 0, 0.02), b.at_joint(rig, CJ::r_ankle)};
  MkmFrame moved = f;
  moved.root_xz_m += Eigen::Vector2d(0.05, 0.04);  // the body moves, the feet must not
  AdaptJob job = b.job(rig, moved);
  job.feet = &locks;
  ASSERT_TRUE(job.Run());
  // A held foot's leg straightens softly near full extension (solve_two_bone_soft): the
  // ankle is on its lock, or at most 0.37 x 1.5 % of the leg short of it where the leg is
  // (nearly) straight.
  for (int side = 0; side < 2; ++side) {
    const CJ ankle = side == 0 ? CJ::l_ankle : CJ::r_ankle;
    const CJ hip = side == 0 ? CJ::l_hip : CJ::r_hip;
    const double leg = rig.morphology.thigh_m[static_cast<std::size_t>(side)] + rig.morphology.shin_m[static_cast<std::size_t>(side)];
    const double d = (locks.ankle_m[static_cast<std::size_t>(side)] - b.at_joint(rig, hip)).norm();
    const double off = (b.at_joint(rig, ankle) - locks.ankle_m[static_cast<std::size_t>(side)]).norm();
    if (d <= leg * (1 - 0.015)) {
      EXPECT_LT(off, 1e-9) << side;
    } else {
      EXPECT_LT(off, 0.37 * 0.015 * leg + 1e-9) << side;
    }
  }
  std::vector<Vector3d> small(3);
  job.global_positions = small;
  EXPECT_FALSE(job.Validate());
  EXPECT_FALSE(job.Run());
}

// A knee whose motion swings it through its leg's axis (a kick aborted as its foot rose: the
// held foot keeps the ankle up in front while the motion's leg swings down and back, its knee
// direction passing through the hip->ankle line) turned to the other side of the leg in one
// frame: 0.6 m in the spar demo with stance steps on. With the last frame's positions and
// max_knee_swivel_rad the knee goes round the side over frames; the ankle stays on its lock.
// SYNTHETIC: the standing pose's right leg turned rigidly about the body's left-right axis,
// 120 deg over 60 frames, the right ankle held 0.6 m in front of the hip and 0.1 m above it.
TEST(Adapt, AKneeSwungThroughItsLegsAxisGoesRoundTheSideWithASwivelLimit) {
  const Skeleton s = synthetic::make_skeleton({});
  const Rig rig = make_rig(s, {}, "c");
  const MkmFrame standing = punch_pose(s, rig, 0);
  Buffers first(rig);
  ASSERT_TRUE(first.job(rig, standing).Run());
  const Vector3d hip = first.at_joint(rig, CJ::r_hip);
  FootLocks locks;
  locks.weight = {0, 1};
  locks.ankle_m = {first.at_joint(rig, CJ::l_ankle), hip + Vector3d(0, 0.1, 0.6)};
  const double dt = 1.0 / 60;
  double worst_knee_step[2] = {0, 0}, worst_ankle_off = 0;
  for (const int limited : {0, 1}) {
    Buffers b(rig);
    std::vector<Vector3d> previous;
    for (int k = 0; k <= 60; ++k) {
      const double a = (-90.0 + 2.0 * k) * std::numbers::pi / 180;  // about +X: -90 deg: the leg forward, its knee up
      const Eigen::AngleAxisd turn(a, Vector3d::UnitX());
      MkmFrame f = standing;
      f.leg_n[kRight] = turn * Vector3d(0, -1, 0) * standing.leg_n[kRight].norm();
      f.leg_pole[kRight] = turn * Vector3d(0, 0, 1);
      AdaptJob job = b.job(rig, f);
      job.feet = &locks;
      if (limited && !previous.empty()) {
        job.previous_positions = previous;
        job.max_knee_swivel_rad = 12 * dt;
      }
      ASSERT_TRUE(job.Run());
      const Vector3d knee = b.at_joint(rig, CJ::r_knee);
      if (!previous.empty())
        worst_knee_step[limited] = std::max(worst_knee_step[limited], (knee - previous[static_cast<std::size_t>(rig.skeleton.index(CJ::r_knee))]).norm());
      if (limited) worst_ankle_off = std::max(worst_ankle_off, (b.at_joint(rig, CJ::r_ankle) - locks.ankle_m[1]).norm());
      previous = b.pos;
    }
  }
  EXPECT_GT(worst_knee_step[0], 0.2) << "the case this test is about: without the limit the knee flips";
  EXPECT_LT(worst_knee_step[1], 0.1) << "with it, the knee goes round over frames";
  EXPECT_LT(worst_ankle_off, 1e-6) << "the ankle stays on its lock";
  // A previous_positions shorter than the rig is refused.
  Buffers b(rig);
  AdaptJob job = b.job(rig, standing);
  std::vector<Vector3d> few(3);
  job.previous_positions = few;
  job.max_knee_swivel_rad = 0.2;
  EXPECT_FALSE(job.Validate());
  job.previous_positions = {};
  job.max_knee_swivel_rad = std::nan("");
  EXPECT_FALSE(job.Validate());
}

TEST(Mkm, MirrorSwapsSidesAndBlendEndsAtItsInputs) {
  const Skeleton s = synthetic::make_skeleton({});
  const Clip clip = synthetic::make_punch_clip(s, 40);
  const CanonicalPose p = fk_canonical(clip, 20);
  CanonicalPose m, mm;
  const GroundFrame g = ground_frame_of(fk_canonical(clip, 0));
  mirror_pose(p, g, m);
  mirror_pose(m, g, mm);
  for (std::size_t j = 0; j < kCanonicalJointCount; ++j) EXPECT_LT((mm[j] - p[j]).norm(), 1e-12);
  EXPECT_NEAR(g.to_local(at(m, CJ::l_wrist)).x(), -g.to_local(at(p, CJ::r_wrist)).x(), 1e-12);
  const Morphology morph = make_rig(s, {}, "c").morphology;
  MkmFrame a, b, out;
  encode_mkm(fk_canonical(clip, 0), morph, 0, nullptr, a);
  encode_mkm(p, morph, 0, nullptr, b);
  blend_mkm(a, b, 0.0, out);
  EXPECT_LT((out.arm_n[1] - a.arm_n[1]).norm(), 1e-12);
  blend_mkm(a, b, 1.0, out);
  EXPECT_LT((out.arm_n[1] - b.arm_n[1]).norm(), 1e-12);
  EXPECT_TRUE(out.pelvis.isApprox(b.pelvis, 1e-12));
}

TEST(Mkm, ACrossFadeOfNearlyOppositePolesKeepsTurningTheWayItBegan) {
  // SYNTHETIC: an arm pointing forward, the fading pose's elbow straight down, the other pose's
  // elbow nearly opposite and drifting through straight up over the cross-fade (175 -> 185 deg
  // about the arm). Turned the shorter way afresh each update, the blended elbow swaps sides
  // when the drift passes 180 deg (the bout's guard elbow across the body, 27 cm in a frame);
  // with the cross-fade's turns carried it keeps going the way it began. Where the turn carried
  // is the shorter one, the pole is the same to the bit as without it.
  const Vector3d axis = Vector3d(0.1, 0.2, 1).normalized();
  MkmFrame a, b, plain, carried;
  for (int s = 0; s < 2; ++s) {
    a.arm_n[s] = b.arm_n[s] = 0.8 * axis;
    a.leg_n[s] = b.leg_n[s] = Vector3d(0, -0.9, 0.1);
    a.arm_pole[s] = across(Vector3d(0, -1, 0), axis, Vector3d::UnitX());
    a.leg_pole[s] = b.leg_pole[s] = Vector3d(0, 0.1, 1).normalized();
  }
  const double deg = std::numbers::pi / 180;
  PoleTurns turns;
  double worst_plain = 0, worst_carried = 0;
  Vector3d last_plain, last_carried;
  for (int k = 0; k <= 100; ++k) {
    const double drift = (175 + 0.1 * k) * deg, w = 0.3 + 0.004 * k;
    b.arm_pole[0] = b.arm_pole[1] = Eigen::AngleAxisd(drift, axis) * a.arm_pole[0];
    blend_mkm(a, b, w, plain);
    blend_mkm(a, b, w, carried, &turns);
    if (k > 0) {
      worst_plain = std::max(worst_plain, std::acos(std::clamp(plain.arm_pole[0].dot(last_plain), -1.0, 1.0)));
      worst_carried = std::max(worst_carried, std::acos(std::clamp(carried.arm_pole[0].dot(last_carried), -1.0, 1.0)));
    }
    last_plain = plain.arm_pole[0];
    last_carried = carried.arm_pole[0];
    EXPECT_NEAR(carried.arm_pole[0].norm(), 1, 1e-12);
    EXPECT_NEAR(carried.arm_pole[0].dot(axis), 0, 1e-12);
  }
  EXPECT_GT(worst_plain, 90 * deg);    // the shorter way swaps sides (the test can fail)
  EXPECT_LT(worst_carried, 1.5 * deg);  // the pace of w and the drift: ~0.6 deg per update
  // Carried all the way, the turn went on past 180 deg (the way it began), not back.
  EXPECT_GT(std::abs(turns.arm_rad[0]), 180 * deg);
  // Poles within the shorter way: the same pole with or without the turns, to the bit.
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 200; ++i) {
    PoleTurns fresh;
    const Vector3d pa = Vector3d(u(rng), u(rng), u(rng)).normalized(), pb = Vector3d(u(rng), u(rng), u(rng)).normalized();
    a.arm_pole[0] = across(pa, axis, Vector3d::UnitX());
    b.arm_pole[0] = across(pb, axis, Vector3d::UnitX());
    const double w = 0.5 * (u(rng) + 1);
    blend_mkm(a, b, w, plain);
    blend_mkm(a, b, w, carried, &fresh);
    EXPECT_EQ(plain.arm_pole[0], carried.arm_pole[0]);
    EXPECT_EQ(plain.leg_pole[0], carried.leg_pole[0]);
  }
}

TEST(Mkm, AFoldedArmsElbowSwingsNoFartherThanItsSourcesWhenTheSourcesStraightArmPoleJitters) {
  // SYNTHETIC: a source arm at 0.98 of its length (its elbow ~5 cm off the axis) whose pole
  // jitters +-8 deg from frame to frame (mocap noise about a nearly straight arm, as 135_06's
  // right arm after its hit), drawn folded to 0.55 (a punch landing nearer than captured: the
  // elbow ~22 cm off the axis). Drawn with the source's pole, the elbow swings 22/5 times as far
  // as the source's (aiko's 5.4 cm in a frame in the bout); limited, no farther than the
  // source's plus the catch-up. Drawn as straight as the source, the pole is the source's to
  // the bit; a pole held back comes back to the source's once it stops turning.
  const double upper = 0.28, lower = 0.25, dt = 1.0 / 60, deg = std::numbers::pi / 180;
  const Vector3d axis = Vector3d(0.1, 0.1, 1).normalized();
  const Vector3d base = across(Vector3d(0, -1, 0), axis, Vector3d::UnitX());
  const auto radius = [&](double ext) {  // the elbow's distance from the axis at this extension
    const double len = ext * (upper + lower), proj = (upper * upper - lower * lower + len * len) / (2 * len);
    return std::sqrt(upper * upper - proj * proj);
  };
  const double src_r = radius(0.98), drawn_r = radius(0.55);
  ASSERT_GT(drawn_r, 3 * src_r);
  DrawnPole mem;
  double worst_src = 0, worst_plain = 0, worst_limited = 0;
  Vector3d last_src, last_limited;
  for (int k = 0; k < 60; ++k) {
    const Vector3d src = Eigen::AngleAxisd((k % 2 ? 8 : -8) * deg, axis) * base;
    const Vector3d pole = limit_folded_pole_turn(mem, src, 0.98 * axis, upper, lower, dt);
    EXPECT_NEAR(pole.norm(), 1, 1e-12);
    EXPECT_NEAR(pole.dot(axis), 0, 1e-12);
    if (k > 0) {
      worst_src = std::max(worst_src, src_r * std::acos(std::clamp(src.dot(last_src), -1.0, 1.0)));  // its arc
      worst_plain = std::max(worst_plain, drawn_r * (src - last_src).norm());
      worst_limited = std::max(worst_limited, drawn_r * (pole - last_limited).norm());
    }
    last_src = src;
    last_limited = pole;
    mem.drawn_radius_m = drawn_r;  // as Behaviour measures it on the drawn frame
  }
  EXPECT_GT(worst_plain, 0.05);  // the unlimited swing (the test can fail)
  EXPECT_LT(worst_limited, worst_src + kFoldedPoleCatchUp_mps * dt + 1e-9);
  EXPECT_LT(worst_limited, 0.03);
  // The source's pole turned 60 deg and held there: the drawn one follows, then is the source's.
  const Vector3d turned = Eigen::AngleAxisd(60 * deg, axis) * base;
  Vector3d pole;
  for (int k = 0; k < 40; ++k) {
    pole = limit_folded_pole_turn(mem, turned, 0.98 * axis, upper, lower, dt);
    mem.drawn_radius_m = drawn_r;
  }
  EXPECT_EQ(pole, turned);
  // Drawn as straight as the source (or on a new body, radius unknown): the source's pole.
  DrawnPole straight;
  for (int k = 0; k < 20; ++k) {
    const Vector3d src = Eigen::AngleAxisd((k % 2 ? 8 : -8) * deg, axis) * base;
    EXPECT_EQ(limit_folded_pole_turn(straight, src, 0.98 * axis, upper, lower, dt), src);
    straight.drawn_radius_m = k % 3 == 0 ? 0.0 : src_r;
  }
}

TEST(Adapt, SoftTwoBoneStraightensWithoutAPop) {
  // A goal moved out along a line in 1 mm steps from 95 % to 103 % of a 0.8 m limb: with the
  // plain solver the middle joint moves centimetres for the last millimetres (a knee "pop");
  // the soft one keeps every middle-joint step within 8 x the goal's step, stays exact
  // below the soft zone and lands within 0.37 x softness of a goal at full extension.
  const Vector3d root(0, 1, 0), dir(0, -1, 0), pole(0, 0, 1);
  const double l1 = 0.42, l2 = 0.38, L = l1 + l2, soft = 0.015 * L, step = 0.001;
  double worst_hard = 0, worst_soft = 0;
  TwoBoneResult last_h = solve_two_bone(root, root + dir * 0.95 * L, l1, l2, pole);
  TwoBoneResult last_s = solve_two_bone_soft(root, root + dir * 0.95 * L, l1, l2, pole, soft);
  for (double d = 0.95 * L + step; d <= 1.03 * L; d += step) {
    const Vector3d goal = root + dir * d;
    const TwoBoneResult h = solve_two_bone(root, goal, l1, l2, pole);
    const TwoBoneResult s = solve_two_bone_soft(root, goal, l1, l2, pole, soft);
    worst_hard = std::max(worst_hard, (h.middle - last_h.middle).norm() / step);
    worst_soft = std::max(worst_soft, (s.middle - last_s.middle).norm() / step);
    if (d <= L - soft) {
      EXPECT_LT((s.end - goal).norm(), 1e-9);
    }
    if (std::abs(d - L) < step / 2) {
      EXPECT_LT((s.end - goal).norm(), 0.37 * soft + 1e-6);
    }
    EXPECT_EQ(s.reached, d <= L + 1e-9);
    last_h = h;
    last_s = s;
  }
  EXPECT_GT(worst_hard, 15.0) << worst_soft;  // the pop the soft solver removes (the test could fail)
  EXPECT_LT(worst_soft, 8.0) << worst_soft;
}

TEST(Adapt, TheTrunkFadesInAsTheGoalNearsTheArmsReach) {
  // SYNTHETIC punch pose; the wrist goal pushed straight out from the shoulder in 2 mm steps
  // from 90 % to 110 % of the arm's length. The trunk joins in over the arm's last 5 % (not
  // only once the arm falls short: a nearly straight arm leans the body in rather than lifting
  // the elbow), and the drawn shoulder moves continuously with the goal (no step of it more
  // than 3 x the goal's), the wrist always on its goal.
  PunchLine line;
  Buffers& b = line.b;
  const Rig& rig = line.rig;
  const double step = 0.002;
  Vector3d last = line.shoulder0;
  double worst = 0;
  for (double k = 0.90; k <= 1.10; k += step / line.arm) {
    const ReachGoal goal = line.goal_at(k);
    AdaptReport rep;
    AdaptJob job = b.job(rig, line.f);
    job.reach = &goal;
    job.report = &rep;
    ASSERT_TRUE(job.Run());
    const Vector3d sh = b.at_joint(rig, CJ::r_shoulder);
    if (k > 0.9) worst = std::max(worst, (sh - last).norm() / step);
    last = sh;
    if (k < 0.949) {
      EXPECT_FALSE(rep.trunk_used) << k;
    }
    if (k > 0.96) {
      EXPECT_TRUE(rep.trunk_used) << k;
    }
    EXPECT_LT(rep.reach_error_m, 1e-6) << k;
  }
  std::printf("worst shoulder step %.2f x the goal's\n", worst);
  EXPECT_LT(worst, 3.0);
}

TEST(Adapt, APlannedLeanAndTheFallbackTogetherTurnTheTrunkNoFurtherThanItsLimits) {
  // SYNTHETIC punch pose, the wrist goal at 1.6 x the arm's length straight out (far out of
  // reach: the trunk turns to its limits). That lean given back as the punch's planned lean,
  // as a strike's plan gives it, with the same goal: the fallback on top may use only what the
  // planned lean left of each pivot's limit. It turned by its whole limits again before (a far
  // punch in the bout: the head dipped twice as far as planned, under the raised elbow).
  PunchLine line;
  Buffers& b = line.b;
  const Rig& rig = line.rig;
  ReachGoal goal = line.goal_at(1.6);
  AdaptReport planned;
  AdaptJob job = b.job(rig, line.f);
  job.reach = &goal;
  job.report = &planned;
  ASSERT_TRUE(job.Run());
  ASSERT_TRUE(planned.trunk_used);
  const double head_planned = b.at_joint(rig, CJ::head).y();
  const auto angle = rotation_angle_rad;
  const TrunkLimits limits;
  EXPECT_GT(angle(planned.trunk.spine), 0.9 * limits.spine_rad);  // at its limit: the goal is far
  goal.lean = planned.trunk;
  AdaptReport rep;
  job.report = &rep;
  ASSERT_TRUE(job.Run());
  const double head = b.at_joint(rig, CJ::head).y();
  std::printf("trunk turns with the planned lean and the fallback: spine %.1f, chest %.1f, clavicle %.1f deg (limits %.1f, %.1f, %.1f); head %.1f mm under the plan's\n",
              angle(rep.trunk.spine) * 180 / std::numbers::pi, angle(rep.trunk.chest) * 180 / std::numbers::pi,
              angle(rep.trunk.clavicle) * 180 / std::numbers::pi, limits.spine_rad * 180 / std::numbers::pi,
              limits.chest_rad * 180 / std::numbers::pi, limits.clavicle_rad * 180 / std::numbers::pi,
              (head_planned - head) * 1000);
  EXPECT_LE(angle(rep.trunk.spine), limits.spine_rad + 1e-6);
  EXPECT_LE(angle(rep.trunk.chest), limits.chest_rad + 1e-6);
  EXPECT_LE(angle(rep.trunk.clavicle), limits.clavicle_rad + 1e-6);
  EXPECT_LT(head_planned - head, 0.01);
}

TEST(Adapt, AKicksReachCarriesOnThePunchsTrunkFallbackWhenGivenItsSide) {
  // SYNTHETIC punch pose: the wrist goal at 110 % of the arm for 8 frames (the trunk bends),
  // then a kick's reach (the left foot, d(t) at nothing) from the next frame, the last frame's
  // fallback eased toward none passed as the least. Given the punch's side, the kick's frame
  // keeps that lean (the shoulder moves as the fallback eases); without it (a leg's reach
  // ignored the fallback before) the trunk springs up in one frame.
  PunchLine line;
  Buffers& b = line.b;
  const Rig& rig = line.rig;
  const double dt = 1.0 / 60;
  const auto kick_step = [&](int side) {
    AdaptReport last;
    for (int i = 0; i < 8; ++i) {
      const ReachGoal goal = line.goal_at(1.1);
      const TrunkLean floor = last.trunk_fallback.scaled(1 - dt / 0.15);
      AdaptReport rep;
      AdaptJob job = b.job(rig, line.f);
      job.reach = &goal;
      job.report = &rep;
      if (i > 0) {
        job.max_trunk_weight = last.trunk_weight + dt / 0.1;
        job.min_trunk_fallback = &floor;
      }
      EXPECT_TRUE(job.Run());
      last = rep;
    }
    EXPECT_FALSE(last.trunk_fallback.identity()) << "the punch bent the trunk";
    const Vector3d prev = b.at_joint(rig, CJ::r_shoulder);
    ReachGoal kick;
    kick.effector = {kLeft, true};
    const TrunkLean floor = last.trunk_fallback.scaled(1 - dt / 0.15);
    AdaptReport rep;
    AdaptJob job = b.job(rig, line.f);
    job.reach = &kick;
    job.report = &rep;
    job.min_trunk_fallback = &floor;
    job.min_trunk_fallback_side = side;
    EXPECT_TRUE(job.Run());
    return (b.at_joint(rig, CJ::r_shoulder) - prev).norm();
  };
  const double carried = kick_step(kRight), dropped = kick_step(-1);
  std::printf("shoulder step at the kick's first frame: %.1f mm carried, %.1f mm dropped\n", carried * 1000, dropped * 1000);
  EXPECT_GT(dropped, 0.03);  // the problem: dropped, the trunk springs up in one frame
  EXPECT_LT(carried, 0.015);  // the fallback easing out by one frame's share
}

TEST(Adapt, TheTrunkFallbackComesInAndGoesOutOverFramesWhenTheCallerBoundsIt) {
  // SYNTHETIC punch pose. Frame sequence as a fighter at 60 Hz draws it: the wrist goal at
  // 90 % of the arm, then at 110 % (beyond: the trunk bends), then back at 90 %. Unbounded, the
  // fallback jumps in and out in one frame (the shoulder steps centimetres); with the caller's
  // bounds (max_trunk_weight = last weight + dt / 0.1 s, min_trunk_fallback = the last frame's
  // eased toward none over 0.15 s) the shoulder moves at most a fraction of that per frame.
  PunchLine line;
  Buffers& b = line.b;
  const Rig& rig = line.rig;
  const double dt = 1.0 / 60;
  const std::vector<double> ks{0.9, 0.9, 1.1, 1.1, 1.1, 1.1, 1.1, 1.1, 1.1, 1.1, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9};
  const auto worst_step = [&](bool bounded, double& reach_at_end_of_stretch) {
    AdaptReport last;
    Vector3d prev = line.shoulder0;
    double worst = 0;
    for (std::size_t i = 0; i < ks.size(); ++i) {
      const ReachGoal goal = line.goal_at(ks[i]);
      const TrunkLean floor = last.trunk_fallback.scaled(1 - dt / 0.15);
      AdaptReport rep;
      AdaptJob job = b.job(rig, line.f);
      job.reach = &goal;
      job.report = &rep;
      if (bounded && i > 0) {
        job.max_trunk_weight = last.trunk_weight + dt / 0.1;
        job.min_trunk_fallback = &floor;
      }
      EXPECT_TRUE(job.Run());
      const Vector3d sh = b.at_joint(rig, CJ::r_shoulder);
      worst = std::max(worst, (sh - prev).norm());
      prev = sh;
      if (i == 9) reach_at_end_of_stretch = rep.reach_error_m;
      last = rep;
    }
    return worst;
  };
  double reach_free = 0, reach_bounded = 0;
  const double free = worst_step(false, reach_free), bounded = worst_step(true, reach_bounded);
  std::printf("largest shoulder step in a frame: %.1f mm unbounded, %.1f mm bounded (reach at full stretch %.2f / %.2f mm)\n",
              free * 1000, bounded * 1000, reach_free * 1000, reach_bounded * 1000);
  EXPECT_GT(free, 0.03);  // the problem: the trunk springs in or out in one frame
  EXPECT_LT(bounded, free / 3);
  EXPECT_LT(reach_bounded, reach_free + 1e-3);  // in by the end of the stretch as far as unbounded
}

TEST(Mkm, AFootsPitchIsCarriedFromItsStandingPitchAndStaysContinuousThroughTheVertical) {
  // A foot standing at 30 deg (an HDM05 skeleton's toe joint below its ankle) re-drawn on a foot
  // standing at 10 deg: standing stays standing, a 20 deg plantar flexion stays 20 deg, the
  // heading is kept; round trips are exact; a foot turning through straight down (its
  // heading turns over there) moves on smoothly.
  const double deg = std::numbers::pi / 180;
  const auto dir = [&](double pitch_deg, double yaw_deg) {
    return Eigen::Vector3d(std::cos(pitch_deg * deg) * std::sin(yaw_deg * deg), -std::sin(pitch_deg * deg),
                           std::cos(pitch_deg * deg) * std::cos(yaw_deg * deg));
  };
  const auto pitch_of = [&](const Eigen::Vector3d& d) { return std::atan2(-d.y(), std::hypot(d.x(), d.z())) / deg; };
  EXPECT_NEAR(pitch_of(repitch(dir(30, 25), 30 * deg, 10 * deg)), 10, 1e-9);
  EXPECT_NEAR(pitch_of(repitch(dir(20, 25), 30 * deg, 10 * deg)), 0, 1e-9);
  const Eigen::Vector3d turned = repitch(dir(35, 25), 30 * deg, 10 * deg);
  EXPECT_NEAR(std::atan2(turned.x(), turned.z()) / deg, 25, 1e-9);
  EXPECT_NEAR(turned.norm(), 1, 1e-12);
  for (double p = -89; p <= 89; p += 7) {
    const Eigen::Vector3d d = dir(p, -40);
    EXPECT_LT((repitch(repitch(d, 30 * deg, 0), 0, 30 * deg) - d).norm(), 1e-12) << p;
  }
  // Through the vertical: pitch 80..100 deg along one heading is one smooth swing of the foot.
  Eigen::Vector3d last = repitch(dir(80, 0), 30 * deg, 10 * deg);
  for (double p = 80.5; p <= 100; p += 0.5) {
    const Eigen::Vector3d now = repitch(dir(p, 0), 30 * deg, 10 * deg);
    EXPECT_LT((now - last).norm(), 1.5 * 0.5 * deg) << p;
    last = now;
  }
}

TEST(Mkm, ACharacterDrawsTheSourcesStandingFootFlatOnTheFloor) {
  // Decoded on each shipped character, the support foot of an HDM05 kick where the actor
  // stands flat (clip frame 49 of HDM_bd_kickLFront1Reps_001_120, read off the raw BVH with an
  // independent FK: the right ankle at its lowest, its toe joint 6.4 cm below it, 27 deg)
  // stands flat too: its toe joint on the floor (the character's rest pose has it at its
  // lowest foot joint), within what the median standing pitch and the bodies' other proportions leave
  // (1.5 cm; 0.4-1.0 cm measured). The source's
  // own 27 deg drawn on a character's 11 deg foot put its toe 3-4 cm through the floor.
  const Database& db = *kumite::content::testing::shipped_database().db;
  const auto it = std::find_if(db.segments.begin(), db.segments.end(),
                               [](const MotionSegment& s) { return s.name == "HDM_bd_kickLFront1Reps_001_120_kick_left_1"; });
  ASSERT_NE(it, db.segments.end());
  for (const Rig& rig : kumite::content::testing::shipped_characters()) {
    CanonicalPose pose;
    decode_canonical(rig, it->frames[static_cast<std::size_t>(49 - it->source_first_frame)], pose);
    EXPECT_NEAR(at(pose, CJ::r_toe).y(), 0.0, 0.015) << rig.name;
  }
}

TEST(Mkm, ASampleBetweenTwoFramesDrawsEveryElbowAndKneeBetweenThem) {
  // Playback samples a clip between its frames (a 120 Hz clip at 60 Hz, a strike's rate) and
  // blends two clips; both blend MkmFrames. Every shipped segment, every pair of neighbouring
  // frames, drawn on each shipped character: the half-way sample's elbows and knees (relative
  // to the shoulder / hip, so the body's own travel cancels) must lie near the middle of the
  // two frames' own. With the swivel stored as an angle about a fixed reference, a limb pointed
  // nearly opposite the reference turned the angle 2 rad in one frame while the mocap's elbow
  // moved 1.5 cm (135_10_step_6, frames 59-60: a guard arm across the body), and the half-way
  // sample swung the elbow round the arm.
  const auto& set = kumite::content::testing::shipped_database();
  const auto rigs = kumite::content::testing::shipped_characters();
  // m from the middle: a fast kick's knee swings 0.15 rad in half a 120 Hz frame, and the lerp
  // of its leg vector is a chord, shorter than the leg: the knee bulges out up to 3 cm. The
  // angle about a fixed reference put 10 elbows 5-8.6 cm off (135_10_step_6 frame 59, every
  // character, the mirror too).
  constexpr double kOff_m = 0.04;
  int pairs = 0, off = 0;
  double worst = 0;
  std::string worst_at;
  for (const Rig& rig : rigs) {
    Buffers b(rig);
    const std::array<std::pair<CJ, CJ>, 4> limbs{{{CJ::l_shoulder, CJ::l_elbow}, {CJ::r_shoulder, CJ::r_elbow},
                                                  {CJ::l_hip, CJ::l_knee}, {CJ::r_hip, CJ::r_knee}}};
    auto draw = [&](const MkmFrame& f, std::array<Vector3d, 4>& out) {
      ASSERT_TRUE(b.job(rig, f).Run());
      for (std::size_t i = 0; i < limbs.size(); ++i) out[i] = b.at_joint(rig, limbs[i].second) - b.at_joint(rig, limbs[i].first);
    };
    for (const MotionSegment& seg : set.db->segments) {
      std::array<Vector3d, 4> a, c, h;
      draw(seg.frames[0], a);
      for (int k = 0; k + 1 < seg.frame_count(); ++k) {
        MkmFrame half;
        blend_mkm(seg.frames[static_cast<std::size_t>(k)], seg.frames[static_cast<std::size_t>(k + 1)], 0.5, half);
        draw(seg.frames[static_cast<std::size_t>(k + 1)], c);
        draw(half, h);
        for (std::size_t i = 0; i < limbs.size(); ++i) {
          const double d = (h[i] - 0.5 * (a[i] + c[i])).norm();
          ++pairs;
          off += d > kOff_m;
          if (d > worst) {
            worst = d;
            worst_at = rig.name + " " + seg.name + " frame " + std::to_string(k) + " " + std::string(to_string(limbs[i].second));
          }
        }
        a = c;
      }
    }
  }
  std::printf("%d frame pairs x limbs: %d half-way samples more than %.0f cm off the middle; worst %.1f cm (%s)\n", pairs, off,
              kOff_m * 100, worst * 100, worst_at.c_str());
  EXPECT_EQ(off, 0);
}

TEST(Mkm, SteadiedPolesCalmAFoldedLimbAndHardlyMoveTheSourcesOwn) {
  // The shipped database built with and without steady_straight_limb_poles, every segment drawn
  // on each shipped character. (1) Drawn as captured, an elbow or knee (relative to its
  // shoulder / hip) moves at most kMoved_m: the steadied pole is used only where the limb is
  // nearly straight, where the joint sits near the axis. (2) Drawn as adaptation draws a
  // strike that lands nearer than captured (its limb folded to 0.65 of its length about the
  // root, the same turn every frame), the limb's middle joint takes no step above kStep_m
  // between frames where the limb is straight at both (135_06's right arm at its hit: the pole
  // turned 21 deg in 1/60 s, the drawn elbow 10 cm).
  constexpr double kStep_m = 0.05;
  const auto& set = kumite::content::testing::shipped_database();
  BuildOptions raw_options;
  raw_options.steady_straight_poles = false;
  const Database raw = build_database(segment_sources(set.annotations, set.clips), raw_options);
  ASSERT_EQ(raw.segments.size(), set.db->segments.size());
  const auto rigs = kumite::content::testing::shipped_characters();
  double moved = 0;
  std::string moved_at;
  std::vector<double> all_moved;
  std::array<int, 2> big_steps{0, 0};  // [raw, steadied]
  std::array<double, 2> worst_step{0, 0};
  for (const Rig& rig : rigs) {
    Buffers b(rig);
    for (std::size_t si = 0; si < raw.segments.size(); ++si) {
      const MotionSegment& seg = set.db->segments[si];
      const MotionSegment& rseg = raw.segments[si];
      ASSERT_EQ(seg.frame_count(), rseg.frame_count());
      const auto eff = seg.effector();
      const std::array<std::pair<CJ, CJ>, 4> limbs{{{CJ::l_shoulder, CJ::l_elbow}, {CJ::r_shoulder, CJ::r_elbow},
                                                    {CJ::l_hip, CJ::l_knee}, {CJ::r_hip, CJ::r_knee}}};
      for (int f = 0; f < seg.frame_count(); ++f) {
        std::array<std::array<Vector3d, 4>, 2> drawn;
        for (int k = 0; k < 2; ++k) {
          ASSERT_TRUE(b.job(rig, (k ? seg : rseg).frames[static_cast<std::size_t>(f)]).Run());
          for (std::size_t i = 0; i < 4; ++i) drawn[k][i] = b.at_joint(rig, limbs[i].second) - b.at_joint(rig, limbs[i].first);
        }
        for (std::size_t i = 0; i < 4; ++i) all_moved.push_back((drawn[0][i] - drawn[1][i]).norm());
        for (std::size_t i = 0; i < 4; ++i)
          if ((drawn[0][i] - drawn[1][i]).norm() > moved) {
            moved = (drawn[0][i] - drawn[1][i]).norm();
            const MkmFrame& fr = seg.frames[static_cast<std::size_t>(f)];
            const double ext = (i < 2 ? fr.arm_n : fr.leg_n)[i % 2].norm();
            moved_at = rig.name + " " + seg.name + " frame " + std::to_string(f) + " " + std::string(to_string(limbs[i].second)) +
                       " extension " + std::to_string(ext);
          }
      }
      if (!eff) continue;
      const std::size_t li = static_cast<std::size_t>(eff->side + 2 * (eff->leg ? 1 : 0));
      ReachGoal fold;
      fold.effector = *eff;
      fold.stretch = 0.65;
      for (int k = 0; k < 2; ++k) {
        const MotionSegment& s = k ? seg : rseg;
        std::vector<double> steps;  // per 1/60 s; NaN where the limb is not straight at both frames
        Vector3d last = Vector3d::Zero();
        bool was_straight = false;
        for (int f = 0; f < s.frame_count(); ++f) {
          const MkmFrame& fr = s.frames[static_cast<std::size_t>(f)];
          AdaptJob job = b.job(rig, fr);
          job.reach = &fold;
          ASSERT_TRUE(job.Run());
          const Vector3d mid = b.at_joint(rig, limbs[li].second) - b.at_joint(rig, limbs[li].first);
          const double ext = (eff->leg ? fr.leg_n : fr.arm_n)[static_cast<std::size_t>(eff->side)].norm();
          const bool straight = ext >= kSteadyFrom;
          if (f > 0) steps.push_back(straight && was_straight ? (mid - last).norm() * (1.0 / 60) / s.frame_time_s : std::nan(""));
          last = mid;
          was_straight = straight;
        }
        // A snap as the bout judges one: a step over kStep_m and over 3 x both neighbours'.
        for (std::size_t i = 1; i + 1 < steps.size(); ++i) {
          if (std::isnan(steps[i])) continue;
          worst_step[static_cast<std::size_t>(k)] = std::max(worst_step[static_cast<std::size_t>(k)], steps[i]);
          const double before = std::isnan(steps[i - 1]) ? 0.0 : steps[i - 1], after = std::isnan(steps[i + 1]) ? 0.0 : steps[i + 1];
          big_steps[static_cast<std::size_t>(k)] += steps[i] > kStep_m && steps[i] > 3 * before && steps[i] > 3 * after;
        }
      }
    }
  }
  std::sort(all_moved.begin(), all_moved.end());
  const double p99 = all_moved[all_moved.size() * 99 / 100];
  std::printf("steadied poles: drawn as captured, elbows/knees moved p99 %.2f cm, at most %.1f cm (%s); folded limb's "
              "middle joint per 1/60 s where straight: worst %.1f cm raw, %.1f cm steadied; snaps (over %.0f cm and 3x "
              "both neighbours): %d raw, %d steadied\n",
              p99 * 100, moved * 100, moved_at.c_str(), worst_step[0] * 100, worst_step[1] * 100, kStep_m * 100,
              big_steps[0], big_steps[1]);
  // The most a source joint moves is where the mocap's own knee flips through straight (HDM05's
  // kicks: 88 deg in one 120 Hz frame and back): the steadied pole keeps the bent side.
  EXPECT_LT(p99, 0.015);
  EXPECT_LT(moved, 0.08);
  EXPECT_GT(big_steps[0], 50);  // the problem is there without steadying
  EXPECT_LT(big_steps[1] * 5, big_steps[0]);
}

TEST(Mkm, SteadyingPolesTakesAnyFrameTimeAndKeepsThemUnit) {
  // SYNTHETIC frames at 120 Hz: an arm bent for 10 frames (pole down), straight for 21 (its
  // pole swinging +-x every frame, as noise), bent again. Steadied, the straight middle takes
  // its bent neighbours' pole. A BVH's frame time has no lower bound: at 1e-12 s three sigma
  // span 1.5e11 frames and the window once was that long (allocated); bounded by the segment,
  // the poles come back unit and across their limbs.
  std::vector<MkmFrame> frames(41);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const bool straight = i >= 10 && i <= 30;
    frames[i].arm_n[0] = Vector3d(0, 0, straight ? 1.0 : 0.7);
    frames[i].arm_pole[0] = straight ? Vector3d(i % 2 ? 1 : -1, 0, 0) : Vector3d(0, -1, 0);
  }
  for (const double ft : {1e-12, 1.0 / 120, 10.0}) {
    std::vector<MkmFrame> f = frames;
    steady_straight_limb_poles(f, ft);
    for (const MkmFrame& x : f) {
      EXPECT_NEAR(x.arm_pole[0].norm(), 1.0, 1e-9) << ft;
      EXPECT_NEAR(x.arm_pole[0].dot(x.arm_n[0].normalized()), 0.0, 1e-9) << ft;
    }
    if (ft == 1.0 / 120) {
      for (int i = 15; i <= 25; ++i) EXPECT_GT(f[static_cast<std::size_t>(i)].arm_pole[0].dot(Vector3d(0, -1, 0)), 0.9) << i;
    }
  }
  std::vector<MkmFrame> none;
  steady_straight_limb_poles(none, 1.0 / 120);
}

TEST(Adapt, AKickingLegStraightensSoftlyAndReachesExactlyBelowItsLockOut) {
  // SYNTHETIC pose (the punch clip's frame 20, standing); the right leg is the effector, its
  // ankle goal moved out along the hip -> ankle line in 1 mm steps from 95 % to 103 % of the
  // leg. The knee steps at most 8 x the goal's step (hard, it moved centimetres for the last
  // millimetres: a kick stretched by d(t) beyond its motion's extension straightened its knee 9
  // cm in one frame), and up to 0.99 of the leg (a kick's lock-out) the ankle is on its goal.
  PunchLine line;
  Buffers& b = line.b;
  const Rig& rig = line.rig;
  ASSERT_TRUE(b.job(rig, line.f).Run());
  const Vector3d hip = b.at_joint(rig, CJ::r_hip), ankle0 = b.at_joint(rig, CJ::r_ankle);
  const Vector3d out = (ankle0 - hip).normalized();
  const double leg = rig.morphology.limb_leg_length(kRight), step = 0.001;
  double worst = 0;
  Vector3d last = Vector3d::Zero();
  bool first = true;
  for (double k = 0.95; k <= 1.03; k += step / leg) {
    ReachGoal goal;
    goal.effector = {kRight, true};
    goal.offset_m = hip + out * (k * leg) - ankle0;
    AdaptJob job = b.job(rig, line.f);
    job.reach = &goal;
    ASSERT_TRUE(job.Run());
    const Vector3d knee = b.at_joint(rig, CJ::r_knee);
    if (!first) worst = std::max(worst, (knee - last).norm() / step);
    first = false;
    last = knee;
    if (k <= 0.99) {
      EXPECT_LT((b.at_joint(rig, CJ::r_ankle) - (hip + out * (k * leg))).norm(), 1e-6) << k;
    }
  }
  std::printf("kicking knee: worst step %.1f x the goal's\n", worst);
  EXPECT_LT(worst, 8.0);
}

// A punch's goal pinned at contact (pin 1) stays put when held feet lower the pelvis; with
// pin_drop_max_m it is kept against that much of the drop only and goes down with the body by
// the rest (a plan checked the arm at its planned drop: held against a deeper one, the arm rose
// steeper than planned, kenji's elbow over his head in the 120-order sweep). With nothing kept
// the arm points from the lowered shoulder exactly as it did from the standing one.
// SYNTHETIC: the punch line's pose, both ankles held 0.1 m under where the pose puts them.
TEST(Adapt, APinnedGoalGoesDownWithTheBodyBeyondItsPinDropMax) {
  PunchLine p;
  const ReachGoal plain = p.goal_at(0.8);
  AdaptJob base = p.b.job(p.rig, p.f);
  base.reach = &plain;
  ASSERT_TRUE(base.Run());
  const Vector3d target = p.b.at_joint(p.rig, CJ::r_wrist);
  const Vector3d arm0 = target - p.b.at_joint(p.rig, CJ::r_shoulder);
  FootLocks locks;
  locks.weight = {1, 1};
  locks.supporting = {true, true};
  locks.ankle_m = {p.b.at_joint(p.rig, CJ::l_ankle) - Vector3d(0, 0.1, 0), p.b.at_joint(p.rig, CJ::r_ankle) - Vector3d(0, 0.1, 0)};
  locks.max_root_drop_m = 0.2;
  const auto run = [&](double pin, double pin_drop_max_m, double& drop) {
    ReachGoal g = plain;
    g.pin = pin;
    g.pin_drop_max_m = pin_drop_max_m;
    AdaptReport rep;
    AdaptJob job = p.b.job(p.rig, p.f);
    job.reach = &g;
    job.feet = &locks;
    job.report = &rep;
    EXPECT_TRUE(job.Run());
    drop = rep.root_drop_m;
    return p.b.at_joint(p.rig, CJ::r_wrist);
  };
  double drop = 0;
  EXPECT_LT((run(1, std::numeric_limits<double>::infinity(), drop) - target).norm(), 1e-6);  // kept
  EXPECT_NEAR(drop, 0.1, 0.01);
  const Vector3d kept_4cm = run(1, 0.04, drop);
  EXPECT_LT((kept_4cm - (target - Vector3d(0, drop - 0.04, 0))).norm(), 1e-6);
  const Vector3d half = run(0.5, 0.04, drop);
  EXPECT_LT((half - (target - Vector3d(0, 0.5 * (drop - 0.04) + 0.5 * drop, 0))).norm(), 1e-6);
  const Vector3d none = run(1, 0, drop);
  EXPECT_LT((none - p.b.at_joint(p.rig, CJ::r_shoulder) - arm0).norm(), 1e-6);
  EXPECT_GT(drop, 0.05);
}

// A held ankle the leg holds above the floor (it does not reach down to it flat) stands on its
// toes: with toe_floor_y_m the toe joint goes no higher than that, the foot pitched down about
// the ankle with its heading kept; by toe_floor_weight in between; a toe already below it is
// left alone (mei's support foot held 6.4 cm up after a kick floated flat over the floor for
// 0.45 s in the 120-order sweep). SYNTHETIC: the standing pose, the left ankle held 6 cm up.
TEST(Adapt, AFootHeldAboveTheFloorKeepsItsToesOnTheFloor) {
  const Skeleton s = synthetic::make_skeleton({});
  const Rig rig = make_rig(s, {}, "c");
  Buffers b(rig);
  const MkmFrame f = punch_pose(s, rig, 0);
  ASSERT_TRUE(b.job(rig, f).Run());
  const Vector3d ankle0 = b.at_joint(rig, CJ::l_ankle), toe0 = b.at_joint(rig, CJ::l_toe);
  FootLocks locks;
  locks.weight = {1, 0};
  locks.ankle_m = {ankle0 + Vector3d(0, 0.06, 0), b.at_joint(rig, CJ::r_ankle)};
  const auto run = [&](double floor_y, double w) {
    locks.toe_floor_y_m = {floor_y, 0};
    locks.toe_floor_weight = {w, 0};
    AdaptJob job = b.job(rig, f);
    job.feet = &locks;
    EXPECT_TRUE(job.Run());
    return std::pair(b.at_joint(rig, CJ::l_ankle), b.at_joint(rig, CJ::l_toe));
  };
  const auto [ankle_off, toe_off] = run(toe0.y(), 0.0);
  EXPECT_NEAR(ankle_off.y(), ankle0.y() + 0.06, 1e-6);
  EXPECT_NEAR(toe_off.y() - toe0.y(), 0.06, 0.005) << "without it the flat foot floats with its ankle";
  const auto [ankle_on, toe_on] = run(toe0.y(), 1.0);
  EXPECT_NEAR(toe_on.y(), toe0.y(), 1e-6);
  EXPECT_LT((ankle_on - ankle_off).norm(), 1e-9) << "the ankle stays where it is held";
  const Eigen::Vector2d h_off(toe_off.x() - ankle_off.x(), toe_off.z() - ankle_off.z());
  const Eigen::Vector2d h_on(toe_on.x() - ankle_on.x(), toe_on.z() - ankle_on.z());
  EXPECT_GT(h_off.normalized().dot(h_on.normalized()), 1 - 1e-9) << "the heading is kept";
  const auto [ankle_half, toe_half] = run(toe0.y(), 0.5);
  EXPECT_GT(toe_half.y(), toe_on.y() + 0.01);
  EXPECT_LT(toe_half.y(), toe_off.y() - 0.01);
  const auto [ankle_low, toe_low] = run(toe_off.y() + 0.01, 1.0);
  EXPECT_LT((toe_low - toe_off).norm(), 1e-9) << "a toe under its floor is left alone";
  // toe_lowest_y_m: no lower than that, pitched up (a toe 2 cm under it comes up to it).
  locks.toe_floor_weight = {0, 0};
  locks.toe_lowest_y_m = {toe_off.y() + 0.02, 0};
  locks.toe_lowest_weight = {1, 0};
  AdaptJob job = b.job(rig, f);
  job.feet = &locks;
  ASSERT_TRUE(job.Run());
  EXPECT_NEAR(b.at_joint(rig, CJ::l_toe).y(), toe_off.y() + 0.02, 1e-6);
  EXPECT_LT((b.at_joint(rig, CJ::l_ankle) - ankle_off).norm(), 1e-9);
  locks.toe_lowest_y_m = {toe_off.y() - 0.01, 0};
  ASSERT_TRUE(job.Run());
  EXPECT_LT((b.at_joint(rig, CJ::l_toe) - toe_off).norm(), 1e-9) << "a toe above its lowest is left alone";
}

TEST(Adapt, AHeldFootsHeadingTurnsContinuouslyAsTheMotionsFootPassesItsOpposite) {
  // kenji at rest, the right foot held where it stands with its heading toward +z at half
  // weight (a hold easing out as the foot lifts), while the motion's foot turns 3 deg a frame
  // from 150 to 210 deg: through the opposite of the held heading. Judged on the drawn joints
  // (the ankle -> toe direction about +y). Handed the last frame's heading difference back
  // (AdaptJob::previous_heading_delta_rad), the toe turns by half the motion's 3 deg a frame;
  // without it, the share turned changes sign where the difference passes +-180 deg and the toe
  // swung round (a kick lifting its foot in the 120-order sweep: the toe 26 cm in one frame).
  const Rig rig = load_character_rig((std::filesystem::path(KUMITE_SOURCE_DIR) / "content" / "characters" / "kenji.bvh").string());
  MkmFrame f;
  encode_mkm(rig.rest_pose, rig.morphology, rig.rest_pose[static_cast<std::size_t>(CJ::r_toe)].y(), nullptr, f);
  Buffers b(rig);
  {
    AdaptJob plain = b.job(rig, f);
    ASSERT_TRUE(plain.Run());
  }
  FootLocks locks;
  locks.weight = {0, 1};
  locks.ankle_m = {Vector3d::Zero(), b.at_joint(rig, CJ::r_ankle)};
  locks.heading_weight = {0, 0.5};
  locks.heading_xz = {Eigen::Vector2d(0, 1), Eigen::Vector2d(0, 1)};
  const double pitch = f.foot_dir[kRight].y();
  const auto toe_heading_deg = [&] {
    const Vector3d d = b.at_joint(rig, CJ::r_toe) - b.at_joint(rig, CJ::r_ankle);
    return std::atan2(d.x(), d.z()) * 180 / std::numbers::pi;
  };
  const auto run = [&](bool hand_back) {
    double most = 0, before = 0;
    AdaptReport report;
    for (int k = 0; k <= 20; ++k) {
      const double a = (150.0 + 3 * k) * std::numbers::pi / 180;
      const double flat = std::sqrt(std::max(0.0, 1 - pitch * pitch));
      f.foot_dir[kRight] = Vector3d(flat * std::sin(a), pitch, flat * std::cos(a));
      AdaptJob job = b.job(rig, f);
      job.feet = &locks;
      job.report = &report;
      if (hand_back && k > 0) job.previous_heading_delta_rad = report.heading_delta_rad;
      EXPECT_TRUE(job.Run());
      const double h = toe_heading_deg();
      if (k > 0) most = std::max(most, std::abs(std::remainder(h - before, 360.0)));
      before = h;
    }
    return most;
  };
  const double chained = run(true), alone = run(false);
  std::printf("the drawn toe's heading, most in one frame: %.1f deg handed back, %.1f deg without\n", chained, alone);
  EXPECT_LT(chained, 2.0);   // half of 3 deg a frame
  EXPECT_GT(alone, 150.0);   // the flip this guards against
  AdaptJob bad = b.job(rig, f);
  bad.previous_heading_delta_rad = {std::numeric_limits<double>::infinity(), 0};
  EXPECT_FALSE(bad.Validate());
}

TEST(Adapt, AGuardsFistTurnsItsThumbTowardTheShouldersSideOfTheForearm) {
  // kenji standing at rest, both arms laid as the guard holds them (the wrist up in front of
  // the face, the elbow down and out), drawn by AdaptJob with fist_neutral 0, 0.5 and 1. Judged
  // on the drawn joints: the thumb's direction (lthumb -> its end, across the forearm) against
  // the shoulder's side of the forearm (shoulder - elbow, across elbow -> wrist), both worked
  // out here from the drawn positions. Swung alone the guard's upright forearm turned the palm
  // to the visitor and the curled fingers at them (the spar demo's frame 95, looked at).
  const Rig rig = load_character_rig((std::filesystem::path(KUMITE_SOURCE_DIR) / "content" / "characters" / "kenji.bvh").string());
  const auto n = static_cast<std::size_t>(rig.joint_count());
  MkmFrame f;
  encode_mkm(rig.rest_pose, rig.morphology, rig.rest_pose[static_cast<std::size_t>(CJ::l_toe)].y(), nullptr, f);
  for (int s = 0; s < 2; ++s) {
    const auto us = static_cast<std::size_t>(s);
    const double x = s == kLeft ? -0.22 : 0.22;  // toward the middle (the chest's x is the body's left)
    f.arm_n[us] = f.chest * Vector3d(x, 0.30, 0.32);
    const Vector3d axis = f.arm_n[us].normalized();
    const Vector3d down_out = f.chest * Vector3d(s == kLeft ? 0.4 : -0.4, -1, 0);
    f.arm_pole[us] = (down_out - down_out.dot(axis) * axis).normalized();
  }
  Buffers b(rig);
  const auto draw = [&](double w) {
    AdaptJob job = b.job(rig, f);
    job.fist_neutral = {w, w};
    EXPECT_TRUE(job.Run());
    return b.pos;
  };
  const auto named = [&](const char* name) {
    const int j = rig.skeleton.find(name);
    EXPECT_GE(j, 0) << name;
    return static_cast<std::size_t>(std::max(j, 0));
  };
  // rad, signed about the forearm: from the shoulder's side of the forearm to the thumb.
  const auto thumb_angle = [&](const std::vector<Vector3d>& p, int s) {
    const auto at = [&](CJ j) { return p[static_cast<std::size_t>(rig.skeleton.index(j))]; };
    const Vector3d sh = at(s == kLeft ? CJ::l_shoulder : CJ::r_shoulder), el = at(s == kLeft ? CJ::l_elbow : CJ::r_elbow),
                   wr = at(s == kLeft ? CJ::l_wrist : CJ::r_wrist);
    const Vector3d a = (wr - el).normalized();
    Vector3d want = sh - el, thumb = p[named(s == kLeft ? "lthumb_end" : "rthumb_end")] - p[named(s == kLeft ? "lthumb" : "rthumb")];
    want -= want.dot(a) * a;
    thumb -= thumb.dot(a) * a;
    return std::atan2(a.dot(want.cross(thumb)), want.dot(thumb));
  };
  const std::vector<Vector3d> swung = draw(0), half = draw(0.5), turned = draw(1);
  for (int s = 0; s < 2; ++s) {
    const double a0 = thumb_angle(swung, s), ah = thumb_angle(half, s), a1 = thumb_angle(turned, s);
    std::printf("side %d: thumb from the shoulder's side of the forearm: swung %.1f deg, half %.1f, turned %.1f\n", s,
                a0 * 180 / M_PI, ah * 180 / M_PI, a1 * 180 / M_PI);
    EXPECT_GT(std::abs(a0), 45 * M_PI / 180) << "the guard's pose no longer shows the swung twist: the test proves nothing";
    EXPECT_LT(std::abs(a1), 2 * M_PI / 180);
    EXPECT_NEAR(ah, a0 / 2, 2 * M_PI / 180);
  }
  // The turn is about the forearm: every joint but those below the elbows stays where it was.
  for (std::size_t j = 0; j < n; ++j) {
    bool below_elbow = false;
    for (int a = rig.skeleton.parents[j]; a >= 0 && !below_elbow; a = rig.skeleton.parents[static_cast<std::size_t>(a)])
      below_elbow = a == rig.skeleton.index(CJ::l_elbow) || a == rig.skeleton.index(CJ::r_elbow);
    const bool wrist = static_cast<int>(j) == rig.skeleton.index(CJ::l_wrist) || static_cast<int>(j) == rig.skeleton.index(CJ::r_wrist);
    if (!below_elbow || wrist) {
      EXPECT_LT((turned[j] - swung[j]).norm(), 1e-9) << rig.skeleton.names[j];
    }
  }
  AdaptJob bad = b.job(rig, f);
  bad.fist_neutral = {1.5, 0};
  EXPECT_FALSE(bad.Validate());
  bad.fist_neutral = {std::nan(""), 0};
  EXPECT_FALSE(bad.Validate());
}

TEST(Adapt, AStretchedPunchKeepsItsWristOffItsShoulder) {
  // A punch shortened onto a near target (stretch < 1) is shrunk about the shoulder: a
  // chambered fist came within 12 cm of the shoulder, the arm folded flat and its elbow swung
  // round (14.7 m/s in the spar demo; at 0.35 of the arm 16.6 m/s, swept round at that
  // radius). The wrist goal keeps at least half the arm from the shoulder (or the motion's own
  // distance, where nearer), and is the stretched one above it.
  // SYNTHETIC punch (its chamber, frame 2, and half way out, frame 10), stretch 1 -> 0.1.
  PunchLine line;
  const double arm = line.arm;
  for (const int frame : {2, 10}) {
    const MkmFrame f = punch_pose(line.s, line.rig, frame);
    const double own = f.arm_n[kRight].norm() * arm;  // the motion's own wrist from the shoulder
    int floored = 0;
    for (double stretch = 1.0; stretch > 0.05; stretch -= 0.05) {
      ReachGoal goal;
      goal.effector = {kRight, false};
      goal.stretch = stretch;
      AdaptReport rep;
      AdaptJob job = line.b.job(line.rig, f);
      job.reach = &goal;
      job.report = &rep;
      ASSERT_TRUE(job.Run());
      const Vector3d shoulder = line.b.at_joint(line.rig, CJ::r_shoulder);
      const double d = (rep.effector_goal - shoulder).norm();
      const double floor = std::min(own, 0.5 * arm);
      EXPECT_GT(d, floor - 1e-9) << "frame " << frame << " stretch " << stretch;
      if (rep.trunk_used) continue;  // (the trunk would move the shoulder)
      if (stretch * own > floor + 1e-6) {
        EXPECT_NEAR(d, stretch * own, 1e-6) << "frame " << frame << " stretch " << stretch;
      } else {
        ++floored;
      }
      EXPECT_GT((line.b.at_joint(line.rig, CJ::r_wrist) - shoulder).norm(), floor - 1e-3);
    }
    std::printf("frame %d: wrist %.3f of the arm from the shoulder; %d of 19 stretches held at the floor\n", frame, own / arm,
                floored);
    EXPECT_GT(floored, 0);
  }
}
