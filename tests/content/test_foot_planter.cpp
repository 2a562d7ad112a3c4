// FootPlanter on SYNTHETIC samples (no motion): which foot steps when.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>

#include <gtest/gtest.h>

#include "kumite/content/adaptation.hpp"
#include "kumite/content/foot_planting.hpp"

namespace {

using Eigen::Vector3d;
using kumite::content::FootLocks;
using kumite::content::FootPlanter;
using kumite::content::FootSample;
using Phase = FootPlanter::Phase;

constexpr double kDt = 1.0 / 60;

/// Both feet standing where the motion has them: ankles 8 cm up (toe joints 1 cm), 0.2 m apart,
/// hips above.
std::array<FootSample, 2> standing() {
  std::array<FootSample, 2> s;
  for (int side = 0; side < 2; ++side) {
    FootSample& f = s[static_cast<std::size_t>(side)];
    const double x = side == 0 ? 0.1 : -0.1;
    f.planted = true;
    f.free_ankle_m = Vector3d(x, 0.08, 0);
    f.drawn_ankle_m = f.free_ankle_m;
    f.hip_m = Vector3d(x, 0.9, 0);
    f.leg_length_m = 0.85;
    f.standing_ankle_y_m = 0.08;
    f.standing_toe_y_m = 0.01;
  }
  return s;
}

/// Both feet standing (standing()) and held: 30 updates with the feet planted.
void both_feet_held(FootPlanter& planter, std::array<FootSample, 2>& s, FootLocks& locks) {
  s = standing();
  for (int k = 0; k < 30; ++k) planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  ASSERT_EQ(planter.phase(0), Phase::held);
}

/// Eight updates into a procedural step of the left foot toward `to` (both feet held at first,
/// standing()): the foot is in the air there; its ankle then is written to `mid_step`.
void left_foot_mid_step(FootPlanter& planter, std::array<FootSample, 2>& s, FootLocks& locks, const Vector3d& to,
                        Vector3d& mid_step) {
  ASSERT_TRUE(planter.step_to(0, to));
  for (int k = 0; k < 8; ++k) planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
  ASSERT_EQ(planter.phase(0), Phase::stepping);
  mid_step = locks.ankle_m[0];
  ASSERT_GT(mid_step.y(), 0.08 + 0.02) << "mid-step, the foot is in the air";
}

/// The left foot's way over up to `updates` updates (nothing else changing; `stop_when_down`:
/// until its procedural step ends): its first move along the floor, its fastest along the floor
/// and in 3-D, and the least weight its lock had.
struct StepWalk {
  double first_move_xz_m = -1, fastest_xz_mps = 0, fastest_mps = 0, least_weight = 1;
};
StepWalk walk_left_foot(FootPlanter& planter, std::array<FootSample, 2>& s, FootLocks& locks, int updates, bool stop_when_down) {
  StepWalk w;
  Vector3d last = locks.ankle_m[0];
  for (int k = 0; k < updates && !(stop_when_down && planter.phase(0) != Phase::stepping); ++k) {
    s[0].drawn_ankle_m = locks.ankle_m[0];
    planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
    const Vector3d d = locks.ankle_m[0] - last;
    const double xz = std::hypot(d.x(), d.z());
    if (w.first_move_xz_m < 0) w.first_move_xz_m = xz;
    w.fastest_xz_mps = std::max(w.fastest_xz_mps, xz / kDt);
    w.fastest_mps = std::max(w.fastest_mps, d.norm() / kDt);
    w.least_weight = std::min(w.least_weight, locks.weight[0]);
    last = locks.ankle_m[0];
  }
  return w;
}

TEST(FootPlanter, AFootThatMustStepGoesAloneTheOtherFootsDueStepWaitsForItsLanding) {
  // The walk bout's hop (27 Nov): a back foot set down at full stretch is out of the leg's
  // reach the next update (it must step at once) in the very update the front foot's step
  // falls due (its spot half a metre ahead): both lifted together, 13 frames with both feet
  // off the floor. The foot that must step goes; the step that is only due waits.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s = standing();
  planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  ASSERT_EQ(planter.phase(0), Phase::held);
  ASSERT_EQ(planter.phase(1), Phase::held);
  // The left foot's spot 0.5 m ahead (a due step); the right leg cannot reach its held ankle
  // (the body, and the motion's right foot with it, 0.3 m to the side).
  s[0].free_ankle_m.z() += 0.5;
  s[1].reached = false;
  s[1].hip_m.x() -= 0.3;
  s[1].free_ankle_m.x() -= 0.3;
  planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  EXPECT_EQ(planter.phase(1), Phase::stepping);
  EXPECT_EQ(planter.phase(0), Phase::held) << "both feet lifted in one update: a hop";
  // Stepping, the right foot is reached again; the left foot steps once it has landed, and at
  // no update are both feet stepping.
  s[1].reached = true;
  int both = 0, updates = 0;
  bool right_landed = false, left_stepped = false;
  for (; updates < 120 && !left_stepped; ++updates) {
    planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
    both += planter.phase(0) == Phase::stepping && planter.phase(1) == Phase::stepping;
    right_landed = right_landed || planter.phase(1) == Phase::held;
    if (planter.phase(0) == Phase::stepping) {
      left_stepped = true;
      EXPECT_TRUE(right_landed) << "the left foot stepped before the right one landed";
    }
  }
  EXPECT_TRUE(left_stepped) << "the due step never came";
  EXPECT_EQ(both, 0);
}

TEST(FootPlanter, TwoFeetThatMustBothStepStepTogether) {
  // Neither leg reaches its held ankle (the body was moved away): each foot steps at once,
  // whatever the other does (held there it would be dragged along the floor).
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s = standing();
  planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  s[0].reached = s[1].reached = false;
  for (FootSample& f : s) {
    f.hip_m.z() += 0.4;
    f.free_ankle_m.z() += 0.4;
  }
  planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
  EXPECT_EQ(planter.phase(0), Phase::stepping);
  EXPECT_EQ(planter.phase(1), Phase::stepping);
}


TEST(FootPlanter, AFootTheLegFallsShortOfStraightAboveIsHeldNotStepped) {
  // Kenji's HDM_bd_001 kick (the grid): the support foot lands from the hop with the pelvis
  // still high over it; the leg falls 1.3 cm short of the ankle held where the motion has its
  // foot. A step there lands where the foot stands after a swing through the air (9 cm up for
  // 2 cm, both feet off 0.3 s with the kicking foot still up): the foot is held until the body
  // comes down to it. A foot the motion has moved away (the body walked off) still steps.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s = standing();
  planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  ASSERT_EQ(planter.phase(1), Phase::held);
  s[1].hip_m.y() += 0.05;  // the pelvis high: the leg falls short straight above the foot
  s[1].reached = false;
  for (int i = 0; i < 10; ++i) {
    planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
    EXPECT_EQ(planter.phase(1), Phase::held) << "update " << i;
  }
  EXPECT_NEAR(locks.ankle_m[1].x(), -0.1, 1e-12);
  EXPECT_NEAR(locks.ankle_m[1].z(), 0.0, 1e-12);
  // The body, and the motion's foot with it, 0.3 m away: out of reach along the floor, it steps.
  s[1].hip_m.z() += 0.3;
  s[1].free_ankle_m.z() += 0.3;
  planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
  EXPECT_EQ(planter.phase(1), Phase::stepping);
}

}  // namespace

