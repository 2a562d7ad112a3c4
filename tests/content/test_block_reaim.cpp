// A block clip (the guard down) re-aimed when the recognised strike it answers switches
// (Behaviour::reaim_block; issue 53, item 3: "a switch of the recognised action re-aims the
// defence from where the body is, without restarting it"). Judged on the drawn joints.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <vector>

#include "fighter_fixtures.hpp"
#include "kumite/content/behaviour.hpp"

using namespace kumite;
using namespace kumite::content;
using CJ = CanonicalJoint;
using Eigen::Vector3d;

namespace {

/// m: the shortest distance between segments p0-p1 and q0-q1 (sampled finely: a test's judge,
/// not the code's).
double segment_distance(const Vector3d& p0, const Vector3d& p1, const Vector3d& q0, const Vector3d& q1) {
  double best = 1e9;
  for (int i = 0; i <= 100; ++i)
    for (int j = 0; j <= 100; ++j) best = std::min(best, ((p0 + (p1 - p0) * (i / 100.0)) - (q0 + (q1 - q0) * (j / 100.0))).norm());
  return best;
}

struct BlockRun {
  int in_place = -1;               ///< update of the block event
  int side = -1;                   ///< the forearm's arm
  bool reaimed = false;            ///< reaim_block accepted the switch
  Vector3d elbow, wrist;           ///< m, room: the drawn forearm at in_place
  Vector3d switch_glove, head, chest;  ///< chest: the stomach aimed at after the switch
  double fastest_mps = 0;          ///< the fastest drawn joint from the block's start to 0.5 s after in_place
  int snaps = 0;                   ///< judge-bvh's one-frame jumps (> 5 cm and > 3x both neighbours)
  int blocks = 0;                  ///< block events
};

/// kenji at the room's origin, the guard down (orders mode: the Behaviour alone), the visitor's
/// head 0.9 m ahead. At 1 s a SYNTHETIC right fist 0.75 m before the drawn head comes at it at
/// 2 m/s and a block clip answers it; 4 updates later (`switch_to_chest`) the fist turns toward
/// the drawn stomach (halfway from the chest joint to the pelvis: a feint high, a punch low),
/// and the block is re-aimed there.
BlockRun block_then_switch(bool switch_to_chest) {
  const auto& set = kumite::content::testing::shipped_database();
  const Rig kenji = load_character_rig("kenji");
  FighterConfig cfg;
  cfg.home = Vector3d::Zero();
  cfg.min_x_m = cfg.min_z_m = -3;
  cfg.max_x_m = cfg.max_z_m = 3;
  Behaviour b(set.db, {kenji}, cfg);
  const double dt = 1.0 / 60;
  double t = 0;
  const Vector3d visitor(0, 1.7, 0.9);
  const auto joint = [&](CJ j) { return b.rig_positions()[static_cast<std::size_t>(kenji.skeleton.index(j))]; };
  for (int k = 0; k < 60; ++k) b.update(t += dt, dt, visitor);
  BlockRun r;
  r.head = joint(CJ::head);
  r.chest = 0.5 * (joint(CJ::chest) + joint(CJ::pelvis));  // the stomach
  const Vector3d start = r.head + Vector3d(0.05, -0.05, 0.75);
  const double speed = 2.0;
  BlockOrder o;
  o.limb = recognition::Role::right_hand;
  o.fist_m = start;
  o.velocity_mps = (r.head - start).normalized() * speed;
  o.arrival_s = (r.head - start).norm() / speed;
  o.recognised = true;
  EXPECT_TRUE(b.block(o, t)) << "no block clip for the punch";
  const int first = 60;
  std::vector<std::vector<Vector3d>> frames;
  for (int k = first; k < first + 90; ++k) {
    if (k == first + 4) {
      const Vector3d glove = start + o.velocity_mps * (4 * dt);
      r.switch_glove = glove;
      if (switch_to_chest) {
        BlockOrder s = o;
        s.fist_m = glove;
        s.velocity_mps = (r.chest - glove).normalized() * speed;
        s.arrival_s = (r.chest - glove).norm() / speed;
        BlockOrder other = s;
        other.limb = recognition::Role::left_hand;
        EXPECT_FALSE(b.reaim_block(other, t)) << "a switch of another limb re-aimed the block";
        r.reaimed = b.reaim_block(s, t);
      }
    }
    b.update(t += dt, dt, visitor);
    for (const FighterEvent& e : b.take_events()) {
      if (e.kind != FighterEvent::Kind::block) continue;
      ++r.blocks;
      if (r.in_place < 0) {
        r.in_place = k;
        r.side = e.side;
        r.elbow = joint(e.side == kLeft ? CJ::l_elbow : CJ::r_elbow);
        r.wrist = joint(e.side == kLeft ? CJ::l_wrist : CJ::r_wrist);
      }
    }
    frames.emplace_back(b.rig_positions().begin(), b.rig_positions().begin() + kenji.joint_count());
    if (r.in_place >= 0 && k > r.in_place + 30) break;
  }
  for (std::size_t f = 1; f < frames.size(); ++f)
    for (std::size_t j = 0; j < frames[f].size(); ++j) {
      const double step = (frames[f][j] - frames[f - 1][j]).norm();
      r.fastest_mps = std::max(r.fastest_mps, step / dt);
      if (f + 1 < frames.size() && f >= 2) {
        const double before = (frames[f - 1][j] - frames[f - 2][j]).norm(), after = (frames[f + 1][j] - frames[f][j]).norm();
        if (step > 0.05 && step > 3 * before && step > 3 * after) ++r.snaps;
      }
    }
  return r;
}

}  // namespace

