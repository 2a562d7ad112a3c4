// Late latching (frame_pacer.hpp): when the tracker's next pose is expected (PoseClock) and
// the window a frame may take it in (FramePacer). Installation::latch waiting in that window
// is tested in test_installation.cpp; bench/app/bench_pose_age.cpp measures pose ages.
#include <gtest/gtest.h>

#include "kumite/app/frame_pacer.hpp"

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
