#pragma once
// Late latching: when, inside a display frame, to take the head pose.
//
// A frame's slot runs from its start (the swap that returned at vsync, or the loop's tick)
// to its deadline (the next one). Drawing takes a while, so the pose can be taken anywhere
// from the slot's start to the deadline less the drawing time, and the picture still reaches
// the walls at the same vsync. Taken at the start, the pose's age depends on the display's
// phase against the camera clock: up to one camera period plus the tracking latency, the same
// for the whole run. Taken just after the tracker publishes its next pose, it is only the
// tracking latency (plus a margin) old, and the walls show the visitor's newer position.
//
// PoseClock predicts when the next pose will be published from the poses seen; FramePacer
// gives the window to take it in: from just after the predicted time until the tracking
// latency the pose-age target allows is spent, and never past the last moment drawing can
// start and still make the deadline. The frame loop (Installation::latch) sleeps to the
// window's start and, if the pose is late, polls until it is out or the window ends.
// That wait only spends the frame's idle time (the thread would otherwise wait for vsync in
// the swap): the picture goes out at the same deadline, a late pose costs nothing but its
// freshness, and a tracker that stops publishing (a camera gone, a recording ended) makes
// the prediction unknown, so frames take the pose at their start as before. All times are
// seconds on the tracker's clock (kumite::now()).
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>

#include "kumite/common/time.hpp"

namespace kumite::app {

/// When the tracker's next pose will be readable, from the poses seen so far.
class PoseClock {
 public:
  /// Poses whose publish latency is kept (about 1 s at 60 Hz).
  static constexpr std::size_t kWindow = 64;
  /// Poses needed before predicting (a period and a latency worth trusting).
  static constexpr std::size_t kMinPoses = 8;
  /// No new pose for this many camera periods: the prediction is unknown.
  static constexpr double kStalePeriods = 3.0;

  /// A published pose: its frame-set number, camera time and publish time (s). The same
  /// frame again (polled twice) is ignored; so is a publish time before the camera time.
  void observe(std::uint64_t frame, Timestamp timestamp, Timestamp ready_at);
  /// When the pose after the newest seen is expected out (s): one period after the newest's
  /// camera time plus the latency; before `t` when it is overdue (it is still the one to
  /// look for: a late pose, or, if its set was dropped, the one after). nullopt while
  /// unknown: too few poses, or none for kStalePeriods periods before `t` (a camera gone).
  std::optional<Timestamp> next_ready(Timestamp t) const;
  double period_s() const { return period_s_; }    ///< s, camera period (0: not yet known)
  /// s, the publish latency expected: the least of the recent ones. A frame starts looking
  /// for the pose then and polls until it is out, so aiming early costs a few polls, aiming
  /// late costs every frame the difference.
  double latency_s() const { return aim_s_; }
  std::size_t poses() const { return seen_; }

 private:
  std::array<double, kWindow> latency_{};  // s, ring
  std::size_t seen_ = 0;
  std::uint64_t last_frame_ = 0;
  Timestamp last_timestamp_ = -1;
  double period_s_ = 0;
  double aim_s_ = 0;
  int outliers_ = 0;  // period samples in a row far from period_s_
};

/// When head poses come out, as the frame loop sees them (TrackingInput::pose_timing).
struct PoseTiming {
  std::uint64_t newest = 0;  ///< 1 + frame-set number of the newest head pose out (0: none yet)
  Timestamp newest_at = -1;  ///< s, its camera time (-1: none)
  /// s: when the one after it is expected out, possibly already past (overdue); nullopt:
  /// unknown (no tracker, too few poses yet, or none lately).
  std::optional<Timestamp> next_ready;
  double period_s = 0;  ///< s, between poses (camera period; 0: unknown)
};

/// When a frame may take its pose: from `first` (the pose expected out) to `last` (drawing
/// must start), s; the pose looked for is the `poses`-th after the newest out at the frame's
/// start (more than 1 when the camera is faster than the display and later ones still fit).
struct LatchWindow {
  Timestamp first = 0;
  Timestamp last = 0;
  int poses = 1;
};

/// Picks when a frame takes its pose (see the top of this file).
class FramePacer {
 public:
  /// Drawing times kept (2 s at 60 Hz): the budget follows the slowest of them.
  static constexpr std::size_t kDrawWindow = 120;
  /// Drawing times needed before latching late (until then: the slot's start).
  static constexpr std::size_t kMinDrawSamples = 10;
  /// The budget: the slowest recent drawing time times this, plus kDrawMargin_s.
  static constexpr double kDrawSafety = 1.25;
  static constexpr double kDrawMargin_s = 0.002;  ///< s: swap, scheduling
  /// s, taken after the predicted publish time (the pose is copied out a little later).
  static constexpr double kLatchMargin_s = 0.0005;
  /// s: the tracking latency the pose-age target allows (one camera period + 3 ms). A frame
  /// looks for the awaited pose until this long after its camera time, less
  /// kWakeAllowance_s: by then the pose it holds is nearly one period + 3 ms old, and
  /// waiting on for a late one risks taking an older pose than the target (the visitor
  /// would see the same picture: the frame's start would have taken the same pose, younger
  /// on the clock).
  static constexpr double kTrackingBudget_s = 0.003;
  /// s: the last look's poll interval and a wake-up's usual lateness, so the pose held when
  /// the frame stops looking is still inside the target when it is taken.
  static constexpr double kWakeAllowance_s = 0.001;

  explicit FramePacer(bool enabled = true) : enabled_(enabled) {}
  bool enabled() const { return enabled_; }

  /// When to take the pose in the frame [start, deadline) given the tracker's timing: from
  /// just after the last pose expected before drawing must start (or `start`, if it is due
  /// already) to kTrackingBudget_s - kWakeAllowance_s after that pose's camera time (when the newest's camera
  /// time and the period are known), but never past the last moment drawing fits before the
  /// deadline. nullopt (take it at `start`): latching off, the tracker's timing or the
  /// drawing time unknown, or the next pose expected too late.
  std::optional<LatchWindow> window(Timestamp start, Timestamp deadline, const PoseTiming& timing) const;
  /// One frame's drawing time: from taking the pose to the picture handed to the display (s).
  void drawn(double seconds);
  /// s, the drawing time latching leaves room for; nullopt until kMinDrawSamples are in.
  std::optional<double> draw_budget_s() const;

 private:
  bool enabled_;
  std::array<double, kDrawWindow> draw_{};  // s, ring
  std::size_t drawn_ = 0;
};

}  // namespace kumite::app
