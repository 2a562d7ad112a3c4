// The fighter's tunables in the installation file ([fighter.behaviour], [fighter.behaviour.feet],
// [fighter.retrieval]): every key read with its unit and range, errors naming file, line and
// key, the printed defaults reading back to the same values, and a changed value changing
// what the fighter does (measured on the drawn joints).
#include <gtest/gtest.h>

#include "fighter_fixtures.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/behaviour.hpp"
#include "kumite/content/tunables.hpp"

using namespace kumite;
using namespace kumite::content;
using Eigen::Vector3d;

namespace {

std::string error_of(const std::string& text) {
  BehaviourTunables b;
  RetrievalTunables r;
  try {
    parse_fighter_tunables(text, "room.toml", b, r);
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST(Tunables, PrintedDefaultsAndChangedValuesReadBackTheSame) {
  BehaviourTunables b;
  RetrievalTunables r;
  parse_fighter_tunables(format_fighter_tunables(b, r), "printed.toml", b, r);
  EXPECT_EQ(b, BehaviourTunables{});
  EXPECT_EQ(r, RetrievalTunables{});
  // Every key changed to a value inside its range (a third of the way) reads back exactly.
  BehaviourTunables b2;
  RetrievalTunables r2;
  for (const TunableKey& k : fighter_tunable_keys()) {
    const double v = k.min + (k.max - k.min) / 3;
    (k.behaviour ? b2.*k.behaviour : k.feet ? b2.feet.*k.feet : r2.*k.retrieval) = v;
  }
  b2.arrive_tolerance_m = 0.01;  // keep the relations between keys true
  b2.stance_step_min_m = 1.0;
  b2.feet.landing_speed_mps = 0.5;
  BehaviourTunables b3;
  RetrievalTunables r3;
  parse_fighter_tunables(format_fighter_tunables(b2, r2), "printed.toml", b3, r3);
  EXPECT_EQ(b3, b2);
  EXPECT_EQ(r3, r2);
  // The other tables of an installation file are not this reader's business.
  BehaviourTunables b4;
  RetrievalTunables r4;
  parse_fighter_tunables("[walls]\nx = 1\n[fighter]\nhome_m = [0, 0, -2]\n[fighter.behaviour]\nwalk_speed_mps = 0.4\n",
                         "room.toml", b4, r4);
  EXPECT_EQ(b4.walk_speed_mps, 0.4);
  EXPECT_EQ(b4.turn_speed_rad_s, BehaviourTunables{}.turn_speed_rad_s);
}

TEST(Tunables, BadValuesNameFileLineAndKey) {
  EXPECT_EQ(error_of("[fighter.behaviour]\nwalk_speed_mps = nan\n"),
            "room.toml:2: fighter.behaviour.walk_speed_mps: must be a finite number");
  EXPECT_EQ(error_of("[fighter.behaviour]\n\nrelease_time_s = 0.05\n"),
            "room.toml:3: fighter.behaviour.release_time_s: must be in [0.15, 2] s, found 0.05");
  EXPECT_EQ(error_of("[fighter.behaviour.feet]\nswing_lift_m = inf\n"),
            "room.toml:2: fighter.behaviour.feet.swing_lift_m: must be a finite number");
  EXPECT_EQ(error_of("[fighter.retrieval]\npose_weight = \"high\"\n"),
            "room.toml:2: fighter.retrieval.pose_weight: must be a number");
  const std::string unknown = error_of("[fighter.behaviour]\nwalk_speed = 0.5\n");
  EXPECT_EQ(unknown.rfind("room.toml:2: fighter.behaviour.walk_speed: unknown key (allowed here: feet, follow_tolerance_m", 0), 0u)
      << unknown;
  EXPECT_EQ(error_of("[fighter.behaviour]\nfollow_tolerance_m = 0.1\narrive_tolerance_m = 0.2\n"),
            "room.toml:3: fighter.behaviour.arrive_tolerance_m: must be less than follow_tolerance_m (it would start "
            "following and never arrive)");
  EXPECT_EQ(error_of("[fighter.behaviour]\nmin_travel_scale = 0.9\n[fighter]\n"), "no error");  // a TOML error is the parser's
}

TEST(Tunables, ValuesMadeInCodeAreCheckedToo) {
  FighterConfig c;
  c.behaviour.feet.max_leg_stretch = 1.2;
  try {
    Behaviour b(kumite::content::testing::synthetic_database().db, kumite::content::testing::synthetic_characters(), c);
    FAIL() << "a leg stretched past its length was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "fighter.behaviour.feet.max_leg_stretch: must be in [0.5, 1], found 1.2");
  }
}

// The key changes what a visitor sees: with walk_speed_mps halved, the fighter's pelvis (as
// drawn) crosses the room at about half the speed while following.
TEST(Tunables, WalkSpeedChangesHowFastTheFighterFollows) {
  const auto follow_speed = [](double walk_speed_mps) {
    FighterConfig c;
    c.home = Vector3d(0, 0, 0);
    c.min_x_m = c.min_z_m = -3;
    c.max_x_m = c.max_z_m = 3;
    c.behaviour.walk_speed_mps = walk_speed_mps;
    Behaviour b(kumite::content::testing::synthetic_database().db, kumite::content::testing::synthetic_characters(), c);
    const double dt = 1.0 / 120;
    double t = 0;
    Vector3d head(0, 1.7, 0.9);
    for (int i = 0; i < 30; ++i) b.update(t += dt, dt, head);
    head = Vector3d(1.5, 1.7, 0.9);  // the visitor steps 1.5 m aside
    const int pelvis = b.character(0).skeleton.index(CanonicalJoint::pelvis);
    double fastest = 0;
    Vector3d before = b.joint_positions()[static_cast<std::size_t>(pelvis)];
    // Mean pelvis speed over 0.5 s windows while following; the fastest window.
    for (int w = 0; w < 6; ++w) {
      for (int i = 0; i < 60; ++i) b.update(t += dt, dt, head);
      const Vector3d now = b.joint_positions()[static_cast<std::size_t>(pelvis)];
      fastest = std::max(fastest, std::hypot(now.x() - before.x(), now.z() - before.z()) / 0.5);
      before = now;
    }
    return fastest;
  };
  const double normal = follow_speed(0.7), slow = follow_speed(0.35);
  RecordProperty("pelvis_mps", std::to_string(normal) + " " + std::to_string(slow));
  EXPECT_GT(normal, 0.5);
  EXPECT_LT(normal, 0.9);
  EXPECT_GT(slow, 0.25);
  EXPECT_LT(slow, 0.45);
}
