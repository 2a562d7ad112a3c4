// Windowed runs: one GLFW window per [[windows]] entry (walls in its viewports, drawn in the
// stereo mode), and the supervisor console in a window of its own.
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <thread>

#include "gl.hpp"
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "console.hpp"
#include "kumite/app/frame_log.hpp"
#include "kumite/app/frame_source.hpp"
#include "kumite/app/headless.hpp"
#include "kumite/app/run.hpp"
#include "kumite/app/service.hpp"
#include "kumite/app/session.hpp"
#include "kumite/app/stereo.hpp"
#include "kumite/common/error.hpp"
#include "swap_group_glx.hpp"

namespace kumite::app {

namespace {

struct WindowSlot {
  GLFWwindow* window = nullptr;
  std::unique_ptr<Renderer> renderer;
  WindowConfig config;
  std::vector<std::size_t> walls;  ///< wall indices shown in it
};

/// What key callbacks need (set as every window's user pointer): the installation the keys
/// order, or (a replay: nothing to order) the config whose quit key ends it.
struct KeyContext {
  Installation* installation = nullptr;
  const InstallationConfig* replay_config = nullptr;
  bool quit = false;  ///< a replay's quit key was pressed
};

void on_key(GLFWwindow* w, int key, int, int action, int) {
  if (action != GLFW_PRESS) return;
  auto* ctx = static_cast<KeyContext*>(glfwGetWindowUserPointer(w));
  if (!ctx) return;
  if (ctx->installation) {
    handle_key(*ctx->installation, key);
  } else if (ctx->replay_config) {
    for (const auto& k : ctx->replay_config->keys)
      if (k.action.kind == KeyAction::Kind::quit && glfw_key_code(k.name) == key) ctx->quit = true;
  }
}

void glfw_error(int code, const char* text) { spdlog::debug("GLFW error 0x{:x}: {}", code, text); }

void context_hints(bool stereo) {
  glfwDefaultWindowHints();
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_STEREO, stereo ? GLFW_TRUE : GLFW_FALSE);
}

GLFWwindow* open_window(const WindowConfig& c, bool stereo, GLFWwindow* share) {
  context_hints(stereo);
  GLFWmonitor* monitor = nullptr;
  int width = c.size[0], height = c.size[1];
  int count = 0;
  GLFWmonitor** monitors = c.fullscreen ? glfwGetMonitors(&count) : nullptr;
  if (c.fullscreen && c.monitor >= count)  // a projector unplugged: show the wall anyway
    spdlog::error("window \"{}\": monitor {} does not exist ({} connected): opened as a {}x{} window instead",
                  c.name, c.monitor, count, width, height);
  if (c.fullscreen && c.monitor < count) {
    monitor = monitors[c.monitor];
    const GLFWvidmode* mode = glfwGetVideoMode(monitor);
    width = mode->width;
    height = mode->height;
  }
  GLFWwindow* w = glfwCreateWindow(width, height, ("kumite: " + c.name).c_str(), monitor, share);
  if (w && !monitor) glfwSetWindowPos(w, c.position[0], c.position[1]);
  return w;
}

/// A wall's viewport in the window's framebuffer: the config's pixels scaled from the
/// configured window size to the actual framebuffer (fullscreen, HiDPI).
Viewport wall_viewport(const WallConfig& wall, const WindowConfig& win, int fb_w, int fb_h) {
  if (!wall.viewport) return {0, 0, fb_w, fb_h};
  const auto& v = *wall.viewport;
  const double sx = static_cast<double>(fb_w) / win.size[0];
  const double sy = static_cast<double>(fb_h) / win.size[1];
  return {static_cast<int>(v[0] * sx), static_cast<int>(v[1] * sy), static_cast<int>(v[2] * sx),
          static_cast<int>(v[3] * sy)};
}

/// A refused stereo mode, located where it was asked for: the config's stereo.mode line, or
/// `kumite --stereo` (which drops that line).
Error stereo_error(const InstallationConfig& cfg, const std::string& why) {
  if (const int line = cfg.line_of("stereo.mode"); line > 0)
    return file_error("app", "no_stereo", cfg.file.string(), line, "stereo.mode", why);
  return Error("app", "no_stereo", fmt::format("--stereo {}: {}", to_string(cfg.stereo.mode), why));
}

void screenshot(GLFWwindow* w, const std::filesystem::path& path) {
  int fb_w = 0, fb_h = 0;
  glfwGetFramebufferSize(w, &fb_w, &fb_h);
  std::vector<std::uint8_t> rgba(static_cast<std::size_t>(fb_w) * fb_h * 4);
  glReadBuffer(GL_BACK);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, fb_w, fb_h, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
  const std::size_t row = static_cast<std::size_t>(fb_w) * 4;
  std::vector<std::uint8_t> flipped(rgba.size());
  for (int y = 0; y < fb_h; ++y)
    std::copy_n(rgba.data() + static_cast<std::size_t>(fb_h - 1 - y) * row, row,
                flipped.data() + static_cast<std::size_t>(y) * row);
  write_png(path, fb_w, fb_h, flipped);
  spdlog::info("screenshot {}", path.string());
}

/// The installation's windows: one per [[windows]] entry with its walls in the stereo mode,
/// and the supervisor console (optional). It sets GLFW up and ends it: one at a time.
class Windows {
 public:
  /// `keys`: every window's key and close target. Throws kumite::Error when a window or the
  /// stereo mode asked for cannot be had.
  Windows(const FrameSource& source, bool with_console, KeyContext* keys,
          const std::optional<SwapGroupRequest>& swap_group = std::nullopt)
      : cfg_(source.config()) {
    glfwSetErrorCallback(glfw_error);
    if (!glfwInit()) throw Error("app", "display", "cannot open the display (GLFW init failed): use --headless");
    try {
      open(source, with_console, keys);
      if (swap_group) {
        std::vector<GLFWwindow*> walls;
        for (const auto& s : slots_) walls.push_back(s.window);
        join_swap_group(walls, *swap_group);
      }
    } catch (...) {
      close();
      throw;
    }
  }
  ~Windows() { close(); }
  Windows(const Windows&) = delete;
  Windows& operator=(const Windows&) = delete;

