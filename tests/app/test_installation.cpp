// The frame loop's CPU side: tracking lost mid-run, a camera gone, stale poses, an eye past a
// wall, orders from scripts (and bad scripts naming file and line), orders for characters
// that do not exist, late latching. A scripted TrackingInput (a test double) stands in for the tracker.
#include <gtest/gtest.h>

#include <spdlog/sinks/ringbuffer_sink.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <fstream>
#include <thread>
#include <vector>

#include "kumite/app/frame_log.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/orders.hpp"
#include "kumite/app/tracking_input.hpp"
#include "kumite/common/time.hpp"
#include "kumite/tracking/synth.hpp"
#include "kumite/tracking/tracker.hpp"
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
  bool is_loading = false;
  bool loading() const override { return is_loading; }
  std::vector<TrackingSnapshot> snaps;
  std::size_t next = 0;
  kumite::Timestamp clock_now = 0;
  kumite::Timestamp display_at = 0;  // the last poll's display time
  void poll(kumite::Timestamp t, kumite::Timestamp display_time, TrackingSnapshot& out) override {
    display_at = display_time;
    clock_now = t;
    out = snaps[std::min(next, snaps.size() - 1)];
    ++next;
  }
  kumite::Timestamp clock() const override { return clock_now; }
  std::string describe() const override { return "scripted"; }
  const std::vector<std::string>& camera_names() const override { return names; }
  std::vector<std::string> names{"cam0", "cam1"};
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
  s.state = TrackerState::tracked;
  s.frame_sets = 1;
  s.cameras = {{kumite::CameraState::ok, 4, 8.0}, {kumite::CameraState::ok, 4, 8.0}};
  return s;
}

TrackingSnapshot lost() {
  TrackingSnapshot s;
  s.state = TrackerState::lost;
  s.cameras = {{kumite::CameraState::ok, 0, 8.0}, {kumite::CameraState::no_frames, 0, 900.0}};
  return s;
}

bool has_problem(const ConsoleState& c, std::string_view what) {
  for (const auto& p : c.problems)
    if (p.find(what) != std::string::npos) return true;
  return false;
}

}  // namespace

TEST(Installation, TheHeadIsPredictedToWhenTheFrameIsSeen) {
  auto cfg = parse_installation_config(kRoom, "room.toml");
  cfg.display_latency_ms = 20;  // the projectors' input lag
  auto tracking = std::make_unique<ScriptedTracking>();
  auto* tr = tracking.get();
  tr->snaps.push_back(tracked(99.995, 0.3, 1.6, 0.2));
  Installation inst(cfg, std::move(tracking), {});
  inst.start(100);
  // Taken 4 ms into a frame whose vsync is at 100.0167 s: seen 20 ms after that.
  const auto& f = inst.step(100.004, 100 + 1 / 60.0);
  EXPECT_NEAR(tr->display_at, 100 + 1 / 60.0 + 0.020, 1e-9);
  EXPECT_NEAR(f.predicted_ahead_ms, (1 / 60.0 - 0.004 + 0.020) * 1e3, 1e-6);
  EXPECT_NEAR(f.pose_age_ms, 9.0, 1e-6) << "the age still counts to the moment the pose is taken";
  // A frame seen at once (simulated time), or one already past its vsync: the latency only.
  inst.step(100.1);
  EXPECT_NEAR(tr->display_at, 100.12, 1e-9);
  inst.step(100.2, 100.19);
  EXPECT_NEAR(tr->display_at, 100.22, 1e-9);
}

// Issue 15: while the source loads (a recording's preload) no camera has a frame yet; that is
// loading (a banner on the console), not a list of camera alarms; once it plays, a camera
// without frames is a problem again.
TEST(Installation, WhileTheSourceLoadsCamerasAreNotAlarms) {
  auto cfg = parse_installation_config(kRoom, "room.toml");
  auto tracking = std::make_unique<ScriptedTracking>();
  auto* tr = tracking.get();
  tr->snaps.push_back(lost());
  tr->is_loading = true;
  Installation inst(cfg, std::move(tracking), {});
  inst.start(100);
  inst.step(100);
  EXPECT_TRUE(inst.tracking_loading());
  EXPECT_FALSE(has_problem(inst.console(), "camera cam1"));
  EXPECT_FALSE(has_problem(inst.console(), "head not tracked"));
  tr->is_loading = false;
  inst.step(100 + 1 / 60.0);
  EXPECT_TRUE(has_problem(inst.console(), "camera cam1: no frames"));
  EXPECT_TRUE(has_problem(inst.console(), "head not tracked (lost, "));
}

