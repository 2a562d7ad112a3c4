#include "kumite/app/frame_source.hpp"

#include <algorithm>

#include "kumite/common/error.hpp"

namespace kumite::app {

namespace {
/// s: where a simulated clock of its own starts (exactly representable, > 0: a time of 0 means
/// "none yet" in places).
constexpr Timestamp kSimulatedClockStart_s = 1.0;
/// s: a swap that returns this close before the next tick is taken to have waited for vsync.
constexpr double kVsyncTolerance_s = 0.001;
}  // namespace

LiveSource::LiveSource(Installation& inst, LivePacing pacing) : inst_(inst), pacing_(pacing) {
  period_ = 1.0 / inst.config().display_rate_hz;
}

void LiveSource::begin() {
  Installation& inst = inst_;
  // Simulated time with nothing on the wall clock (no tracker, or one that follows the frames'
  // clock): the clock starts at a fixed second, not at the machine's uptime, so every time the
  // frames compute (t - start, a pose's age) rounds the same on any machine at any uptime.
  const bool own_clock =
      pacing_ == LivePacing::simulated && (!inst.has_tracker() || inst.tracking_follows_frames());
  t0_ = own_clock ? kSimulatedClockStart_s : now();
  slot_ = t0_;
  inst.start(t0_);
}

const FrameData* LiveSource::next() {
  if (inst_.quit_requested()) return nullptr;
  const Timestamp step = period_;
  switch (pacing_) {
    case LivePacing::simulated: {
      // Exact steps of 1/rate, as fast as drawing goes; the frame is its own moment. A poses
      // file or a camera recording follows the frames' clock (the tracking input hands over
      // what is due by t). Live cameras stamp their poses on the real clock: with them
      // simulated time never runs ahead of it (frames faster than the display rate would find
      // every pose too old).
      t_ = t0_ + static_cast<double>(i_) * step;
      if (inst_.has_tracker() && !inst_.tracking_follows_frames()) sleep_until(t_);
      ++i_;
      return &inst_.step(t_, t_);
    }
    case LivePacing::real_time: {
      // Wait for the frame's slot; when drawing is slower than the display rate the frame is
      // late and takes the present time. Late latching (config late_latch): the frame's pose
      // just after the tracker's next one is out, when this frame's work still fits before
      // the next tick, which is when it counts as shown (a window's next vsync).
      t_ = t0_ + static_cast<double>(i_) * step;
      const Timestamp shown = t_ + step;
      sleep_until(t_);
      t_ = std::max(t_, inst_.latch(now(), shown));
      ++i_;
      return &inst_.step(t_, shown);
    }
    case LivePacing::display: {
      // The picture is seen at the next vsync: the head is predicted to then; late latching
      // takes the pose just after the tracker's next one if drawing still fits before it.
      t_ = inst_.latch(now(), slot_ + period_);
      ++i_;
      return &inst_.step(t_, slot_ + period_);
    }
  }
  return nullptr;
}

void LiveSource::drawn() {
  // The frame's whole work (GPU, reading PNGs back, the log) is what the latch must leave room
  // for before the next tick.
  if (pacing_ == LivePacing::display || (pacing_ == LivePacing::real_time && inst_.config().late_latch))
    inst_.drawn(now() - t_);
}

void LiveSource::shown(Timestamp swapped) {
  if (pacing_ != LivePacing::display) return;
  // The next frame starts at the vsync the swap waited for: a swap that came back at most
  // kVsyncTolerance_s before the next tick did wait for one (a display a little faster than
  // display_rate_hz: anchored to its vsync, the ticks do not drift away from it). One that
  // came back earlier did not (Xvfb, no vsync): the next tick holds the display rate. Late
  // frames start at once.
  slot_ = swapped > slot_ + period_ - kVsyncTolerance_s ? swapped : slot_ + period_;
  sleep_until(slot_);
}

// ---- a recorded session -------------------------------------------------------------------

SessionSource::SessionSource(const std::filesystem::path& session, ReplayOptions options) {
  const auto inner = options.on_frame;
  options.on_start = [this](const Installation& inst) {
    std::unique_lock lock(m_);
    inst_ = &inst;
  };
  options.on_frame = [this, inner](const FrameData& f) {
    if (inner) inner(f);
    hand_over(&f, false);
  };
  const auto inner_stop = options.stop_requested;
  options.stop_requested = [this, inner_stop] { return stop_.load() || (inner_stop && inner_stop()); };
  options.on_end = [this](const Installation&) { hand_over(nullptr, true); };
  thread_ = std::thread([this, session, options] {
    try {
      report_ = replay_session(session, options);
    } catch (...) {
      error_ = std::current_exception();
    }
    std::unique_lock lock(m_);
    ended_ = true;
    frame_ = nullptr;
    inst_ = nullptr;
    turn_ = Turn::presenter;
    cv_.notify_all();
  });
  // The replay's installation (made inside replay_session) is there at its first frame or end:
  // wait for that turn; a session that cannot be replayed ends the thread with its error.
  std::unique_lock lock(m_);
  cv_.wait(lock, [&] { return turn_ == Turn::presenter; });
  if (!inst_) {
    lock.unlock();
    thread_.join();
    if (error_) std::rethrow_exception(error_);
    throw Error("replay", "session", session.string() + ": no frames to replay");
  }
}

void SessionSource::hand_over(const FrameData* frame, bool end) {
  std::unique_lock lock(m_);
  if (detached_) return;
  frame_ = frame;
  ended_ = end;
  turn_ = Turn::presenter;
  cv_.notify_all();
  cv_.wait(lock, [&] { return turn_ == Turn::replay || detached_; });
}

const FrameData* SessionSource::next() {
  std::unique_lock lock(m_);
  if (detached_) return nullptr;
  // The frame handed over at construction is the first: taken as it is.
  if (!first_taken_) {
    first_taken_ = true;
  } else {
    if (ended_) return nullptr;
    turn_ = Turn::replay;
    cv_.notify_all();
    cv_.wait(lock, [&] { return turn_ == Turn::presenter; });
  }
  return ended_ ? nullptr : frame_;
}

ReplayReport SessionSource::finish() {
  {
    std::unique_lock lock(m_);
    detached_ = true;
    turn_ = Turn::replay;
    cv_.notify_all();
  }
  if (thread_.joinable()) thread_.join();
  if (error_) {
    auto e = error_;
    error_ = nullptr;
    std::rethrow_exception(e);
  }
  return report_;
}

SessionSource::~SessionSource() {
  try {
    if (thread_.joinable()) finish();
  } catch (...) {
  }
}

}  // namespace kumite::app
