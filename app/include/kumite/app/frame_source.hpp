#pragma once
// Where the frames a presenter draws come from. One presenter loop (headless EGL or windows,
// run.hpp) draws from a FrameSource, whichever it is:
//   LiveSource     the installation's own step, paced by its clock (a live run);
//   SessionSource  a recorded session re-run (replay_session), frame by frame;
//   a render node  the cluster master's frame states over the network (kumite::cluster).
// The loop is: begin(), then each frame next() -> draw -> drawn() -> show -> shown(). A source is used from one thread.
#include <atomic>
#include <condition_variable>
#include <exception>
#include <filesystem>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <thread>

#include "kumite/app/installation.hpp"
#include "kumite/app/session.hpp"

namespace kumite::app {

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  /// The installation file the frames are drawn with (walls, windows, stereo).
  virtual const InstallationConfig& config() const = 0;
  /// The walls' fixed geometry (the renderer's walls).
  virtual std::span<const WallFrame> walls() const = 0;
  /// The presenter is set up (windows open, contexts made): the source starts its clock.
  virtual void begin() {}
  /// The next frame to draw, once it is due (may wait: pacing, the network); nullptr: the
  /// source is over. The frame stays valid until the next call.
  virtual const FrameData* next() = 0;
  /// The frame's console text (the frame log's console fields).
  virtual ConsoleState console(const FrameData& frame) const = 0;
  /// The frame is drawn (and, when wait_for_gpu(), the GPU is done): returns when it may be
  /// shown. A live step measures its drawing time here; a render node waits for the GO.
  virtual void drawn() {}
  /// The frame was shown at `at` (s, the clock of now()): a display-paced source waits here
  /// for its next frame's slot.
  virtual void shown(Timestamp /*at*/) {}
  /// The presenter should wait for the GPU before drawn() (late latching, a swap barrier).
  virtual bool wait_for_gpu() const { return false; }
  /// The installation the frames are stepped by, which keys and the console's buttons order
  /// (nullptr: a recording or the network: nothing to order).
  virtual Installation* orders() { return nullptr; }
  /// The installation whose state the console shows (nullptr: none, no console).
  virtual const Installation* installation() const { return nullptr; }
  /// The frame just returned is the last (the installation's quit): drawn, then the run ends.
  virtual bool ending() const { return false; }
  /// A window asked to close at `at`: whether that ends the run (the live show: the quit key's
  /// two presses; a replay: at once).
  virtual bool close_asked(Timestamp /*at*/) { return true; }
  /// The frame just returned is the one before again (a render node waiting for its master
  /// keeps its picture): drawn, not logged.
  virtual bool repeated() const { return false; }
  /// A line every wall shows over the frame just returned, in letters across its middle (a
  /// render node waiting for its master: "waiting for master"); empty: none.
  virtual std::string_view notice() const { return {}; }
  /// The viewer ends the run after the frame just returned (no more frames are drawn).
  virtual void stop() {}
};

/// How a live run's frames are timed.
enum class LivePacing : std::uint8_t {
  /// Headless, the display rate's steps on the run's clock, waiting for real time.
  real_time,
  /// Headless, exact steps of 1/rate as fast as drawing goes (a live camera still holds
  /// it to real time).
  simulated,
  /// Windows: each frame starts at the vsync its predecessor's swap waited for (shown()).
  display,
};

/// The installation's own frame step as a source.
class LiveSource final : public FrameSource {
 public:
  LiveSource(Installation& installation, LivePacing pacing);
  /// Starts the installation (Installation::start) at the pacing's first moment.
  void begin() override;
  const InstallationConfig& config() const override { return inst_.config(); }
  std::span<const WallFrame> walls() const override { return inst_.walls(); }
  const FrameData* next() override;
  ConsoleState console(const FrameData& frame) const override { return inst_.console(frame); }
  void drawn() override;
  void shown(Timestamp at) override;
  bool wait_for_gpu() const override { return inst_.config().late_latch; }
  Installation* orders() override { return &inst_; }
  const Installation* installation() const override { return &inst_; }
  bool ending() const override { return inst_.quit_requested(); }
  bool close_asked(Timestamp at) override { return inst_.quit_key(at); }
  /// s: the run's first moment (the clock's, or the simulated clock's start).
  Timestamp start() const { return t0_; }

 private:
  Installation& inst_;
  LivePacing pacing_;
  double period_ = 0;
  Timestamp t0_ = 0, slot_ = 0, t_ = 0;
  std::uint64_t i_ = 0;
};

/// A recorded session re-run frame by frame (replay_session on a thread of its own, handing
/// each frame over and waiting until the presenter has taken the next one: the replay's
/// installation is never used by both threads at once). The report is the replay's.
class SessionSource final : public FrameSource {
 public:
  /// Starts the replay and waits for its installation. Throws what replay_session throws
  /// before its first frame (a session that cannot be replayed).
  SessionSource(const std::filesystem::path& session, ReplayOptions options);
  /// Lets the replay run to its end without presenting (its frames are still compared).
  ~SessionSource() override;
  SessionSource(const SessionSource&) = delete;
  SessionSource& operator=(const SessionSource&) = delete;

  const InstallationConfig& config() const override { return inst_->config(); }
  std::span<const WallFrame> walls() const override { return inst_->walls(); }
  const FrameData* next() override;
  ConsoleState console(const FrameData& frame) const override { return inst_->console(frame); }
  const Installation* installation() const override { return inst_; }
  void stop() override { stop_ = true; }
  /// Runs the replay to its end (frames not presented are still replayed and compared) and
  /// returns its report. Rethrows what replay_session threw.
  ReplayReport finish();

 private:
  enum class Turn { replay, presenter };
  void hand_over(const FrameData* frame, bool end);
  std::mutex m_;
  std::condition_variable cv_;
  Turn turn_ = Turn::replay;
  const Installation* inst_ = nullptr;
  const FrameData* frame_ = nullptr;
  bool ended_ = false;
  bool first_taken_ = false;
  bool detached_ = false;  ///< the presenter takes no more frames
  std::atomic<bool> stop_{false};
  std::exception_ptr error_;
  ReplayReport report_;
  std::thread thread_;
};

}  // namespace kumite::app
