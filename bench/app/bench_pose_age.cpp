// Pose age at render and app CPU per frame on the recorded path, with the real tracker and
// fighter: the first N frame sets of the demo recording are loaded into memory (so the
// figure measures tracking + app, not PNG decoding on a busy disk), replayed in real time on
// the tracker's thread (timestamps rebased onto now(), looped), while a 60 Hz display loop
// runs Installation::step() (tracking poll + prediction, orders, fighter, 4 walls x 2 eyes,
// console) without GL. Prints one JSON object.
//   build/bin/kumite_app_pose_age [config/demo.toml] [frame sets to preload = 60] [seconds = 6]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <thread>

#include <fmt/format.h>

#include "kumite/app/config.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/tracking_input.hpp"
#include "kumite/common/error.hpp"
#include "kumite/tracking/tracker.hpp"

using namespace kumite;

namespace {

/// Frame sets from memory, paced by their timestamps (rebased onto now()), looped.
class MemorySource final : public tracking::FrameSource {
 public:
  explicit MemorySource(std::vector<tracking::FrameSet> sets) : sets_(std::move(sets)) {
    period_ = sets_.back().timestamp - sets_.front().timestamp +
              (sets_.size() > 1 ? (sets_[1].timestamp - sets_[0].timestamp) : 1.0 / 60);
  }
  bool next(tracking::FrameSet& out, double) override {
    if (start_ < 0) start_ = now();
    const std::size_t i = n_ % sets_.size();
    const double loop = static_cast<double>(n_ / sets_.size());
    const Timestamp due = start_ + (sets_[i].timestamp - sets_[0].timestamp) + loop * period_;
    while (!closed_ && now() < due)
      std::this_thread::sleep_for(std::chrono::duration<double>(std::min(due - now(), 0.05)));
    out = sets_[i];
    out.timestamp = due;
    for (auto& t : out.camera_times) t = due;
    out.frame = n_++;
    return !closed_;
  }
  bool end_of_stream() const override { return closed_; }
  void close() override { closed_ = true; }
  double frame_period() const { return sets_.size() > 1 ? sets_[1].timestamp - sets_[0].timestamp : 0; }

 private:
  std::vector<tracking::FrameSet> sets_;
  double period_ = 0;
  Timestamp start_ = -1;
  std::size_t n_ = 0;
  std::atomic<bool> closed_{false};
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return -1;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

int run(int argc, char** argv) {
  const std::string config_path = argc > 1 ? argv[1] : "config/demo.toml";
  const std::size_t preload = argc > 2 ? std::stoul(argv[2]) : 60;
  const double seconds = argc > 3 ? std::stod(argv[3]) : 6.0;
  auto cfg = app::load_installation_config(config_path);
  cfg.orders_script.reset();
  const auto rig = tracking::read_calibration(cfg.resolve(cfg.tracking.calibration));
  tracking::Recording rec(cfg.resolve(cfg.tracking.recording), rig);
  std::vector<tracking::FrameSet> sets;
  for (std::size_t i = 0; i < std::min(preload, rec.size()); ++i) sets.push_back(rec.load(i));
  auto source = std::make_unique<MemorySource>(std::move(sets));
  const double camera_period = source->frame_period();
  app::Installation inst(cfg, app::make_tracking_input(cfg, std::move(source)), {});
  const double step = 1.0 / cfg.display_rate_hz;
  std::vector<double> ages, cpu;
  int live = 0, frames = 0;
  const Timestamp t0 = now();
  inst.start(t0);
  for (Timestamp next = t0; now() - t0 < seconds; next += step) {
    while (now() < next) std::this_thread::sleep_for(std::chrono::duration<double>(next - now()));
    const auto& f = inst.step(now());
    ++frames;
    if (now() - t0 < 1.0) continue;  // the tracker's first second: filter and mask settle
    if (f.pose_age_ms >= 0) ages.push_back(f.pose_age_ms);
    if (inst.console().head_live) ++live;
    cpu.push_back(inst.console().frame_cpu_ms);
  }
  std::printf(
      "{\"frames\": %d, \"measured_frames\": %zu, \"head_live_frames\": %d, \"camera_period_ms\": %.3f, "
      "\"pose_age_ms\": {\"median\": %.3f, \"p95\": %.3f, \"max\": %.3f}, "
      "\"target_pose_age_ms\": %.3f, "
      "\"step_cpu_ms\": {\"median\": %.4f, \"p95\": %.4f, \"max\": %.4f}, \"walls\": %zu, "
      "\"fighter\": %s}\n",
      frames, cpu.size(), live, camera_period * 1e3, percentile(ages, 0.5), percentile(ages, 0.95),
      percentile(ages, 1.0), camera_period * 1e3 + 3.0, percentile(cpu, 0.5), percentile(cpu, 0.95),
      percentile(cpu, 1.0), cfg.walls.size(), inst.frame().has_fighter ? "true" : "false");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kumite_app_pose_age: %s\n", e.what());
    return 1;
  }
}
