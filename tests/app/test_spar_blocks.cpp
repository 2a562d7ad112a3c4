// The sparring fighter against the mocap visitor of the shipped spar demo (config/demo-spar.toml:
// CMU 135_06's kata punches, head, gloves and shoes from a poses file), with blocks turned on:
// the gloves reach the fighter through the installation, it blocks some strikes (block events in
// the frames, the forearm side and the visitor's limb said), the console's planner line carries
// the score, and the same run twice gives the same events.
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "kumite/app/config.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/tracking_input.hpp"
#include "kumite/content/planner.hpp"

using namespace kumite::app;
namespace fs = std::filesystem;

namespace {

struct SparRun {
  std::vector<std::string> events;  // "frame kind limb side"
  int blocks = 0;
  std::string planner_line;
};

constexpr double kT0 = 5000.0;  ///< s, the simulated clock's start

/// config/demo-spar.toml on the demo data, `adjust`ed, on the simulated clock, started at kT0.
std::unique_ptr<Installation> spar_demo(const std::function<void(InstallationConfig&)>& adjust) {
  auto cfg = load_installation_config(fs::path(KUMITE_SOURCE_DIR) / "config" / "demo-spar.toml", fs::path(KUMITE_BINARY_DIR) / "demo");
  adjust(cfg);
  TrackingInputOptions o;
  o.simulated_clock = true;
  auto inst = std::make_unique<Installation>(cfg, make_tracking_input(cfg, o), InstallationOptions{});
  inst->start(kT0);
  return inst;
}

SparRun spar_with_blocks(bool block) {
  SparRun r;
  const auto run = spar_demo([block](InstallationConfig& cfg) {
    cfg.recognition.model.clear();  // the defence reads the gloves, not a recognised class
    cfg.fighter.planner->block = block;
    cfg.fighter.planner->attack_rate_per_s = 0;  // defence alone
    cfg.fighter.planner->counter_probability = 0;
  });
  Installation& inst = *run;
  for (int i = 0; i < 60 * 12; ++i) {
    inst.step(kT0 + i / 60.0);
    for (const FrameEvent& e : inst.frame().events) {
      if (e.type != EventType::block && e.type != EventType::blocked && e.type != EventType::visitor_hit) continue;
      r.events.push_back(std::to_string(i) + " " + std::string(kumite::content::to_string(e.type)) + " " +
                         std::string(kumite::recognition::to_string(e.fighter.limb)) + " " + std::to_string(e.fighter.side));
      if (e.type == EventType::block) ++r.blocks;
    }
  }
  r.planner_line = inst.console().planner;  // the console's (and a render node's) line
  EXPECT_EQ(r.planner_line, inst.planner_line());
  return r;
}

}  // namespace

TEST(SparBlocks, TheSparDemoWithBlocksOnBlocksTheMocapVisitorsStrikesAndSaysTheScore) {
  if (!fs::exists(fs::path(KUMITE_BINARY_DIR) / "demo" / "fighter.kdb")) GTEST_SKIP() << "no demo data (scripts/setup.sh makes it)";
  const SparRun on = spar_with_blocks(true);
  EXPECT_GE(on.blocks, 1) << "12 s of the kata's punches";
  EXPECT_NE(on.planner_line.find("score: visitor hits"), std::string::npos) << on.planner_line;
  EXPECT_NE(on.planner_line.find("blocks " + std::to_string(on.blocks) + " (met"), std::string::npos) << on.planner_line;
  EXPECT_EQ(spar_with_blocks(true).events, on.events) << "the same inputs, the same events";
  const SparRun off = spar_with_blocks(false);
  EXPECT_EQ(off.blocks, 0);
  EXPECT_NE(off.planner_line.find("(off)"), std::string::npos) << off.planner_line;
}

// The spar demo with stance steps on (`[fighter.planner] stance_step_min_m = 0.5`, the default), 60 s of
// the kata visitor, blocks, counters and hit reactions, judged on the drawn joints as
// scripts/judge-bvh.py judges a bout: no one-frame step of a joint over 5 cm that is 3x both its
// neighbours' (a snap). A guard over the whole bout, not a reproduction: the headless run's bout
// (kumite --simulated-time) found a parry's way back folding the arm shut (the elbow flipped 7 cm
// in a frame) and the fighter waiting out of reach; this in-process bout (another start time,
// so another bout) met neither, before or after those fixes (0 snaps; 198-254 of 3600 frames
// approaching, 412 since the fighting distance is kept from the drawn head).
TEST(SparBlocks, TheSparDemoWithStanceStepsDrawsNoSnapInAMinute) {
  if (!fs::exists(fs::path(KUMITE_BINARY_DIR) / "demo" / "fighter.kdb")) GTEST_SKIP() << "no demo data (scripts/setup.sh makes it)";
  const auto run = spar_demo([](InstallationConfig& cfg) { cfg.fighter.planner->stance_step_min_m = 0.5; });
  Installation& inst = *run;
  std::vector<std::vector<glm::dvec3>> joints;
  int approaching = 0;
  for (int i = 0; i < 60 * 60; ++i) {
    inst.step(kT0 + i / 60.0);
    joints.push_back(inst.frame().fighter.joints);
    const auto st = inst.planner_status();
    approaching += st && st->state == kumite::content::PlannerState::approaching;
  }
  int snaps = 0;
  for (std::size_t k = 2; k + 1 < joints.size(); ++k) {
    if (joints[k].size() != joints[k - 1].size() || joints[k].size() != joints[k + 1].size() || joints[k].size() != joints[k - 2].size()) continue;
    for (std::size_t j = 0; j < joints[k].size(); ++j) {
      const double before = glm::length(joints[k - 1][j] - joints[k - 2][j]), step = glm::length(joints[k][j] - joints[k - 1][j]),
                   after = glm::length(joints[k + 1][j] - joints[k][j]);
      if (step > 0.05 && step > 3 * before && step > 3 * after) {
        ++snaps;
        ADD_FAILURE() << "snap: joint " << j << " " << step * 100 << " cm at frame " << k;
      }
    }
  }
  std::printf("60 s sparring with stance steps: %d snaps, %d of 3600 frames approaching\n", snaps, approaching);
  EXPECT_GT(joints.back().size(), 0u) << "a fighter drawn";
}
