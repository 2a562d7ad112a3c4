#include "kumite/app/frame_pacer.hpp"

#include <algorithm>
#include <cmath>

namespace kumite::app {

namespace {

/// A period sample this far from the estimate is an outlier (a skipped timestamp, a clock
/// step); this many in a row mean the camera rate really changed: start over from them.
constexpr double kPeriodOutlierRatio = 2.0;
constexpr int kOutliersToReseed = 8;
/// Weight of a new period sample (camera periods are steady: a slow average is fine).
constexpr double kPeriodWeight = 0.1;

}  // namespace

void PoseClock::observe(std::uint64_t frame, Timestamp timestamp, Timestamp ready_at) {
  if (ready_at < timestamp) return;
  if (seen_ > 0 && frame == last_frame_) return;
  if (seen_ > 0 && frame < last_frame_) *this = PoseClock{};  // the tracker started over
  if (seen_ > 0 && timestamp > last_timestamp_) {
    const double sample = (timestamp - last_timestamp_) / static_cast<double>(frame - last_frame_);
    const bool outlier = period_s_ > 0 && (sample > kPeriodOutlierRatio * period_s_ ||
                                           sample < period_s_ / kPeriodOutlierRatio);
    outliers_ = outlier ? outliers_ + 1 : 0;
    if (period_s_ <= 0 || outliers_ >= kOutliersToReseed)
      period_s_ = sample, outliers_ = 0;
    else if (!outlier)
      period_s_ += kPeriodWeight * (sample - period_s_);
  }
  latency_[seen_ % kWindow] = ready_at - timestamp;
  ++seen_;
  last_frame_ = frame;
  last_timestamp_ = timestamp;
  const std::size_t n = std::min(seen_, kWindow);
  aim_s_ = *std::min_element(latency_.begin(), latency_.begin() + static_cast<std::ptrdiff_t>(n));
}

std::optional<Timestamp> PoseClock::next_ready(Timestamp t) const {
  if (seen_ < kMinPoses || period_s_ <= 0) return std::nullopt;
  if (t - last_timestamp_ > kStalePeriods * period_s_) return std::nullopt;
  return last_timestamp_ + period_s_ + aim_s_;
}

std::optional<LatchWindow> FramePacer::window(Timestamp start, Timestamp deadline, const PoseTiming& timing) const {
  const auto budget = draw_budget_s();
  if (!enabled_ || !timing.next_ready || !budget) return std::nullopt;
  const double period = timing.period_s;
  const Timestamp expected = *timing.next_ready + kLatchMargin_s;
  const Timestamp drawing = deadline - *budget;  // drawing must start
  if (std::max(start, expected) > drawing) return std::nullopt;
  // A camera faster than the display: the poses after the next that are still expected
  // before drawing must start are fresher; wait for the last of them.
  const int later = period > 0 ? static_cast<int>(std::floor((drawing - expected) / period)) : 0;
  LatchWindow w{std::max(start, expected + later * period), drawing, 1 + later};
  if (period > 0 && timing.newest_at >= 0) {  // no longer than the tracking budget (at least one look)
    const Timestamp due = timing.newest_at + (1 + later) * period;
    w.last = std::min(w.last, std::max(w.first, due + kTrackingBudget_s - kWakeAllowance_s));
  }
  return w;
}

void FramePacer::drawn(double seconds) {
  draw_[drawn_ % kDrawWindow] = std::max(0.0, seconds);
  ++drawn_;
}

std::optional<double> FramePacer::draw_budget_s() const {
  if (drawn_ < kMinDrawSamples) return std::nullopt;
  const std::size_t n = std::min(drawn_, kDrawWindow);
  const double slowest = *std::max_element(draw_.begin(), draw_.begin() + static_cast<std::ptrdiff_t>(n));
  return slowest * kDrawSafety + kDrawMargin_s;
}

}  // namespace kumite::app
