// The fighter's action states (content/README.md, "Action states"), each reached by driving a
// fighter from FighterInputs alone (the shipped characters and the demo database), and every
// change of state seen in its frames checked against the table as the README writes it (a copy
// here, not the code's own table).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "kumite/content/fighter.hpp"

namespace fs = std::filesystem;
using namespace kumite;
using namespace kumite::content;
using A = FighterAction;
using L = FighterLocomotion;
using Eigen::Vector3d;

namespace {

std::optional<FighterConfig> open_room(const std::vector<std::string>& characters) {
  const fs::path db = fs::path(KUMITE_BINARY_DIR) / "demo" / "fighter.kdb";
  if (!fs::exists(db)) return std::nullopt;
  FighterConfig c;
  c.database = db;
  for (const auto& name : characters) {
    c.characters.push_back(fs::path(KUMITE_SOURCE_DIR) / "content" / "characters" / (name + ".bvh"));
    c.character_names.push_back(name);
  }
  // At the room's origin, with room to step in or back around it.
  c.home = Vector3d::Zero();
  c.min_x_m = c.min_z_m = -3;
  c.max_x_m = c.max_z_m = 3;
  return c;
}

/// The action changes one frame to the next may show: the README's table, and the two changes
/// that happen within one update (an order taken again goes retaking -> idle -> awaiting_plan;
/// a plan that comes back at once: awaiting_plan -> its outcome).
bool allowed(A from, A to) {
  static const std::set<std::pair<A, A>> table = {
      {A::idle, A::awaiting_plan},
      {A::awaiting_plan, A::idle},         {A::awaiting_plan, A::stepping_in}, {A::awaiting_plan, A::stepping_back},
      {A::awaiting_plan, A::restance},     {A::awaiting_plan, A::support_step}, {A::awaiting_plan, A::retaking},
      {A::awaiting_plan, A::striking},
      {A::stepping_in, A::retaking},       {A::stepping_back, A::retaking},    {A::restance, A::retaking},
      {A::support_step, A::retaking},
      {A::retaking, A::idle},              {A::retaking, A::awaiting_plan},
      {A::striking, A::recovering},
      {A::recovering, A::idle},
  };
  return from == to || table.count({from, to}) > 0;
}

struct Driven {
  std::vector<A> actions;           ///< each change, in order (the first frame's first)
  std::vector<L> locomotions;       ///< each change, in order
  std::vector<std::string> bad;     ///< changes the table does not allow
  std::vector<FighterEvent> events;
  FighterFrame last;
  bool contact = false;             ///< a hit, dodged or miss event came
};

/// Steps a fighter at 120 Hz: `head(k)` is the visitor's head at update k, `order(k)` the order
/// given at update k (none: kind select_character with character -1 is skipped).
template <class Head, class OrderAt>
Driven drive(Fighter& f, int updates, Head head, OrderAt order) {
  Driven d;
  FighterOutput out;
  for (int k = 0; k < updates; ++k) {
    FighterInput in;
    in.now = k / 120.0;
    in.dt_s = k == 0 ? 0.0 : 1 / 120.0;
    in.head_m = head(k);
    std::optional<Order> o = order(k);
    if (o) {
      o->time = in.now;
      in.orders = std::span<const Order>(&*o, 1);
    }
    f.step(in, out);
    const A a = out.frame.action;
    const L l = out.frame.locomotion;
    if (d.actions.empty() || d.actions.back() != a) {
      if (!d.actions.empty() && !allowed(d.actions.back(), a))
        d.bad.push_back(fmt::format("{} -> {} at update {}", to_string(d.actions.back()), to_string(a), k));
      d.actions.push_back(a);
    }
    if (d.locomotions.empty() || d.locomotions.back() != l) d.locomotions.push_back(l);
    // The frame's state is the action's and the locomotion's (README table).
    const FighterState want = a == A::striking     ? FighterState::striking
                              : a == A::recovering ? FighterState::recovering
                              : l == L::at_spot    ? FighterState::resting
                                                   : FighterState::following;
    if (out.frame.state != want)
      d.bad.push_back(fmt::format("state {} with {} / {} at update {}", to_string(out.frame.state), to_string(a), to_string(l), k));
    if ((a == A::striking || a == A::recovering) && l != L::at_spot)
      d.bad.push_back(fmt::format("locomotion {} while {} at update {}", to_string(l), to_string(a), k));
    for (const auto& e : out.events) {
      d.events.push_back(e);
      d.contact |= e.kind == FighterEvent::Kind::hit || e.kind == FighterEvent::Kind::dodged || e.kind == FighterEvent::Kind::miss;
    }
    d.last = out.frame;
  }
  return d;
}

/// `want` appears in `seen` in order (not necessarily next to each other).
template <class T>
bool in_order(const std::vector<T>& seen, const std::vector<T>& want) {
  auto it = seen.begin();
  for (const T& w : want) {
    it = std::find(it, seen.end(), w);
    if (it == seen.end()) return false;
    ++it;
  }
  return true;
}

template <class T>
std::string names(const std::vector<T>& v) {
  std::string s;
  for (const T& x : v) s += std::string(s.empty() ? "" : " ") + std::string(to_string(x));
  return s;
}

std::optional<Order> none(int) { return std::nullopt; }

}  // namespace

