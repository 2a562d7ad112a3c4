// The frame loop's CPU side: tracking lost mid-run, a camera gone, stale poses, an eye past a
// wall, orders from scripts (and bad scripts naming file and line), orders for characters
// that do not exist. A scripted TrackingInput (a test double) stands in for the tracker.
#include <gtest/gtest.h>

#include <fstream>

#include "kumite/app/frame_log.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/orders.hpp"
#include "kumite/common/error.hpp"

using namespace kumite::app;

namespace {

const char* kRoom = R"(
[[walls]]
name = "front"
lower_left = [-1.5, 0.0, -1.5]
lower_right = [1.5, 0.0, -1.5]
upper_left = [-1.5, 2.4, -1.5]
resolution = [320, 180]
[[walls]]
name = "left"
lower_left = [-1.5, 0.0, 1.5]
lower_right = [-1.5, 0.0, -1.5]
upper_left = [-1.5, 2.4, 1.5]
[stereo]
mode = "side_by_side"
[[characters]]
name = "A"
bvh = "a.bvh"
[fighter]
database = "/nonexistent/fighter.kdb"
[tracking]
source = "recording"
calibration = "c.yaml"
tracking = "t.toml"
recording = "rec"
lost_after_s = 0.25
)";

/// Plays a list of snapshots, one per poll, the last one repeated.
class ScriptedTracking final : public TrackingInput {
 public:
  std::vector<TrackingSnapshot> snaps;
  std::size_t next = 0;
  kumite::Timestamp clock_now = 0;
  TrackingSnapshot poll(kumite::Timestamp t) override {
    clock_now = t;
    const auto& s = snaps[std::min(next, snaps.size() - 1)];
    ++next;
    return s;
  }
  kumite::Timestamp clock() const override { return clock_now; }
  std::string describe() const override { return "scripted"; }
};

TrackingSnapshot tracked(double t, double x, double y, double z) {
  TrackingSnapshot s;
  kumite::BodyPose p;
  p.timestamp = t;
  p.status = kumite::TrackingStatus::tracked;
  p.position = {x, y, z};
  p.markers = 4;
  s.head = p;
  s.measured_at = t;
  s.measured_ready_at = t + 0.0012;  // published 1.2 ms after its camera time
  s.status = "tracked";
  s.cameras = {{"cam0", "ok", 4, 8.0}, {"cam1", "ok", 4, 8.0}};
  return s;
}

TrackingSnapshot lost() {
  TrackingSnapshot s;
  s.status = "lost";
  s.cameras = {{"cam0", "ok", 0, 8.0}, {"cam1", "no frames", 0, 900.0}};
  return s;
}

bool has_problem(const ConsoleState& c, std::string_view what) {
  for (const auto& p : c.problems)
    if (p.find(what) != std::string::npos) return true;
  return false;
}

}  // namespace

TEST(Installation, TrackingLostMidRunKeepsTheLastGoodEyes) {
  auto cfg = parse_installation_config(kRoom, "room.toml");
  auto tracking = std::make_unique<ScriptedTracking>();
  auto* tr = tracking.get();
  // Poses are measured 5 ms before each display time (60 Hz frames from t = 100 s).
  for (int i = 0; i < 10; ++i) tr->snaps.push_back(tracked(100 + i / 60.0 - 0.005, 0.3, 1.6, 0.2 + 0.01 * i));
  tr->snaps.push_back(lost());
  Installation inst(cfg, std::move(tracking), {});
  inst.start(100);
  FrameData last_tracked;
  for (int i = 0; i < 10; ++i) {
    const auto& f = inst.step(100 + i / 60.0);
    EXPECT_TRUE(inst.console().head_live);
    EXPECT_NEAR(f.pose_age_ms, 5.0, 1e-6);
    EXPECT_NEAR(f.tracking_latency_ms, 1.2, 1e-6);
    last_tracked = f;
  }
  EXPECT_NEAR(last_tracked.head.position.z, 0.29, 1e-9);
  for (int i = 10; i < 20; ++i) {
    const auto& f = inst.step(100 + i / 60.0);
    EXPECT_FALSE(inst.console().head_live);
    EXPECT_EQ(f.pose_age_ms, -1);
    EXPECT_EQ(f.tracking_latency_ms, -1);
    EXPECT_EQ(f.head.position, last_tracked.head.position);
    EXPECT_EQ(f.eyes.left, last_tracked.eyes.left);
    EXPECT_EQ(f.views[0][0].view, last_tracked.views[0][0].view);
    EXPECT_TRUE(has_problem(inst.console(), "head not tracked (lost): walls drawn from the last good head position"));
    EXPECT_TRUE(has_problem(inst.console(), "camera cam1: no frames"));
  }
  // The fighter's database is missing: said, and the walls still have views.
  EXPECT_TRUE(has_problem(inst.console(), "no fighter"));
  EXPECT_TRUE(has_problem(inst.console(), "/nonexistent/fighter.kdb"));
}

TEST(Installation, CoastingPoseHasAnAgeButNoLatencySplit) {
  // The head was last measured 30 ms ago (two sets missed it): its age says so, but the age
  // is not "tracking latency + waiting for the display" then.
  auto cfg = parse_installation_config(kRoom, "room.toml");
  auto tracking = std::make_unique<ScriptedTracking>();
  TrackingSnapshot s = tracked(100 - 0.030, 0.3, 1.6, 0.2);
  s.head->status = kumite::TrackingStatus::coasting;
  s.status = "coasting";
  tracking->snaps.push_back(s);
  Installation inst(cfg, std::move(tracking), {});
  const auto& f = inst.step(100);
  EXPECT_NEAR(f.pose_age_ms, 30.0, 1e-6);
  EXPECT_EQ(f.tracking_latency_ms, -1);
}