// Issue 15: a camera that goes bad (here: blind, as a black or covered one is) is one warning
// line in the log when it happens and one when it is back, not a line per frame.
TEST(Installation, ACameraGoingBadIsOneLogLineEachWay) {
  auto sink = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(64);
  spdlog::default_logger()->sinks().push_back(sink);
  auto cfg = parse_installation_config(kRoom, "room.toml");
  auto tracking = std::make_unique<ScriptedTracking>();
  auto* tr = tracking.get();
  TrackingSnapshot ok = tracked(100, 0, 1.6, 0), bad = ok;
  ok.cameras = {{kumite::CameraState::ok, 5, 8.0}, {kumite::CameraState::ok, 5, 8.0}};
  bad.cameras = {{kumite::CameraState::ok, 5, 8.0}, {kumite::CameraState::blind, 0, 8.0}};
  for (int i = 0; i < 5; ++i) tr->snaps.push_back(ok);
  for (int i = 0; i < 30; ++i) tr->snaps.push_back(bad);
  for (int i = 0; i < 5; ++i) tr->snaps.push_back(ok);
  Installation inst(cfg, std::move(tracking), {});
  inst.start(100);
  for (int i = 0; i < 40; ++i) inst.step(100 + i / 60.0);
  spdlog::default_logger()->sinks().pop_back();
  int warned = 0, back = 0;
  for (const auto& line : sink->last_formatted()) {
    warned += line.find("camera cam1: sees no markers while others see the head") != std::string::npos;
    back += line.find("camera cam1: ok again") != std::string::npos;
  }
  EXPECT_EQ(warned, 1);
  EXPECT_EQ(back, 1);
}

// Issue 15: one press of the quit key does not end the show: it arms a quit for
// [console] quit_confirm_s; a second press within that time quits, a late one arms again.
TEST(Installation, QuittingTakesTwoPressesWithinTheConfirmTime) {
  auto cfg = parse_installation_config(std::string(kRoom) + "\n[console]\nquit_confirm_s = 2.0\n", "room.toml");
  Installation inst(cfg, make_fixed_head_input("test"), {});
  inst.start(100);
  EXPECT_FALSE(inst.quit_key(100.0));
  EXPECT_FALSE(inst.quit_requested());
  ASSERT_TRUE(inst.quit_armed_until(101.0));
  EXPECT_EQ(*inst.quit_armed_until(101.0), 102.0);
  EXPECT_FALSE(inst.quit_armed_until(102.5)) << "expired";
  EXPECT_FALSE(inst.quit_key(103.0)) << "too late: armed again";
  EXPECT_TRUE(inst.quit_key(104.5));
  EXPECT_TRUE(inst.quit_requested());
  // quit_confirm_s = 0: one press quits (an installation that wants it so).
  auto once = parse_installation_config(std::string(kRoom) + "\n[console]\nquit_confirm_s = 0\n", "room.toml");
  Installation inst2(once, make_fixed_head_input("test"), {});
  EXPECT_TRUE(inst2.quit_key(100.0));
}

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
    EXPECT_TRUE(has_problem(inst.console(), "head not tracked (lost, 0 frame sets): walls drawn from the last good head position"));
    EXPECT_TRUE(has_problem(inst.console(), "camera cam1: no frames"));
  }
  // The fighter's database is missing: said, and the walls still have views.
  EXPECT_TRUE(has_problem(inst.console(), "no fighter"));
  EXPECT_EQ(inst.console().planner, "") << "no fighter, no planner line";
  EXPECT_TRUE(has_problem(inst.console(), "/nonexistent/fighter.kdb"));
}

TEST(Installation, CoastingPoseHasAnAgeButNoLatencySplit) {
  // The head was last measured 30 ms ago (two sets missed it): its age says so, but the age
  // is not "tracking latency + waiting for the display" then.
  auto cfg = parse_installation_config(kRoom, "room.toml");
  auto tracking = std::make_unique<ScriptedTracking>();
  TrackingSnapshot s = tracked(100 - 0.030, 0.3, 1.6, 0.2);
  s.head->status = kumite::TrackingStatus::coasting;
  s.state = TrackerState::coasting;
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
  EXPECT_TRUE(has_problem(inst.console(), "an eye is on or behind the plane of wall(s) left: drawn from their last good view"));
}