TEST(FootPlanter, AHoldTakenFromNothingSoftensItsLegOverAFewFrames) {
  // A foot taken from free (at the start, after a character switch) is held at once where it
  // stands (weight 1: eased in, the foot followed the motion along the floor), but the leg's
  // soft extension comes in over 0.1 s: with it at once a straight leg's knee jumped 5.7 cm in
  // one frame (viktor in the scripted bout with stance steps on).
  FootPlanter planter;
  FootLocks locks;
  const std::array<FootSample, 2> s = standing();
  planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  ASSERT_EQ(planter.phase(0), Phase::held);
  EXPECT_EQ(locks.weight[0], 1.0);
  EXPECT_GT(locks.softness[0], 0.0);
  EXPECT_LT(locks.softness[0], 0.25);
  double last = locks.softness[0];
  for (int k = 0; k < 10; ++k) {
    planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
    EXPECT_LE(locks.softness[0] - last, kDt / 0.1 + 1e-12);
    EXPECT_GE(locks.softness[0], last);
    last = locks.softness[0];
  }
  EXPECT_EQ(locks.softness[0], 1.0);
  planter.reset();
  planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  EXPECT_LT(locks.softness[1], 0.25);
}

TEST(FootPlanter, AHeldHeelRisesTowardAHigherFloorAtAFewMillimetresAFrame) {
  // A held foot's floor raised 1 cm at once (the heel lift read at a lunge's handover to rest,
  // the source's ankle itself still): it rose 1 cm in one frame at landing_speed_mps while the
  // hip came down, and the nearly straight knee moved 5.2 cm (the spar demo, planner seed 29 at
  // 47.6 s). It rises at 0.3 m/s now (5 mm a frame at 60 Hz), all the way.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s;
  both_feet_held(planter, s, locks);
  const double before = locks.ankle_m[0].y();
  s[0].source_lift_m = 0.010;
  double last = before;
  for (int k = 0; k < 10; ++k) {
    planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
    ASSERT_EQ(planter.phase(0), Phase::held);
    EXPECT_LE(locks.ankle_m[0].y() - last, 0.3 * kDt + 1e-9) << "update " << k;
    last = locks.ankle_m[0].y();
  }
  EXPECT_NEAR(locks.ankle_m[0].y(), before + 0.010, 1e-9) << "up to the floor in the end";
}

TEST(FootPlanter, AFootTheSourceLiftsMidStrideLeavesTheFloorBeforeItTravelsAndRisesAtAFootsPace) {
  // A strike that starts mid-step (135_06's lunge: its stepping foot already 20 cm up and
  // travelling 3.6 m/s) lifts a foot that stands on the floor. Heading for the landing along a
  // sine over its way, the foot rose 1.2 cm over its first 7 cm along the floor (a lunge's back
  // foot dragged at 2.7 m/s, judge-strikes.py); it now clears 2 cm by then, and never rises
  // faster than a foot's pace (1.2 m/s): a foot lifted again just after landing went 3.9 cm up
  // in one frame on a straight leg.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s = standing();
  s[0].source_lift_m = 0.012;  // the back foot's heel 1.2 cm up, as the rest stance has it
  for (int k = 0; k < 30; ++k) planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  ASSERT_EQ(planter.phase(0), Phase::held);
  const Vector3d start = locks.ankle_m[0];
  ASSERT_NEAR(start.y(), 0.092, 1e-9);
  FootSample& f = s[0];
  f.planted = false;
  f.has_landing = true;
  f.landing_ankle_m = Vector3d(0.1, 0.08, 1.1);  // 1.1 m ahead (a scaled lunge)
  f.swing_left_s = 0.5;
  const Vector3d step(0, -0.008, 0.045);  // the source's foot: 2.7 m/s forward, coming down from 20 cm
  double worst_rise = 0, height_after_7cm = -1;
  double last_y = locks.ankle_m[0].y();
  for (int k = 0; k < 20; ++k) {
    f.source_step_m = step;
    f.source_path_left_m = std::max(0.0, 1.1 - 0.045 * (k + 1));
    f.free_ankle_m += step;
    f.drawn_ankle_m = locks.ankle_m[0];
    f.swing_left_s = std::max(0.02, 0.5 - k * kDt);
    planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
    worst_rise = std::max(worst_rise, locks.ankle_m[0].y() - last_y);
    last_y = locks.ankle_m[0].y();
    const double gone = std::hypot(locks.ankle_m[0].x() - start.x(), locks.ankle_m[0].z() - start.z());
    if (height_after_7cm < 0 && gone >= 0.07) height_after_7cm = locks.ankle_m[0].y() - start.y();
  }
  std::printf("after 7 cm along the floor: %.4f m up; fastest rise %.4f m per update\n", height_after_7cm, worst_rise);
  ASSERT_EQ(planter.phase(0), Phase::swinging);
  EXPECT_GE(height_after_7cm, 0.02);
  EXPECT_LE(worst_rise, 1.2 * kDt + 1e-9);
}

TEST(FootPlanter, AStillFootLiftedWhereItsSourceIsAlreadyFastGathersSpeedAndStillLeavesTheFloor) {
  // A strike that starts mid-stride (viktor's lunge from its frame 11, stance steps on) lifts a
  // foot that stood still where the source's foot already moves at 5 m/s. It went at the
  // source's speed at once: 8 cm in its first frame, the knee 9 cm (a drawn snap). It now gathers
  // speed at a foot's acceleration (the source's own gain, or 100 m/s^2), and leaves the floor
  // as the source's foot does (held low while slow, it slid along the floor at 0.6 m/s).
  // SYNTHETIC samples: the source's foot at a constant 5 m/s toward a landing 0.9 m ahead.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s;
  ASSERT_NO_FATAL_FAILURE(both_feet_held(planter, s, locks));
  const Vector3d start = locks.ankle_m[0];
  FootSample& f = s[0];
  f.planted = false;
  f.has_landing = true;
  f.landing_ankle_m = Vector3d(0.1, 0.08, 0.9);
  const Vector3d step(0, 0.004, 5.0 * kDt);  // the source's foot: 5 m/s forward, rising
  double fastest = 0, worst_gain = 0, last_move = 0, height_after_3 = -1;
  Vector3d last = start;
  for (int k = 0; k < 12; ++k) {
    f.source_step_m = step;
    f.source_step_before_m = step;  // as fast one update before: no gain of its own
    f.source_path_left_m = std::max(0.0, 0.9 - step.z() * (k + 1));
    f.free_ankle_m += step;
    f.drawn_ankle_m = locks.ankle_m[0];
    f.swing_left_s = std::max(0.02, 0.18 - k * kDt);
    planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
    const Vector3d now = locks.ankle_m[0];
    const double move = std::hypot(now.x() - last.x(), now.z() - last.z());
    fastest = std::max(fastest, move);
    worst_gain = std::max(worst_gain, move - last_move);
    last_move = move;
    last = now;
    if (k == 2) height_after_3 = now.y() - start.y();
  }
  std::printf("largest gain %.4f m per update, fastest %.4f m; after 3 updates %.4f m up; ends at z %.3f\n", worst_gain,
              fastest, height_after_3, last.z());
  EXPECT_LE(worst_gain, 100 * kDt * kDt + 1e-9) << "it jumped to its source's speed";
  EXPECT_GT(fastest, 5.0 * kDt) << "it never came up to the source's speed";
  EXPECT_NEAR(last.z(), 0.9, 1e-6) << "it did not reach the landing";
  EXPECT_GE(height_after_3, 0.02) << "it slid along the floor";
}