TEST(BlockReaim, ASwitchOfTheStrikeAnsweredByABlockClipPutsTheForearmOnTheNewPathWithoutARestart) {
  const BlockRun kept = block_then_switch(false), switched = block_then_switch(true);
  ASSERT_GE(kept.in_place, 0) << "the block never came into place";
  ASSERT_GE(switched.in_place, 0) << "the re-aimed block never came into place";
  EXPECT_TRUE(switched.reaimed) << "reaim_block refused the switch";
  // The fist's ways after the switch: to the head (kept) and to the stomach (switched).
  const auto to_head = [&](const BlockRun& r) { return segment_distance(r.elbow, r.wrist, switched.switch_glove, switched.head); };
  const auto to_chest = [&](const BlockRun& r) { return segment_distance(r.elbow, r.wrist, switched.switch_glove, switched.chest); };
  std::printf("kept: in place at %d, forearm %.3f m from the way to the head, %.3f m from the way to the stomach; fastest %.2f m/s\n",
              kept.in_place, to_head(kept), to_chest(kept), kept.fastest_mps);
  std::printf("switched: in place at %d, forearm %.3f m from the way to the head, %.3f m from the way to the stomach; fastest %.2f m/s\n",
              switched.in_place, to_head(switched), to_chest(switched), switched.fastest_mps);
  // Across the new way: within a fist's and a forearm's radius (0.1 m) of it.
  EXPECT_LE(to_chest(switched), 0.1) << "the re-aimed forearm is not across the fist's way to the stomach";
  EXPECT_GT(to_chest(kept), 0.1) << "without the switch the forearm lay across the stomach's way anyway: the test shows nothing";
  // No restart: the same clip comes into place at the same update, one block event, and no
  // drawn joint jumps (judge-bvh's snap) or goes faster than the block played as it was.
  EXPECT_LE(std::abs(switched.in_place - kept.in_place), 1);
  EXPECT_EQ(switched.blocks, 1);
  EXPECT_EQ(switched.snaps, 0);
  EXPECT_LE(switched.fastest_mps, std::max(6.0, kept.fastest_mps * 1.25));
}
