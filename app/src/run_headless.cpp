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
#include "kumite/app/session.hpp"
#include "kumite/common/error.hpp"

namespace kumite::app {

/// What a headless run or a rendered replay does with each frame: draw every wall and eye
/// off-screen, write PNGs of the frames asked for (every K-th and each strike's contact) on
/// the writer thread, log the frame to frames.jsonl.
class HeadlessPresenter {
 public:
  HeadlessPresenter(const Installation& inst, const std::filesystem::path& out, int save_every,
                    std::optional<std::array<int, 2>> resolution, bool wait_for_pngs)
      : out_(out), save_every_(save_every) {
    const auto& cfg = inst.config();
    make_output_folder(out, "headless output folder");
    context_ = std::make_unique<HeadlessContext>();
    spdlog::info("headless: {}", gl_description());
    renderer_ = std::make_unique<Renderer>(inst.walls());
    renderer_->configure(cfg);
    for (const auto& w : cfg.walls) {
      const auto res = resolution.value_or(w.resolution);
      targets_.push_back(std::make_unique<OffscreenTarget>(res[0], res[1]));
      names_.push_back(w.name);
    }
    stereo_ = cfg.stereo.mode != StereoMode::mono;
    log_ = std::make_unique<FrameLog>(out / "frames.jsonl", static_cast<std::uint64_t>(cfg.frames_log_budget_mb * 1e6));
    // Two frames' images may wait for the writer; in real time, more are dropped (and said).
    pngs_ = std::make_unique<PngWriter>(2 * targets_.size() * (stereo_ ? 2 : 1), wait_for_pngs);
  }

  /// Draws frame `i` (its number in the PNG names) and logs it.
  void present(const Installation& inst, const FrameData& f, int i) {
    const char* eye_names[2] = {stereo_ ? "left" : "mono", "right"};
    // Every K-th frame, and each strike's moment of contact (a hit or a miss), which a
    // strike-long run would otherwise rarely catch.
    const bool contact = std::any_of(f.events.begin(), f.events.end(),
                                     [](const FrameEvent& e) { return is_strike_outcome(e.type); });
    const bool save = save_every_ > 0 && (i % save_every_ == 0 || contact);
    {
      const Timestamp r0 = now();
      renderer_->begin_frame(f.fighter);  // the body's retarget and palette: once for all walls
      render_s_ += now() - r0;
    }
    for (std::size_t w = 0; w < targets_.size(); ++w) {
      for (int e = 0; e < (stereo_ ? 2 : 1); ++e) {
        const Timestamp r0 = now();
        auto& target = *targets_[w];
        target.bind();
        renderer_->clear(0, 0, target.width(), target.height());
        renderer_->draw(f.views[w][static_cast<std::size_t>(e)], f.items);
        if (!save) {
          glFlush();
          render_s_ += now() - r0;
          continue;
        }
        target.read(pixels_);
        render_s_ += now() - r0;
        if (!pngs_->push(out_ / fmt::format("{}_{}_{:05}.png", names_[w], eye_names[e], i), target.width(),
                         target.height(), std::move(pixels_)) &&
            pngs_->dropped() == 1)
          spdlog::warn("headless: frame {}: the PNG writer is behind, images are being dropped", i);
        pixels_ = {};
      }
    }
    for (const auto& e : pngs_->take_errors()) spdlog::warn("headless: {}", e);
    log_->write(f, inst.console(f), names_, stereo_);
    // Nothing queued behind the frame just drawn: without a swap chain nothing else throttles
    // the driver, and Mesa's software renderer (the headless demo's, CI's) keeps every scene it
    // ever had to queue when its threads fell behind (the soak's RSS stepped up whenever the
    // machine got loaded: 263 -> 384 MB). A fence per frame (one frame in flight) did the same,
    // but a soak with it crashed after 40 minutes in malloc (heap corruption, cause not found):
    // glFinish is the path every other frame loop here takes (late latch, windows).
    glFinish();
  }

  /// Writes what is queued and closes the log. Throws kumite::Error on a failed write.
  void finish() {
    glFinish();
    pngs_->flush();
    for (const auto& e : pngs_->take_errors()) spdlog::warn("headless: {}", e);
    log_->close();
  }
  double render_s() const { return render_s_; }
  const PngWriter& pngs() const { return *pngs_; }