TEST(FootPlanter, AStillFootLiftedWhereItsSourceRisesFastGathersSpeedInTheAirToo) {
  // The same start mid-stride with the source's foot also rising fast (aiko's 135_06 punch
  // from its frame 20 after a step-in, 2 Dec): the way along the floor kept to a foot's
  // acceleration, the rise followed the source's on top of it, 2 cm up and 2.8 cm along in the
  // first frame (the knee of a near-straight leg 5 cm: a drawn snap). Rise and way together now
  // gather speed at 100 m/s^2. SYNTHETIC samples: the source's foot at 5 m/s forward and
  // 1.2 m/s up toward a landing 0.9 m ahead.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s;
  ASSERT_NO_FATAL_FAILURE(both_feet_held(planter, s, locks));
  FootSample& f = s[0];
  f.planted = false;
  f.has_landing = true;
  f.landing_ankle_m = Vector3d(0.1, 0.08, 0.9);
  const Vector3d step(0, 1.2 * kDt, 5.0 * kDt);
  Vector3d last = locks.ankle_m[0];
  double last_move = 0, worst_gain = 0, fastest = 0;
  for (int k = 0; k < 10; ++k) {
    f.source_step_m = step;
    f.source_step_before_m = step;
    f.source_path_left_m = std::max(0.0, 0.9 - step.z() * (k + 1));
    f.free_ankle_m += step;
    f.drawn_ankle_m = locks.ankle_m[0];
    f.swing_left_s = std::max(0.02, 0.18 - k * kDt);
    planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
    const double move = (locks.ankle_m[0] - last).norm();  // 3-D: along the floor and up
    worst_gain = std::max(worst_gain, move - last_move);
    fastest = std::max(fastest, move);
    last_move = move;
    last = locks.ankle_m[0];
  }
  std::printf("largest 3-D gain %.4f m per update, fastest %.4f m\n", worst_gain, fastest);
  EXPECT_LE(worst_gain, 100 * kDt * kDt + 1e-9) << "it jumped toward its source's speed";
  EXPECT_GT(fastest, 5.0 * kDt) << "it never came up to the source's speed";
}

TEST(FootPlanter, AStepCutShortComesDownWhereItIs) {
  // A strike whose clip stands from its start on a foot that is in a procedural step (the last
  // strike's recovery stepping it back): the step ends where the foot is (land) and the foot
  // stands there, instead of going on to the step's target while the clip stands on it (a hop
  // where the mocap has a foot down). step_end says where a step would have put it down.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s = standing();
  planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  EXPECT_EQ(planter.step_end(0), nullptr) << "held: no step";
  planter.land(0);
  EXPECT_EQ(planter.phase(0), Phase::held) << "land() changes nothing for a foot not stepping";
  const Vector3d to(0.1, 0.08, -0.3);
  Vector3d mid_step;
  ASSERT_NO_FATAL_FAILURE(left_foot_mid_step(planter, s, locks, to, mid_step));
  ASSERT_NE(planter.step_end(0), nullptr);
  EXPECT_EQ(*planter.step_end(0), to);
  planter.land(0);
  EXPECT_EQ(planter.phase(0), Phase::landing);
  EXPECT_EQ(planter.step_end(0), nullptr);
  s[0].hip_m.z() = mid_step.z();  // the body over the foot (the leg reaches the floor there)
  for (int k = 0; k < 30; ++k) {
    s[0].drawn_ankle_m = locks.ankle_m[0];
    planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
    EXPECT_NEAR(locks.ankle_m[0].x(), mid_step.x(), 1e-12) << "update " << k;
    EXPECT_NEAR(locks.ankle_m[0].z(), mid_step.z(), 1e-12) << "update " << k << ": it went on toward the step's target";
  }
  EXPECT_EQ(planter.phase(0), Phase::held);
  EXPECT_NEAR(locks.ankle_m[0].y(), 0.08, 1e-9) << "down on the floor";
}

TEST(FootPlanter, AKickThatTakesAFootAlreadyInTheAirStartsItsSwingWhereTheFootIs) {
  // A kick ordered while a stance step had the foot in the air (viktor, stance steps on, 17.0 s):
  // the kick carried on the step's swing, whose lift-off spot lay 15 cm back, and the rule that
  // keeps a kicking foot "as high as it has gone along the floor" put it 16 cm up in one frame
  // (the knee 17 cm). The kick's swing now starts where the foot is. SYNTHETIC samples.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s;
  ASSERT_NO_FATAL_FAILURE(both_feet_held(planter, s, locks));
  FootSample& f = s[0];
  f.planted = false;  // the step lifts it: low along the floor, 3 m/s
  f.swing_left_s = 0.3;
  const Vector3d step(0, 0.002, 0.05);
  for (int k = 0; k < 4; ++k) {
    f.source_step_m = step;
    f.free_ankle_m += step;
    f.drawn_ankle_m = locks.ankle_m[0];
    planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
  }
  ASSERT_EQ(planter.phase(0), Phase::swinging);
  const Vector3d before = locks.ankle_m[0];
  ASSERT_LT(before.y(), 0.08 + 0.03) << "the step's foot should still be low";
  f.effector = true;  // the kick takes it
  f.source_step_m = Vector3d(0, 0.01, 0.03);
  f.free_ankle_m += f.source_step_m;
  f.drawn_ankle_m = locks.ankle_m[0];
  planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
  const double moved = (locks.ankle_m[0] - before).norm();
  std::printf("the kick's first update moved the foot %.4f m (%.4f m up)\n", moved, locks.ankle_m[0].y() - before.y());
  EXPECT_LT(moved, 0.05);
}

