// The sparring planner on its own (planner.hpp): its decisions counted by the test from the
// orders it returns (not from its own counts), against the configured rates.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <tuple>
#include <vector>

#include "kumite/content/fighter.hpp"
#include "kumite/content/planner.hpp"
#include "kumite/content/tunables.hpp"

using namespace kumite;
using namespace kumite::content;

namespace {

PlannerTunables spar(double rate, double counter_p, double reaction_s) {
  PlannerTunables t;
  t.mode = PlannerMode::spar;
  t.attack_rate_per_s = rate;
  t.counter_probability = counter_p;
  t.reaction_time_s = reaction_s;
  return t;
}

/// The visitor at the fighting distance in front of a fighter at the origin.
PlannerInput engaged(double now, std::uint64_t seed = 7) {
  PlannerInput in;
  in.now = now;
  in.seed = seed;
  in.head_m = {0, 1.6, 0.75};
  in.fighter_root_m = {0, 0, 0};
  in.fighter_idle = true;
  return in;
}

bool effector_of_kind(OrderKind k) {
  return k == OrderKind::punch_left || k == OrderKind::punch_right || k == OrderKind::kick_left || k == OrderKind::kick_right;
}

struct Given {
  double t;
  OrderKind kind;
};

}  // namespace

TEST(Planner, InOrdersModeItDecidesNothing) {
  PlannerTunables t = spar(5, 1, 0.1);
  t.mode = PlannerMode::orders;
  SparPlanner p(t);
  VisitorStrikeSeen s;
  for (int k = 0; k < 6000; ++k) {
    PlannerInput in = engaged(k / 60.0);
    in.strikes = std::span<const VisitorStrikeSeen>(&s, 1);
    EXPECT_FALSE(p.step(in).has_value());
  }
  EXPECT_EQ(p.state(), PlannerState::off);
  EXPECT_FALSE(p.next().has_value());
}

TEST(Planner, FartherThanTheFightingDistanceItApproachesAndDoesNotAttack) {
  SparPlanner p(spar(5, 0, 0.1));
  for (int k = 0; k < 6000; ++k) {
    PlannerInput in = engaged(k / 60.0);
    in.head_m.z() = 2.0;  // 2 m away
    EXPECT_FALSE(p.step(in).has_value());
  }
  EXPECT_EQ(p.state(), PlannerState::approaching);
}

TEST(Planner, AttacksAtTheConfiguredRateWhileTheFighterCouldStrike) {
  for (const double rate : {1.0, 0.3}) {
    SparPlanner p(spar(rate, 0, 0.1));
    // The fighter is busy for 1 s after each attack (the timer stops meanwhile): the rate is
    // per second of time it could strike, counted here from the updates the test gave as idle.
    double idle_s = 0, busy_until = -1;
    int attacks = 0;
    const double dt = 1.0 / 60;
    for (int k = 0; k < 60 * 3000; ++k) {
      PlannerInput in = engaged(k * dt, 42);
      in.fighter_idle = in.now >= busy_until;
      if (in.fighter_idle && k > 0) idle_s += dt;
      if (const auto o = p.step(in)) {
        ASSERT_TRUE(in.fighter_idle);
        ++attacks;
        busy_until = in.now + 1.0;
      }
    }
    const double measured = attacks / idle_s;
    EXPECT_NEAR(measured, rate, 0.1 * rate) << attacks << " attacks in " << idle_s << " s idle";
  }
}