 private:
  std::filesystem::path out_;
  int save_every_ = 1;
  std::unique_ptr<HeadlessContext> context_;
  std::unique_ptr<Renderer> renderer_;
  std::vector<std::unique_ptr<OffscreenTarget>> targets_;
  std::vector<std::string> names_;
  bool stereo_ = false;
  std::unique_ptr<FrameLog> log_;
  std::unique_ptr<PngWriter> pngs_;
  std::vector<std::uint8_t> pixels_;
  double render_s_ = 0;
};

namespace {
/// s: where a simulated clock of its own starts (exactly representable, > 0: a time of 0 means
/// "none yet" in places).
constexpr Timestamp kSimulatedClockStart_s = 1.0;
}  // namespace

int run_headless(Installation& inst, const HeadlessOptions& opt) {
  const auto& cfg = inst.config();
  HeadlessPresenter presenter(inst, opt.out, opt.save_every, opt.resolution, !opt.real_time);
  const double step = 1.0 / cfg.display_rate_hz;
  // Simulated time with nothing on the wall clock (no tracker, or one that follows the frames'
  // clock): the clock starts at a fixed second, not at the machine's uptime, so every time the
  // frames compute (t - start, a pose's age) rounds the same on any machine at any uptime.
  const bool own_clock = !opt.real_time && (!inst.has_tracker() || inst.tracking_follows_frames());
  const Timestamp wall0 = now();
  const Timestamp t0 = own_clock ? kSimulatedClockStart_s : wall0;
  inst.start(t0);
  const auto stopping = [&] { return opt.stop && opt.stop->load() != 0; };
  int frames = 0;  // rendered and logged
  for (int i = 0; i < opt.frames && !inst.quit_requested() && !stopping(); ++i) {
    // Real time: wait for the frame's slot; when rendering is slower than the display rate,
    // the frame is late and takes the present time (the fighter and tracker move on in real
    // time). Simulated: exact steps of 1/rate, as fast as rendering goes.
    Timestamp t = t0 + i * step;
    Timestamp shown = t;  // simulated: the frame is its own moment
    // Simulated time: a poses file or a camera recording follows the frames' clock (the
    // tracking input hands over what is due by t), so frames go as fast as rendering goes.
    // Live cameras stamp their poses on the real clock: with them simulated time never runs
    // ahead of it (frames faster than the display rate would find every pose too old).
    if (!opt.real_time && inst.has_tracker() && !inst.tracking_follows_frames()) sleep_until(t);
    if (opt.real_time) {
      // Late latching (config late_latch) as in windows: the frame's pose just after the
      // tracker's next one is out, when this frame's work still fits before the next tick,
      // which is when it counts as shown (a window's next vsync).
      shown = t + step;
      sleep_until(t);
      t = std::max(t, inst.latch(now(), shown));
    }
    const FrameData& f = inst.step(t, shown);
    presenter.present(inst, f, i);
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
  const double wall_s = now() - wall0;
  if (stopping())
    spdlog::info("headless: stopped (signal {}) after {} of {} frames; writing the PNGs queued", opt.stop->load(),
                 frames, opt.frames);
  presenter.finish();
  spdlog::info("headless: {} frames in {:.2f} s ({:.1f} ms/frame, GL {:.1f} ms of it); {} PNGs written -> {}",
               frames, wall_s, wall_s * 1e3 / std::max(frames, 1), presenter.render_s() * 1e3 / std::max(frames, 1),
               presenter.pngs().written(), opt.out.string());
  log_retrieval_timing(inst);
  log_spar_summary(inst);
  if (presenter.pngs().dropped() > 0)
    spdlog::warn("headless: {} PNGs not written: the writer was behind (real time never waits for it; "
                 "--save-every larger, or --simulated-time, writes them all)",
                 presenter.pngs().dropped());
  return 0;
}

int replay_headless(const std::filesystem::path& session, ReplayOptions options, const HeadlessOptions& opt,
                    ReplayReport& report) {
  // The replay's installation is made inside replay_session: the presenter with it.
  std::unique_ptr<HeadlessPresenter> presenter;
  const Installation* installation = nullptr;
  int shown = 0;
  options.on_start = [&](const Installation& inst) {
    installation = &inst;
    presenter = std::make_unique<HeadlessPresenter>(inst, opt.out, opt.save_every, opt.resolution, true);
  };
  const auto inner = options.on_frame;
  options.on_frame = [&](const FrameData& f) {
    if (inner) inner(f);
    if (!presenter || shown >= opt.frames) return;
    presenter->present(*installation, f, static_cast<int>(f.frame));  // named by the session's frame
    ++shown;
  };
  report = replay_session(session, options);
  if (presenter) {
    presenter->finish();
    spdlog::info("replay: {} frames drawn, {} PNGs written -> {}", shown, presenter->pngs().written(), opt.out.string());
  }
  return 0;
}

bool display_available() {
  const char* x = std::getenv("DISPLAY");
  const char* w = std::getenv("WAYLAND_DISPLAY");
  return (x && *x) || (w && *w);
}

}  // namespace kumite::app