TEST(FootPlanter, AKickThatTakesAFootMidStepWhileItsSourceRisesFastGathersTheRiseAtAFootsPace) {
  // A kick taking its own foot mid-step, its clip starting where the source's ankle already
  // rises 5.3 cm per update (viktor's HDM_dg_017 kick from its frame 8 at 17.0 s of the scripted
  // bout, the support step redirected): "at least as high as the source has risen since it was
  // lifted" put the foot 5.4 cm up in one update, the knee 7 cm. The rise now gathers at a
  // foot's pace (kSwingAccel_mps2). SYNTHETIC samples: the composed ankle rises 0.4 cm per update.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s = standing();
  planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  // Three updates into a procedural step: the foot 3 cm up, still within landing_height_m of
  // the floor (the floor band the rule keeps a kicking foot rising out of).
  ASSERT_TRUE(planter.step_to(0, Vector3d(0.1, 0.08, 0.3)));
  for (int k = 0; k < 3; ++k) planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
  const Vector3d mid_step = locks.ankle_m[0];
  ASSERT_GT(mid_step.y(), 0.08 + 0.01);
  ASSERT_LT(mid_step.y(), 0.08 + 0.04);
  FootSample& f = s[0];
  f.planted = false;
  f.effector = true;
  f.swing_left_s = 0.4;
  f.free_ankle_m = Vector3d(mid_step.x(), 0.09, mid_step.z());
  double last_y = locks.ankle_m[0].y(), last_rise = 0, worst_gain = 0;
  for (int k = 0; k < 6; ++k) {
    f.source_step_m = Vector3d(0, 0.053, 0.01);
    f.source_step_before_m = f.source_step_m;
    f.free_ankle_m += Vector3d(0, 0.004, 0.01);
    f.drawn_ankle_m = locks.ankle_m[0];
    planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
    const double rise = locks.ankle_m[0].y() - last_y;
    worst_gain = std::max(worst_gain, rise - std::max(0.0, last_rise));
    last_rise = rise;
    last_y = locks.ankle_m[0].y();
  }
  std::printf("largest gain of the kicking foot's rise per update: %.4f m\n", worst_gain);
  EXPECT_LE(worst_gain, 100 * kDt * kDt + 1e-9);
}

TEST(FootPlanter, AKickRetrievedWhereItsSourceRisesFastLiftsAStandingFootAtAFootsPace) {
  // A kick retrieved from a clip frame where the source's ankle already rises 5.2 cm per update
  // (the spar demo with stance steps on, planner seed 1, frame 606: the kick took a foot
  // standing on the floor): "at least as high as the source has risen since it was lifted"
  // put the foot 5.2 cm up in its first update, the knee 5.1 cm (a drawn snap). A standing
  // foot whose source is caught rising faster than a foot from rest can now gathers the rise
  // (kSwingAccel_mps2), as a foot taken mid-step does. One whose source starts from rest keeps
  // the rule whole, even where the source's rise then gathers faster than that (a foot held
  // back there stays flat on the floor while it travels: the grid's kicks slid). SYNTHETIC
  // samples: the composed ankle rises 0.4 cm per update, the source's as listed.
  const std::array<double, 6> fast = {0.052, 0.052, 0.052, 0.052, 0.052, 0.052};
  const std::array<double, 6> from_rest = {0.0, 0.01, 0.045, 0.05, 0.05, 0.05};
  for (const auto* source : {&fast, &from_rest}) {
    FootPlanter planter;
    FootLocks locks;
    std::array<FootSample, 2> s;
    ASSERT_NO_FATAL_FAILURE(both_feet_held(planter, s, locks));
    FootSample& f = s[0];
    f.planted = false;  // the kick takes it: this update lifts it, the next ones move it
    f.effector = true;
    f.swing_left_s = 0.4;
    double last_y = locks.ankle_m[0].y(), last_rise = 0, worst_gain = 0, source_up = 0;
    std::array<double, 6> up{};
    for (std::size_t k = 0; k < source->size(); ++k) {
      f.source_step_before_m = f.source_step_m;
      f.source_step_m = Vector3d(0, (*source)[k], 0.005);
      f.free_ankle_m += Vector3d(0, 0.004, 0.005);
      f.drawn_ankle_m = locks.ankle_m[0];
      planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
      if (k > 0) source_up += (*source)[k];  // the source's rise since the foot was lifted
      const double rise = locks.ankle_m[0].y() - last_y;
      worst_gain = std::max(worst_gain, rise - std::max(0.0, last_rise));
      last_rise = rise;
      last_y = locks.ankle_m[0].y();
      up[k] = last_y - 0.08;
      if (source == &from_rest && source_up < 0.04) {  // in the floor band: the rule whole
        EXPECT_GE(up[k], source_up - 1e-9) << "update " << k << ": held back below its source's rise";
      }
    }
    std::printf("%s: up %.4f %.4f %.4f %.4f m, largest gain %.4f m per update\n", source == &fast ? "fast" : "from rest",
                up[1], up[2], up[3], up[4], worst_gain);
    if (source == &fast) {
      EXPECT_LE(worst_gain, 100 * kDt * kDt + 1e-9) << "it jumped toward its source's rise";
      EXPECT_GT(up[3], 0.04) << "still on the floor three updates on";
    }
  }
}

TEST(FootPlanter, ANewBodysFirstUpdatePutsItsFeetOnItsOwnFloor) {
  // A character switch mid-kick (bruno -> mei, 15.25 s): mei's feet were held where bruno's
  // stood, 1.6 cm below mei's own floor, and rose onto it at a landing's pace over the frames
  // after the switch: on mei's near-straight support leg the knee moved 5.1 cm in the first
  // frame (a drawn snap, twice in the shipped 120-order sweep). On the new body's first update
  // (hidden by the switch's easing) they go onto its floor at once. SYNTHETIC samples.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s = standing();
  for (auto& f : s) {  // the old body: its ankles stand 5 cm up
    f.standing_ankle_y_m = 0.05;
    f.free_ankle_m.y() = 0.05;
    f.drawn_ankle_m.y() = 0.05;
  }
  for (int k = 0; k < 30; ++k) planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  ASSERT_EQ(planter.phase(0), Phase::held);
  ASSERT_NEAR(locks.ankle_m[0].y(), 0.05, 1e-9);
  planter.keep_held_only();  // the new body, whose ankles stand 1.6 cm higher
  for (auto& f : s) {
    f.standing_ankle_y_m = 0.066;
    f.free_ankle_m.y() = 0.066;  // drawn: still the old body's
  }
  planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  EXPECT_NEAR(locks.ankle_m[0].y(), 0.066, 1e-9);
  EXPECT_NEAR(locks.ankle_m[1].y(), 0.066, 1e-9);
  // ...and after it, as before: a foot held below its floor rises at a landing's pace.
  for (auto& f : s) {
    f.standing_ankle_y_m = 0.09;
    f.free_ankle_m.y() = 0.09;
  }
  planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  EXPECT_LT(locks.ankle_m[0].y(), 0.09 - 1e-3);
}

