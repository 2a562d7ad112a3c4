// Headless runs: EGL surfaceless context, one framebuffer per wall, PNG per wall and eye.
#include <algorithm>
#include <chrono>
#include <thread>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gl.hpp"
#include "kumite/app/frame_log.hpp"
#include "kumite/app/headless.hpp"
#include "kumite/app/renderer.hpp"
#include "kumite/app/run.hpp"
#include "kumite/app/service.hpp"
#include "kumite/common/error.hpp"

namespace kumite::app {

int run_headless(Installation& inst, const HeadlessOptions& opt) {
  const auto& cfg = inst.config();
  make_output_folder(opt.out, "headless output folder");
  HeadlessContext context;
  spdlog::info("headless: {}", gl_description());
  Renderer renderer(inst.walls());
  std::vector<std::unique_ptr<OffscreenTarget>> targets;
  std::vector<std::string> names;
  for (const auto& w : cfg.walls) {
    const auto res = opt.resolution.value_or(w.resolution);
    targets.push_back(std::make_unique<OffscreenTarget>(res[0], res[1]));
    names.push_back(w.name);
  }
  const bool stereo = cfg.stereo.mode != StereoMode::mono;
  const char* eye_names[2] = {stereo ? "left" : "mono", "right"};
  FrameLog log(opt.out / "frames.jsonl",
               static_cast<std::uint64_t>(inst.config().frames_log_budget_mb * 1e6));
  // Two frames' images may wait for the writer; in real time, more are dropped (and said).
  PngWriter pngs(2 * targets.size() * (stereo ? 2 : 1), !opt.real_time);
  std::vector<std::uint8_t> pixels;
  const double step = 1.0 / cfg.display_rate_hz;
  const Timestamp t0 = now();
  inst.start(t0);
  double render_s = 0;
  const auto stopping = [&] { return opt.stop && opt.stop->load() != 0; };
  int frames = 0;  // rendered and logged
  for (int i = 0; i < opt.frames && !inst.quit_requested() && !stopping(); ++i) {
    // Real time: wait for the frame's slot; when rendering is slower than the display rate,
    // the frame is late and takes the present time (the fighter and tracker move on in real
    // time). Simulated: exact steps of 1/rate, as fast as rendering goes.
    Timestamp t = t0 + i * step;
    Timestamp shown = t;  // simulated: the frame is its own moment
    if (opt.real_time) {
      // Late latching (config late_latch) as in windows: the frame's pose just after the
      // tracker's next one is out, when this frame's work still fits before the next tick,
      // which is when it counts as shown (a window's next vsync).
      shown = t + step;
      sleep_until(t);
      t = std::max(t, inst.latch(now(), shown));
    }
    const FrameData& f = inst.step(t, shown);
    // Every K-th frame, and each strike's moment of contact (a hit or a miss), which a
    // strike-long run would otherwise rarely catch.
    const bool contact = std::any_of(f.events.begin(), f.events.end(),
                                     [](const FrameEvent& e) { return is_strike_outcome(e.type); });
    const bool save = opt.save_every > 0 && (i % opt.save_every == 0 || contact);
    for (std::size_t w = 0; w < targets.size(); ++w) {
      for (int e = 0; e < (stereo ? 2 : 1); ++e) {
        const Timestamp r0 = now();
        auto& target = *targets[w];
        target.bind();
        renderer.clear(0, 0, target.width(), target.height());
        renderer.draw(f.views[w][static_cast<std::size_t>(e)], f.items);
        if (!save) {
          glFlush();
          render_s += now() - r0;
          continue;
        }
        target.read(pixels);
        render_s += now() - r0;
        if (!pngs.push(opt.out / fmt::format("{}_{}_{:05}.png", names[w], eye_names[e], i), target.width(),
                       target.height(), std::move(pixels)) &&
            pngs.dropped() == 1)
          spdlog::warn("headless: frame {}: the PNG writer is behind, images are being dropped", i);
        pixels = {};
      }
    }
    for (const auto& e : pngs.take_errors()) spdlog::warn("headless: {}", e);
    log.write(f, inst.console(), names, stereo);
    frames = i + 1;
    if (opt.monitor) opt.monitor->frame_done(inst, f);
    if (opt.real_time && cfg.late_latch) {
      // The frame's whole work (GPU, reading PNG frames back, log) is what the latch must
      // leave room for before the next tick: a frame that saves PNGs holds the budget up for
      // the next 120 frames.
      glFinish();
      inst.drawn(now() - t);
    }
  }
  glFinish();
  if (opt.monitor) opt.monitor->stopping(stopping() ? fmt::format("signal {}", opt.stop->load()) : "run complete", &inst);
  const double wall_s = now() - t0;
  if (stopping())
    spdlog::info("headless: stopped (signal {}) after {} of {} frames; writing the PNGs queued", opt.stop->load(),
                 frames, opt.frames);
  pngs.flush();
  for (const auto& e : pngs.take_errors()) spdlog::warn("headless: {}", e);
  log.close();
  spdlog::info("headless: {} frames in {:.2f} s ({:.1f} ms/frame, GL {:.1f} ms of it); {} PNGs written -> {}",
               frames, wall_s, wall_s * 1e3 / std::max(frames, 1), render_s * 1e3 / std::max(frames, 1), pngs.written(),
               opt.out.string());
  log_retrieval_timing(inst);
  if (pngs.dropped() > 0)
    spdlog::warn("headless: {} PNGs not written: the writer was behind (real time never waits for it; "
                 "--save-every larger, or --simulated-time, writes them all)",
                 pngs.dropped());
  return 0;
}

bool display_available() {
  const char* x = std::getenv("DISPLAY");
  const char* w = std::getenv("WAYLAND_DISPLAY");
  return (x && *x) || (w && *w);
}

}  // namespace kumite::app
