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
// Every frame over the target is then put down to a cause the run measured, if one is found:
// a frame set it should have had was late for the machine (the tracker thread, at real-time
// priority, woke late to take it, or lost its core while processing it: its wall time minus
// its CPU time, read on the tracker thread by a wrapper round the source) or was dropped, or
// the display loop itself woke late. What no measured delay explains is counted apart: that
// part is ours to fix. "tracking_latency_less_machine_ms" is the tracking latency with the
// machine's delays taken out: the latency of our code on a machine that never took a core away.
// Both hold for a recording played from memory: streamed from disk (preload 0), waiting for
// the decoders counts as the machine's too.
//   build/bin/kumite_app_pose_age [config/demo.toml] [frame sets to preload = 60] [seconds = 6]
//                                 [decode threads = 1] [check: ms of CPU added per 30th set = 0]
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

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

/// ms a delay must exceed to count as a cause (a set's or the display loop's).
constexpr double kStall_ms = 1.0;

/// One frame set as the tracker thread saw it (s on now()'s clock; cpu_s on its CPU clock).
struct SetSeen {
  std::uint64_t frame = 0;  ///< the set's frame number
  Timestamp due = 0;      ///< the set's camera time (due on the recording's clock)
  Timestamp asked = 0;    ///< the tracker's call for it began (its previous set was done)
  Timestamp handed = 0;   ///< handed over
  Timestamp done = -1;    ///< the tracker asked for the next one (this pose published)
  double cpu_s = 0;       ///< tracker thread CPU from handed to done
  /// ms of the set's tracking latency that the machine took: waking late to take it, and
  /// the core lost while processing it (or while the previous set held it past `due`).
  double machine_ms = 0;
};

/// Wraps the recording source; next() runs on the tracker thread, so the wrapper sees when
/// each set is handed over and how long the tracker then worked on it, in wall and CPU time.
class WatchedSource : public tracking::FrameSource {
 public:
  /// `spin_ms` > 0: a check of the attribution itself; the tracker thread burns that much
  /// CPU on every kSpinEvery-th set, as slow code of ours would (it must show as unexplained).
  WatchedSource(std::unique_ptr<tracking::FrameSource> inner, double spin_ms)
      : inner_(std::move(inner)), spin_s_(spin_ms * 1e-3) {
    sets_.reserve(1 << 16);
  }
  bool next(tracking::FrameSet& out, double timeout_s) override {
    const Timestamp asked = now();
    const double cpu = thread_cpu_time();
    if (pending_) {
      pending_->done = asked;
      pending_->cpu_s = cpu - pending_cpu_;
      std::lock_guard lock(mutex_);
      sets_.push_back(*pending_);
      pending_.reset();
    }
    if (!inner_->next(out, timeout_s)) return false;
    pending_ = SetSeen{out.frame, out.timestamp, asked, now()};
    pending_cpu_ = thread_cpu_time();
    if (spin_s_ > 0 && ++handed_ % kSpinEvery == 0)
      while (thread_cpu_time() - pending_cpu_ < spin_s_) {
      }
    return true;
  }
  bool end_of_stream() const override { return inner_->end_of_stream(); }
  void close() override { inner_->close(); }
  std::vector<std::string> take_messages() override { return inner_->take_messages(); }
  /// The sets seen so far, finished ones only, with machine_ms filled in.
  std::vector<SetSeen> seen() const {
    std::vector<SetSeen> v;
    {
      std::lock_guard lock(mutex_);
      v = sets_;
    }
    for (std::size_t i = 0; i < v.size(); ++i) {
      SetSeen& s = v[i];
      const double woke_late = s.handed - std::max(s.due, s.asked);
      const double lost_core = (s.done - s.handed) - s.cpu_s;
      // The machine's delay of the previous set held this one back as far as that set ran
      // past this one's due time.
      const double carried = i > 0 && s.asked > s.due ? std::min(1e-3 * v[i - 1].machine_ms, s.asked - s.due) : 0.0;
      s.machine_ms = 1e3 * (std::max(0.0, woke_late) + std::max(0.0, lost_core) + carried);
    }
    return v;
  }

