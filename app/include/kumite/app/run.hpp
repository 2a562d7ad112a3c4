#pragma once
// The two ways the installation runs: headless (EGL, PNGs + frames.jsonl) and in windows
// (GLFW, stereo modes, the supervisor console).
#include <array>
#include <filesystem>
#include <optional>

#include "kumite/app/installation.hpp"

namespace kumite::app {

struct HeadlessOptions {
  int frames = 60;                 ///< frames to render
  std::filesystem::path out;       ///< output folder (made if missing)
  int save_every = 1;              ///< write PNGs every K-th frame (frame % K == 0) and at each hit or miss (0 = none)
  std::optional<std::array<int, 2>> resolution;  ///< pixels, overrides every wall's
  /// Frame times: true = the display rate's steps on the run's clock, waiting for real time
  /// when rendering is faster (so a live tracker and the fighter see real time); false =
  /// simulated steps, as fast as rendering goes.
  bool real_time = true;
};
/// Renders `options.frames` frames. Returns the process exit code.
int run_headless(Installation& installation, const HeadlessOptions& options);

struct WindowOptions {
  std::optional<double> seconds;   ///< s, stop after this long (none: until quit)
  bool console = true;             ///< open the supervisor console window
  std::optional<std::filesystem::path> screenshot;  ///< PNG of the first window at the end
  std::optional<std::filesystem::path> log;         ///< frames.jsonl
};
/// Opens the windows and runs until quit (Escape / closing a window) or `seconds`.
/// Throws kumite::Error when a window or the requested stereo mode cannot be had.
int run_windows(Installation& installation, const WindowOptions& options);

/// Whether a display is there to open windows on ($DISPLAY or $WAYLAND_DISPLAY).
bool display_available();

}  // namespace kumite::app