#define NEED_DEMO(cfg) \
  if (!(cfg)) GTEST_SKIP() << "no demo database (scripts/setup.sh makes it)"

TEST(ActionStates, IdleAtItsSpotThenWalkingToAVisitorWhoMovedThenAtItsSpotAgain) {
  const auto cfg = open_room({"kenji"});
  NEED_DEMO(cfg);
  auto f = Fighter::create(*cfg);
  // The visitor at the strike distance, then 1 m farther after 1 s.
  const Driven d = drive(*f, 720, [&](int k) { return Vector3d(0, 1.6, cfg->strike_distance_m + (k < 120 ? 0.0 : 1.0)); }, none);
  EXPECT_EQ(d.actions, std::vector<A>{A::idle}) << names(d.actions);
  EXPECT_TRUE(in_order(d.locomotions, {L::at_spot, L::walking, L::at_spot})) << names(d.locomotions);
  EXPECT_EQ(std::count(d.locomotions.begin(), d.locomotions.end(), L::stance_step), 0) << "stance steps are off";
  EXPECT_TRUE(d.bad.empty()) << d.bad.front();
}

TEST(ActionStates, AStanceStepFromTheMocapCarriesTheFollowing) {
  auto cfg = open_room({"kenji"});
  NEED_DEMO(cfg);
  cfg->behaviour.stance_step_min_m = 0.5;
  auto f = Fighter::create(*cfg);
  // The visitor walks 1 m away in 1 s and stands.
  const double z0 = cfg->strike_distance_m;
  const Driven d = drive(*f, 720, [&](int k) { return Vector3d(0, 1.6, z0 + std::clamp((k - 120) / 120.0, 0.0, 1.0)); }, none);
  EXPECT_EQ(d.actions, std::vector<A>{A::idle}) << names(d.actions);
  EXPECT_TRUE(in_order(d.locomotions, {L::at_spot, L::stance_step, L::at_spot})) << names(d.locomotions);
  EXPECT_TRUE(d.bad.empty()) << d.bad.front();
}

TEST(ActionStates, AStrikeOrderAwaitsItsPlanStrikesRecoversAndIsIdleAgain) {
  const auto cfg = open_room({"kenji"});
  NEED_DEMO(cfg);
  auto f = Fighter::create(*cfg);
  const Vector3d head(0, 1.6, cfg->strike_distance_m);
  const Driven d = drive(*f, 480, [&](int) { return head; },
                         [](int k) { return k == 60 ? std::optional<Order>(Order{0, OrderKind::punch_right}) : std::nullopt; });
  EXPECT_EQ(d.actions, (std::vector<A>{A::idle, A::awaiting_plan, A::striking, A::recovering, A::idle})) << names(d.actions);
  EXPECT_TRUE(d.contact);
  EXPECT_TRUE(d.bad.empty()) << d.bad.front();
}

TEST(ActionStates, AStrikeBeyondItsReachStepsInThenTakesTheOrderAgain) {
  const auto cfg = open_room({"kenji"});
  NEED_DEMO(cfg);
  auto f = Fighter::create(*cfg);
  // The visitor stands farther than the lunge reaches (the grid's first left punch target), the
  // order given before the fighter has followed.
  const Vector3d head(0.0374, 1.5834, 0.7125);
  const Driven d = drive(*f, 900, [&](int) { return head; },
                         [](int k) { return k == 30 ? std::optional<Order>(Order{0, OrderKind::punch_left}) : std::nullopt; });
  EXPECT_TRUE(in_order(d.actions, {A::idle, A::awaiting_plan, A::stepping_in, A::retaking, A::awaiting_plan, A::striking,
                                   A::recovering, A::idle}))
      << names(d.actions);
  EXPECT_TRUE(d.contact);
  EXPECT_TRUE(d.bad.empty()) << d.bad.front();
}