TEST(Installation, TheOrdersScriptStartsWhenTheHeadIsTracked) {
  auto cfg = parse_installation_config(kRoom, "room.toml");
  const auto script = std::filesystem::temp_directory_path() / "kumite_test_orders_wait.csv";
  std::ofstream(script) << "time_s,order\n0.1,punch_left\n";
  InstallationOptions opt;
  opt.orders_script = script;
  for (const bool ever_tracked : {true, false}) {
    auto tracking = std::make_unique<ScriptedTracking>();
    auto* tr = tracking.get();
    for (int i = 0; i < 120; ++i) tr->snaps.push_back(lost());  // the tracker loading: 2 s
    tr->snaps.push_back(ever_tracked ? tracked(52, 0.3, 1.6, 0.2) : lost());
    Installation inst(cfg, std::move(tracking), opt);
    inst.start(50);
    std::vector<FrameEvent> events;
    bool said_waiting = false;
    for (int i = 0; i < 60 * 40; ++i) {
      const auto& f = inst.step(50 + i / 60.0);
      events.insert(events.end(), f.events.begin(), f.events.end());
      said_waiting |= has_problem(inst.console(), "orders script waits for the head to be tracked");
    }
    EXPECT_TRUE(said_waiting);
    ASSERT_EQ(events.size(), 1u);
    ASSERT_TRUE(events[0].order);
    EXPECT_EQ(kumite::to_string(*events[0].order), "punch_left");
    // 0.1 s after the first tracked frame (2 s in), or after the longest wait (30 s).
    EXPECT_NEAR(events[0].time_s, (ever_tracked ? 2.0 : Installation::kScriptWaitForHead_s) + 0.1, 1.0 / 60 + 1e-9)
        << ever_tracked;
  }
  std::filesystem::remove(script);
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
  const auto order = [](const FrameEvent& e) { return e.order ? kumite::to_string(*e.order) : std::string("none"); };
  EXPECT_EQ(order(events[0]), "punch_left");
  EXPECT_NEAR(events[0].time_s, 0.1, 1.0 / 60 + 1e-9);
  EXPECT_EQ(order(events[1]), "character 7");
  EXPECT_EQ(order(events[2]), "kick_right");
  // No fighter here (missing database): each is ignored, saying why.
  for (const auto& e : events) {
    EXPECT_EQ(e.type, EventType::order_ignored);
    EXPECT_EQ(e.cause, EventCause::no_fighter);
    EXPECT_NE(inst.event_text(e).find("no fighter"), std::string::npos) << inst.event_text(e);
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
  // Saved by a spreadsheet as "CSV UTF-8": a byte-order mark before the header, CRLF lines.
  const auto bom = parse_orders_script("\xEF\xBB\xBFtime_s,order\r\n0.5,punch_right\r\n", "o.csv");
  ASSERT_EQ(bom.size(), 1u);
  EXPECT_EQ(bom[0].kind, kumite::OrderKind::punch_right);
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
  // from_chars reads nan, inf and infinity (either sign) as numbers: refused by name.
  for (const char* t : {"nan", "-nan", "inf", "-inf", "infinity", "NaN"})
    EXPECT_EQ(msg(("0.5,pause\n" + std::string(t) + ",resume\n").c_str()),
              "o.csv:2: time_s: must be a finite number (found \"" + std::string(t) + "\")");
  EXPECT_NO_THROW(load_orders_script(KUMITE_SOURCE_DIR + "/config/orders-demo.csv"));
  // A folder read as an empty script: no orders and no word (rc 0).
  try {
    load_orders_script(KUMITE_SOURCE_DIR + "/config");
    FAIL();
  } catch (const kumite::Error& e) {
    EXPECT_EQ(std::string(e.what()), std::string(KUMITE_SOURCE_DIR + "/config") + ": is a folder, not a file: give the orders script (.csv)");
  }
}

TEST(Installation, ConsoleFrameRateFromFrameIntervals) {
  auto cfg = parse_installation_config(kRoom, "room.toml");
  Installation inst(cfg, make_fixed_head_input("none"), {});
  inst.start(10.0);
  for (int i = 0; i < 200; ++i) inst.step(10.0 + 1e-4 + i / 50.0);  // 50 Hz
  EXPECT_NEAR(inst.console().fps, 50.0, 0.01);
}

// Late latching: Installation::latch waits in the window FramePacer gives (frame_pacer.hpp)
// for a tracker scripted on the real clock; the waits are checked by what they waited for.
namespace {

/// A tracker whose next pose is expected at `expected`, with poses coming out at `outs` (on
/// kumite::now()'s clock) every `period` s; counts how often the frame loop looked.
class TimedTracking final : public TrackingInput {
 public:
  kumite::Timestamp expected = 0;
  std::vector<kumite::Timestamp> outs;
  double period = 0;
  kumite::Timestamp newest_at = -1;  // camera time of the pose out at the start (-1: not given)
  bool known = true;
  int looks = 0;
  void poll(kumite::Timestamp, kumite::Timestamp, TrackingSnapshot& out) override { out = {}; }
  kumite::Timestamp clock() const override { return kumite::now(); }
  std::string describe() const override { return "timed"; }
  PoseTiming pose_timing(kumite::Timestamp) override {
    ++looks;
    PoseTiming p;
    p.newest = 1;  // a pose was out at the start
    for (const kumite::Timestamp o : outs) p.newest += kumite::now() >= o ? 1 : 0;
    if (known) p.next_ready = expected;
    p.period_s = period;
    p.newest_at = newest_at;
    return p;
  }
};

/// One frame of a slow loop (1 s frames, 0.3 s drawing times measured, so the latch window
/// ends at about 0.62 s: a loaded machine's late wake-ups cannot blur what is checked).
constexpr double kFrame = 1.0, kDraw = 0.3;

struct Setup {
  bool late_latch = true;
  bool known = true;               ///< the tracker's timing known
  double expected_after = 0.004;   ///< s into the frame: the next pose expected
  std::vector<double> out_after;   ///< s into the frame: poses out (none: never)
  double period = 0;               ///< s between poses (0: unknown)
  double newest_at = -1;           ///< s into the frame: camera time of the pose out at its start
  bool newest_known = false;
};

struct Latched {
  kumite::Timestamp start = 0, returned = 0, last = 0;
  int looks = 0;
  double latch_ms = 0;
  std::optional<LatchWindow> window;  ///< the window it waited in
};

Latched latch_once(const Setup& setup) {
  auto cfg = parse_installation_config(kRoom, "room.toml");
  cfg.late_latch = setup.late_latch;
  auto tracking = std::make_unique<TimedTracking>();
  auto* tr = tracking.get();
  Installation inst(cfg, std::move(tracking), {});
  for (int i = 0; i < 20; ++i) inst.drawn(kDraw);
  Latched r;
  r.start = kumite::now();
  tr->expected = r.start + setup.expected_after;
  for (const double o : setup.out_after) tr->outs.push_back(r.start + o);
  tr->known = setup.known;
  tr->period = setup.period;
  if (setup.newest_known) tr->newest_at = r.start + setup.newest_at;
  r.last = r.start + kFrame - (kDraw * FramePacer::kDrawSafety + FramePacer::kDrawMargin_s);
  r.returned = inst.latch(r.start, r.start + kFrame);
  r.looks = tr->looks;
  r.window = inst.last_latch_window();
  r.latch_ms = inst.step(r.returned).latch_ms;
  return r;
}

}  // namespace

TEST(InstallationLatch, WaitsForThePoseExpectedInTheFrame) {
  const Latched r = latch_once({.out_after = {0.006}});  // out 2 ms later than expected
  EXPECT_GE(r.returned, r.start + 0.006);
  EXPECT_LT(r.returned, r.start + 0.3);  // and stops looking once it is out
  EXPECT_GT(r.looks, 1);
  EXPECT_NEAR(r.latch_ms, (r.returned - r.start) * 1e3, 1e-9);
}

TEST(InstallationLatch, AnOverduePoseIsLookedForFromTheStart) {
  // Due 2 ms before the frame, out 3 ms into it.
  const Latched r = latch_once({.expected_after = -0.002, .out_after = {0.003}});
  EXPECT_GE(r.returned, r.start + 0.003);
  EXPECT_LT(r.returned, r.start + 0.3);
  EXPECT_GT(r.looks, 1);
}

TEST(InstallationLatch, ACameraFasterThanTheDisplayGivesTheLastPoseThatFits) {
  // Poses every 0.25 s: at 0.004, 0.254, 0.504 s fit before drawing must start (0.62 s).
  const Latched r = latch_once({.out_after = {0.004, 0.254, 0.504}, .period = 0.25});
  EXPECT_GE(r.returned, r.start + 0.504);
  EXPECT_LT(r.returned, r.start + kFrame - 0.15);
}

TEST(InstallationLatch, NoLongerThanTheTrackingBudgetAfterTheAwaitedPoseIsDue) {
  // Poses every 0.25 s; the one out at the start was measured 0.246 s before it, so the
  // next two are due 0.004 and 0.254 s in (out on time) and the third, awaited, 0.504 s in
  // (never out): the frame stops looking kTrackingBudget_s after that, not at 0.62 s.
  const Latched r = latch_once({.out_after = {0.004, 0.254}, .period = 0.25, .newest_at = -0.246,
                                .newest_known = true});
  EXPECT_GE(r.returned, r.start + 0.504 + FramePacer::kTrackingBudget_s - FramePacer::kWakeAllowance_s);
  EXPECT_LT(r.returned, r.start + 0.58);
}

TEST(InstallationLatch, NeverPastTheMomentDrawingMustStart) {
  const Latched r = latch_once({});  // the pose never comes (a camera gone)
  EXPECT_GE(r.returned, r.last);
  ASSERT_TRUE(r.window);
  EXPECT_NEAR(r.window->last, r.last, 1e-9);  // the window it reports is the one it waited in
  EXPECT_LT(r.returned, r.start + kFrame - 0.15);  // drawing still fits before the deadline
  EXPECT_GT(r.looks, 1);
}

TEST(InstallationLatch, TakesThePoseAtOnceWhenOffOrTheTimingIsUnknown) {
  for (const auto& r : {latch_once({.late_latch = false, .out_after = {0.006}}),
                        latch_once({.known = false, .out_after = {0.006}})}) {
    EXPECT_EQ(r.looks, 1);  // looked once, did not wait
    EXPECT_FALSE(r.window);
  }
}

TEST(TrackingInput, AMissingTrackerFileIsNamedAtItsConfigKey) {
  // The demo's file, so every key has its line; each file in turn points nowhere.
  const auto demo = load_installation_config(KUMITE_SOURCE_DIR + "/config/demo.toml");
  for (const char* key : {"tracking.calibration", "tracking.tracking", "tracking.recording"}) {
    auto cfg = demo;
    if (std::string(key) == "tracking.calibration") cfg.tracking.calibration = "/nonexistent/calibration.yaml";
    if (std::string(key) == "tracking.tracking") cfg.tracking.tracking = "/nonexistent/tracking.toml";
    if (std::string(key) == "tracking.recording") cfg.tracking.recording = "/nonexistent/recording";
    try {
      (void)make_tracking_input(cfg);
      ADD_FAILURE() << key << ": no error";
    } catch (const kumite::Error& e) {
      const std::string msg = e.what();
      EXPECT_GT(demo.line_of(key), 0) << key;
      const std::string at = fmt::format("demo.toml:{}: {}: ", demo.line_of(key), key);
      EXPECT_NE(msg.find(at), std::string::npos) << msg;
      EXPECT_NE(msg.find("/nonexistent/"), std::string::npos) << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << "one line: " << msg;
    }
  }
}

TEST(TrackingInput, AProjectorLagDoesNotMakeAFreshPoseLost) {
  auto cfg = load_installation_config(KUMITE_SOURCE_DIR + "/config/demo.toml");
  const auto rig = kumite::tracking::read_calibration(cfg.resolve(cfg.tracking.calibration));
  const auto tc = kumite::tracking::read_tracking_config(cfg.resolve(cfg.tracking.tracking));
  // SYNTHETIC frame sets of a visitor standing still, handed over at 60 Hz as cameras would.
  auto input = make_tracking_input(
      cfg, kumite::tracking::synthetic_live_source(rig, tc.bodies.at(0), kumite::tracking::static_visitor));
  // Wait for the tracker's first measurement of the head. Not for a poll that happens to call it
  // tracked: on a loaded 2-core CI machine the synthetic renderer managed 7 frame sets a second,
  // each set reached the tracker more than its 0.1 s coasting time after its capture, and 20 s of
  // polls at the wall clock never saw "tracked" (CI, 26 Nov: "lost, 137 frame sets"). What is
  // checked below is the display time, so the polls are placed on the measurement's own clock.
  TrackingSnapshot s;
  const kumite::Timestamp give_up = kumite::now() + 60;
  do {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    input->poll(kumite::now(), kumite::now(), s);
  } while (s.measured_at < 0 && kumite::now() < give_up);
  ASSERT_GE(s.measured_at, 0) << describe(s);
  // Polled 20 ms after that capture and seen 80 ms and 1.25 s from then (a slow projector; past
  // the tracker's 0.1 s coasting time: a pose judged by its age at the display time would be
  // lost): still tracked, where the visitor stands. The control: polled itself past the coasting
  // time, the same pose is no longer tracked (the status is the tracker's own, as of the poll).
  const kumite::Timestamp polled = s.measured_at + 0.02;
  for (const double ahead : {0.08, 1.25}) {
    TrackingSnapshot later;
    input->poll(polled, polled + ahead, later);
    ASSERT_TRUE(later.head);
    EXPECT_EQ(later.head->status, kumite::TrackingStatus::tracked) << ahead;
    EXPECT_NEAR(later.head->position[1], 1.65, 0.02) << ahead;
  }
  TrackingSnapshot stale;
  input->poll(kumite::now() + 1.25, kumite::now() + 1.25, stale);
  ASSERT_TRUE(stale.head);
  EXPECT_NE(stale.head->status, kumite::TrackingStatus::tracked);
}

// Issue 14: the app finds the glasses by their role, the body tracking.toml names `head`
// (gloves and shoes are other bodies), unless [tracking] head_body picks one by index.
TEST(Installation, TheHeadIsTheBodyNamedHead) {
  const std::string bodies =
      "[[bodies]]\nname = \"left_hand\"\nmarkers = [[0,0,0],[0.1,0,0],[0,0.07,0]]\n"
      "[[bodies]]\nname = \"head\"\nmarkers = [[0,0,0],[0.12,0,0],[0,0.05,0.03]]\n";
  const auto tc = kumite::tracking::parse_tracking_config(bodies, "t.toml");
  auto cfg = parse_installation_config(kRoom, "room.toml");
  EXPECT_EQ(head_body_index(cfg, tc), 1);
  cfg.tracking.head_body = 0;
  EXPECT_EQ(head_body_index(cfg, tc), 0) << "an explicit index wins";
  cfg.tracking.head_body = 2;
  EXPECT_THROW(head_body_index(cfg, tc), kumite::Error);
  cfg.tracking.head_body.reset();
  const auto unnamed = kumite::tracking::parse_tracking_config(
      "[[bodies]]\nname = \"glasses\"\nmarkers = [[0,0,0],[0.1,0,0],[0,0.07,0]]\n", "t.toml");
  EXPECT_EQ(head_body_index(cfg, unnamed), 0) << "no body named head: body 0, said in the log";
}

TEST(Installation, ARecordingThatFallsBehindSaysWhichSideIsBehind) {
  // The console advised "set tracking.recording_preload" to a run playing from memory, whose
  // sets were dropped by a tracker behind on a loaded machine (the issue 15 audit, 27 Nov).
  SourceStats s;
  s.recording = true;
  s.decode_ms = 49;
  s.rates = {95, 3, 2};
  EXPECT_FALSE(source_problem(s).has_value());  // 95 % reach the tracker
  s.rates = {50, 10, 0};                         // from disk, the decoder behind
  ASSERT_TRUE(source_problem(s).has_value());
  EXPECT_EQ(*source_problem(s),
            "recording: only 83% of frame sets reach the tracker (PNG decoding 49 ms per set): pose age grows; set "
            "tracking.recording_preload to play from memory");
  s.from_memory = true;  // looping from memory: nothing to decode, the tracker drops them
  s.rates = {50, 0, 10};
  ASSERT_TRUE(source_problem(s).has_value());
  EXPECT_EQ(*source_problem(s),
            "recording: only 83% of frame sets reach the tracker (10.0/s dropped: the tracker is behind, 0.0/s skipped "
            "by the decoder): pose age grows; the machine is too busy for the cameras' rate");
  s.from_memory = false;  // from disk but the tracker the one behind
  s.rates = {50, 1, 9};
  EXPECT_EQ(source_problem(s)->find("set tracking.recording_preload"), std::string::npos);
}