 private:
  static constexpr std::uint64_t kSpinEvery = 30;
  std::unique_ptr<tracking::FrameSource> inner_;
  double spin_s_ = 0;
  std::uint64_t handed_ = 0;        // tracker thread only
  std::optional<SetSeen> pending_;  // tracker thread only
  double pending_cpu_ = 0;          // tracker thread only
  mutable std::mutex mutex_;
  std::vector<SetSeen> sets_;
};

/// One measured frame, for the attribution after the run (s on now()'s clock).
struct FrameSeen {
  int mode = 0;
  Timestamp sampled = 0;   ///< the time the frame took the pose (step's argument)
  Timestamp used = 0;      ///< camera time of the measurement it used
  double age_ms = -1;
  double loop_late_ms = 0; ///< the display loop's wake-up past its tick, and step's lost core
};

/// Why frames were over the target: counts per cause, and what no measured delay explains.
struct OverTarget {
  int frames = 0, tracker_late = 0, set_dropped = 0, loop_late = 0, unexplained = 0;
  double worst_unexplained_ms = 0;
  std::string json() const {
    return fmt::format(
        "{{\"frames\": {}, \"set_late_for_the_machine\": {}, \"set_dropped\": {}, \"display_loop_late\": {}, "
        "\"unexplained\": {}, \"worst_unexplained_age_ms\": {:.3f}}}",
        frames, tracker_late, set_dropped, loop_late, unexplained, worst_unexplained_ms);
  }
};

