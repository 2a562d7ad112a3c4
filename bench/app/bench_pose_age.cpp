// Pose age at render and app CPU per frame on the recorded path, with the real tracker and
// fighter: the demo recording plays through the app's own source (RecordingSource, real-time
// clock, looped), either from memory (the first N frame sets decoded before the clock
// starts: the figure measures tracking + app) or streamed from disk (N = 0: PNG decoding on
// this machine decides how many sets arrive), while a 60 Hz display loop runs
// Installation::step() (tracking poll + prediction, orders, fighter, 4 walls x 2 eyes,
// console) without GL. Prints one JSON object; the source's counts are in it, and the
// machine's own wake-up lateness for a real-time thread (measured first, 3 s), the floor
// under any pose-age figure here. Pose age = tracking latency (frame set due -> pose published)
// + display wait (published -> sampled by a frame); the wait depends on the display loop's
// phase against the camera clock (up to one camera period), the latency is ours.
// Two ways of taking the pose, in alternating one-second blocks of the same run (so the same
// phases and the same machine): at the frame's start, and late-latched (Installation::
// latch: just after the tracker's next pose is out, but never so late that the frame's work
// would miss the next tick). Each gets `seconds` of measurement. After each pair of blocks
// the display's ticks move by 1/seconds of a frame, so the run sweeps the phase against the
// camera clock evenly (one run's phase would otherwise be luck: anywhere from best to worst).
//   build/bin/kumite_app_pose_age [config/demo.toml] [frame sets to preload = 60] [seconds = 6]
//                                 [decode threads = 1]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <cstdio>
#include <thread>


#include <fmt/format.h>

#include "kumite/app/config.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/tracking_input.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/realtime.hpp"
#include "kumite/tracking/tracker.hpp"

using namespace kumite;

