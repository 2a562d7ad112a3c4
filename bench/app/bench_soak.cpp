// Soak: the demo run for a long show time (default 1 h = 216000 frames at 60 Hz) at simulated
// time, headless, at a low resolution, with its RSS (from /proc), frame rate, frame count and
// event counts (from its health report) sampled every few seconds. Prints one JSON object: the
// samples and, after the warm-up (the preload and the first `warmup` share of the show), the
// RSS's least-squares slope (MB per hour of show time) and the change it makes over the run as
// a percentage of the RSS at the end of the warm-up (target: within +-5 %). Not run in CI.
//
//   build/bin/kumite_app_soak [--config config/demo.toml] [--show-s 3600] [--resolution 64x36]
//                             [--sample-s 10] [--warmup 0.1] [--out DIR] [-- more kumite args]
//
// The kumite binary is the one beside this one (build/bin/kumite). Its frames.jsonl goes to
// DIR (default: a folder under /tmp, removed at the end): some 4 kB per frame.
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

extern char** environ;

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

struct Sample {
  double wall_s = 0;      ///< since the start
  double rss_mb = 0;
  double in_use_mb = -1;  ///< the health report's memory.in_use_mb (allocated now); -1 = none
  double show_s = 0;      ///< the run's show time (frames / rate)
  std::uint64_t frames = 0;
  double fps = 0;         ///< the health report's rolling rate
  json events = json::object();
  std::string state;
};

double rss_mb(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("VmRSS:", 0) == 0) return std::atof(line.c_str() + 6) / 1024.0;
  return -1;
}

double hwm_mb(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("VmHWM:", 0) == 0) return std::atof(line.c_str() + 6) / 1024.0;
  return -1;
}

volatile std::sig_atomic_t g_stop = 0;
extern "C" void on_stop(int) { g_stop = 1; }

[[noreturn]] void usage_error(const std::string& what) {
  std::cerr << "kumite_app_soak: " << what << " (see the comment at the top of bench/app/bench_soak.cpp)\n";
  std::exit(2);
}