  StereoMode mode() const { return mode_; }
  Console* console() { return console_.get(); }
  GLFWwindow* first() const { return slots_[0].window; }

  /// Draws `f` into every wall's viewport, `notice` across each (none: empty), (`finish`: and
  /// waits for the GPU).
  void draw(const FrameData& f, bool finish, std::string_view notice = {}) {
    for (auto& s : slots_) {
      glfwMakeContextCurrent(s.window);
      int fb_w = 0, fb_h = 0;
      glfwGetFramebufferSize(s.window, &fb_w, &fb_h);
      s.renderer->begin_frame(f.fighter);
      s.renderer->clear(0, 0, fb_w, fb_h);
      for (std::size_t w : s.walls) {
        const Viewport v = wall_viewport(cfg_.walls[w], s.config, fb_w, fb_h);
        draw_wall_stereo(*s.renderer, mode_, v, f.views[w], f.items);
        draw_notice_stereo(mode_, v, notice);
      }
      if (finish) glFinish();
    }
  }
  /// Shows what draw() drew (`wait_flip`: until the first window's flip is done).
  void swap(bool wait_flip) {
    for (auto& s : slots_) glfwSwapBuffers(s.window);
    if (wait_flip) {
      glfwMakeContextCurrent(slots_[0].window);
      glFinish();
    }
  }
  /// A window (a wall's or the console) asked to close since the last call.
  bool close_asked() {
    bool asked = false;
    const auto take = [&](GLFWwindow* w) {
      if (w && glfwWindowShouldClose(w)) {
        glfwSetWindowShouldClose(w, GLFW_FALSE);
        asked = true;
      }
    };
    if (console_) take(console_->window());
    for (auto& s : slots_) take(s.window);
    return asked;
  }

