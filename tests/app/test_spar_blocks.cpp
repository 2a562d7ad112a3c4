// The sparring fighter against the mocap visitor of the shipped spar demo (config/demo-spar.toml:
// CMU 135_06's kata punches, head, gloves and shoes from a poses file), with blocks turned on:
// the gloves reach the fighter through the installation, it blocks some strikes (block events in
// the frames, the forearm side and the visitor's limb said), the console's planner line carries
// the score, and the same run twice gives the same events.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "kumite/app/config.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/tracking_input.hpp"

using namespace kumite::app;
namespace fs = std::filesystem;

namespace {

struct SparRun {
  std::vector<std::string> events;  // "frame kind limb side"
  int blocks = 0;
  std::string planner_line;
};

SparRun spar_with_blocks(bool block) {
  SparRun r;
  const fs::path data = fs::path(KUMITE_BINARY_DIR) / "demo";
  auto cfg = load_installation_config(fs::path(KUMITE_SOURCE_DIR) / "config" / "demo-spar.toml", data);
  cfg.recognition.model.clear();  // the defence reads the gloves, not a recognised class
  cfg.fighter.planner.block = block;
  cfg.fighter.planner.attack_rate_per_s = 0;  // defence alone
  cfg.fighter.planner.counter_probability = 0;
  TrackingInputOptions o;
  o.simulated_clock = true;
  Installation inst(cfg, make_tracking_input(cfg, o), {});
  const double t0 = 5000.0;
  inst.start(t0);
  for (int i = 0; i < 60 * 12; ++i) {
    inst.step(t0 + i / 60.0);
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