TEST(Planner, CountersAVisitorStrikeWithTheArmOnItsOpenSideAfterTheReactionDelay) {
  SparPlanner p(spar(0, 1.0, 0.1));
  const double dt = 1.0 / 240;
  std::vector<double> delays;
  int left = 0, right = 0;
  double strike_t = -1;
  recognition::Role limb = recognition::Role::right_hand;
  for (int k = 0; k < 240 * 1200; ++k) {
    PlannerInput in = engaged(k * dt, 3);
    VisitorStrikeSeen s;
    if (k % (240 * 3) == 0) {  // a strike every 3 s, alternating hands
      limb = (k / (240 * 3)) % 2 ? recognition::Role::left_hand : recognition::Role::right_hand;
      s.t = in.now;
      s.type = recognition::EventType::begin;
      s.limb = limb;
      in.strikes = std::span<const VisitorStrikeSeen>(&s, 1);
      strike_t = in.now;
    }
    if (const auto o = p.step(in)) {
      delays.push_back(in.now - strike_t);
      // The visitor's right hand leaves their right side open: on the fighter's left.
      if (limb == recognition::Role::right_hand) {
        EXPECT_EQ(o->kind, OrderKind::punch_left);
        ++left;
      } else {
        EXPECT_EQ(o->kind, OrderKind::punch_right);
        ++right;
      }
    }
  }
  ASSERT_EQ(static_cast<int>(delays.size()), 400);
  double sum = 0;
  for (const double d : delays) sum += d;
  EXPECT_NEAR(sum / delays.size(), 0.1, 0.01);
  EXPECT_EQ(left, 200);
  EXPECT_EQ(right, 200);
  // The counts kumite-motion spar reports: the delays ordered, and of them the drawn ones. The
  // fighter always idle here, each order comes on the update nearest its draw: at most half an
  // update off, and none late on average (on the first update at or after it, the mean came
  // half an update late).
  EXPECT_EQ(p.counts().counters, 400);
  EXPECT_NEAR(p.counts().reaction_sum_s, sum, 1e-9);
  EXPECT_NEAR(p.counts().reaction_drawn_sum_s, p.counts().reaction_sum_s, 400 * dt / 2 + 1e-9);
  EXPECT_LT(std::abs(p.counts().reaction_sum_s - p.counts().reaction_drawn_sum_s) / 400, dt / 8);
}

TEST(Planner, CountersWithTheConfiguredProbability) {
  SparPlanner p(spar(0, 0.3, 0.05));
  int strikes = 0, counters = 0;
  for (int k = 0; k < 60 * 3000; ++k) {
    PlannerInput in = engaged(k / 60.0, 11);
    VisitorStrikeSeen s;
    if (k % 120 == 0) {
      s.t = in.now;
      in.strikes = std::span<const VisitorStrikeSeen>(&s, 1);
      ++strikes;
    }
    counters += p.step(in).has_value();
  }
  EXPECT_NEAR(static_cast<double>(counters) / strikes, 0.3, 0.03) << counters << " of " << strikes;
}

TEST(Planner, TheSupervisorComesFirstAndTheSameSeedGivesTheSameDecisions) {
  const auto run = [](std::uint64_t seed, bool supervisor) {
    SparPlanner p(spar(1.0, 0.5, 0.2));
    std::vector<Given> given;
    for (int k = 0; k < 60 * 120; ++k) {
      PlannerInput in = engaged(k / 60.0, seed);
      in.supervisor_strike = supervisor;
      VisitorStrikeSeen s;
      if (k % 150 == 0) {
        s.t = in.now;
        in.strikes = std::span<const VisitorStrikeSeen>(&s, 1);
      }
      if (const auto o = p.step(in)) given.push_back({in.now, o->kind});
    }
    return given;
  };
  const auto a = run(5, false), b = run(5, false), c = run(6, false);
  ASSERT_GT(a.size(), 50u);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].t, b[i].t);
    EXPECT_EQ(a[i].kind, b[i].kind);
  }
  bool differ = a.size() != c.size();
  for (std::size_t i = 0; !differ && i < a.size(); ++i) differ = a[i].t != c[i].t || a[i].kind != c[i].kind;
  EXPECT_TRUE(differ) << "another seed gives other decisions";
  EXPECT_TRUE(run(5, true).empty()) << "a supervisor ordering strikes every update leaves the planner none";
}

