// kumite-track: optical head tracking from a recording or live V4L2 cameras, and the
// SYNTHETIC recording generator.
//
//   kumite-track --calibration cal.yaml --config tracking.toml --recording DIR --out poses.csv
//   kumite-track --calibration cal.yaml --config tracking.toml --live --out poses.csv
//   kumite-track synth --calibration cal.yaml --config tracking.toml --out DIR [options]
//   kumite-track rig --out calibration.yaml      (the shipped default 4-camera rig)
#include <algorithm>
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/sinks/sink.h>
#include <spdlog/spdlog.h>

#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/log.hpp"
#include "kumite/common/realtime.hpp"
#include "kumite/tracking/calibration_file.hpp"
#include "kumite/tracking/config.hpp"
#include "kumite/tracking/pipeline.hpp"
#include "kumite/tracking/recording.hpp"
#include "kumite/recognition/poses_file.hpp"
#include "kumite/tracking/synth.hpp"
#include "kumite/tracking/tracker.hpp"

namespace fs = std::filesystem;
using namespace kumite;
using namespace kumite::tracking;

namespace {

std::atomic<bool> g_interrupted{false};
void on_signal(int) { g_interrupted.store(true); }

struct RunOptions {
  std::string calibration, config, recording, out;
  bool live = false;
  bool realtime = false;
  int decode_threads = 1;
  bool unfiltered = false;
  double duration_s = 0;
  int verbosity = 1;
};

struct SynthCli {
  std::string calibration, config, out, trajectory = "scripted", poses;
  double duration_s = 10;
  SynthOptions options;
  std::string hidden;
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double pos = p * (static_cast<double>(v.size()) - 1);
  const auto i = static_cast<std::size_t>(pos);
  const double f = pos - static_cast<double>(i);
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

/// Collects poses.csv rows and the summary figures from the tracker thread.
class Collector {
 public:
  Collector(std::optional<TruthTable> truth, bool unfiltered, std::vector<std::string> cameras, double camera_timeout_s,
            std::vector<std::string> body_names)
      : truth_(std::move(truth)), unfiltered_(unfiltered), camera_timeout_s_(camera_timeout_s),
        camera_names_(std::move(cameras)),
        images_(camera_names_.size(), 0), last_image_(camera_names_.size(), -1.0),
        body_names_(std::move(body_names)) {
    rows_ = "frame,timestamp_s,body,status,x,y,z,qw,qx,qy,qz,markers,cameras,latency_ms\n";
  }

  void add(const FrameResult& r) {
    std::lock_guard lock(mutex_);
    // One row per body of tracking.toml per frame set, named as there (head, left_hand, ...:
    // kumite-recognise reads the bodies whose names are roles and ignores the others).
    for (std::size_t b = 0; b < body_names_.size(); ++b) {
      const BodyPose& p = unfiltered_ ? r.raw.at(b) : r.filtered.at(b);
      rows_ += fmt::format("{},{:.6f},{},{},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{},{},{:.3f}\n", r.frame,
                           r.timestamp, body_names_[b], to_string(p.status), p.position[0], p.position[1], p.position[2],
                           p.orientation[0], p.orientation[1], p.orientation[2], p.orientation[3], p.markers,
                           p.cameras, r.latency_ms);
    }
    const BodyPose& p = unfiltered_ ? r.raw.at(0) : r.filtered.at(0);
    latency_.push_back(r.latency_ms);
    ++frames_;
    if (frames_ == 1) first_time_ = r.timestamp;
    last_time_ = r.timestamp;
    status_[static_cast<int>(p.status)]++;
    for (std::size_t c = 0; c < images_.size() && c < r.has_image.size(); ++c) {
      if (!r.has_image[c]) continue;
      ++images_[c];
      last_image_[c] = r.timestamp;
    }
    const BodyPose& f = r.filtered.at(0);
    // The console says when the head is lost (past coasting) and when it is found again.
    if (f.status == TrackingStatus::lost && was_tracked_) {
      spdlog::warn("{}: lost at {:.3f} s (frame {})", body_names_.front(), r.timestamp - first_time_, r.frame);
    } else if (f.status == TrackingStatus::tracked && !was_tracked_) {
      spdlog::info("{}: {} at {:.3f} s (frame {}, {} markers, {} cameras)", body_names_.front(),
                   ever_tracked_ ? "tracked again" : "found", r.timestamp - first_time_, r.frame, f.markers, f.cameras);
      ever_tracked_ = true;
    }
    if (f.status != TrackingStatus::coasting) was_tracked_ = f.status == TrackingStatus::tracked;
    const TruthRow* t = truth_ ? truth_->find(r.frame) : nullptr;
    if (f.status == TrackingStatus::tracked && (!truth_ || t)) {
      // Jitter = RMS distance of the filtered position from its mean. With truth, of the
      // filtered position minus the truth (the visitor's own motion is not jitter; on a moving
      // head the filter's varying lag still counts); without, meaningful only when still.
      Eigen::Vector3d x(f.position[0], f.position[1], f.position[2]);
      if (t) x -= Eigen::Vector3d(t->x, t->y, t->z);
      jitter_sum_ += x;
      jitter_sum2_ += x.squaredNorm();
      ++jitter_n_;
    }
    if (!t) return;
    const Eigen::Vector3d tp(t->x, t->y, t->z);
    const Eigen::Quaterniond tq(t->qw, t->qx, t->qy, t->qz);
    for (int k = 0; k < 2; ++k) {
      const BodyPose& b = k == 0 ? r.raw.at(0) : r.filtered.at(0);
      if (b.status != TrackingStatus::tracked) continue;
      const Eigen::Vector3d bp(b.position[0], b.position[1], b.position[2]);
      const Eigen::Quaterniond bq(b.orientation[0], b.orientation[1], b.orientation[2], b.orientation[3]);
      err_[k].pos2 += (bp - tp).squaredNorm();
      const double a = bq.angularDistance(tq) * 180.0 / M_PI;
      err_[k].rot2 += a * a;
      ++err_[k].n;
    }
  }