 private:
  void open(const FrameSource& source, bool with_console, KeyContext* keys) {
    mode_ = cfg_.stereo.mode;
    std::vector<WindowConfig> windows = cfg_.windows;
    if (windows.empty()) windows.push_back(WindowConfig{"main"});
    slots_.resize(windows.size());
    for (std::size_t i = 0; i < windows.size(); ++i) {
      auto& s = slots_[i];
      s.config = windows[i];
      GLFWwindow* share = i > 0 ? slots_[0].window : nullptr;
      s.window = open_window(s.config, mode_ == StereoMode::quad_buffer, share);
      if (!s.window && mode_ == StereoMode::quad_buffer) {
        const std::string why = fmt::format(
            "quad-buffer stereo: the display offers no stereo OpenGL context for window \"{}\" "
            "(Xvfb and most consumer GPUs have none)",
            s.config.name);
        if (!cfg_.stereo.allow_fallback)
          throw stereo_error(cfg_, why + "; set [stereo] allow_fallback = true or another mode");
        mode_ = cfg_.stereo.fallback;
        spdlog::warn("{}: falling back to {} (stereo.allow_fallback)", why, to_string(mode_));
        s.window = open_window(s.config, false, share);
      }
      if (!s.window)
        throw Error("app", "window", fmt::format("cannot open window \"{}\" with an OpenGL 3.3 core context", s.config.name));
      glfwMakeContextCurrent(s.window);
      if (mode_ == StereoMode::quad_buffer) {
        GLboolean stereo = GL_FALSE;
        glGetBooleanv(GL_STEREO, &stereo);
        if (!stereo)
          throw stereo_error(cfg_, fmt::format("quad-buffer: the context of window \"{}\" has no stereo buffers", s.config.name));
      }
      glfwSwapInterval(i == 0 ? 1 : 0);
      glfwSetWindowUserPointer(s.window, keys);
      glfwSetKeyCallback(s.window, on_key);
      s.renderer = std::make_unique<Renderer>(source.walls());
      s.renderer->configure(cfg_);
      spdlog::info("window \"{}\": {} ({} stereo)", s.config.name, gl_description(), to_string(mode_));
    }
    for (std::size_t w = 0; w < cfg_.walls.size(); ++w) {
      const int i = cfg_.window_of(w);
      slots_[static_cast<std::size_t>(std::max(0, i))].walls.push_back(w);
    }
    if (with_console) {
      context_hints(false);
      // [console] size and position: apart from the walls' windows (a console over the front
      // wall shows on the wall).
      const auto& cc = cfg_.console;
      GLFWwindow* cw = glfwCreateWindow(cc.size[0], cc.size[1], "kumite: supervisor console", nullptr, nullptr);
      if (!cw) throw Error("app", "window", "cannot open the supervisor console window");
      if (cc.position) glfwSetWindowPos(cw, (*cc.position)[0], (*cc.position)[1]);
      glfwSetWindowUserPointer(cw, keys);
      glfwSetKeyCallback(cw, on_key);  // before ImGui, which chains to it
      console_ = std::make_unique<Console>(cw, mode_);
    }
  }
  void close() {
    console_.reset();
    for (auto& s : slots_) {
      if (!s.window) continue;
      glfwMakeContextCurrent(s.window);
      s.renderer.reset();
      glfwDestroyWindow(s.window);
    }
    slots_.clear();
    glfwTerminate();
  }

  const InstallationConfig& cfg_;
  StereoMode mode_ = StereoMode::mono;
  std::vector<WindowSlot> slots_;
  std::unique_ptr<Console> console_;
};

}  // namespace

