// Visitor safety: the tracked head near a wall (or beyond it, or lost near it) is a fact of the
// frame (FrameData::visitor_near_wall), an event when it starts and ends, a console problem,
// and a glow drawn on that wall. Heads placed by a scripted tracker; the walls' distances
// follow from the room's geometry (3 m x 3 m, walls at x = -1.5 and z = -1.5).
#include <gtest/gtest.h>

#include <algorithm>

#include "kumite/app/config.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/scene.hpp"
#include "kumite/common/error.hpp"

using namespace kumite::app;

namespace {

const char* kRoom = R"(
[[walls]]
name = "front"
lower_left = [-1.5, 0.0, -1.5]
lower_right = [1.5, 0.0, -1.5]
upper_left = [-1.5, 2.4, -1.5]
[[walls]]
name = "left"
lower_left = [-1.5, 0.0, 1.5]
lower_right = [-1.5, 0.0, -1.5]
upper_left = [-1.5, 2.4, 1.5]
[[walls]]
name = "floor"
lower_left = [-1.5, 0.0, 1.5]
lower_right = [1.5, 0.0, 1.5]
upper_left = [-1.5, 0.0, -1.5]
[fighter]
database = "/nonexistent/fighter.kdb"
[tracking]
source = "recording"
calibration = "c.yaml"
tracking = "t.toml"
recording = "rec"
)";

/// The head where the test puts it (nullopt: not tracked), measured 5 ms before each poll.
class PlacedHead final : public TrackingInput {
 public:
  std::optional<glm::dvec3> at;
  kumite::Timestamp t = 0;
  void poll(kumite::Timestamp now, kumite::Timestamp, TrackingSnapshot& out) override {
    t = now;
    TrackingSnapshot& s = out;
    s = {};
    s.state = at ? TrackerState::tracked : TrackerState::lost;
    if (at) {
      kumite::BodyPose p;
      p.timestamp = now - 0.005;
      p.status = kumite::TrackingStatus::tracked;
      p.position = {at->x, at->y, at->z};
      p.markers = 4;
      s.head = p;
      s.measured_at = now - 0.005;
      s.measured_ready_at = now - 0.004;
    }
  }
  kumite::Timestamp clock() const override { return t; }
  std::string describe() const override { return "placed"; }
};

struct Room {
  explicit Room(const std::string& extra = "") {
    auto tracking = std::make_unique<PlacedHead>();
    head = tracking.get();
    inst = std::make_unique<Installation>(parse_installation_config(std::string(kRoom) + "[safety]\n" + extra, "room.toml"),
                                          std::move(tracking), InstallationOptions{});
    inst->start(100);
  }
  const FrameData& step(std::optional<glm::dvec3> at) {
    head->at = at;
    t += 1 / 60.0;
    return inst->step(t);
  }
  PlacedHead* head = nullptr;
  std::unique_ptr<Installation> inst;
  double t = 100;
};

int count(const FrameData& f, EventType type) {
  return static_cast<int>(std::count_if(f.events.begin(), f.events.end(), [&](const auto& e) { return e.type == type; }));
}

bool has_problem(const ConsoleState& c, std::string_view what) {
  return std::any_of(c.problems.begin(), c.problems.end(), [&](const auto& p) { return p.find(what) != std::string::npos; });
}

}  // namespace

