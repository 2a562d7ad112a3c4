// Late latching (frame_pacer.hpp): when the tracker's next pose is expected (PoseClock), the
// window a frame may take it in (FramePacer), and Installation::latch waiting in that window
// for a scripted tracker. No figure here depends on this machine's speed: the waits are
// checked by what they waited for (bench/app/bench_pose_age.cpp measures pose ages).
#include <gtest/gtest.h>

#include "kumite/app/frame_pacer.hpp"
#include "kumite/app/installation.hpp"

using namespace kumite::app;
using kumite::Timestamp;

namespace {

constexpr double kPeriod = 1.0 / 60.0;

/// Poses of a 60 Hz camera from t = 100 s, published 1.5, 2.0, 2.5, 1.5, ... ms after their
/// camera time.
void observe_60hz(PoseClock& c, int from, int to) {
  for (int i = from; i < to; ++i)
    c.observe(static_cast<std::uint64_t>(i), 100 + i * kPeriod, 100 + i * kPeriod + 0.0015 + 0.0005 * (i % 3));
}

/// What the frame loop knows of the tracker's timing.
PoseTiming timing(std::optional<Timestamp> next_ready, double period_s = 0, Timestamp newest_at = -1) {
  PoseTiming t;
  t.newest = 1;
  t.newest_at = newest_at;
  t.next_ready = next_ready;
  t.period_s = period_s;
  return t;
}

}  // namespace

TEST(PoseClock, UnknownUntilEnoughPoses) {
  PoseClock c;
  EXPECT_FALSE(c.next_ready(100).has_value());
  observe_60hz(c, 0, static_cast<int>(PoseClock::kMinPoses) - 1);
  EXPECT_FALSE(c.next_ready(100.1).has_value());
  observe_60hz(c, static_cast<int>(PoseClock::kMinPoses) - 1, static_cast<int>(PoseClock::kMinPoses));
  EXPECT_TRUE(c.next_ready(100.1).has_value());
}

TEST(PoseClock, PredictsTheNextPublishFromPeriodAndFastestLatency) {
  PoseClock c;
  observe_60hz(c, 0, 20);  // newest: frame 19 at 100 + 19/60
  EXPECT_NEAR(c.period_s(), kPeriod, 1e-12);
  EXPECT_NEAR(c.latency_s(), 0.0015, 1e-12);
  const Timestamp last = 100 + 19 * kPeriod;
  const Timestamp frame20 = last + kPeriod + 0.0015;
  // Just after the newest was out: frame 20, one period on.
  EXPECT_NEAR(*c.next_ready(last + 0.003), frame20, 1e-9);
  // Even before the newest's own expected publish: it is out (seen), so the next.
  EXPECT_NEAR(*c.next_ready(last), frame20, 1e-9);
  // Frame 20 overdue (not seen yet): still the one to look for, though its time is past.
  EXPECT_NEAR(*c.next_ready(last + kPeriod + 0.008), frame20, 1e-9);
  EXPECT_NEAR(*c.next_ready(last + 2.5 * kPeriod), frame20, 1e-9);
  // Nothing for more than kStalePeriods periods (a camera gone): unknown.
  EXPECT_TRUE(c.next_ready(last + 2.9 * kPeriod).has_value());
  EXPECT_FALSE(c.next_ready(last + 3.1 * kPeriod).has_value());
}

TEST(PoseClock, SkippedSetsRepeatsAndRestarts) {
  PoseClock c;
  // Every other set reaches the display (a 30 Hz poll of a 60 Hz camera): still 60 Hz.
  for (int i = 0; i < 40; i += 2) c.observe(static_cast<std::uint64_t>(i), 100 + i * kPeriod, 100 + i * kPeriod + 0.002);
  EXPECT_NEAR(c.period_s(), kPeriod, 1e-12);
  const std::size_t n = c.poses();
  c.observe(38, 100 + 38 * kPeriod, 100 + 38 * kPeriod + 0.009);  // the same pose polled again
  EXPECT_EQ(c.poses(), n);
  EXPECT_NEAR(c.latency_s(), 0.002, 1e-12);
  c.observe(50, 100 + 50 * kPeriod, 99);  // published before its camera time: not a latency
  EXPECT_EQ(c.poses(), n);
  c.observe(3, 200, 200.001);  // the tracker started over
  EXPECT_EQ(c.poses(), 1u);
  EXPECT_EQ(c.period_s(), 0);
}

TEST(PoseClock, OneGapLeavesThePeriodARealRateChangeResetsIt) {
  PoseClock c;
  observe_60hz(c, 0, 20);
  // A 1 s hole between two consecutive sets (a stalled camera): one outlier, ignored.
  c.observe(20, 101 + 20 * kPeriod, 101 + 20 * kPeriod + 0.0015);
  EXPECT_NEAR(c.period_s(), kPeriod, 1e-12);
  // The camera now runs at 200 Hz: every set an outlier, until the estimate starts over.
  Timestamp t = 101 + 20 * kPeriod;
  for (int i = 21; i < 30; ++i) {
    t += 1.0 / 200;
    c.observe(static_cast<std::uint64_t>(i), t, t + 0.0015);
  }
  EXPECT_NEAR(c.period_s(), 1.0 / 200, 1e-9);
  // A small drift (199 Hz) is followed gradually.
  for (int i = 30; i < 130; ++i) {
    t += 1.0 / 199;
    c.observe(static_cast<std::uint64_t>(i), t, t + 0.0015);
  }
  EXPECT_NEAR(c.period_s(), 1.0 / 199, 1e-8);
}