TEST(FootPlanter, AFootSteppingAtACharacterSwitchGoesOnWithItsStep) {
  // A character switch while a foot is in a procedural step (bruno -> aiko at 6.0 s of the
  // scripted bout: bruno's left foot mid-step). Forgotten, a stepping foot went to the new
  // body's motion in one frame (5.5 cm, mei -> kenji); put down where it was (until session 37),
  // it stood 6.4 cm up and 0.45 m from where the new motion has it, held while the other foot
  // stepped (13 frames with both feet off the floor). Now the step goes on: the foot moves at a
  // step's pace, never lets go, and is held where the step puts it down. SYNTHETIC samples: the
  // new body's motion has that ankle 6 cm to the side.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s = standing();
  planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  const Vector3d to(0.1, 0.08, 0.3);
  Vector3d mid_step;
  ASSERT_NO_FATAL_FAILURE(left_foot_mid_step(planter, s, locks, to, mid_step));
  planter.keep_held_only();
  EXPECT_EQ(planter.phase(0), Phase::stepping) << "the step goes on";
  ASSERT_NE(planter.step_end(0), nullptr);
  EXPECT_EQ(*planter.step_end(0), to);
  s[0].free_ankle_m = Vector3d(0.16, 0.08, 0.3);  // the new body's motion: 6 cm to the side
  s[0].hip_m.z() = 0.3;  // the body over the step's end (the leg reaches the floor there)
  const StepWalk w = walk_left_foot(planter, s, locks, 30, false);
  std::printf("the step after the switch: fastest %.2f m/s\n", w.fastest_mps);
  EXPECT_EQ(w.least_weight, 1.0) << "the foot let go";
  EXPECT_LT(w.fastest_mps, 2.5) << "a step's pace (0.3 m in step_time_s), not a jump";
  EXPECT_EQ(planter.phase(0), Phase::held);
  EXPECT_NEAR((locks.ankle_m[0] - to).norm(), 0, 1e-9) << "down where the step puts it";
}

TEST(FootPlanter, ARedirectedStepGoesOnFromWhereTheFootIsToItsNewEnd) {
  // A strike whose clip stands from its start on a foot in a procedural step too far from where
  // the clip has it to carry the clip there (kenji at 11.58 s of the scripted bout: 0.48 m
  // against 0.30 + 0.10): the step is sent on to where the clip stands on the foot
  // (FootPlanter::redirect). The foot does not move for the redirect, goes on at no more than
  // about the peak speed asked for (the step slowed where its new way wants it), and is held at
  // the new end. SYNTHETIC samples.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s = standing();
  planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  EXPECT_FALSE(planter.redirect(0, Vector3d(0.1, 0.08, 0.5), 2.5)) << "a held foot has no step to send on";
  EXPECT_EQ(planter.phase(0), Phase::held);
  Vector3d mid_step;
  ASSERT_NO_FATAL_FAILURE(left_foot_mid_step(planter, s, locks, Vector3d(0.1, 0.08, 0.2), mid_step));
  const double left_before = planter.step_left_s(0);
  ASSERT_GT(left_before, 0);
  const Vector3d to(0.1, 0.08, 0.5);
  ASSERT_TRUE(planter.redirect(0, to, 2.5));
  EXPECT_EQ(*planter.step_end(0), to);
  EXPECT_GT(planter.step_left_s(0), left_before) << "the longer way takes longer";
  s[0].hip_m.z() = 0.45;
  const StepWalk w = walk_left_foot(planter, s, locks, 60, true);
  std::printf("redirected: first move %.4f m, fastest %.2f m/s\n", w.first_move_xz_m, w.fastest_xz_mps);
  EXPECT_LT(w.first_move_xz_m, 2.5 * kDt) << "it jumped toward its new end";
  EXPECT_LT(w.fastest_xz_mps, 2.5 * 1.1) << "faster than the peak asked for";
  EXPECT_EQ(planter.phase(0), Phase::held);
  EXPECT_NEAR((locks.ankle_m[0] - to).norm(), 0, 1e-9) << "held where it was sent";
}

TEST(FootPlanter, AStepRedirectedAtItsEndIsTakenAgainFromWhereTheFootIs) {
  // Its travel all but done (past kMostRedirectedShare), a step is taken again from where the
  // foot is: re-based instead, the way left would be crossed in the last frames. SYNTHETIC.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s = standing();
  planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  ASSERT_TRUE(planter.step_to(0, Vector3d(0.1, 0.08, 0.2)));
  for (int k = 0; k < 16; ++k) planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);  // 0.27 s of 0.30
  ASSERT_EQ(planter.phase(0), Phase::stepping);
  const Vector3d to(0.1, 0.08, 0.45);
  ASSERT_TRUE(planter.redirect(0, to, 2.5));
  EXPECT_GE(planter.step_left_s(0), 0.3 - 1e-9) << "a whole step again";
  s[0].hip_m.z() = 0.4;
  const StepWalk w = walk_left_foot(planter, s, locks, 60, true);
  std::printf("taken again: fastest %.2f m/s\n", w.fastest_mps);
  EXPECT_LT(w.fastest_mps, 2.5 * 1.1);
  EXPECT_EQ(planter.phase(0), Phase::held);
  EXPECT_NEAR((locks.ankle_m[0] - to).norm(), 0, 1e-9);
}

TEST(FootPlanter, ASwingHeadingForItsLandingGetsThereWhenTheSourcesPathIsShort) {
  // A foot lifted 12 cm from where the motion lands it, the source's own foot travelling 9 cm to
  // its landing (mei's lunge back foot, 135_06_punch_right_2:mirror from frame 0): handed to the
  // source's own step once the source's path was under min_swing_path_m (5 cm), the foot kept
  // the gap it had then and came down 7 cm short. It now heads for the landing to the end of
  // the source's path. SYNTHETIC samples.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s;
  ASSERT_NO_FATAL_FAILURE(both_feet_held(planter, s, locks));
  const Vector3d start = locks.ankle_m[0];
  FootSample& f = s[0];
  f.planted = false;
  f.has_landing = true;
  f.landing_ankle_m = start + Vector3d(0, 0, 0.12);
  const int updates = 9;
  const Vector3d step(0, 0, 0.01);  // the source's foot: 0.6 m/s, 9 cm in all
  for (int k = 0; k < updates; ++k) {
    f.source_step_m = step;
    f.source_step_before_m = k == 0 ? Vector3d::Zero() : step;
    f.source_path_left_m = 0.01 * (updates - 1 - k);
    f.free_ankle_m += step;
    f.swing_left_s = (updates - k) * kDt;
    f.drawn_ankle_m = locks.ankle_m[0];
    planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
    ASSERT_EQ(planter.phase(0), Phase::swinging) << "update " << k;
  }
  const double short_m = Eigen::Vector2d(f.landing_ankle_m.x() - locks.ankle_m[0].x(), f.landing_ankle_m.z() - locks.ankle_m[0].z()).norm();
  std::printf("when the source puts it down: %.4f m from its landing\n", short_m);
  EXPECT_LT(short_m, 0.01);
}