TEST(Safety, NearAWallIsAFactAnEventOnceAProblemAndAGlowOnThatWall) {
  Room room;
  auto f = room.step(glm::dvec3(0, 1.6, 0));  // the middle: 1.5 m from every wall
  EXPECT_FALSE(f.visitor_near_wall);
  EXPECT_TRUE(f.items.empty());  // no fighter here: nothing drawn
  f = room.step(glm::dvec3(0.2, 1.6, -1.15));  // 0.35 m from the front wall (the default limit: 0.4 m)
  ASSERT_TRUE(f.visitor_near_wall);
  EXPECT_EQ(f.visitor_near_wall->wall, 0);
  EXPECT_NEAR(f.visitor_near_wall->distance_m, 0.35, 1e-9);
  EXPECT_FALSE(f.visitor_near_wall->outside);
  EXPECT_EQ(count(f, EventType::visitor_near_wall), 1);
  EXPECT_TRUE(has_problem(room.inst->console(), "visitor: 0.35 m from wall front"));
  // The glow: bars 1 cm in front of the front wall (z = -1.49), round the head's x.
  ASSERT_FALSE(f.items.empty());
  for (const auto& item : f.items) {
    EXPECT_NEAR(item.model[3].z, -1.49f, 1e-4f);
    EXPECT_NEAR(item.model[3].x, 0.2f, 0.81f);
    EXPECT_EQ(item.colour, glow_colour(0.25));  // the faintest: 1 - 0.35 / 0.4 is below it
  }
  f = room.step(glm::dvec3(0.2, 1.6, -1.2));  // 0.30 m, still near: no new event
  EXPECT_EQ(count(f, EventType::visitor_near_wall), 0);
  EXPECT_TRUE(f.visitor_near_wall);
  f = room.step(glm::dvec3(0.2, 1.6, -1.05));  // 0.45 m: inside the 0.1 m hysteresis, still near
  EXPECT_TRUE(f.visitor_near_wall);
  f = room.step(glm::dvec3(0.2, 1.6, -0.9));  // 0.6 m: clear
  EXPECT_FALSE(f.visitor_near_wall);
  EXPECT_EQ(count(f, EventType::visitor_clear), 1);
  EXPECT_TRUE(f.items.empty());
  EXPECT_FALSE(has_problem(room.inst->console(), "visitor"));
}

TEST(Safety, TheNearestWallIsNamedTheFloorIsNoWallBeyondAndLostAreSaid) {
  Room room;
  auto f = room.step(glm::dvec3(-1.3, 0.2, 0.5));  // 0.2 m from the left wall, head 0.2 m over the floor
  ASSERT_TRUE(f.visitor_near_wall);
  EXPECT_EQ(f.visitor_near_wall->wall, 1);
  EXPECT_NEAR(f.visitor_near_wall->distance_m, 0.2, 1e-9);
  // Lost there: the visitor left the tracked area near the left wall (said once, glow stays).
  f = room.step(std::nullopt);
  ASSERT_TRUE(f.visitor_near_wall);
  EXPECT_TRUE(f.visitor_near_wall->lost);
  EXPECT_EQ(count(f, EventType::visitor_near_wall), 1);
  bool said = false;
  for (const auto& e : f.events)
    said |= room.inst->event_text(e).find("left the tracked area near wall left") != std::string::npos;
  EXPECT_TRUE(said);
  EXPECT_FALSE(f.items.empty());
  f = room.step(std::nullopt);
  EXPECT_EQ(count(f, EventType::visitor_near_wall), 0);
  // Tracked again, beyond the front wall: out of the room.
  f = room.step(glm::dvec3(0, 1.6, -1.6));
  ASSERT_TRUE(f.visitor_near_wall);
  EXPECT_EQ(f.visitor_near_wall->wall, 0);
  EXPECT_TRUE(f.visitor_near_wall->outside);
  EXPECT_NEAR(f.visitor_near_wall->distance_m, -0.1, 1e-9);
  EXPECT_EQ(count(f, EventType::visitor_near_wall), 1);
  // Lost in the middle of the room (never near a wall): nothing to say.
  Room middle;
  middle.step(glm::dvec3(0, 1.6, 0));
  f = middle.step(std::nullopt);
  EXPECT_FALSE(f.visitor_near_wall);
  EXPECT_EQ(count(f, EventType::visitor_near_wall), 0);
}

TEST(Safety, OffInTheConfigAndValidated) {
  Room off("enabled = false\n");
  EXPECT_FALSE(off.step(glm::dvec3(0, 1.6, -1.4)).visitor_near_wall);
  const auto error_of = [](const std::string& extra) -> std::string {
    try {
      parse_installation_config(std::string(kRoom) + "[safety]\n" + extra, "room.toml");
    } catch (const kumite::Error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(error_of("wall_distance_m = 0.0\n").find("safety.wall_distance_m: must be 0.05..2 m"), std::string::npos);
  EXPECT_NE(error_of("enabled = 1\n").find("safety.enabled: must be true or false"), std::string::npos);
  EXPECT_EQ(kumite::content::parse_event_kind("visitor_near_wall"), EventType::visitor_near_wall);
  EXPECT_EQ(kumite::content::parse_event_kind("visitor_clear"), EventType::visitor_clear);
}