double number(const std::string& option, const char* text) {
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (!end || *end || !std::isfinite(v) || v <= 0) usage_error(option + ": expected a positive number, got \"" + text + "\"");
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  std::string config = "config/demo.toml", resolution = "64x36";
  double show_s = 3600, sample_s = 10, warmup = 0.1;
  fs::path out;
  std::vector<std::string> extra;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&]() -> const char* {
      if (i + 1 >= argc) usage_error(a + " needs a value");
      return argv[++i];
    };
    if (a == "--config") config = value();
    else if (a == "--show-s") show_s = number(a, value());
    else if (a == "--resolution") resolution = value();
    else if (a == "--sample-s") sample_s = number(a, value());
    else if (a == "--warmup") warmup = number(a, value());
    else if (a == "--out") out = value();
    else if (a == "--") {
      extra.assign(argv + i + 1, argv + argc);
      break;
    } else usage_error("unknown argument \"" + a + "\"");
  }
  if (warmup >= 1) usage_error("--warmup: a share of the show time, below 1");
  const bool own_out = out.empty();
  if (own_out) out = fs::temp_directory_path() / ("kumite_soak_" + std::to_string(::getpid()));
  fs::create_directories(out);
  const fs::path health = out / "health.json";
  const fs::path exe = fs::canonical("/proc/self/exe").parent_path() / "kumite";
  const double rate = 60.0;  // the demo's display_rate_hz; frames = show time x rate
  const auto frames = static_cast<long>(std::llround(show_s * rate));
  std::vector<std::string> args{exe.string(), "--config", config, "--headless", "--simulated-time",
                                "--frames", std::to_string(frames), "--resolution", resolution,
                                "--save-every", "0", "--out", out.string(), "--health-file", health.string(),
                                "-v", "0"};
  args.insert(args.end(), extra.begin(), extra.end());
  std::vector<char*> argv2;
  for (auto& s : args) argv2.push_back(s.data());
  argv2.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  const std::string console = (out / "console.txt").string();
  posix_spawn_file_actions_addopen(&fa, 1, console.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&fa, 1, 2);
  pid_t pid = -1;
  if (posix_spawn(&pid, exe.c_str(), &fa, nullptr, argv2.data(), environ) != 0) {
    std::cerr << "kumite_app_soak: cannot start " << exe << "\n";
    return 1;
  }
  posix_spawn_file_actions_destroy(&fa);

  // SIGINT/SIGTERM: the run is stopped (kumite ends cleanly) and what was sampled is reported.
  std::signal(SIGINT, on_stop);
  std::signal(SIGTERM, on_stop);
  bool forwarded = false;
  std::vector<Sample> samples;
  const auto t0 = std::chrono::steady_clock::now();
  const auto since = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  int status = 0;
  double peak_mb = 0;
  for (;;) {
    std::this_thread::sleep_for(std::chrono::duration<double>(sample_s));
    const double hwm = hwm_mb(pid);
    if (hwm > peak_mb) peak_mb = hwm;
    Sample s;
    s.wall_s = since();
    s.rss_mb = rss_mb(pid);
    std::ifstream in(health);
    std::stringstream text;
    text << in.rdbuf();
    const json h = json::parse(text.str(), nullptr, false);
    if (!h.is_discarded() && h.is_object()) {
      s.frames = h.value("frames", std::uint64_t{0});
      s.show_s = static_cast<double>(s.frames) / rate;
      s.fps = h.value("fps", 0.0);
      if (h.contains("events")) s.events = h["events"];
      s.state = h.value("state", "");
      if (h.contains("memory") && h["memory"].is_object() && h["memory"].contains("in_use_mb") &&
          h["memory"]["in_use_mb"].is_number())
        s.in_use_mb = h["memory"]["in_use_mb"].get<double>();
    }
    if (::waitpid(pid, &status, WNOHANG) == pid) break;
    if (g_stop && !forwarded) {
      ::kill(pid, SIGTERM);
      forwarded = true;
    }
    if (s.rss_mb > 0) {
      samples.push_back(s);
      std::cerr << json{{"t_s", std::round(s.wall_s)}, {"rss_mb", std::round(s.rss_mb * 10) / 10},
                        {"show_s", std::round(s.show_s)}, {"fps", std::round(s.fps)}, {"state", s.state}}
                       .dump()
                << "\n";
    }
  }
  const double wall_s = since();

  // After the warm-up: the preload done (the report says "running") and `warmup` of the show.
  std::vector<const Sample*> steady;
  for (const auto& s : samples)
    if (s.state == "running" && s.show_s >= warmup * show_s) steady.push_back(&s);
  json result;
  result["benchmark"] = "kumite_app_soak";
  result["config"] = config;
  result["resolution"] = resolution;
  result["show_s_asked"] = show_s;
  result["frames_asked"] = frames;
  result["exit_status"] = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  // How the run ended, in words: a kumite killed by a signal it was not sent is a crash, the
  // soak's worst finding (exit_status 139 alone was easy to read past).
  std::string ended;
  if (WIFSIGNALED(status)) {
    ended = std::string(forwarded ? "stopped" : "CRASHED") + ": killed by signal " + std::to_string(WTERMSIG(status)) +
            " (" + strsignal(WTERMSIG(status)) + ")";
  } else if (WIFEXITED(status)) {
    ended = WEXITSTATUS(status) == 0 ? "complete" : "exit " + std::to_string(WEXITSTATUS(status));
    if (forwarded) ended = "stopped (SIGTERM forwarded), " + ended;
  }
  result["ended"] = ended;
  if (WIFSIGNALED(status) && !forwarded) std::cerr << "kumite_app_soak: kumite " << ended << "\n";
  result["wall_s"] = wall_s;
  result["peak_rss_mb"] = peak_mb;
  result["samples_taken"] = samples.size();
  if (!samples.empty()) {
    const auto& last = samples.back();
    result["show_s_reached"] = last.show_s;
    result["frames_reached"] = last.frames;
    result["frames_per_wall_s"] = static_cast<double>(last.frames) / wall_s;
    result["stopped_early"] = forwarded;
    result["events"] = last.events;
  }
  // Least squares y = a + b * show time over the steady samples: the slope (MB per show hour)
  // and the change it makes over them as a percentage of its value at their start.
  struct Trend {
    double start = 0, end = 0, lo = 1e300, hi = 0, slope = 0, change_pct = 0;
    double fitted_start = 0;  ///< the fit at the first steady sample; <= 0: no change to speak of
    int n = 0;
  };
  const auto trend = [&](double Sample::*field) {
    Trend t;
    double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (const Sample* s : steady) {
      const double x = s->show_s / 3600, y = s->*field;
      if (y < 0) continue;
      if (t.n++ == 0) t.start = y;
      t.end = y;
      n += 1;
      sx += x;
      sy += y;
      sxx += x * x;
      sxy += x * y;
      t.lo = std::min(t.lo, y);
      t.hi = std::max(t.hi, y);
    }
    if (t.n < 3) return t;
    t.slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    const double a = (sy - t.slope * sx) / n;
    const double x0 = steady.front()->show_s / 3600, x1 = steady.back()->show_s / 3600;
    const double at_start = a + t.slope * x0;
    t.fitted_start = at_start;
    t.change_pct = at_start > 0 ? 100 * t.slope * (x1 - x0) / at_start : 0;
    return t;
  };
  if (steady.size() >= 3) {
    const Trend r = trend(&Sample::rss_mb);
    result["steady"] = {{"from_show_s", steady.front()->show_s},
                        {"to_show_s", steady.back()->show_s},
                        {"samples", steady.size()},
                        {"rss_start_mb", r.start},
                        {"rss_end_mb", r.end},
                        {"rss_min_mb", r.lo},
                        {"rss_max_mb", r.hi},
                        {"rss_slope_mb_per_show_hour", r.slope},
                        {"rss_change_pct", r.change_pct},
                        {"rss_spread_pct", r.lo > 0 ? 100 * (r.hi - r.lo) / r.lo : 0}};
    result["flat_within_5pct"] = r.fitted_start > 0 && std::abs(r.change_pct) <= 5;
    // What the allocator has in use (the health report's memory.in_use_mb): kumite keeps freed
    // memory for reuse, so RSS is the high-water mark of transient peaks (a software GL
    // driver's per-draw allocations among them) and may step up where nothing leaks; a leak
    // shows here as a slope. It swings from sample to sample with those transients.
    const Trend u = trend(&Sample::in_use_mb);
    if (u.n >= 3) {
      result["steady"]["in_use_samples"] = u.n;
      result["steady"]["in_use_start_mb"] = u.start;
      result["steady"]["in_use_end_mb"] = u.end;
      result["steady"]["in_use_min_mb"] = u.lo;
      result["steady"]["in_use_max_mb"] = u.hi;
      result["steady"]["in_use_slope_mb_per_show_hour"] = u.slope;
      result["steady"]["in_use_change_pct"] = u.change_pct;
    }
  } else {
    result["steady"] = nullptr;
    result["note"] = "fewer than 3 samples after the warm-up: no slope";
  }
  json series = json::array();
  for (const auto& s : samples)
    series.push_back({{"t_s", s.wall_s}, {"rss_mb", s.rss_mb}, {"in_use_mb", s.in_use_mb}, {"show_s", s.show_s}, {"fps", s.fps}});
  result["samples"] = series;
  std::cout << result.dump(2) << "\n";
  if (own_out) fs::remove_all(out);
  return 0;
}