TEST(FootPlanter, AnOverStretchedLegStepsOnlyWhereTheStepEasesIt) {
  // After a stance step the back leg of the rest stance was held 0.3 % past its stretch, the
  // drawn hip lower than the motion's (the held feet drop the pelvis): its step to where the
  // motion has the foot left the leg as straight, and it stepped 1 mm again and again (the
  // walk-away test, 2 of its 6 procedural steps). A step that eases the stretch is still taken.
  // SYNTHETIC samples.
  for (const bool eases : {false, true}) {
    FootPlanter planter;
    FootLocks locks;
    std::array<FootSample, 2> s = standing();
    planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
    ASSERT_EQ(planter.phase(1), Phase::held);
    FootSample& f = s[1];
    f.hip_m = Vector3d(-0.1, 0.9, 0.15);  // the leg held at (0.15^2 + 0.82^2)^0.5 / 0.85 = 0.981
    // The motion's foot: 2 cm up where it is held (its leg 0.958), or 10 cm nearer the hip (0.966).
    f.free_ankle_m = eases ? Vector3d(-0.1, 0.08, 0.1) : Vector3d(-0.1, 0.10, 0.0);
    planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
    EXPECT_EQ(planter.phase(1), eases ? Phase::stepping : Phase::held) << (eases ? "eases" : "as straight");
  }
}

namespace {
/// A stance step's stepping foot on SYNTHETIC samples: lifted where it stands, the source's
/// foot travelling 1 m to its landing over 40 updates, still moving when it gets there (135_03's karate steps glide in along the floor). With `lead` (landing_lead)
/// its way left over the source's last 5 %, and the most it still moves along the floor then;
/// its fastest along the floor beside the source's.
struct GlideIn {
  double way_left_m = -1, moved_after_m = 0, fastest_xz_mps = 0, source_fastest_mps = 0;
};
GlideIn glide_in(double lead) {
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s = standing();
  for (int k = 0; k < 30; ++k) planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  const Vector3d start = locks.ankle_m[0];
  FootSample& f = s[0];
  f.planted = false;
  f.has_landing = true;
  f.landing_lead = lead;
  f.landing_ankle_m = start + Vector3d(0, 0, 1.0);
  constexpr int kUpdates = 40;
  // From standing, fastest 5/8 of the way through, still at 60 % of that speed at the end.
  const auto share = [](int k) { return (1 - std::cos(0.8 * std::numbers::pi * k / kUpdates)) / (1 - std::cos(0.8 * std::numbers::pi)); };
  GlideIn g;
  Vector3d last = start;
  for (int k = 0; k < kUpdates; ++k) {
    const Vector3d step(0, 0, share(k + 1) - share(k));
    f.source_step_before_m = f.source_step_m;
    f.source_step_m = step;
    f.source_path_left_m = 1.0 - share(k + 1);
    f.free_ankle_m += step;
    f.swing_left_s = (kUpdates - k) * kDt;
    f.drawn_ankle_m = locks.ankle_m[0];
    planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
    const Vector3d d = locks.ankle_m[0] - last;
    last = locks.ankle_m[0];
    g.fastest_xz_mps = std::max(g.fastest_xz_mps, std::hypot(d.x(), d.z()) / kDt);
    g.source_fastest_mps = std::max(g.source_fastest_mps, step.norm() / kDt);
    if (f.source_path_left_m <= 0.05) {
      if (g.way_left_m < 0) g.way_left_m = std::hypot(f.landing_ankle_m.x() - last.x(), f.landing_ankle_m.z() - last.z());
      else g.moved_after_m += std::hypot(d.x(), d.z());
    }
  }
  return g;
}
}  // namespace

TEST(FootPlanter, AStanceStepsSteppingFootIsOverItsLandingBeforeItsSourceGlidesIn) {
  // Followed to the end of the source's path, the foot came down over the last centimetres of
  // its way and slid onto its landing (the spar demo with stance steps on: 0.54 m/s along the
  // floor at 0.7 s, judge-bvh.py). With landing_lead 0.05 it is over its landing when the
  // source still has 5 % of its path to go and moves no more, at most 1.11x the source's pace.
  const GlideIn with = glide_in(0.05), without = glide_in(0);
  std::printf("lead 0.05: %.4f m left, %.4f m moved after, fastest %.3f m/s (source %.3f); lead 0: %.4f m left, %.4f m moved after\n",
              with.way_left_m, with.moved_after_m, with.fastest_xz_mps, with.source_fastest_mps, without.way_left_m,
              without.moved_after_m);
  EXPECT_LT(with.way_left_m, 0.002);
  EXPECT_LT(with.moved_after_m, 0.001);
  EXPECT_LE(with.fastest_xz_mps, 1.12 * with.source_fastest_mps);
  EXPECT_GT(without.moved_after_m, 0.02) << "the glide the lead takes out";
}

namespace {

/// One update of the left foot as a kick's effector: its source (and the composed ankle with
/// it) moved by `step`, the drawn ankle where the last update held it.
void left_kick_update(FootPlanter& planter, std::array<FootSample, 2>& s, FootLocks& locks, const Vector3d& step) {
  FootSample& f = s[0];
  f.source_step_before_m = f.source_step_m;
  f.source_step_m = step;
  f.free_ankle_m += step;
  f.drawn_ankle_m = locks.ankle_m[0];
  planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
}

/// The left foot kicked up from standing (standing(), held; `mid_step`: taken in the air by
/// the kick, eight updates into a procedural step) at `rise_m` per update for `updates`
/// updates, the composed ankle with it (the kick's source): the foot in the air, swinging.
void left_foot_kicked_up(FootPlanter& planter, std::array<FootSample, 2>& s, FootLocks& locks, double rise_m, int updates,
                         bool mid_step = false) {
  ASSERT_NO_FATAL_FAILURE(both_feet_held(planter, s, locks));
  FootSample& f = s[0];
  if (mid_step) {
    Vector3d in_the_air;
    ASSERT_NO_FATAL_FAILURE(left_foot_mid_step(planter, s, locks, Vector3d(0.1, 0.08, 0.3), in_the_air));
    f.free_ankle_m = in_the_air;
  }
  f.planted = false;
  f.effector = true;
  f.swing_left_s = 0.5;
  for (int k = 0; k < updates; ++k) left_kick_update(planter, s, locks, Vector3d(0, rise_m, 0.2 * rise_m));
  ASSERT_EQ(planter.phase(0), Phase::swinging);
}

}  // namespace