TEST(FramePacer, WindowFromTheExpectedPoseToTheLastMomentDrawingFits) {
  FramePacer p;
  const Timestamp start = 10, deadline = 10 + kPeriod;
  // No drawing time measured yet: take the pose at the start.
  EXPECT_FALSE(p.window(start, deadline, timing(10.005)).has_value());
  for (std::size_t i = 0; i < FramePacer::kMinDrawSamples; ++i) p.drawn(0.002);
  ASSERT_TRUE(p.draw_budget_s().has_value());
  const double budget = 0.002 * FramePacer::kDrawSafety + FramePacer::kDrawMargin_s;
  EXPECT_NEAR(*p.draw_budget_s(), budget, 1e-12);
  const auto w = p.window(start, deadline, timing(10.005));
  ASSERT_TRUE(w.has_value());
  EXPECT_NEAR(w->first, 10.005 + FramePacer::kLatchMargin_s, 1e-12);
  EXPECT_NEAR(w->last, deadline - budget, 1e-12);
  // Due already (late): look from the start.
  EXPECT_NEAR(p.window(start, deadline, timing(9.999))->first, start, 1e-12);
  // Expected too late for drawing to fit, or unknown: at the start.
  EXPECT_FALSE(p.window(start, deadline, timing(deadline - budget + 0.0001)).has_value());
  EXPECT_FALSE(p.window(start, deadline, timing(std::nullopt)).has_value());
  // A 120 Hz camera: the pose after the next is expected before drawing must start too.
  const auto fast = p.window(start, deadline, timing(10.002, 1.0 / 120));
  ASSERT_TRUE(fast.has_value());
  EXPECT_EQ(fast->poses, 2);
  EXPECT_NEAR(fast->first, 10.002 + 1.0 / 120 + FramePacer::kLatchMargin_s, 1e-12);
  EXPECT_EQ(p.window(start, deadline, timing(10.005, 1.0 / 120))->poses, 1);  // the second would not fit
  EXPECT_EQ(p.window(start, deadline, timing(10.005, 1.0 / 60))->poses, 1);
  // No longer than the tracking budget past the awaited pose's camera time: the pose held
  // is then one period + kTrackingBudget_s old.
  const Timestamp due = 10.006;
  const auto capped = p.window(start, deadline, timing(due + 0.0015, kPeriod, due - kPeriod));
  ASSERT_TRUE(capped.has_value());
  EXPECT_NEAR(capped->first, due + 0.0015 + FramePacer::kLatchMargin_s, 1e-12);
  EXPECT_NEAR(capped->last, due + FramePacer::kTrackingBudget_s - FramePacer::kWakeAllowance_s, 1e-12);
  // A tracker slower than the budget: one look when the pose is expected.
  const auto slow = p.window(start, deadline, timing(due + 0.003, kPeriod, due - kPeriod));
  EXPECT_NEAR(slow->last, slow->first, 1e-12);
  // Latching off (config late_latch = false).
  FramePacer off(false);
  for (int i = 0; i < 20; ++i) off.drawn(0.002);
  EXPECT_FALSE(off.window(start, deadline, timing(10.005)).has_value());
}

TEST(FramePacer, BudgetFollowsTheSlowestRecentFrame) {
  FramePacer p;
  p.drawn(0.010);
  for (std::size_t i = 1; i < FramePacer::kDrawWindow; ++i) p.drawn(0.001);
  EXPECT_NEAR(*p.draw_budget_s(), 0.010 * FramePacer::kDrawSafety + FramePacer::kDrawMargin_s, 1e-12);
  p.drawn(0.001);  // the slow frame leaves the window
  EXPECT_NEAR(*p.draw_budget_s(), 0.001 * FramePacer::kDrawSafety + FramePacer::kDrawMargin_s, 1e-12);
  // A frame too slow for any latch: no window even for a pose due at once.
  for (std::size_t i = 0; i < FramePacer::kDrawWindow; ++i) p.drawn(0.016);
  EXPECT_FALSE(p.window(10, 10 + kPeriod, timing(10.0)).has_value());
}

namespace {

const char* kRoom = R"(
[[walls]]
name = "front"
lower_left = [-1.5, 0.0, -1.5]
lower_right = [1.5, 0.0, -1.5]
upper_left = [-1.5, 2.4, -1.5]
[[characters]]
name = "A"
bvh = "a.bvh"
[fighter]
database = "/nonexistent/fighter.kdb"
)";

/// A tracker whose next pose is expected at `expected`, with poses coming out at `outs` (on
/// kumite::now()'s clock) every `period` s; counts how often the frame loop looked.
class TimedTracking final : public TrackingInput {
 public:
  Timestamp expected = 0;
  std::vector<Timestamp> outs;
  double period = 0;
  Timestamp newest_at = -1;  // camera time of the pose out at the start (-1: not given)
  bool known = true;
  int looks = 0;
  TrackingSnapshot poll(Timestamp) override { return {}; }
  Timestamp clock() const override { return kumite::now(); }
  std::string describe() const override { return "timed"; }
  PoseTiming pose_timing(Timestamp) override {
    ++looks;
    PoseTiming p;
    p.newest = 1;  // a pose was out at the start
    for (const Timestamp o : outs) p.newest += kumite::now() >= o ? 1 : 0;
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
  Timestamp start = 0, returned = 0, last = 0;
  int looks = 0;
  double latch_ms = 0;
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
  EXPECT_LT(r.returned, r.start + kFrame - 0.15);  // drawing still fits before the deadline
  EXPECT_GT(r.looks, 1);
}

TEST(InstallationLatch, TakesThePoseAtOnceWhenOffOrTheTimingIsUnknown) {
  for (const auto& r : {latch_once({.late_latch = false, .out_after = {0.006}}),
                        latch_once({.known = false, .out_after = {0.006}})}) {
    EXPECT_EQ(r.looks, 1);  // looked once, did not wait
  }
}