int present_windows(FrameSource& source, const WindowOptions& opt) {
  const auto& cfg = source.config();
  // Keys order the installation the frames are stepped by; a recording's or the network's
  // frames take no orders: their quit key (or closing a window) ends the run.
  KeyContext keys{source.orders(), source.orders() ? nullptr : &cfg};
  Windows windows(source, opt.console && source.installation() != nullptr, &keys, opt.swap_group);
  const StereoMode mode = windows.mode();

  std::unique_ptr<FrameLog> log;
  std::vector<std::string> names;
  for (const auto& w : cfg.walls) names.push_back(w.name);
  if (opt.log) log = std::make_unique<FrameLog>(*opt.log, static_cast<std::uint64_t>(cfg.frames_log_budget_mb * 1e6));

  const bool finish = source.wait_for_gpu();
  const auto stopped = [&] { return opt.stop && opt.stop->load() != 0; };  // SIGINT/SIGTERM: as a quit
  source.begin();
  FrameData kept;  // the last frame shown, for a screenshot taken after the source ended
  bool kept_any = false, shot = false;
  bool done = false;
  while (!done) {
    glfwPollEvents();
    const FrameData* fp = source.next();
    if (!fp) break;
    const FrameData& f = *fp;
    windows.draw(f, finish, source.notice());
    source.drawn();
    const bool last = source.ending() || stopped() || keys.quit || (opt.seconds && f.time_s >= *opt.seconds);
    if (last && opt.screenshot) {
      glfwMakeContextCurrent(windows.first());
      screenshot(windows.first(), *opt.screenshot);
      shot = true;
    } else if (opt.screenshot) {
      kept = f;
      kept_any = true;
    }
    // Drivers that queue the swap return at once: wait for the flip (late latching), so the
    // swap's return is the vsync and the next frame's drawing time does not include this one's.
    windows.swap(finish);
    const Timestamp swapped = now();
    if (Console* console = windows.console()) {
      console->frame(*source.installation(), f, source.orders());
      if (last && opt.screenshot) {
        auto p = *opt.screenshot;
        screenshot(console->window(), p.replace_filename(p.stem().string() + "-console.png"));
      }
      console->swap();
    }
    if (log && !source.repeated()) log->write(f, source.console(f), names, mode != StereoMode::mono);
    if (opt.monitor && source.installation()) opt.monitor->frame_done(*source.installation(), f);
    // Closing the console (or a wall window) ends the run: the live show's after a second
    // close within [console] quit_confirm_s (a stray click ends no show).
    if (windows.close_asked() && source.close_asked(now())) done = true;
    if (keys.quit) done = true;
    if (last) done = true;
    if (done) source.stop();
    source.shown(swapped);
  }
  // A source that ended by itself (a replay's last frame): the last frame shown, drawn again
  // for the screenshot (the windows' back buffers hold nothing after a swap).
  if (opt.screenshot && !shot && kept_any) {
    windows.draw(kept, true);
    glfwMakeContextCurrent(windows.first());
    screenshot(windows.first(), *opt.screenshot);
    if (Console* console = windows.console()) {
      console->frame(*source.installation(), kept, source.orders());
      auto p = *opt.screenshot;
      screenshot(console->window(), p.replace_filename(p.stem().string() + "-console.png"));
    }
  }
  if (opt.monitor)
    opt.monitor->stopping(stopped() ? fmt::format("signal {}", opt.stop->load()) : "quit", source.installation());
  if (log) log->close();
  if (stopped()) spdlog::info("windows: stopped (signal {})", opt.stop->load());
  return 0;
}

int run_windows(Installation& inst, const WindowOptions& opt) {
  LiveSource source(inst, LivePacing::display);
  const int rc = present_windows(source, opt);
  log_retrieval_timing(inst);
  log_spar_summary(inst);
  return rc;
}

int replay_windows(const std::filesystem::path& session, ReplayOptions options, const WindowOptions& opt,
                   ReplayReport& report) {
  SessionSource source(session, std::move(options));
  {
    WindowOptions wo = opt;
    wo.monitor = nullptr;
    wo.seconds.reset();
    present_windows(source, wo);
  }
  report = source.finish();
  return 0;
}

}  // namespace kumite::app