TEST(Planner, PresetsAndRanges) {
  const auto aggressive = planner_preset("aggressive_unskilled");
  const auto defensive = planner_preset("defensive_skilled");
  ASSERT_TRUE(aggressive && defensive);
  EXPECT_EQ(aggressive->attack_rate_per_s, 1.0);
  EXPECT_EQ(aggressive->counter_probability, 0.0);
  EXPECT_EQ(defensive->attack_rate_per_s, 0.3);
  EXPECT_EQ(defensive->reaction_time_s, 0.1);
  EXPECT_GT(defensive->counter_probability, 0.5);
  EXPECT_FALSE(planner_preset("timid").has_value());
  EXPECT_EQ(validate(PlannerTunables{}), "");
  PlannerTunables t;
  t.attack_rate_per_s = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(validate(t).find("attack_rate_per_s"), std::string::npos);
  t = {};
  t.counter_probability = 1.5;
  EXPECT_NE(validate(t).find("counter_probability"), std::string::npos);
  t = {};
  t.fighting_distance_m = -1;
  EXPECT_NE(validate(t).find("fighting_distance_m"), std::string::npos);
}

TEST(Planner, ReadFromTheInstallationFileWithAPresetAndKeysBesideIt) {
  PlannerTunables p;
  std::uint64_t seed = 1;
  parse_planner_tunables("[fighter.planner]\nmode = \"spar\"\npreset = \"defensive_skilled\"\nreaction_time_s = 0.2\nseed = 9\n",
                         "room.toml", p, seed);
  EXPECT_EQ(p.mode, PlannerMode::spar);
  EXPECT_EQ(p.attack_rate_per_s, 0.3);  // the preset's
  EXPECT_EQ(p.reaction_time_s, 0.2);    // the key beside it
  EXPECT_EQ(seed, 9u);
  const auto error = [](const std::string& text) -> std::string {
    PlannerTunables q;
    std::uint64_t s = 1;
    try {
      parse_planner_tunables(text, "room.toml", q, s);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  const auto error_with_tolerance = [](const std::string& text, double follow_tolerance_m) -> std::string {
    PlannerTunables q;
    std::uint64_t s = 1;
    try {
      parse_planner_tunables(text, "room.toml", q, s, follow_tolerance_m);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(error("[fighter.planner]\nmode = \"fight\"\n").find("room.toml:2"), std::string::npos);
  EXPECT_NE(error("[fighter.planner]\nmode = \"fight\"\n").find("mode"), std::string::npos);
  EXPECT_NE(error("[fighter.planner]\npreset = \"timid\"\n").find("preset"), std::string::npos);
  EXPECT_NE(error("[fighter.planner]\n\ncounter_probability = 2\n").find("room.toml:3"), std::string::npos);
  EXPECT_NE(error("[fighter.planner]\nattack_rate_per_s = nan\n").find("attack_rate_per_s"), std::string::npos);
  EXPECT_NE(error("[fighter.planner]\nattack_rate = 1\n").find("attack_rate"), std::string::npos);
  EXPECT_NE(error("[fighter.planner]\nseed = -1\n").find("seed"), std::string::npos);
  // The sparring fighter's stance steps: on (0.5 m) unless said, checked like the rest.
  EXPECT_EQ(p.stance_step_min_m, 0.5);
  parse_planner_tunables("[fighter.planner]\nstance_step_min_m = 0\n", "room.toml", p, seed);
  EXPECT_EQ(p.stance_step_min_m, 0.0);
  // Not written, the default is not held against a larger follow_tolerance_m (the behaviour
  // raises it to that); written, it is.
  EXPECT_EQ(error_with_tolerance("[fighter.planner]\nmode = \"spar\"\n", 0.6), "");
  EXPECT_NE(error_with_tolerance("[fighter.planner]\nstance_step_min_m = 0.5\n", 0.6).find("follow_tolerance_m (0.6 m)"), std::string::npos);
  EXPECT_NE(error("[fighter.planner]\nstance_step_min_m = nan\n").find("room.toml:2: fighter.planner.stance_step_min_m"), std::string::npos)
      << error("[fighter.planner]\nstance_step_min_m = nan\n");
  EXPECT_NE(error("[fighter.planner]\nstance_step_min_m = 3\n").find("stance_step_min_m"), std::string::npos);
  // Over 0 and below [fighter.behaviour] follow_tolerance_m (0.25 m by default): refused as the
  // behaviour's own key is, not quietly raised.
  EXPECT_NE(error("[fighter.planner]\nstance_step_min_m = 0.1\n").find("room.toml:2: fighter.planner.stance_step_min_m"), std::string::npos)
      << error("[fighter.planner]\nstance_step_min_m = 0.1\n");
  EXPECT_NE(error("[fighter.planner]\nstance_step_min_m = 0.1\n").find("follow_tolerance_m (0.25 m)"), std::string::npos);
  PlannerTunables bad;
  bad.stance_step_min_m = -0.1;
  EXPECT_NE(validate(bad).find("stance_step_min_m"), std::string::npos);
  // The sparring fighter keeps to within 45 degrees of the way from the visitor to its home
  // unless said; 10..180 degrees.
  EXPECT_EQ(p.follow_arc_deg, 45.0);
  parse_planner_tunables("[fighter.planner]\nfollow_arc_deg = 180\n", "room.toml", p, seed);
  EXPECT_EQ(p.follow_arc_deg, 180.0);
  EXPECT_NE(error("[fighter.planner]\nfollow_arc_deg = nan\n").find("room.toml:2: fighter.planner.follow_arc_deg"), std::string::npos)
      << error("[fighter.planner]\nfollow_arc_deg = nan\n");
  EXPECT_NE(error("[fighter.planner]\nfollow_arc_deg = 5\n").find("follow_arc_deg"), std::string::npos);
  EXPECT_NE(error("[fighter.planner]\nfollow_arc_deg = 181\n").find("follow_arc_deg"), std::string::npos);
  PlannerTunables wide;
  wide.follow_arc_deg = 200;
  EXPECT_NE(validate(wide).find("follow_arc_deg"), std::string::npos);
}

TEST(Planner, TheSparAndOrdersOrdersSwitchTheModeAndTheFighterStrikesOnItsOwnOnlyWhileSparring) {
  const std::filesystem::path db = std::filesystem::path(KUMITE_BINARY_DIR) / "demo" / "fighter.kdb";
  if (!std::filesystem::exists(db)) GTEST_SKIP() << "no demo database (scripts/setup.sh makes it)";
  EXPECT_EQ(parse_order("spar")->kind, OrderKind::spar);
  EXPECT_EQ(parse_order("orders")->kind, OrderKind::orders_only);
  FighterConfig cfg;
  cfg.database = db;
  cfg.characters = {std::filesystem::path(KUMITE_SOURCE_DIR) / "content" / "characters" / "kenji.bvh"};
  cfg.character_names = {"kenji"};
  cfg.planner.attack_rate_per_s = 1.0;
  auto f = Fighter::create(cfg);
  FighterOutput out;
  int accepted_sparring = 0, accepted_after = 0;
  const double dt = 1.0 / 60;
  for (int k = 0; k < 60 * 30; ++k) {
    FighterInput in;
    in.now = 1 + k * dt;
    in.dt_s = k ? dt : 0;
    in.seed = 3;
    in.head_m = {0, 1.65, -1.6};  // the visitor 0.9 m in front of the fighter's home
    Order o{in.now, k == 60 ? OrderKind::spar : OrderKind::orders_only, -1};
    if (k == 60 || k == 60 * 15) in.orders = std::span<const Order>(&o, 1);
    f->step(in, out);
    if (k == 61) {
      EXPECT_EQ(f->planner_status().mode, PlannerMode::spar);
    }
    for (const auto& e : out.events) {
      if (e.kind != FighterEvent::Kind::order_accepted || !effector_of_kind(e.order.kind)) continue;
      if (k < 60 * 15) ++accepted_sparring;
      else if (k > 60 * 17) ++accepted_after;  // (one under way at the switch may still be taken)
    }
  }
  EXPECT_EQ(f->planner_status().mode, PlannerMode::orders);
  EXPECT_GE(accepted_sparring, 3) << "14 s of sparring at 1 attack/s of idle time";
  EXPECT_EQ(accepted_after, 0) << "orders only: it strikes only when ordered";
}

TEST(Planner, AbortsItsStrikeUnderWayWithTheConfiguredProbabilityWhenAVisitorStrikeBegins) {
  PlannerTunables t = spar(0, 0, 0.1);
  t.abort_probability = 0.3;
  SparPlanner p(t);
  const double dt = 1.0 / 60;
  int aborts = 0, begins = 0;
  for (int k = 0; k < 60 * 2000; ++k) {
    PlannerInput in = engaged(k * dt, 11);
    in.fighter_attacking = (k / 60) % 2 == 0;  // its own strike under way every other second
    VisitorStrikeSeen s;
    if (k % 30 == 0) {  // a visitor strike begins every 0.5 s
      s.t = in.now;
      s.type = recognition::EventType::begin;
      in.strikes = std::span<const VisitorStrikeSeen>(&s, 1);
      begins += in.fighter_attacking;
    }
    p.step(in);
    if (p.take_abort()) {
      ++aborts;
      EXPECT_TRUE(in.fighter_attacking) << "an abort drawn with no strike of its own under way, at " << in.now << " s";
      EXPECT_FALSE(p.take_abort()) << "taken once";
    }
  }
  EXPECT_EQ(p.counts().abort_draws, begins);
  EXPECT_EQ(p.counts().aborts, aborts);
  EXPECT_NEAR(static_cast<double>(aborts) / begins, 0.3, 0.03) << aborts << " of " << begins;
  t.abort_probability = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(validate(t).find("abort_probability"), std::string::npos);
  t.abort_probability = 1.5;
  EXPECT_NE(validate(t).find("abort_probability"), std::string::npos);
}

TEST(Planner, AFighterWhoseStrikeIsUnderWayWhenAVisitorStrikeBeginsAbortsItAtProbabilityOne) {
  const std::filesystem::path db = std::filesystem::path(KUMITE_BINARY_DIR) / "demo" / "fighter.kdb";
  if (!std::filesystem::exists(db)) GTEST_SKIP() << "no demo database (scripts/setup.sh makes it)";
  const auto run = [&](double abort_p) {
    FighterConfig cfg;
    cfg.database = db;
    cfg.characters = {std::filesystem::path(KUMITE_SOURCE_DIR) / "content" / "characters" / "kenji.bvh"};
    cfg.character_names = {"kenji"};
    cfg.planner = spar(0, 0, 0.1);
    cfg.planner.abort_probability = abort_p;
    auto f = Fighter::create(cfg);
    FighterOutput out;
    const double dt = 1.0 / 60;
    int contacts = 0, recovering_within = -1, sent = -1;
    for (int k = 0; k < 60 * 6; ++k) {
      FighterInput in;
      in.now = k * dt;
      in.dt_s = k ? dt : 0;
      in.seed = 5;
      in.head_m = {0, 1.65, -1.6};
      const Order punch{in.now, OrderKind::punch_right, -1};
      if (k == 120) in.orders = std::span<const Order>(&punch, 1);
      VisitorStrikeSeen s;
      if (sent < 0 && out.frame.action == FighterAction::striking) {  // its strike began last update
        s.t = in.now;
        s.type = recognition::EventType::begin;
        in.strikes = std::span<const VisitorStrikeSeen>(&s, 1);
        sent = k;
      }
      f->step(in, out);
      for (const auto& e : out.events)
        if (e.kind == FighterEvent::Kind::hit || e.kind == FighterEvent::Kind::miss || e.kind == FighterEvent::Kind::dodged) ++contacts;
      if (sent >= 0 && recovering_within < 0 && out.frame.action == FighterAction::recovering) recovering_within = k - sent;
    }
    return std::tuple{sent, contacts, recovering_within, f->planner_status().counts.aborts};
  };
  const auto [sent, contacts, recovering, aborts] = run(1.0);
  ASSERT_GE(sent, 0) << "the ordered punch never started";
  EXPECT_EQ(aborts, 1);
  EXPECT_EQ(contacts, 0) << "the aborted punch reached no contact";
  EXPECT_GE(recovering, 0);
  EXPECT_LE(recovering, 19) << "back to rest within the 0.3 s abort window";
  const auto [sent0, contacts0, recovering0, aborts0] = run(0.0);
  EXPECT_EQ(aborts0, 0);
  EXPECT_EQ(contacts0, 1) << "not aborted, the punch lands (hit, miss or dodged)";
}