TEST(ActionStates, AStrikeAtATargetTooNearStepsBackFirst) {
  const auto cfg = open_room({"kenji"});
  NEED_DEMO(cfg);
  auto f = Fighter::create(*cfg);
  const Vector3d head(0.0, 1.30, 0.30);  // inside the fighter's reach: the arm would land folded
  const Driven d = drive(*f, 900, [&](int) { return head; },
                         [](int k) { return k == 0 ? std::optional<Order>(Order{0, OrderKind::punch_right}) : std::nullopt; });
  EXPECT_TRUE(in_order(d.actions, {A::awaiting_plan, A::stepping_back, A::retaking, A::awaiting_plan, A::striking}))
      << names(d.actions);
  EXPECT_TRUE(d.contact);
  EXPECT_TRUE(d.bad.empty()) << d.bad.front();
}

TEST(ActionStates, APunchAfterAStanceStepTakesTheFightingStanceOnTheWay) {
  // After a stance step to the area's front edge (its take's long stance), a punch at a visitor
  // 0.95 m ahead takes the rest stance the strikes are made for on the way, for some of the
  // characters and arms (the others strike from the long stance).
  int restanced = 0, tried = 0;
  std::string bad;
  for (const char* name : {"aiko", "bruno", "kenji", "mei", "viktor"}) {
    for (const OrderKind kind : {OrderKind::punch_right, OrderKind::punch_left}) {
      auto cfg = open_room({name});
      NEED_DEMO(cfg);
      cfg->behaviour.stance_step_min_m = 0.5;
      cfg->max_z_m = 0.55;  // the stance step ends at the area's front edge
      auto f = Fighter::create(*cfg);
      const double z0 = cfg->strike_distance_m;
      // The visitor walks 0.8 m away in 1 s and stands; at 4 s stands 0.95 m ahead of the
      // fighter's pelvis, and the punch is ordered.
      double root_z = 0;
      int order_at = -1;
      const auto head = [&](int k) {
        if (k < 480) return Vector3d(0, 1.6, z0 + 0.8 * std::clamp((k - 60) / 120.0, 0.0, 1.0));
        return Vector3d(0, 1.6, root_z + 0.95);
      };
      const Driven walk = drive(*f, 480, head, none);
      root_z = walk.last.root.z();
      if (walk.last.action != A::idle || walk.last.locomotion != L::at_spot ||
          std::count(walk.locomotions.begin(), walk.locomotions.end(), L::stance_step) == 0)
        continue;
      ++tried;
      order_at = 0;
      const Driven d = drive(*f, 600, [&](int) { return head(480); },
                             [&](int k) { return k == order_at ? std::optional<Order>(Order{0, kind}) : std::nullopt; });
      if (!d.bad.empty()) bad += d.bad.front() + "; ";
      if (in_order(d.actions, {A::awaiting_plan, A::restance, A::retaking, A::awaiting_plan, A::striking})) ++restanced;
    }
  }
  EXPECT_GE(tried, 5) << "too few stance steps to test anything";
  EXPECT_GE(restanced, 1) << "no punch took the fighting stance on the way (of " << tried << ")";
  EXPECT_TRUE(bad.empty()) << bad;
}

TEST(ActionStates, AKickWhoseSupportFootStandsElsewhereStepsItFirst) {
  // A kick ordered after a punch (the feet left where the punch put them) at a visitor off to
  // the side: the clip stands on its support foot out of where that foot is held, which steps
  // there first (the scripted bout's kicks at 7, 15 and 17 s).
  int seen = 0, tried = 0;
  std::string bad, first;
  for (const char* name : {"aiko", "bruno", "kenji", "mei", "viktor"}) {
    for (const OrderKind kind : {OrderKind::kick_left, OrderKind::kick_right}) {
      for (const double x : {-0.6, 0.0, 0.6}) {
        const auto cfg = open_room({name});
        NEED_DEMO(cfg);
        auto f = Fighter::create(*cfg);
        ++tried;
        const Driven d = drive(
            *f, 900, [&](int k) { return k < 240 ? Vector3d(-x, 1.7, 0.9) : Vector3d(x, 1.6, 0.8); },
            [&](int k) {
              if (k == 0) return std::optional<Order>(Order{0, OrderKind::punch_right});
              if (k == 300) return std::optional<Order>(Order{0, kind});
              return std::optional<Order>();
            });
        if (!d.bad.empty()) bad += d.bad.front() + "; ";
        if (in_order(d.actions, {A::awaiting_plan, A::support_step, A::retaking, A::awaiting_plan, A::striking})) {
          ++seen;
          if (first.empty()) first = fmt::format("{} {} at x {}: {}", name, to_string(kind), x, names(d.actions));
        }
      }
    }
  }
  std::printf("support steps: %d of %d kicks (%s)\n", seen, tried, first.c_str());
  EXPECT_GE(seen, 1) << "no kick stepped its support foot first";
  EXPECT_TRUE(bad.empty()) << bad;
}