  void write(const fs::path& out) const { write_file_atomically(out, rows_); }
  /// s of source time covered so far (first to latest frame set).
  double elapsed_s() {
    std::lock_guard lock(mutex_);
    return frames_ ? last_time_ - first_time_ : 0.0;
  }
  /// s: timestamp of the latest frame set (0 before the first).
  Timestamp last_time() {
    std::lock_guard lock(mutex_);
    return last_time_;
  }

  /// `problems`: per camera, what the console said was wrong with it ("" = nothing).
  void summary(std::size_t skipped, const std::vector<std::string>& problems) {
    std::lock_guard lock(mutex_);
    std::printf("frame sets: %d (tracked %d, coasting %d, lost %d); warnings: %zu\n", frames_, status_[1],
                status_[2], status_[0], skipped);
    if (truth_) {
      const char* names[2] = {"measured (unsmoothed)", "published (filtered)"};
      for (int k = 0; k < 2; ++k) {
        if (err_[k].n == 0) continue;
        std::printf("vs truth.csv, %s, %d frame sets: RMS position error %.3f mm, RMS orientation error %.3f deg\n",
                    names[k], err_[k].n, 1e3 * std::sqrt(err_[k].pos2 / err_[k].n), std::sqrt(err_[k].rot2 / err_[k].n));
      }
    } else {
      std::printf("no truth.csv: no accuracy figures\n");
    }
    if (jitter_n_ > 0) {
      const Eigen::Vector3d mean = jitter_sum_ / jitter_n_;
      std::printf("jitter (%s, RMS distance from its mean): %.3f mm\n",
                  truth_ ? "filtered position minus truth" : "filtered position; includes real motion",
                  1e3 * std::sqrt(std::max(0.0, jitter_sum2_ / jitter_n_ - mean.squaredNorm())));
    }
    for (std::size_t c = 0; c < camera_names_.size(); ++c) {
      std::string line = fmt::format("camera {}: images in {} of {} frame sets", camera_names_[c], images_[c], frames_);
      if (last_image_[c] < 0) {
        line += ", never delivered one";
      } else if (last_time_ - last_image_[c] > camera_timeout_s_) {  // it stopped
        line += fmt::format(", the last at {:.3f} s ({:.3f} s before the end)", last_image_[c] - first_time_,
                            last_time_ - last_image_[c]);
      }
      if (c < problems.size() && !problems[c].empty()) line += "; PROBLEM: " + problems[c];
      std::printf("%s\n", line.c_str());
    }
    std::printf("latency per frame set (ms): p50 %.3f, p90 %.3f, p99 %.3f, max %.3f\n", percentile(latency_, 0.5),
                percentile(latency_, 0.9), percentile(latency_, 0.99), percentile(latency_, 1.0));
  }