TEST(Installation, StalePoseCountsAsLost) {
  auto cfg = parse_installation_config(kRoom, "room.toml");
  auto tracking = std::make_unique<ScriptedTracking>();
  tracking->snaps.push_back(tracked(99.0, 0.3, 1.6, 0.2));  // 1 s old at t = 100
  Installation inst(cfg, std::move(tracking), {});
  const auto& f = inst.step(100);
  EXPECT_FALSE(inst.console().head_live);
  EXPECT_NEAR(f.pose_age_ms, 1000.0, 1e-6);
  EXPECT_EQ(f.head.position, glm::dvec3(0.0, 1.7, 0.0));  // the default head
}

TEST(Installation, EyePastAWallKeepsThatWallsLastView) {
  auto cfg = parse_installation_config(kRoom, "room.toml");
  auto tracking = std::make_unique<ScriptedTracking>();
  tracking->snaps = {tracked(100, 0, 1.6, 0), tracked(100, -1.6, 1.6, 0)};  // through the left wall
  Installation inst(cfg, std::move(tracking), {});
  const FrameData before = inst.step(100);
  const auto& after = inst.step(100 + 1 / 60.0);
  EXPECT_EQ(after.views[1][0].view, before.views[1][0].view);   // left wall: kept
  EXPECT_NE(after.views[0][0].view, before.views[0][0].view);   // front wall: follows
  EXPECT_TRUE(has_problem(inst.console(), "behind 2 wall plane(s)"));
}

TEST(Installation, ScriptedAndKeyedOrdersAreLoggedWithOutcomes) {
  auto cfg = parse_installation_config(kRoom, "room.toml");
  const auto script = std::filesystem::temp_directory_path() / "kumite_test_orders.csv";
  std::ofstream(script) << "time_s,order\n0.1,punch_left\n0.2,character 7\n";
  InstallationOptions opt;
  opt.orders_script = script;
  Installation inst(cfg, make_fixed_head_input("none"), opt);
  inst.start(50);
  std::vector<FrameEvent> events;
  for (int i = 0; i < 20; ++i) {
    if (i == 15) inst.order(*kumite::parse_order("kick_right"));
    const auto& f = inst.step(50 + i / 60.0);
    events.insert(events.end(), f.events.begin(), f.events.end());
  }
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[0].order, "punch_left");
  EXPECT_NEAR(events[0].time_s, 0.1, 1.0 / 60 + 1e-9);
  EXPECT_EQ(events[1].order, "character 7");
  EXPECT_EQ(events[2].order, "kick_right");
  // No fighter here (missing database): each is ignored, saying why.
  for (const auto& e : events) {
    EXPECT_EQ(e.type, "order_ignored");
    EXPECT_NE(e.text.find("no fighter"), std::string::npos) << e.text;
  }
  EXPECT_EQ(inst.console().last_order, "kick_right");
  // The frame log line carries them.
  const auto json = frame_json(inst.frame(), inst.console(), {"front", "left"}, true);
  EXPECT_NE(json.find("\"walls\":{\"front\":{\"left\":{\"projection\":["), std::string::npos) << json.substr(0, 400);
  std::filesystem::remove(script);
}

TEST(Orders, ScriptParsing) {
  const auto o = parse_orders_script("# demo\ntime_s,order\n0.5, punch_right\n\n1.0,character 2\r\n2,pause\n", "o.csv");
  ASSERT_EQ(o.size(), 3u);
  EXPECT_EQ(o[0].kind, kumite::OrderKind::punch_right);
  EXPECT_DOUBLE_EQ(o[0].time, 0.5);
  EXPECT_EQ(o[1].character, 1);
  EXPECT_EQ(o[2].kind, kumite::OrderKind::pause);
}

TEST(Orders, BadRowsNameFileAndLine) {
  auto msg = [](const char* text) {
    try {
      parse_orders_script(text, "o.csv");
    } catch (const kumite::Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(msg("time_s,order\n0.5,punch_right\n1.0,uppercut\n"),
            "o.csv:3: order: unknown order \"uppercut\" (punch_left, punch_right, kick_left, "
            "kick_right, character N, pause, resume, recentre)");
  EXPECT_EQ(msg("0.5 punch_right\n"), "o.csv:1: expected `time_s,order`");
  EXPECT_EQ(msg("1.0,pause\nsoon,resume\n"), "o.csv:2: time_s: \"soon\" is not a time in seconds >= 0");
  EXPECT_EQ(msg("2.0,pause\n1.0,resume\n"), "o.csv:2: time_s: 1 s comes before the previous row (2 s)");
  EXPECT_NO_THROW(load_orders_script(KUMITE_SOURCE_DIR "/config/orders-demo.csv"));
}

TEST(Installation, ConsoleFrameRateFromFrameIntervals) {
  auto cfg = parse_installation_config(kRoom, "room.toml");
  Installation inst(cfg, make_fixed_head_input("none"), {});
  inst.start(10.0);
  for (int i = 0; i < 200; ++i) inst.step(10.0 + 1e-4 + i / 50.0);  // 50 Hz
  EXPECT_NEAR(inst.console().fps, 50.0, 0.01);
}
