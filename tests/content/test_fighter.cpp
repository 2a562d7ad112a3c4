// The Fighter facade end to end: files on disk (SYNTHETIC database and characters written as
// BVH), the retrieval worker thread, orders and events, frames ready to draw.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <thread>

#include "fighter_fixtures.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/bvh.hpp"
#include "kumite/content/fighter.hpp"

using namespace kumite;
using namespace kumite::content;

namespace {
struct TempDir {
  std::filesystem::path path = std::filesystem::temp_directory_path() / ("kumite_fighter_" + std::to_string(::getpid()));
  TempDir() { std::filesystem::create_directories(path); }
  ~TempDir() { std::filesystem::remove_all(path); }
};

std::filesystem::path write_character(const std::filesystem::path& dir, const std::string& name, const Skeleton& s) {
  Clip c;
  c.name = name;
  c.skeleton = s;
  c.unit_m = 0.01;
  c.frame_count = 1;
  c.root_positions = {Eigen::Vector3d(0, 0.95, 0)};
  c.local_rotations.assign(static_cast<std::size_t>(s.joint_count()), Eigen::Quaterniond::Identity());
  const auto path = dir / (name + ".bvh");
  write_bvh(path, c);
  return path;
}
}  // namespace

TEST(Fighter, StrikesOnOrderThroughTheWorkerAndSwitchesCharacters) {
  TempDir tmp;
  FighterConfig cfg;
  cfg.database = tmp.path / "fighter.kdb";
  save_database(*kumite::content::testing::synthetic_database().db, cfg.database);
  cfg.characters = {write_character(tmp.path, "small", synthetic::make_skeleton({.scale = 0.86})),
                    write_character(tmp.path, "tall", synthetic::make_skeleton({.scale = 1.14, .arm = 1.1}))};
  cfg.character_names = {"Small", "Tall"};
  auto fighter = Fighter::create(cfg);
  ASSERT_EQ(fighter->character_count(), 2);
  EXPECT_EQ(fighter->character_name(1), "Tall");

  const Eigen::Vector3d head(0, 1.6, cfg.home.z() + cfg.strike_distance_m);
  double t = 0;
  std::vector<FighterEvent> events;
  auto step = [&] {
    t += 1.0 / 60;
    fighter->update(t, 1.0 / 60, head);
    for (auto& e : fighter->take_events()) events.push_back(e);
  };
  for (int i = 0; i < 10; ++i) step();
  fighter->order(Order{t, OrderKind::punch_right});
  bool striking = false, hit_or_miss = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (std::chrono::steady_clock::now() < deadline && !hit_or_miss) {
    step();
    const FighterFrame f = fighter->frame();
    ASSERT_EQ(f.joints.size(), f.parents.size());
    ASSERT_EQ(f.joint_radii_m.size(), f.parents.size());
    striking |= f.state == FighterState::striking;
    if (striking && f.state == FighterState::striking) {
      ASSERT_TRUE(f.target.has_value());
      fighter->order(Order{t, OrderKind::kick_left});  // ignored mid-strike
      fighter->order(Order{t, OrderKind::select_character, 1});
    }
    for (const auto& e : events) hit_or_miss |= e.kind == FighterEvent::Kind::hit || e.kind == FighterEvent::Kind::miss;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  EXPECT_TRUE(striking);
  EXPECT_TRUE(hit_or_miss);
  EXPECT_EQ(fighter->frame().character, 1);
  auto count = [&](FighterEvent::Kind k) { return std::count_if(events.begin(), events.end(), [&](auto& e) { return e.kind == k; }); };
  EXPECT_GE(count(FighterEvent::Kind::order_ignored), 1);
  EXPECT_EQ(count(FighterEvent::Kind::character_changed), 1);
  EXPECT_EQ(count(FighterEvent::Kind::hit), 1);  // head at strike distance is within reach
}

TEST(Fighter, MissingDatabaseOrCharacterIsAnErrorNamingTheFile) {
  FighterConfig cfg;
  cfg.database = "/nonexistent/fighter.kdb";
  try {
    Fighter::create(cfg);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/fighter.kdb"), std::string::npos);
  }
  TempDir tmp;
  cfg.database = tmp.path / "fighter.kdb";
  save_database(*kumite::content::testing::synthetic_database().db, cfg.database);
  cfg.characters = {tmp.path / "nobody.bvh"};
  try {
    Fighter::create(cfg);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("nobody"), std::string::npos);
  }
}
