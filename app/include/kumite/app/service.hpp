#pragma once
// Running all day with nobody at a terminal: the service manager told the show is up and that
// its frame loop still turns (systemd's sd_notify: READY=1, WATCHDOG=1, STATUS=, STOPPING=1),
// and a health report on disk that staff read from anywhere (`kumite status`, or `cat` over
// ssh). Both runners call RunMonitor::frame_done() once per frame drawn; everything slow (the
// JSON, the file) happens on the monitor's own thread.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "kumite/app/installation.hpp"

namespace kumite::app {

/// systemd's notification protocol through libsystemd. Without $NOTIFY_SOCKET (not run by
/// systemd) every call does nothing.
class ServiceNotifier {
 public:
  ServiceNotifier();
  /// $NOTIFY_SOCKET is set: a service manager listens.
  bool enabled() const { return enabled_; }
  /// s, the watchdog timeout asked for ($WATCHDOG_USEC for this pid); none: no watchdog.
  std::optional<double> watchdog_s() const { return watchdog_s_; }
  /// s, the interval between WATCHDOG=1 pings: a quarter of the timeout (systemd asks for
  /// less than half), so two late pings still land in time.
  double ping_interval_s() const { return watchdog_s_ ? *watchdog_s_ / 4 : 0; }
  /// Sends `state` ("READY=1\nSTATUS=...", ...); false when not enabled or it failed.
  bool notify(const std::string& state) const;

 private:
  bool enabled_ = false;
  std::optional<double> watchdog_s_;
};

/// What the run is, for the health report.
struct RunInfo {
  std::filesystem::path config;            ///< the installation file
  std::string mode;                        ///< "headless" or "windows"
  std::optional<std::filesystem::path> frames_log;  ///< frames.jsonl being written
  std::optional<std::filesystem::path> session;     ///< `--record` folder
};

struct RunMonitorOptions {
  /// The health report's file (JSON, rewritten atomically about every `health_interval_s`);
  /// none: no report.
  std::optional<std::filesystem::path> health_file;
  double health_interval_s = 1.0;
  /// Test aid (kumite --debug-hang-after-frames): after this many frames the frame loop stops
  /// advancing, as a hung render or tracker would, until a stop signal; 0 = never.
  std::uint64_t debug_hang_after_frames = 0;
  /// The run's stop flag (stop_on_signals()); a debug hang ends when it is set.
  const std::atomic<int>* stop = nullptr;
  /// s, now() when the process started (main's first line): uptime and the time to READY count
  /// from it; none: from the monitor's construction.
  std::optional<Timestamp> process_started;
};

/// One run's watchdog pings, readiness and health report.
class RunMonitor {
 public:
  RunMonitor(RunInfo info, RunMonitorOptions options);
  /// Writes the report's last state ("stopped") and says STOPPING=1.
  ~RunMonitor();
  RunMonitor(const RunMonitor&) = delete;
  RunMonitor& operator=(const RunMonitor&) = delete;

  /// Once per frame, after it is drawn (its picture handed to the display or written). Says
  /// READY=1 the first time the show is up (a frame drawn and tracking past any preload),
  /// WATCHDOG=1 when a ping is due, STATUS= every few seconds; hands the report's thread a
  /// copy of the state when it asks for one. Cheap: no allocation on most frames.
  void frame_done(const Installation& installation, const FrameData& frame);
  /// The run ends (`why`: "quit", "signal 15", ...): STOPPING=1 and a final report (of the
  /// installation's last frame, when given).
  void stopping(const std::string& why, const Installation* installation = nullptr);

  const ServiceNotifier& notifier() const { return notifier_; }
  bool ready_sent() const { return ready_sent_; }

 private:
  struct Snapshot;
  void write_loop();
  void take_snapshot(const Installation& installation, const FrameData& frame, Snapshot& s) const;
  nlohmann::json to_json(const Snapshot& s) const;
  void write_report(const Snapshot& s);

  RunInfo info_;
  RunMonitorOptions options_;
  ServiceNotifier notifier_;
  double started_wall_ = 0;   ///< s, Unix time of the start (process_started, else construction)
  Timestamp started_ = 0;     ///< s, now() of the start
  bool ready_sent_ = false;
  Timestamp last_ping_ = -1, last_status_ = -1;
  std::uint64_t frames_ = 0;
  std::map<std::string, std::uint64_t> events_;  ///< events by type since the start
  std::string last_problem_;
  double last_problem_wall_ = 0;  ///< s, Unix time it was first seen
  std::size_t last_problems_count_ = 0;

  // The report's thread asks (want_) and the frame loop fills `pending_` at its next frame.
  std::unique_ptr<Snapshot> pending_;
  std::atomic<bool> want_{false};
  std::mutex mutex_;
  std::condition_variable cv_;
  bool have_ = false, closing_ = false;
  std::string stop_reason_;
  std::thread writer_;
  bool stopped_ = false;
};

/// `kumite status`: reads a health report and returns one line for people and whether all is
/// well (fresh and no problem). `now_unix_s` is the present (Unix time).
struct StatusLine {
  std::string text;
  int exit_code = 0;  ///< 0 all well; 1 problems or stopped; 2 stale; 3 unreadable
};
StatusLine read_status(const std::filesystem::path& file, double now_unix_s);

/// Unix time, s (the health report's clock: comparable across processes and machines).
double unix_now();

}  // namespace kumite::app