/// For each frame over `target_ms`: the sets due after its pose's camera time and at least
/// kStall_ms before it sampled (those it should have had). A cause is the first found of:
/// one of them lost more than kStall_ms to the machine and would have been out in time
/// without that, one was never handed over (dropped: the tracker was behind), the display
/// loop was late.
std::array<OverTarget, 2> attribute(const std::vector<FrameSeen>& frames, const std::vector<SetSeen>& sets,
                                    double period_s, double target_ms) {
  std::array<OverTarget, 2> out;
  for (const auto& f : frames) {
    if (f.age_ms <= target_ms) continue;
    OverTarget& o = out[static_cast<std::size_t>(f.mode)];
    ++o.frames;
    const Timestamp used = f.used;
    const Timestamp by = f.sampled - kStall_ms * 1e-3;
    auto it = std::upper_bound(sets.begin(), sets.end(), used + 0.5e-3,
                               [](Timestamp t, const SetSeen& s) { return t < s.due; });
    bool late = false;
    int expected = 0, handed = 0;
    for (; it != sets.end() && it->due <= by; ++it) {
      ++handed;
      // Late for the machine: without its delay, the set's pose would have been out in time.
      late = late || (it->machine_ms > kStall_ms && it->done - 1e-3 * it->machine_ms <= f.sampled);
    }
    // Sets due in (used, by] on the camera clock that the tracker never got: dropped.
    if (period_s > 0) expected = static_cast<int>(std::floor((by - used) / period_s + 1e-6));
    if (late) ++o.tracker_late;
    else if (handed < expected) ++o.set_dropped;
    else if (f.loop_late_ms > kStall_ms) ++o.loop_late;
    else {
      ++o.unexplained;
      o.worst_unexplained_ms = std::max(o.worst_unexplained_ms, f.age_ms);
    }
  }
  return out;
}

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
  const double spin_ms = argc > 5 ? std::stod(argv[5]) : 0.0;
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
  auto watched = std::make_unique<WatchedSource>(tracking::open_recording_source(dir, rig, tc, ro), spin_ms);
  const WatchedSource& watch = *watched;
  app::Installation inst(cfg, app::make_tracking_input(cfg, std::move(watched)), {});
  const Timestamp load0 = now();
  while (!counters->playing.load()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const double load_s = now() - load0;
  const double step = 1.0 / cfg.display_rate_hz;
  Samples modes[2];  // [0] pose at the frame's start, [1] late-latched
  const Timestamp t0 = now();
  inst.start(t0);
  std::uint64_t counts0[3] = {0, 0, 0};
  int pair = 0;
  std::vector<FrameSeen> seen;
  seen.reserve(static_cast<std::size_t>(2 * seconds * cfg.display_rate_hz) + 64);
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
    const double woke_late = now() - next;
    const Timestamp t = mode == 1 ? inst.latch(now(), next + step) : now();
    const double cpu0 = thread_cpu_time();
    const auto& f = inst.step(t, next + step);  // seen at the next tick, as a window's vsync
    const double step_lost = (now() - t) - (thread_cpu_time() - cpu0);
    inst.drawn(now() - t);  // no GL here: the frame's work is step()
    if (!measuring) {
      counts0[0] = counters->delivered.load(), counts0[1] = counters->not_decoded.load(),
      counts0[2] = counters->dropped_stale.load();
      continue;
    }
    Samples& m = modes[mode];
    if (f.pose_age_ms >= 0) {
      m.ages.push_back(f.pose_age_ms);
      // A latched frame that waited is late by how far it woke past its window's end (its
      // tick does not matter); either way, the core lost inside step() (before the pose is
      // read) delays it.
      const auto& w = inst.last_latch_window();
      const double late = mode == 1 && w ? t - w->last : woke_late;
      seen.push_back({mode, t, f.pose_measured_at, f.pose_age_ms, 1e3 * std::max(late, step_lost)});
    }
    if (f.pose_age_ms >= 0 && f.tracking_latency_ms >= 0) {
      m.latency.push_back(f.tracking_latency_ms);
      m.wait.push_back(f.pose_age_ms - f.tracking_latency_ms);
    }
    m.latch.push_back(f.latch_ms);
    if (inst.console().head_live) ++m.live;
    m.cpu.push_back(inst.console().frame_cpu_ms);
  }
  const double measured_s = now() - t0 - 1.0;
  const double target_ms = camera_period * 1e3 + 3.0;
  const std::vector<SetSeen> sets = watch.seen();
  const auto over = attribute(seen, sets, camera_period, target_ms);
  std::vector<double> ours;  // tracking latency less the machine's delays (ms), measured sets
  for (const auto& st : sets)
    if (st.due >= t0 + 1.0) ours.push_back(1e3 * (st.done - st.due) - st.machine_ms);
  std::printf(
      "{\"source\": \"%s\", \"decode_threads\": %d, \"load_s\": %.2f, \"camera_period_ms\": %.3f, "
      "\"frame_sets_per_s\": {\"tracked\": %.1f, \"skipped_decoder_behind\": %.1f, \"dropped_tracker_behind\": %.1f}, "
      "\"decode_ms_per_set\": %.1f, \"max_handover_late_ms\": %.2f, \"target_pose_age_ms\": %.3f, "
      "\"walls\": %zu, \"fighter\": %s, \"check_cpu_added_ms_per_30th_set\": %.1f,\n \"at_frame_start\": %s,\n \"late_latch\": %s,\n "
      "\"over_target\": {\"at_frame_start\": %s, \"late_latch\": %s},\n "
      "\"tracking_latency_less_machine_ms\": {\"median\": %.3f, \"p99\": %.3f, \"max\": %.3f},\n "
      "\"machine_wake_late_ms\": {\"p50\": %.3f, \"p99\": %.3f, \"p999\": %.3f, \"max\": %.3f}}\n",
      preload > 0 ? fmt::format("memory ({} frame sets)", std::min(preload, rec.size())).c_str() : "disk",
      threads, load_s, camera_period * 1e3,
      static_cast<double>(counters->delivered.load() - counts0[0]) / measured_s,
      static_cast<double>(counters->not_decoded.load() - counts0[1]) / measured_s,
      static_cast<double>(counters->dropped_stale.load() - counts0[2]) / measured_s, counters->decode_ms.load(),
      counters->max_handover_late_ms.load(), target_ms, cfg.walls.size(),
      inst.frame().fighter.present ? "true" : "false", spin_ms, modes[0].json().c_str(), modes[1].json().c_str(),
      over[0].json().c_str(), over[1].json().c_str(), percentile(ours, 0.5), percentile(ours, 0.99),
      percentile(ours, 1.0), percentile(wake, 0.5), percentile(wake, 0.99), percentile(wake, 0.999), percentile(wake, 1.0));
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