namespace {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return -1;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

/// One way of taking the pose: its frames' figures (ms).
struct Samples {
  std::vector<double> ages, latency, wait, latch, cpu;
  int live = 0;
  std::string json() const {
    return fmt::format(
        "{{\"frames\": {}, \"head_live_frames\": {}, \"frames_with_pose_age\": {}, "
        "\"pose_age_ms\": {{\"median\": {:.3f}, \"p95\": {:.3f}, \"p99\": {:.3f}, \"max\": {:.3f}}}, "
        "\"tracking_latency_ms\": {{\"median\": {:.3f}, \"p99\": {:.3f}, \"max\": {:.3f}}}, "
        "\"display_wait_ms\": {{\"median\": {:.3f}, \"p99\": {:.3f}, \"max\": {:.3f}}}, "
        "\"latch_ms\": {{\"median\": {:.3f}, \"max\": {:.3f}}}, "
        "\"step_cpu_ms\": {{\"median\": {:.4f}, \"p95\": {:.4f}, \"max\": {:.4f}}}}}",
        cpu.size(), live, ages.size(), percentile(ages, 0.5), percentile(ages, 0.95), percentile(ages, 0.99),
        percentile(ages, 1.0), percentile(latency, 0.5), percentile(latency, 0.99), percentile(latency, 1.0),
        percentile(wait, 0.5), percentile(wait, 0.99), percentile(wait, 1.0), percentile(latch, 0.5),
        percentile(latch, 1.0), percentile(cpu, 0.5), percentile(cpu, 0.95), percentile(cpu, 1.0));
  }
};

/// The machine's own share of pose age: how late a SCHED_FIFO thread (as the tracker's)
/// wakes from a 2 ms sleep, over `seconds`, with nothing of ours running. On a virtual
/// machine the hypervisor's scheduling shows here; no code of ours can do better than this.
std::vector<double> wake_latency_ms(double seconds) {
  std::vector<double> late;
  std::thread probe([&] {
    (void)run_this_thread_realtime(10);  // as the tracker (else normal)
    const Timestamp end = now() + seconds;
    while (now() < end) {
      const Timestamp due = now() + 0.002;
      std::this_thread::sleep_for(std::chrono::duration<double>(due - now()));
      late.push_back((now() - due) * 1e3);
    }
  });
  probe.join();
  return late;
}

int run(int argc, char** argv) {
  const std::string config_path = argc > 1 ? argv[1] : "config/demo.toml";
  const std::size_t preload = argc > 2 ? std::stoul(argv[2]) : 60;
  const double seconds = argc > 3 ? std::stod(argv[3]) : 6.0;
  const int threads = argc > 4 ? std::stoi(argv[4]) : 1;
  const std::vector<double> wake = wake_latency_ms(3.0);
  auto cfg = app::load_installation_config(config_path);
  cfg.orders_script.reset();
  const auto rig = tracking::read_calibration(cfg.resolve(cfg.tracking.calibration));
  const auto tc = tracking::read_tracking_config(cfg.resolve(cfg.tracking.tracking));
  auto counters = std::make_shared<tracking::RecordingOptions::Counters>();
  tracking::RecordingOptions ro;
  ro.realtime = true;
  ro.loop = true;
  ro.preload_sets = preload;
  ro.decode_threads = threads;
  ro.counters = counters;
  const auto dir = cfg.resolve(cfg.tracking.recording);
  const tracking::Recording rec(dir, rig);
  const double camera_period = rec.size() > 1 ? (rec.index().rows.back().timestamp - rec.index().rows.front().timestamp) /
                                                    static_cast<double>(rec.size() - 1)
                                              : 0;
  app::Installation inst(cfg, app::make_tracking_input(cfg, tracking::open_recording_source(dir, rig, tc, ro)), {});
  const Timestamp load0 = now();
  while (!counters->playing.load()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const double load_s = now() - load0;
  const double step = 1.0 / cfg.display_rate_hz;
  Samples modes[2];  // [0] pose at the frame's start, [1] late-latched
  const Timestamp t0 = now();
  inst.start(t0);
  std::uint64_t counts0[3] = {0, 0, 0};
  int pair = 0;
  for (Timestamp next = t0; now() - t0 < 1.0 + 2 * seconds; next += step) {
    sleep_until(next);
    const double since = now() - t0;
    // The tracker's first second: filter and mask settle (and the drawing time is measured).
    const bool measuring = since >= 1.0;
    const int block = measuring ? static_cast<int>(std::floor(since - 1.0)) : -1;
    const int mode = measuring ? block % 2 : 1;
    if (measuring && block / 2 != pair) {  // a new pair of blocks: the next phase
      pair = block / 2;
      next += step / seconds;
      sleep_until(next);
    }
    const Timestamp t = mode == 1 ? inst.latch(now(), next + step) : now();
    const auto& f = inst.step(t);
    inst.drawn(now() - t);  // no GL here: the frame's work is step()
    if (!measuring) {
      counts0[0] = counters->delivered.load(), counts0[1] = counters->not_decoded.load(),
      counts0[2] = counters->dropped_stale.load();
      continue;
    }
    Samples& m = modes[mode];
    if (f.pose_age_ms >= 0) m.ages.push_back(f.pose_age_ms);
    if (f.pose_age_ms >= 0 && f.tracking_latency_ms >= 0) {
      m.latency.push_back(f.tracking_latency_ms);
      m.wait.push_back(f.pose_age_ms - f.tracking_latency_ms);
    }
    m.latch.push_back(f.latch_ms);
    if (inst.console().head_live) ++m.live;
    m.cpu.push_back(inst.console().frame_cpu_ms);
  }
  const double measured_s = now() - t0 - 1.0;
  std::printf(
      "{\"source\": \"%s\", \"decode_threads\": %d, \"load_s\": %.2f, \"camera_period_ms\": %.3f, "
      "\"frame_sets_per_s\": {\"tracked\": %.1f, \"skipped_decoder_behind\": %.1f, \"dropped_tracker_behind\": %.1f}, "
      "\"decode_ms_per_set\": %.1f, \"max_handover_late_ms\": %.2f, \"target_pose_age_ms\": %.3f, "
      "\"walls\": %zu, \"fighter\": %s,\n \"at_frame_start\": %s,\n \"late_latch\": %s,\n "
      "\"machine_wake_late_ms\": {\"p50\": %.3f, \"p99\": %.3f, \"p999\": %.3f, \"max\": %.3f}}\n",
      preload > 0 ? fmt::format("memory ({} frame sets)", std::min(preload, rec.size())).c_str() : "disk",
      threads, load_s, camera_period * 1e3,
      static_cast<double>(counters->delivered.load() - counts0[0]) / measured_s,
      static_cast<double>(counters->not_decoded.load() - counts0[1]) / measured_s,
      static_cast<double>(counters->dropped_stale.load() - counts0[2]) / measured_s, counters->decode_ms.load(),
      counters->max_handover_late_ms.load(), camera_period * 1e3 + 3.0, cfg.walls.size(),
      inst.frame().has_fighter ? "true" : "false", modes[0].json().c_str(), modes[1].json().c_str(),
      percentile(wake, 0.5), percentile(wake, 0.99), percentile(wake, 0.999), percentile(wake, 1.0));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  kumite::keep_freed_memory();  // as kumite does
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kumite_app_pose_age: %s\n", e.what());
    return 1;
  }
}
