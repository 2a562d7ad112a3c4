#pragma once
// The two ways the installation runs: headless (EGL, PNGs + frames.jsonl) and in windows
// (GLFW, stereo modes, the supervisor console). The presenters' library (kumite::app); the
// frame step they present is kumite::app_core, which has no GL.
#include <array>
#include <atomic>
#include <filesystem>
#include <optional>
#include <string_view>

#include "kumite/app/installation.hpp"
#include "kumite/app/run_control.hpp"
#include "kumite/app/swap_group.hpp"

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
class FrameSource;  // frame_source.hpp

/// The headless presenter loop: at most `options.frames` frames of `source` drawn off-screen
/// (PNGs every `save_every` frames and at each contact, named by the frame's number) and
/// logged to frames.jsonl, until the source ends or `options.stop`. Returns the exit code.
int present_headless(FrameSource& source, const HeadlessOptions& options);
/// A live run headless: the installation's step (LiveSource) through present_headless.
/// Renders `options.frames` frames. Returns the process exit code.
int run_headless(Installation& installation, const HeadlessOptions& options);

struct ReplayOptions;
struct ReplayReport;
/// A replay (replay_session) drawn headless: from `options.from` on, at most
/// `headless.frames` frames rendered into `headless.out` as a run would (PNGs every
/// `save_every` frames and at each contact, frames.jsonl). The report is the replay's.
int replay_headless(const std::filesystem::path& session, ReplayOptions options, const HeadlessOptions& headless,
                    ReplayReport& report);

struct WindowOptions {
  std::optional<double> seconds;   ///< s, stop after this long (none: until quit)
  bool console = true;             ///< open the supervisor console window
  std::optional<std::filesystem::path> screenshot;  ///< PNG of the first window at the end
  std::optional<std::filesystem::path> log;         ///< frames.jsonl
  /// Non-zero: the run ends at its next frame as if a window was closed (screenshot, log).
  const std::atomic<int>* stop = nullptr;
  /// Told of every frame drawn (watchdog pings, readiness, health report); none: nothing.
  RunMonitor* monitor = nullptr;
  /// A render node's hardware swap group ([[cluster.nodes]] swap_group): its windows join it
  /// where the display offers GLX_NV_swap_group, else one line says so; none: not asked.
  std::optional<SwapGroupRequest> swap_group;
};
/// The GLFW key code of a canonical key name (canonical_key_name in config.hpp), or nullopt:
/// the key map's names become codes only here, next to the windowed runner.
std::optional<int> glfw_key_code(std::string_view name);

/// A replay (replay_session) shown in the installation's windows and its console (buttons
/// greyed: the frames are the recording's), from `options.from` on; the quit key, closing a
/// window or `window.stop` ends it. Pass `options.real_time` for the recorded pace.
int replay_windows(const std::filesystem::path& session, ReplayOptions options, const WindowOptions& window,
                   ReplayReport& report);

/// The windowed presenter loop: `source`'s frames in the installation's windows (and the
/// console, where the source has an installation), until the source ends, quit, or `seconds`.
int present_windows(FrameSource& source, const WindowOptions& options);
/// Opens the windows and runs until quit (Escape / closing a window) or `seconds`.
/// Throws kumite::Error when a window or the requested stereo mode cannot be had.
int run_windows(Installation& installation, const WindowOptions& options);

}  // namespace kumite::app
