// The fighter driven from plain data alone (FighterInput -> FighterOutput), without the app:
// the input a sparring planner, a replay or a render node hands it.
#include <gtest/gtest.h>

#include <filesystem>

#include "kumite/content/fighter.hpp"

namespace fs = std::filesystem;
using namespace kumite;
using namespace kumite::content;

namespace {

/// The shipped characters and the demo database (made at set-up); nullopt when absent.
std::optional<FighterConfig> demo_fighter() {
  const fs::path db = fs::path(KUMITE_BINARY_DIR) / "demo" / "fighter.kdb";
  if (!fs::exists(db)) return std::nullopt;
  FighterConfig c;
  c.database = db;
  for (const char* name : {"kenji", "mei"}) {
    c.characters.push_back(fs::path(KUMITE_SOURCE_DIR) / "content" / "characters" / (std::string(name) + ".bvh"));
    c.character_names.emplace_back(name);
  }
  c.home = Eigen::Vector3d(0, 0, -2.5);
  c.max_z_m = 0.6;  // as the demo: it may step into the room
  return c;
}

/// Runs `updates` updates at 60 Hz with a punch ordered at update `at`; the root's path and
/// the events' kinds, for comparison.
struct Bout {
  std::vector<Eigen::Vector3d> roots;
  std::vector<FighterEvent::Kind> kinds;
};
Bout run(const FighterConfig& cfg, int updates, int at, bool with_visitor) {
  auto fighter = Fighter::create(cfg);
  FighterOutput out;
  Bout r;
  const Order punch{0, OrderKind::punch_right, -1};
  std::vector<VisitorBody> bodies(1);
  std::vector<VisitorStrikeSeen> strikes(1);
  for (int k = 0; k < updates; ++k) {
    FighterInput in;
    in.now = k / 60.0;
    in.dt_s = k == 0 ? 0.0 : 1 / 60.0;
    in.head_m = {0, 1.6, 0};
    Order o = punch;
    o.time = in.now;
    if (k == at) in.orders = std::span<const Order>(&o, 1);
    if (with_visitor) {
      bodies[0].position_m = in.head_m;
      bodies[0].tracked = true;
      bodies[0].t = in.now;
      in.bodies = bodies;
      strikes[0].t = in.now;
      strikes[0].impact_m = {0, 1.5, -0.6};
      in.strikes = strikes;
    }
    fighter->step(in, out);
    r.roots.push_back(out.frame.root);
    for (const auto& e : out.events) r.kinds.push_back(e.kind);
  }
  return r;
}

}  // namespace

TEST(FighterInput, AFighterDrivenFromPlainDataStrikesAndRepeatsItself) {
  const auto cfg = demo_fighter();
  if (!cfg) GTEST_SKIP() << "no demo database (scripts/setup.sh makes it)";
  const Bout a = run(*cfg, 120, 10, false);
  // The order was taken and the strike came to an outcome at the visitor's head.
  ASSERT_FALSE(a.kinds.empty());
  EXPECT_EQ(a.kinds.front(), FighterEvent::Kind::order_accepted);
  bool outcome = false;
  for (const auto k : a.kinds)
    outcome |= k == FighterEvent::Kind::hit || k == FighterEvent::Kind::dodged || k == FighterEvent::Kind::miss;
  EXPECT_TRUE(outcome);
  // The same inputs give the same frames; the visitor's bodies and strikes, carried in the input,
  // change nothing today (no decision reads them yet).
  const Bout b = run(*cfg, 120, 10, false);
  const Bout c = run(*cfg, 120, 10, true);
  ASSERT_EQ(a.roots.size(), b.roots.size());
  for (std::size_t i = 0; i < a.roots.size(); ++i) {
    EXPECT_EQ(a.roots[i], b.roots[i]) << i;
    EXPECT_EQ(a.roots[i], c.roots[i]) << i;
  }
  EXPECT_EQ(a.kinds, b.kinds);
  EXPECT_EQ(a.kinds, c.kinds);
}