TEST(FootPlanter, AKickAbortedHighComesBackDownWithinHalfASecond) {
  // A kick aborted as its foot rose (the spar demo, planner seed 1, 38.5 s: the visitor's kick
  // began, the fighter's own front kick was cut at 1.05 m, its foot rising 4.8 m/s): the rest
  // motion has the foot down at once, and the foot returned at 2 m/s turning at 40 m/s^2 - on
  // up 0.29 m more, then 0.9 s floating down in a straight line. It now brakes and returns at
  // a kick's retraction pace: down within half a second, never a jump. SYNTHETIC samples.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s;
  ASSERT_NO_FATAL_FAILURE(left_foot_kicked_up(planter, s, locks, 0.08, 12));
  const Vector3d kicked_from = locks.ankle_m[0];  // the kick's last update (its step: the foot's speed)
  {
    FootSample& f = s[0];
    f.source_step_m = Vector3d(0, 0.08, 0.016);
    f.free_ankle_m += f.source_step_m;
    f.drawn_ankle_m = locks.ankle_m[0];
    planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
  }
  const double aborted_y = locks.ankle_m[0].y();
  ASSERT_GT(aborted_y, 0.08 + 0.9) << "the kick's foot should be high when it is aborted";
  FootSample& f = s[0];
  f.planted = true;  // the rest motion: the foot down where it stood
  f.effector = false;
  f.swing_left_s = 0;
  f.source_step_before_m = f.source_step_m = Vector3d::Zero();
  f.free_ankle_m = standing()[0].free_ankle_m;
  double highest = aborted_y, worst_gain = 0;
  Vector3d last = locks.ankle_m[0], last_step = last - kicked_from;
  int down_after = -1;
  for (int k = 0; k < 120 && down_after < 0; ++k) {
    f.drawn_ankle_m = locks.ankle_m[0];
    planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
    const Vector3d step = locks.ankle_m[0] - last;
    worst_gain = std::max(worst_gain, (step - last_step).norm());
    last_step = step;
    last = locks.ankle_m[0];
    highest = std::max(highest, locks.ankle_m[0].y());
    EXPECT_GE(locks.ankle_m[0].y(), 0.08 - 1e-9) << "under the floor at update " << k;
    if (planter.phase(0) == Phase::held) down_after = k + 1;
  }
  std::printf("aborted at %.3f m: on up %.3f m, held again after %d updates (%.3f s), largest change of step %.4f m\n",
              aborted_y, highest - aborted_y, down_after, down_after * kDt, worst_gain);
  ASSERT_GT(down_after, 0) << "the foot never came down";
  EXPECT_LE(down_after * kDt, 0.5);
  EXPECT_LE(highest - aborted_y, 0.15);
  EXPECT_LE(worst_gain, 0.03 + 1e-9) << "a step grows by at most 3 cm an update (kMostStepGain_m)";
}

TEST(FootPlanter, AKickingFootIsNeverTakenUnderTheFloor) {
  // A kick's retraction whose composed ankle passes under the floor (a pelvis adapted lower than
  // the clip's: HDM_bk_kickLFront1Reps_009 in the spar demo, planner seed 5, 6.7 cm under) took
  // the kicking foot 3 cm into the floor at 3.5 m/s (a kick that took its foot mid-step: the
  // floor band that keeps a foot lifted from the floor rising does not hold it). It stays on
  // the floor. SYNTHETIC samples.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s;
  ASSERT_NO_FATAL_FAILURE(left_foot_kicked_up(planter, s, locks, 0.03, 10, true));
  FootSample& f = s[0];
  double lowest = 1e9;
  for (int k = 0; k < 20; ++k) {  // down 4 cm an update to 10 cm under the standing ankle's height
    f.source_step_before_m = f.source_step_m;
    f.source_step_m = Vector3d(0, -0.04, -0.01);
    f.free_ankle_m += f.source_step_m;
    f.free_ankle_m.y() = std::max(f.free_ankle_m.y(), 0.08 - 0.10);
    f.drawn_ankle_m = locks.ankle_m[0];
    planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
    lowest = std::min(lowest, locks.ankle_m[0].y());
  }
  std::printf("the kicking foot's lowest: %.4f m (the floor's ankle height 0.08)\n", lowest);
  EXPECT_GE(lowest, 0.08 - 1e-9);
}

// A strike begun while the fighter steps in: its clip lifts the back foot for the lunge while
// the procedural step of the other foot is still in the air where the clip has that foot down.
// Lifted at once, both feet were off the floor where the mocap stands on one (mei stepping in
// at 18.55 s of the 120-order sweep's bout 7: 26 frames). The lifted foot stays on the floor
// until the other is down, kMostLiftWait_s (0.1 s) at most; then it swings to its landing with
// the way it lost, off the floor while it travels. SYNTHETIC: standing(), the left foot
// stepping 0.3 m ahead; from the step's fourth update the right foot's motion lunges 0.4 m
// forward in 0.3 s (constant speed, a 6 cm sine arc) to its landing.
TEST(FootPlanter, AFootTheMotionLiftsWhileTheOtherStepsWaitsForItToComeDown) {
  struct Walk {
    int both_up = 0, held_after_lift = 0, slid = 0;
    double fastest_mps = 0, least_toes_kept = 1;
    Vector3d end{0, 0, 0};
  };
  const auto run = [](double step_time_s, bool left_steps = true) {
    kumite::content::FootPlantingTunables tun;
    tun.step_time_s = step_time_s;
    FootPlanter planter(tun);
    FootLocks locks;
    std::array<FootSample, 2> s;
    both_feet_held(planter, s, locks);
    if (left_steps) {
      EXPECT_TRUE(planter.step_to(0, Vector3d(0.1, 0.08, 0.3)));
    }
    const Vector3d from = s[1].free_ankle_m, landing = from + Vector3d(0, 0, 0.4);
    constexpr int kLift = 3, kLunge = 18;  // updates: the lunge's start, its length
    Walk w;
    Vector3d last = locks.ankle_m[1];
    for (int k = 0; k < 45; ++k) {
      const int u = k - kLift + 1;  // the lunge's update (1..kLunge), <= 0 before it
      if (u >= 1) {
        const double p = std::min(1.0, static_cast<double>(u) / kLunge);
        const Vector3d next = from + (landing - from) * p + Vector3d(0, 0.06 * std::sin(std::numbers::pi * p), 0);
        s[1].source_step_before_m = s[1].source_step_m;
        s[1].source_step_m = next - s[1].free_ankle_m;
        s[1].free_ankle_m = next;
        s[1].planted = p >= 1;
        s[1].has_landing = p < 1;
        s[1].landing_ankle_m = landing;
        s[1].source_path_left_m = (landing - next).norm();
        s[1].swing_left_s = (kLunge - std::min(u, kLunge)) * kDt;
      }
      s[0].drawn_ankle_m = locks.ankle_m[0];
      s[1].drawn_ankle_m = locks.ankle_m[1];
      planter.update(kDt, s, false, Eigen::Vector2d::Zero(), locks);
      const bool right_up = planter.phase(1) != Phase::held;
      w.both_up += planter.phase(0) == Phase::stepping && right_up;
      // Held while it waits, its toes are kept out of the floor (the motion rolls it onto them).
      if (u >= 1 && !s[1].planted && planter.phase(1) == Phase::held) w.least_toes_kept = std::min(w.least_toes_kept, locks.toe_lowest_weight[1]);
      w.held_after_lift += u >= 1 && !s[1].planted && planter.phase(1) == Phase::held;
      const Vector3d d = locks.ankle_m[1] - last;
      w.fastest_mps = std::max(w.fastest_mps, d.norm() / kDt);
      // Along the floor faster than 0.5 m/s with the ankle within 5 mm of it: a slide.
      w.slid += std::hypot(d.x(), d.z()) / kDt > 0.5 && locks.ankle_m[1].y() < 0.08 + 0.005;
      last = locks.ankle_m[1];
    }
    w.end = locks.ankle_m[1];
    return w;
  };
  // Without the left foot's step the right one goes at once (it lands 3.5 cm short: a foot
  // from rest gathers speed at kSwingAccel_mps2, and moves at most 1.5 x its source's pace).
  Walk w = run(0.15, false);
  std::printf("no step: right held %d updates after its lift, fastest %.2f m/s, %.3f m from its landing\n", w.held_after_lift,
              w.fastest_mps, (w.end - Vector3d(-0.1, 0.08, 0.4)).norm());
  EXPECT_EQ(w.held_after_lift, 0);
  EXPECT_LT((w.end - Vector3d(-0.1, 0.08, 0.4)).norm(), 0.04);
  // A step of 0.15 s lands within the wait: the right foot leaves the floor only then, and
  // lands 2 cm shorter than without the wait.
  w = run(0.15);
  std::printf("step 0.15 s: both up %d updates, right held %d updates after its lift, slid %d, fastest %.2f m/s, %.3f m from its landing\n",
              w.both_up, w.held_after_lift, w.slid, w.fastest_mps, (w.end - Vector3d(-0.1, 0.08, 0.4)).norm());
  EXPECT_EQ(w.both_up, 0);
  EXPECT_GE(w.held_after_lift, 5);
  EXPECT_EQ(w.least_toes_kept, 1.0);
  EXPECT_EQ(w.slid, 0);
  EXPECT_LT(w.fastest_mps, 3.0);
  EXPECT_LT((w.end - Vector3d(-0.1, 0.08, 0.4)).norm(), 0.07);
  // A long step (0.5 s): the right foot waits 0.1 s at most, then goes (both up after that),
  // off the floor, not in a rush, and lands short by the way the wait and its catching up cost.
  w = run(0.5);
  std::printf("step 0.5 s: both up %d updates, right held %d updates after its lift, slid %d, fastest %.2f m/s, %.3f m from its landing\n",
              w.both_up, w.held_after_lift, w.slid, w.fastest_mps, (w.end - Vector3d(-0.1, 0.08, 0.4)).norm());
  EXPECT_LE(w.held_after_lift, 7);  // 0.1 s at 60 Hz and the update it is let go on
  EXPECT_GT(w.both_up, 0);
  EXPECT_EQ(w.slid, 0);
  EXPECT_LT(w.fastest_mps, 3.0);
  EXPECT_LT((w.end - Vector3d(-0.1, 0.08, 0.4)).norm(), 0.13);
}

