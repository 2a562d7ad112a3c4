// Headless runs: EGL surfaceless context, one framebuffer per wall, PNG per wall and eye.
#include <algorithm>
#include <chrono>
#include <thread>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gl.hpp"
#include "kumite/app/frame_log.hpp"
#include "kumite/app/frame_source.hpp"
#include "kumite/app/headless.hpp"
#include "kumite/app/renderer.hpp"
#include "kumite/app/run.hpp"
#include "kumite/app/service.hpp"
#include "kumite/app/session.hpp"
#include "kumite/common/error.hpp"
#include "kumite/app/wall_notice.hpp"

namespace kumite::app {

/// What a headless run or a rendered replay does with each frame: draw every wall and eye
/// off-screen, write PNGs of the frames asked for (every K-th and each strike's contact) on
/// the writer thread, log the frame to frames.jsonl.
class HeadlessPresenter {
 public:
  HeadlessPresenter(const FrameSource& source, const std::filesystem::path& out, int save_every,
                    std::optional<std::array<int, 2>> resolution, bool wait_for_pngs)
      : out_(out), save_every_(save_every) {
    const auto& cfg = source.config();
    make_output_folder(out, "headless output folder");
    context_ = std::make_unique<HeadlessContext>();
    spdlog::info("headless: {}", gl_description());
    renderer_ = std::make_unique<Renderer>(source.walls());
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

  /// Draws frame `i` (its number in the PNG names) and logs it. A frame the source hands again
  /// (repeated(): a render node waiting for its master) is drawn with its notice, saved as
  /// WALL_EYE_NNNNN_notice.png (whenever PNGs are saved at all) and not logged.
  void present(const FrameSource& source, const FrameData& f, int i) {
    const bool again = source.repeated();
    const std::string_view notice = source.notice();
    const char* eye_names[2] = {stereo_ ? "left" : "mono", "right"};
    // Every K-th frame, and each strike's moment of contact (a hit or a miss), which a
    // strike-long run would otherwise rarely catch.
    const bool contact = std::any_of(f.events.begin(), f.events.end(),
                                     [](const FrameEvent& e) { return is_strike_outcome(e.type); });
    const bool save = save_every_ > 0 && (i % save_every_ == 0 || contact || again);
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
        draw_wall_notice(notice, 0, 0, target.width(), target.height());
        if (!save) {
          glFlush();
          render_s_ += now() - r0;
          continue;
        }
        target.read(pixels_);
        render_s_ += now() - r0;
        if (!pngs_->push(out_ / fmt::format("{}_{}_{:05}{}.png", names_[w], eye_names[e], i, again ? "_notice" : ""),
                         target.width(),
                         target.height(), std::move(pixels_)) &&
            pngs_->dropped() == 1)
          spdlog::warn("headless: frame {}: the PNG writer is behind, images are being dropped", i);
        pixels_ = {};
      }
    }
    for (const auto& e : pngs_->take_errors()) spdlog::warn("headless: {}", e);
    if (!again) log_->write(f, source.console(f), names_, stereo_);
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

int present_headless(FrameSource& source, const HeadlessOptions& opt) {
  HeadlessPresenter presenter(source, opt.out, opt.save_every, opt.resolution, !opt.real_time);
  const auto stopping = [&] { return opt.stop && opt.stop->load() != 0; };
  const Timestamp wall0 = now();
  source.begin();
  int frames = 0;  // drawn and logged
  while (frames < opt.frames && !stopping()) {
    const FrameData* f = source.next();
    if (!f) break;
    presenter.present(source, *f, static_cast<int>(f->frame));
    // present() waited for the GPU (glFinish): the frame's whole work is done.
    source.drawn();
    source.shown(now());
    if (source.repeated()) continue;  // the last frame again (its notice drawn): not counted
    ++frames;
    if (opt.monitor && source.installation()) opt.monitor->frame_done(*source.installation(), *f);
    if (source.ending()) break;
  }
  if (stopping()) source.stop();
  glFinish();
  if (opt.monitor)
    opt.monitor->stopping(stopping() ? fmt::format("signal {}", opt.stop->load()) : "run complete",
                          source.installation());
  const double wall_s = now() - wall0;
  if (stopping())
    spdlog::info("headless: stopped (signal {}) after {} of {} frames; writing the PNGs queued", opt.stop->load(),
                 frames, opt.frames);
  presenter.finish();
  spdlog::info("headless: {} frames in {:.2f} s ({:.1f} ms/frame, GL {:.1f} ms of it); {} PNGs written -> {}",
               frames, wall_s, wall_s * 1e3 / std::max(frames, 1), presenter.render_s() * 1e3 / std::max(frames, 1),
               presenter.pngs().written(), opt.out.string());
  if (presenter.pngs().dropped() > 0)
    spdlog::warn("headless: {} PNGs not written: the writer was behind (real time never waits for it; "
                 "--save-every larger, or --simulated-time, writes them all)",
                 presenter.pngs().dropped());
  return 0;
}

int run_headless(Installation& inst, const HeadlessOptions& opt) {
  LiveSource source(inst, opt.real_time ? LivePacing::real_time : LivePacing::simulated);
  const int rc = present_headless(source, opt);
  log_retrieval_timing(inst);
  log_spar_summary(inst);
  return rc;
}

int replay_headless(const std::filesystem::path& session, ReplayOptions options, const HeadlessOptions& opt,
                    ReplayReport& report) {
  SessionSource source(session, std::move(options));
  HeadlessOptions ho = opt;
  ho.real_time = false;  // every PNG asked for is written: a replay waits for the writer
  ho.monitor = nullptr;
  ho.stop = nullptr;
  present_headless(source, ho);
  report = source.finish();  // the frames past --frames are still replayed and compared
  return 0;
}

bool display_available() {
  const char* x = std::getenv("DISPLAY");
  const char* w = std::getenv("WAYLAND_DISPLAY");
  return (x && *x) || (w && *w);
}

}  // namespace kumite::app
