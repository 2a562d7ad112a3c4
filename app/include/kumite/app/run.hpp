#pragma once
// The two ways the installation runs: headless (EGL, PNGs + frames.jsonl) and in windows
// (GLFW, stereo modes, the supervisor console).
#include <array>
#include <atomic>
#include <filesystem>
#include <optional>
#include <string_view>

#include "kumite/app/installation.hpp"

namespace kumite::app {

class RunMonitor;  // service.hpp

struct HeadlessOptions {
  int frames = 60;                 ///< frames to render
  std::filesystem::path out;       ///< output folder (made if missing)
  int save_every = 1;              ///< write PNGs every K-th frame (frame % K == 0) and at each hit or miss (0 = none)
  std::optional<std::array<int, 2>> resolution;  ///< pixels, overrides every wall's
  /// Frame times: true = the display rate's steps on the run's clock, waiting for real time
  /// when rendering is faster (so a live tracker and the fighter see real time); false =
  /// simulated steps, as fast as rendering goes.
  bool real_time = true;
  /// Non-zero (set from a signal handler or another thread): the run ends at its next frame,
  /// cleanly (PNG queue flushed, frames.jsonl closed), and run_headless returns 0.
  const std::atomic<int>* stop = nullptr;
  /// Told of every frame drawn (watchdog pings, readiness, health report); none: nothing.
  RunMonitor* monitor = nullptr;
};
/// Renders `options.frames` frames. Returns the process exit code.
int run_headless(Installation& installation, const HeadlessOptions& options);

struct WindowOptions {
  std::optional<double> seconds;   ///< s, stop after this long (none: until quit)
  bool console = true;             ///< open the supervisor console window
  std::optional<std::filesystem::path> screenshot;  ///< PNG of the first window at the end
  std::optional<std::filesystem::path> log;         ///< frames.jsonl
  /// Non-zero: the run ends at its next frame as if a window was closed (screenshot, log).
  const std::atomic<int>* stop = nullptr;
  /// Told of every frame drawn (watchdog pings, readiness, health report); none: nothing.
  RunMonitor* monitor = nullptr;
};
/// Opens the windows and runs until quit (Escape / closing a window) or `seconds`.
/// Throws kumite::Error when a window or the requested stereo mode cannot be had.
int run_windows(Installation& installation, const WindowOptions& options);

/// From the first call on, SIGINT and SIGTERM no longer kill the process: they store their
/// number in the returned flag (pass it as the options' `stop`), so the run ends at its next
/// frame with its outputs complete. A second such signal kills the process at once (a run
/// stuck in start-up or in a driver can still be interrupted).
const std::atomic<int>& stop_on_signals();

/// Creates `dir` and its missing parents (or checks an existing one is writable), else throws
/// kumite::Error("io", "folder") in one line: "<what>: <why>" (`what` e.g. "--out out/x",
/// why: a file in the way, no permission).
void make_output_folder(const std::filesystem::path& dir, std::string_view what);

/// One line at the end of a run: strike plans asked for, and how many updates had to wait
/// for the retrieval worker (content::kRetrievalDelayUpdates).
void log_retrieval_timing(const Installation& installation);

/// Whether a display is there to open windows on ($DISPLAY or $WAYLAND_DISPLAY).
bool display_available();

}  // namespace kumite::app