// A held foot whose heel the motion raised and lowers again while the leg does not reach down
// to the floor flat (the pelvis up: a kick's support leg) waits on its toes: its lock stays up
// and FootLocks::toe_floor_weight asks for the toes on the floor, coming in no faster than over
// kOnToesEase_s (0.15 s), and going out as slowly once the foot is let down or lifted.
// SYNTHETIC: standing(), the left heel raised 6 cm by the motion, the left hip then raised so
// that the leg (0.85 m) reaches no lower than 5 cm over its floor, the heel lowered.
TEST(FootPlanter, AHeldFootWaitingAboveTheFloorStandsOnItsToes) {
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s;
  both_feet_held(planter, s, locks);
  for (int k = 0; k < 30; ++k) {
    s[0].source_lift_m = 0.06;
    planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
  }
  EXPECT_NEAR(locks.ankle_m[0].y(), 0.14, 1e-9) << "the heel is up with the motion's";
  EXPECT_EQ(locks.toe_floor_weight[0], 0.0) << "a raised heel is the motion's: its toes are down already";
  EXPECT_EQ(locks.toe_floor_y_m[0], 0.01);
  s[0].hip_m.y() = 0.13 + 0.85 * planter.tunables().max_leg_stretch;  // the leg reaches 5 cm over the floor at most
  double most_step = 0, last = locks.toe_floor_weight[0];
  int k = 0;
  for (; k < 60; ++k) {
    s[0].source_lift_m = 0;
    planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
    ASSERT_EQ(planter.phase(0), Phase::held);
    most_step = std::max(most_step, std::abs(locks.toe_floor_weight[0] - last));
    last = locks.toe_floor_weight[0];
  }
  EXPECT_GT(locks.ankle_m[0].y(), 0.08 + 0.04) << "it waits up, on its toes";
  EXPECT_EQ(locks.toe_floor_weight[0], 1.0);
  EXPECT_LE(most_step, kDt / 0.15 + 1e-12);
  EXPECT_EQ(locks.toe_floor_weight[1], 0.0) << "the other foot stands flat";
  // The hip comes down: the foot settles onto the floor and its toes are let go as slowly.
  s[0].hip_m.y() = 0.9;
  most_step = 0;
  for (k = 0; k < 60; ++k) {
    planter.update(kDt, s, true, Eigen::Vector2d::Zero(), locks);
    most_step = std::max(most_step, std::abs(locks.toe_floor_weight[0] - last));
    last = locks.toe_floor_weight[0];
  }
  EXPECT_NEAR(locks.ankle_m[0].y(), 0.08, 1e-9);
  EXPECT_EQ(locks.toe_floor_weight[0], 0.0);
  EXPECT_LE(most_step, kDt / 0.15 + 1e-12);
}

TEST(FootPlanter, AKickingFootComingBackDownFarFromWhereItLeftStaysDown) {
  // A kick's retraction brought the kicking foot down to the floor 0.4 m from where it left it,
  // still the kick's effector: the rule that lifts a kicking foot off the floor before it
  // travels ("at least as far up as it has gone along the floor") took it 41 cm up in one
  // update (the spar demo, planner seed 2, at 21.88 s: the knee 35 cm in a frame). It comes
  // down with its source. SYNTHETIC samples: the left foot lifted slowly from standing, carried
  // 0.6 m forward in the air, then brought straight down to the floor and kept there.
  FootPlanter planter;
  FootLocks locks;
  std::array<FootSample, 2> s;
  ASSERT_NO_FATAL_FAILURE(both_feet_held(planter, s, locks));
  FootSample& f = s[0];
  f.planted = false;
  f.effector = true;
  f.swing_left_s = 0.5;
  for (int k = 0; k < 10; ++k) left_kick_update(planter, s, locks, Vector3d(0, 0.012, 0.02));  // up 12 cm, 20 cm on
  for (int k = 0; k < 10; ++k) left_kick_update(planter, s, locks, Vector3d(0, 0, 0.04));      // 40 cm on in the air
  ASSERT_GT(locks.ankle_m[0].y(), 0.08 + 0.08) << "the kicking foot is in the air";
  double most_rise = 0;
  for (int k = 0; k < 14; ++k) {
    const double before = locks.ankle_m[0].y();
    left_kick_update(planter, s, locks, Vector3d(0, -std::min(0.02, f.free_ankle_m.y() - 0.08), 0));  // down to the floor, then still
    most_rise = std::max(most_rise, locks.ankle_m[0].y() - before);
  }
  std::printf("coming down: most rise in an update %.4f m; the ankle at the end %.4f m (standing 0.08)\n", most_rise,
              locks.ankle_m[0].y());
  EXPECT_LT(most_rise, 0.005);
  EXPECT_LT(locks.ankle_m[0].y(), 0.08 + 0.02);
}