 private:
  struct Err {
    double pos2 = 0, rot2 = 0;
    int n = 0;
  };
  std::mutex mutex_;
  std::optional<TruthTable> truth_;
  bool unfiltered_;
  std::string rows_;
  std::vector<double> latency_;
  double camera_timeout_s_;
  std::vector<std::string> camera_names_;
  std::vector<int> images_;          // per camera: frame sets with an image
  std::vector<Timestamp> last_image_;  // per camera: time of its last image (s, -1 = none)
  Timestamp first_time_ = 0, last_time_ = 0;
  bool was_tracked_ = false, ever_tracked_ = false;
  std::vector<std::string> body_names_;  // every body of tracking.toml, [[bodies]] order (body 0 first)
  Eigen::Vector3d jitter_sum_{0, 0, 0};
  double jitter_sum2_ = 0;
  int jitter_n_ = 0;
  int frames_ = 0;
  int status_[3] = {0, 0, 0};
  Err err_[2];
};

std::optional<TruthTable> read_truth(const fs::path& dir) {
  const fs::path p = dir / "truth.csv";
  if (!fs::exists(p)) return std::nullopt;
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_truth_csv(ss.str(), p.string());
}

int run_tracker(const RunOptions& o) {
  init_logging(o.verbosity);
  if (o.live == !o.recording.empty()) throw Error("cli", "args", "give exactly one of --recording DIR or --live");
  const RigCalibration rig = read_calibration(o.calibration);
  const TrackingConfig config = read_tracking_config(o.config);
  std::unique_ptr<FrameSource> source;
  std::optional<TruthTable> truth;
  auto playback = std::make_shared<RecordingOptions::Counters>();
  if (o.live) {
    source = open_live_source(rig, config);
  } else {
    RecordingOptions ro;
    ro.realtime = o.realtime;
    ro.decode_threads = o.decode_threads;
    ro.counters = playback;
    source = open_recording_source(o.recording, rig, config, ro);
    truth = read_truth(o.recording);
    if (truth) {
      for (const auto& s : truth->skipped) spdlog::warn("{}", s);
    }
    if (fs::exists(fs::path(o.recording) / "README.txt")) {
      std::ifstream in(fs::path(o.recording) / "README.txt");
      std::string first;
      std::getline(in, first);
      if (first.find("SYNTHETIC") != std::string::npos) spdlog::info("{}", first);
    }
  }
  std::vector<std::string> names;
  for (const auto& c : rig.cameras) names.push_back(c.name);
  std::vector<std::string> body_names;
  for (const auto& b : config.bodies) body_names.push_back(b.name);
  Collector collector(std::move(truth), o.unfiltered, names, config.camera_timeout_s, std::move(body_names));
  Tracker tracker(rig, config);
  std::atomic<std::size_t> skipped{0};
  tracker.on_frame([&](const FrameResult& r) { collector.add(r); });
  // Count what the sources skipped: they log one warning line each.
  auto sink_count = std::make_shared<std::atomic<std::size_t>>(0);
  struct CountingSink : spdlog::sinks::sink {
    std::shared_ptr<std::atomic<std::size_t>> n;
    explicit CountingSink(std::shared_ptr<std::atomic<std::size_t>> c) : n(std::move(c)) {}
    void log(const spdlog::details::log_msg& m) override {
      if (m.level == spdlog::level::warn) n->fetch_add(1);
    }
    void flush() override {}
    void set_pattern(const std::string&) override {}
    void set_formatter(std::unique_ptr<spdlog::formatter>) override {}
  };
  spdlog::default_logger()->sinks().push_back(std::make_shared<CountingSink>(sink_count));
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  const Timestamp start = kumite::now();
  tracker.start(std::move(source));
  Timestamp last_status = start;
  // Camera states as the console shows them: every change (a camera that stops, comes back or
  // reconnects), and for live cameras a reminder every 2 s while one is not ok.
  std::vector<CameraState> shown(rig.cameras.size(), CameraState::ok);
  std::vector<std::string> problems(rig.cameras.size());  // for the summary
  std::vector<bool> problem_open(rig.cameras.size(), false);  // its last span has not ended
  const auto report_cameras = [&](bool remind) {
    if (tracker.frames_processed() == 0) return;
    // Live: against now (all cameras may have stopped). A recording: against its latest frame
    // set, i.e. whether a camera keeps up with the others (played in real time, decoding may
    // fall behind the clock, and after the end nothing arrives at all).
    const auto cams = o.live ? tracker.camera_status() : tracker.camera_status(collector.last_time());
    for (std::size_t c = 0; c < cams.size(); ++c) {
      if (cams[c].state == shown[c] && !(remind && cams[c].state != CameraState::ok)) continue;
      // A camera that has not delivered its first image is only reported once the others
      // have run for camera_timeout_s (a dropped first frame is not news).
      if (cams[c].since_last_s < 0 && collector.elapsed_s() <= config.camera_timeout_s) continue;
      if (problem_open[c] && cams[c].state != CameraState::blind) {
        // The span ends: the summary says when (a camera blind for the first seconds only is
        // not reported as if it still were).
        problems[c] += fmt::format(" to {:.1f} s)", collector.elapsed_s());
        problem_open[c] = false;
      }
      if (cams[c].state == CameraState::ok) {
        spdlog::info("camera {}: ok again", rig.cameras[c].name);
      } else if (cams[c].state == CameraState::blind) {
        // A camera that delivers images but not the head the others see (covered, dark,
        // knocked out of place): a problem, said once when it starts and in the summary.
        spdlog::warn("camera {}: {}", rig.cameras[c].name, describe(cams[c]));
        const double from = collector.elapsed_s() - cams[c].blind_s;
        problems[c] += fmt::format("{}{} (from {:.1f} s", problems[c].empty() ? "" : "; ", to_string(cams[c].state),
                                   std::max(0.0, from));
        problem_open[c] = true;
      } else if (cams[c].since_last_s < 0) {
        spdlog::warn("camera {}: {} (no frame yet)", rig.cameras[c].name, to_string(cams[c].state));
      } else {
        spdlog::warn("camera {}: {} ({:.1f} s since the last frame)", rig.cameras[c].name, to_string(cams[c].state),
                     cams[c].since_last_s);
      }
      shown[c] = cams[c].state;
    }
  };
  while (tracker.running() && !g_interrupted.load()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (o.duration_s > 0 && kumite::now() - start > o.duration_s) break;
    const bool remind = o.live && kumite::now() - last_status > 2.0;
    if (remind) last_status = kumite::now();
    report_cameras(remind);
  }
  report_cameras(false);
  for (std::size_t c = 0; c < problems.size(); ++c)
    if (problem_open[c]) problems[c] += " to the end)";
  tracker.stop();
  skipped = sink_count->load();
  collector.write(o.out);
  collector.summary(skipped.load(), problems);
  if (o.realtime) {
    std::printf("real-time playback: %llu frame sets delivered, %llu skipped (not decoded in time: try "
                "--decode-threads), %llu dropped (the tracker was behind)\n",
                static_cast<unsigned long long>(playback->delivered.load()),
                static_cast<unsigned long long>(playback->not_decoded.load()),
                static_cast<unsigned long long>(playback->dropped_stale.load()));
  }
  std::printf("wrote %s\n", o.out.c_str());
  return 0;
}

std::vector<int> parse_index_list(const std::string& text) {
  std::vector<int> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (item.empty()) continue;
    try {
      out.push_back(std::stoi(item));
    } catch (const std::exception&) {
      throw Error("cli", "args", fmt::format("--hide: \"{}\" is not a marker index", item));
    }
  }
  return out;
}

int run_synth(SynthCli s) {
  init_logging(1);
  const RigCalibration rig = read_calibration(s.calibration);
  const TrackingConfig config = read_tracking_config(s.config);
  const BodyConfig& body = config.bodies.at(0);
  s.options.hidden_markers = parse_index_list(s.hidden);
  for (int h : s.options.hidden_markers) {
    if (h < 0 || h >= static_cast<int>(body.markers.size())) {
      throw Error("cli", "args", fmt::format("--hide: marker {} does not exist (body \"{}\" has {})", h, body.name, body.markers.size()));
    }
  }
  if (s.options.dead_camera >= static_cast<int>(rig.cameras.size())) {
    throw Error("cli", "args", fmt::format("--dead-camera: the calibration has {} cameras", rig.cameras.size()));
  }
  std::vector<TrajectoryPoint> trajectory;
  std::string description;
  const int frames = std::max(1, static_cast<int>(std::lround(s.duration_s * s.options.fps)));
  if (!s.poses.empty()) {
    // A mocap visitor (issue 14): every body of tracking.toml named like a body of the poses
    // file (head, left_hand, ...) drawn where the file has it, linearly interpolated.
    const auto file = recognition::read_poses_csv(s.poses);
    if (file.samples.empty()) throw Error("cli", "args", fmt::format("--poses: {}: no rows of a known body", s.poses));
    std::vector<std::vector<recognition::PoseSample>> per_body(config.bodies.size());
    std::string drawn;
    for (std::size_t b = 0; b < config.bodies.size(); ++b) {
      const auto role = recognition::role_from_string(config.bodies[b].name);
      if (!role) continue;
      for (const auto& smp : file.samples)
        if (smp.role == *role) per_body[b].push_back(smp);
      if (!per_body[b].empty()) drawn += fmt::format("{}{}", drawn.empty() ? "" : ", ", config.bodies[b].name);
    }
    if (drawn.empty())
      throw Error("cli", "args", fmt::format("--poses: {} has no body that {} names", s.poses, s.config));
    const double t0 = file.samples.front().t, t1 = file.samples.back().t;
    std::vector<Timestamp> times;
    std::vector<std::vector<std::optional<TrajectoryPoint>>> poses;
    for (int i = 0; i < frames && t0 + i / s.options.fps <= t1 + 1e-9; ++i) {
      const double t = t0 + i / s.options.fps;
      times.push_back(t - t0);
      auto& row = poses.emplace_back(config.bodies.size());
      for (std::size_t b = 0; b < per_body.size(); ++b) {
        const auto& v = per_body[b];
        if (v.size() < 2 || t < v.front().t || t > v.back().t) continue;
        const auto it = std::upper_bound(v.begin(), v.end(), t, [](double x, const recognition::PoseSample& q) { return x < q.t; });
        const auto& hi = it == v.end() ? v.back() : *it;
        const auto& lo = it == v.begin() ? v.front() : *(it - 1);
        if (!lo.tracked || !hi.tracked) continue;
        const double f = hi.t > lo.t ? (t - lo.t) / (hi.t - lo.t) : 0;
        TrajectoryPoint p;
        p.t = t - t0;
        for (int k = 0; k < 3; ++k)
          p.position[k] = lo.position[static_cast<std::size_t>(k)] + f * (hi.position[static_cast<std::size_t>(k)] - lo.position[static_cast<std::size_t>(k)]);
        const Eigen::Quaterniond qa(lo.orientation[0], lo.orientation[1], lo.orientation[2], lo.orientation[3]);
        const Eigen::Quaterniond qb(hi.orientation[0], hi.orientation[1], hi.orientation[2], hi.orientation[3]);
        p.orientation = qa.normalized().slerp(f, qb.normalized());
        row[b] = p;
      }
    }
    description = fmt::format("mocap visitor: {} (bodies drawn: {}; {} at {} Hz)", s.poses, drawn,
                              fmt::format("{:.2f} s", times.size() / s.options.fps), s.options.fps);
    write_synthetic_recording(s.out, rig, config.bodies, times, poses, s.options, description);
    std::printf("wrote SYNTHETIC recording %s: %zu frame sets x %zu cameras (%s)\n", s.out.c_str(), times.size(),
                rig.cameras.size(), description.c_str());
    return 0;
  }
  if (s.trajectory == "scripted" || s.trajectory == "static") {
    for (int i = 0; i < frames; ++i) {
      const double t = i / s.options.fps;
      trajectory.push_back(s.trajectory == "scripted" ? scripted_visitor(t) : static_visitor(t));
    }
    description = fmt::format("trajectory: built-in {} visitor, {} s", s.trajectory, s.duration_s);
  } else {
    const auto csv = read_trajectory_csv(s.trajectory);
    for (int i = 0; i < frames; ++i) {
      const double t = csv.front().t + i / s.options.fps;
      if (t > csv.back().t) break;
      trajectory.push_back(sample(csv, t));
    }
    description = fmt::format("trajectory: {} (resampled at {} Hz)", s.trajectory, s.options.fps);
  }
  write_synthetic_recording(s.out, rig, body, trajectory, s.options, description);
  std::printf("wrote SYNTHETIC recording %s: %zu frame sets x %zu cameras (%s)\n", s.out.c_str(), trajectory.size(),
              rig.cameras.size(), description.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  kumite::keep_freed_memory();  // before any thread: frame-sized buffers are reused, not remapped
  CLI::App app{"kumite-track: optical head tracking (recorded or live cameras) and synthetic recordings"};
  app.require_subcommand(0, 1);
  RunOptions run;
  app.add_option("--calibration", run.calibration, "rig calibration (OpenCV YAML)");
  app.add_option("--config", run.config, "tracking.toml");
  app.add_option("--recording", run.recording, "recording folder (frames.csv, camN/NNNNNN.png)");
  app.add_flag("--live", run.live, "capture from the V4L2 cameras in the config's [[cameras]]");
  app.add_option("--out", run.out, "poses.csv to write");
  app.add_flag("--realtime", run.realtime, "play a recording at its own pace (default: as fast as possible)");
  app.add_option("--decode-threads", run.decode_threads, "--realtime: threads decoding PNGs ahead of the clock")
      ->capture_default_str()->check(CLI::Range(1, 16));
  app.add_flag("--unfiltered", run.unfiltered, "write the unsmoothed measurement instead of the filtered pose");
  app.add_option("--duration", run.duration_s, "stop after this many seconds (0 = until the end / Ctrl-C)");
  app.add_option("-v,--verbosity", run.verbosity, "0 = warnings, 1 = info, 2 = debug")->check(CLI::Range(0, 2));

  SynthCli synth;
  auto* sc = app.add_subcommand("synth", "write a SYNTHETIC recording (frames, truth.csv) from a trajectory");
  sc->add_option("--calibration", synth.calibration, "rig calibration (OpenCV YAML)")->required()->check(CLI::ExistingFile);
  sc->add_option("--config", synth.config, "tracking.toml (its first body is drawn)")->required()->check(CLI::ExistingFile);
  sc->add_option("--out", synth.out, "recording folder to create (must not exist or be empty)")->required();
  sc->add_option("--trajectory", synth.trajectory, "scripted, static, or a CSV timestamp_s,x,y,z,qw,qx,qy,qz")->capture_default_str();
  sc->add_option("--poses", synth.poses,
                 "a mocap visitor instead: a poses.csv (kumite-recognise poses --bvh); every body of --config "
                 "named like one of its bodies (head, left_hand, ...) is drawn, for --duration s at most")
      ->check(CLI::ExistingFile);
  sc->add_option("--duration", synth.duration_s, "seconds")->capture_default_str()->check(CLI::Range(0.001, 3600.0));
  sc->add_option("--fps", synth.options.fps, "frame sets per second")->capture_default_str()->check(CLI::Range(1.0, 1000.0));
  sc->add_option("--noise-px", synth.options.centroid_sigma_px, "jitter of each spot centre: sigma per image axis (px)")->capture_default_str();
  sc->add_option("--image-noise", synth.options.image_noise, "sensor noise sigma (grey levels)")->capture_default_str();
  sc->add_option("--hide", synth.hidden, "model markers not drawn, e.g. 0,3 (all the time, or see --hide-from/--hide-until)");
  sc->add_option("--hide-from", synth.options.hide_from_s, "hide them from this time on (s)")->capture_default_str();
  sc->add_option("--hide-until", synth.options.hide_until_s, "hide them until this time (s)");
  sc->add_option("--spurious", synth.options.spurious_blobs, "random spots per camera per frame")->capture_default_str();
  sc->add_option("--lamps", synth.options.static_lamps, "static bright spots per camera")->capture_default_str();
  sc->add_option("--dead-camera", synth.options.dead_camera, "camera index that stops delivering")->capture_default_str();
  sc->add_option("--dead-after", synth.options.dead_after_s, "... from this time on (s)")->capture_default_str();
  sc->add_option("--drop", synth.options.drop_probability, "probability that a camera's frame is missing")
      ->capture_default_str()->check(CLI::Range(0.0, 1.0));
  sc->add_option("--seed", synth.options.seed, "random seed")->capture_default_str();

  std::string rig_out;
  auto* rc = app.add_subcommand("rig", "write the default rig calibration (4 cameras in the corners of 3 m x 3 m)");
  rc->add_option("--out", rig_out, "calibration YAML to write")->required();

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    if (sc->parsed()) return run_synth(synth);
    if (rc->parsed()) {
      write_calibration(rig_out, corner_rig());
      std::printf("wrote %s\n", rig_out.c_str());
      return 0;
    }
    if (run.calibration.empty() || run.config.empty() || run.out.empty()) {
      throw Error("cli", "args", "needs --calibration, --config, --out and --recording DIR or --live (see --help)");
    }
    return run_tracker(run);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kumite-track: %s\n", e.what());
    return 1;
  }
}
