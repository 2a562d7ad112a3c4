// sd_notify readiness and watchdog pings, and the health report (see service.hpp).
#include "kumite/app/service.hpp"
#include "kumite/app/session.hpp"

#include <systemd/sd-daemon.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/realtime.hpp"

namespace kumite::app {

using nlohmann::json;

double unix_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// --- sd_notify -----------------------------------------------------------------------------

ServiceNotifier::ServiceNotifier() {
  const char* socket = std::getenv("NOTIFY_SOCKET");
  enabled_ = socket && *socket;
  std::uint64_t usec = 0;
  // > 0: the watchdog is on for this process (WATCHDOG_PID, when set, names it).
  if (enabled_ && sd_watchdog_enabled(0, &usec) > 0 && usec > 0) watchdog_s_ = static_cast<double>(usec) * 1e-6;
}

bool ServiceNotifier::notify(const std::string& state) const {
  if (!enabled_) return false;
  return sd_notify(0, state.c_str()) > 0;
}

// --- the run's monitor ---------------------------------------------------------------------

namespace {
/// s between STATUS= lines (systemctl status shows the newest).
constexpr double kStatusInterval_s = 5.0;
}  // namespace

struct RunMonitor::Snapshot {
  double wall = 0;  ///< Unix time of the frame
  double uptime_s = 0;
  std::uint64_t frames = 0;
  double show_time_s = 0;
  double fps = 0;
  double frame_cpu_ms = 0;
  bool ready = false;
  std::string tracking, tracking_source, recognition;
  bool head_live = false;
  double pose_age_ms = -1;
  int head_body = 0;
  std::vector<ConsoleCamera> cameras;
  int markers_seen = 0;
  std::string fighter_state;
  std::string character_name;
  bool paused = false;
  std::vector<std::string> problems;
  std::string last_problem;
  double last_problem_wall = 0;
  std::map<std::string, std::uint64_t> events;
  std::string last_order, last_outcome;
  std::string session_dir, session_status;  ///< the session recorder attached now ("" = none): its folder and line
  std::string state = "running";  ///< running | loading | stopped
  std::string stop_reason;
  kumite::MemoryFigures memory;  ///< taken on the report's thread when it is written
};

RunMonitor::RunMonitor(RunInfo info, RunMonitorOptions options)
    : info_(std::move(info)), options_(std::move(options)), started_(options_.process_started.value_or(now())) {
  started_wall_ = unix_now() - (now() - started_);
  if (notifier_.enabled())
    spdlog::info("service: sd_notify to $NOTIFY_SOCKET{}",
                 notifier_.watchdog_s() ? fmt::format(", watchdog {:.1f} s (a ping every {:.2f} s while frames advance)",
                                                      *notifier_.watchdog_s(), notifier_.ping_interval_s())
                                        : ", no watchdog");
  if (options_.debug_hang_after_frames > 0)
    spdlog::warn("debug: the frame loop will hang after {} frames (--debug-hang-after-frames, a test aid)",
                 options_.debug_hang_after_frames);
  if (options_.health_file) {
    // A report from before this run must not read as this run's: the first one is written at once.
    Snapshot s;
    s.wall = started_wall_;
    s.state = "starting";
    write_report(s);
    spdlog::info("health report: {} (every {:.1f} s; `kumite status --file {}`)", options_.health_file->string(),
                 options_.health_interval_s, options_.health_file->string());
    want_ = true;
    writer_ = std::thread([this] { write_loop(); });
  }
}

RunMonitor::~RunMonitor() {
  stopping(stop_reason_.empty() ? "end of run" : stop_reason_);
}

void RunMonitor::stopping(const std::string& why, const Installation* inst) {
  if (stopped_) return;
  stopped_ = true;
  notifier_.notify(fmt::format("STOPPING=1\nSTATUS=stopping: {}", why));
  if (writer_.joinable()) {
    std::unique_ptr<Snapshot> last;
    if (inst && frames_ > 0) {
      last = std::make_unique<Snapshot>();
      take_snapshot(*inst, inst->frame(), *last);
    }
    {
      std::lock_guard lock(mutex_);
      if (last) {
        pending_ = std::move(last);
        have_ = true;
      }
      closing_ = true;
      stop_reason_ = why;
    }
    cv_.notify_all();
    writer_.join();
  }
}

void RunMonitor::take_snapshot(const Installation& inst, const FrameData& f, Snapshot& s) const {
  const ConsoleState c = inst.console();
  s.wall = unix_now();
  s.uptime_s = now() - started_;
  s.frames = frames_;
  s.show_time_s = f.time_s;
  s.fps = c.fps;
  s.frame_cpu_ms = c.frame_cpu_ms;
  s.ready = ready_sent_ || !inst.tracking_loading();
  s.state = inst.tracking_loading() ? "loading" : "running";
  s.tracking = c.tracking;
  s.tracking_source = c.tracking_source;
  s.recognition = c.recognition;
  s.head_live = c.head_live;
  s.pose_age_ms = c.pose_age_ms;
  s.head_body = inst.config().tracking.head_body.value_or(-1);  // -1: the body named "head"
  s.cameras = c.cameras;
  s.markers_seen = c.markers_seen;
  s.fighter_state = c.fighter_state;
  s.character_name = c.character_name;
  s.paused = c.paused;
  s.problems = c.problems;
  s.last_problem = last_problem_;
  s.last_problem_wall = last_problem_wall_;
  s.events = events_;
  s.last_order = c.last_order;
  s.last_outcome = c.last_outcome;
  // A session recorded now (--record, or the record key mid-run): what the console shows of it.
  if (const SessionRecorder* r = inst.recorder()) {
    s.session_dir = r->dir().string();
    s.session_status = r->status_line();
  } else {
    s.session_dir.clear();
    s.session_status.clear();
  }
}

void RunMonitor::frame_done(const Installation& inst, const FrameData& f) {
  ++frames_;
  for (const auto& e : f.events) ++events_[std::string(to_string(e.type))];
  // The newest problem, with the moment it first showed (a problem that stays is not new).
  const auto problems = inst.problems();
  if (!problems.empty() && (problems.size() != last_problems_count_ || problems.front() != last_problem_)) {
    if (problems.front() != last_problem_) {
      last_problem_ = problems.front();
      last_problem_wall_ = unix_now();
    }
  }
  last_problems_count_ = problems.size();
  for (const auto& e : f.events)
    if (e.type == EventType::warning) {
      last_problem_ = inst.event_text(e);
      last_problem_wall_ = unix_now();
    }

  const Timestamp t = now();
  if (!ready_sent_ && !inst.tracking_loading()) {
    ready_sent_ = true;
    notifier_.notify(fmt::format("READY=1\nSTATUS=running: frame {}, tracking {}", frames_, inst.console().tracking));
    spdlog::info("service: the show is up {:.2f} s after the process started (frame {}){}", t - started_, frames_,
                 notifier_.enabled() ? ": READY=1 sent" : "");
  }
  if (notifier_.watchdog_s() && (last_ping_ < 0 || t - last_ping_ >= notifier_.ping_interval_s())) {
    notifier_.notify("WATCHDOG=1");
    last_ping_ = t;
  }
  if (notifier_.enabled() && (last_status_ < 0 || t - last_status_ >= kStatusInterval_s)) {
    const ConsoleState c = inst.console();
    notifier_.notify(fmt::format("STATUS={}: frame {}, {:.1f} fps, tracking {}, fighter {}{}",
                                 ready_sent_ ? "running" : "loading", frames_, c.fps, c.tracking, c.fighter_state,
                                 c.problems.empty() ? "" : ", problem: " + c.problems.front()));
    last_status_ = t;
  }
  if (want_.load(std::memory_order_relaxed)) {
    auto s = std::make_unique<Snapshot>();
    take_snapshot(inst, f, *s);
    {
      std::lock_guard lock(mutex_);
      pending_ = std::move(s);
      have_ = true;
      want_ = false;
    }
    cv_.notify_all();
  }
  if (options_.debug_hang_after_frames > 0 && frames_ == options_.debug_hang_after_frames) {
    spdlog::warn("debug: frame {}: the frame loop hangs now (--debug-hang-after-frames): no more frames, no "
                 "watchdog pings, until SIGINT/SIGTERM",
                 frames_);
    while (!(options_.stop && options_.stop->load() != 0))
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

void RunMonitor::write_loop() {
  const auto interval = std::chrono::duration<double>(options_.health_interval_s);
  auto next = std::chrono::steady_clock::now();
  Snapshot last;
  last.wall = started_wall_;
  last.state = "starting";
  for (;;) {
    next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(interval);
    std::unique_ptr<Snapshot> s;
    bool closing = false;
    {
      std::unique_lock lock(mutex_);
      cv_.wait_until(lock, next, [&] { return closing_; });
      closing = closing_;
      if (have_) {
        s = std::move(pending_);
        have_ = false;
      }
      if (!closing) want_ = true;  // the frame loop fills the next one
    }
    if (s) last = *s;
    if (closing) {
      last.state = "stopped";
      last.stop_reason = stop_reason_;
      last.memory = kumite::memory_figures();
      last.wall = unix_now();
      last.uptime_s = now() - started_;
      write_report(last);
      return;
    }
    // No new frame since the last report: the file says so by its frame time (written_at
    // stays the frame's), so `kumite status` sees a hung loop as stale.
    if (s) {
      last.memory = kumite::memory_figures();  // here, off the frame thread
      write_report(last);
    }
    if (std::chrono::steady_clock::now() > next + interval) next = std::chrono::steady_clock::now();
  }
}

json RunMonitor::to_json(const Snapshot& s) const {
  json j;
  j["kumite_health"] = 1;
  j["pid"] = static_cast<long>(::getpid());
  j["config"] = info_.config.string();
  j["mode"] = info_.mode;
  j["state"] = s.state;
  if (!s.stop_reason.empty()) j["stop_reason"] = s.stop_reason;
  j["written_at"] = s.wall;
  j["started_at"] = started_wall_;
  j["interval_s"] = options_.health_interval_s;
  j["uptime_s"] = s.uptime_s;
  j["frames"] = s.frames;
  j["show_time_s"] = s.show_time_s;
  j["fps"] = s.fps;
  j["frame_cpu_ms"] = s.frame_cpu_ms;
  j["ready"] = s.ready;
  j["watchdog_s"] = notifier_.watchdog_s() ? json(*notifier_.watchdog_s()) : json(nullptr);
  j["tracking"] = {{"status", s.tracking}, {"source", s.tracking_source}, {"markers_seen", s.markers_seen}};
  if (!s.recognition.empty()) j["tracking"]["recognition"] = s.recognition;
  j["tracking"]["bodies"] = json::array({json{{"body", s.head_body >= 0 ? json(s.head_body) : json(nullptr)},  // null: by its role
                                              {"role", "head"},
                                              {"status", s.tracking},
                                              {"live", s.head_live},
                                              {"pose_age_ms", s.pose_age_ms}}});
  json cams = json::array();
  for (const auto& c : s.cameras)
    cams.push_back({{"name", c.name}, {"status", c.status}, {"blobs", c.blobs}, {"since_last_ms", c.since_last_ms}});
  j["tracking"]["cameras"] = cams;
  j["fighter"] = {{"state", s.fighter_state}, {"character", s.character_name}, {"paused", s.paused},
                  {"last_order", s.last_order}, {"last_outcome", s.last_outcome}};
  j["problems"] = s.problems;
  j["last_problem"] = s.last_problem.empty() ? json(nullptr)
                                             : json{{"text", s.last_problem}, {"at", s.last_problem_wall}};
  j["events"] = s.events;
  // The resident set beside what the allocator has in use: freed memory is kept for reuse
  // (keep_freed_memory), so RSS is the high-water mark of transient peaks; in_use_mb is live.
  if (s.memory.rss_mb > 0)
    j["memory"] = {{"rss_mb", s.memory.rss_mb},
                   {"in_use_mb", s.memory.allocator_known ? json(s.memory.in_use_mb) : json(nullptr)},
                   {"held_mb", s.memory.allocator_known ? json(s.memory.held_mb) : json(nullptr)},
                   {"took_ms", s.memory.took_ms}};  // null: the allocator does not say (sanitizer builds)
  // `session`: the folder a session is recorded into now (the record key starts and stops one
  // mid-run), else the one the run was started with; `session_status`: its console line.
  const bool session_now = !s.session_dir.empty();
  j["recording"] = {{"frames_log", info_.frames_log ? json(info_.frames_log->string()) : json(nullptr)},
                    {"session", session_now    ? json(s.session_dir)
                                : info_.session ? json(info_.session->string())
                                                : json(nullptr)},
                    {"session_status", session_now ? json(s.session_status) : json(nullptr)},
                    {"active", s.state != "stopped" && (info_.frames_log || info_.session || session_now)}};
  return j;
}

void RunMonitor::write_report(const Snapshot& s) {
  try {
    write_file_atomically(*options_.health_file, to_json(s).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  } catch (const Error& e) {
    static std::atomic<int> warned{0};
    if (warned++ == 0) spdlog::warn("health report: {} (said once)", e.what());
  }
}

// --- kumite status -------------------------------------------------------------------------

namespace {
std::string ago(double s) {
  if (s < 90) return fmt::format("{:.0f} s", s);
  if (s < 5400) return fmt::format("{:.0f} min", s / 60);
  return fmt::format("{:.1f} h", s / 3600);
}
std::string duration(double s) {
  const auto total = static_cast<long>(s);
  return fmt::format("{}h{:02}m{:02}s", total / 3600, (total / 60) % 60, total % 60);
}
}  // namespace

StatusLine read_status(const std::filesystem::path& file, double now_s) {
  StatusLine out;
  std::ifstream in(file);
  if (!in) {
    out.text = fmt::format("{}: cannot read the health report ({})", file.string(), std::strerror(errno));
    out.exit_code = 3;
    return out;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  const json j = json::parse(ss.str(), nullptr, false);
  const auto num = [&](const char* k) {
    return j.contains(k) && j[k].is_number() ? j[k].get<double>() : std::nan("");
  };
  if (j.is_discarded() || !j.is_object() || !j.contains("kumite_health") || !std::isfinite(num("written_at"))) {
    out.text = fmt::format("{}: not a kumite health report", file.string());
    out.exit_code = 3;
    return out;
  }
  const double age = now_s - num("written_at");
  const double interval = std::isfinite(num("interval_s")) ? num("interval_s") : 1.0;
  const std::string state = j.value("state", "?");
  std::string cams;
  int ok = 0, all = 0;
  if (j.contains("tracking") && j["tracking"].contains("cameras"))
    for (const auto& c : j["tracking"]["cameras"]) {
      ++all;
      if (c.value("status", "") == "ok") ++ok;
    }
  const std::string tracking = j.contains("tracking") ? j["tracking"].value("status", "?") : "?";
  const std::string fighter = j.contains("fighter") ? j["fighter"].value("state", "?") : "?";
  const bool recording = j.contains("recording") && j["recording"].is_object() && j["recording"].value("active", false);
  // What is written: a session (its console line), the frames log alone, or nothing.
  std::string recorded = recording ? "recording on" : "recording off";
  if (recording) {
    const json& r = j["recording"];
    if (r.contains("session_status") && r["session_status"].is_string())
      recorded = r["session_status"].get<std::string>();
    else if (r.contains("session") && r["session"].is_string())
      recorded = "recording " + r["session"].get<std::string>();
    else if (r.contains("frames_log") && r["frames_log"].is_string())
      recorded = "frames logged, no session recorded";
  }
  const auto problems = j.contains("problems") && j["problems"].is_array() ? j["problems"].size() : 0;
  std::string text = fmt::format("kumite {} (pid {}): up {}, frame {}, {:.1f} fps, tracking {}", state,
                                 j.value("pid", 0L), duration(num("uptime_s")), j.value("frames", 0UL), num("fps"),
                                 tracking.substr(0, tracking.find(',')));
  if (all > 0) text += fmt::format(", cameras {}/{} ok", ok, all);
  text += fmt::format(", fighter {}, {}", fighter, recorded);
  if (problems > 0) text += fmt::format(", {} problem{}: {}", problems, problems == 1 ? "" : "s", j["problems"][0].get<std::string>());
  else if (j.contains("last_problem") && j["last_problem"].is_object())
    text += fmt::format(", last problem {} ago: {}", ago(now_s - j["last_problem"].value("at", now_s)),
                        j["last_problem"].value("text", ""));
  // Stale: no report for 3 intervals (and 2 s for a loaded machine): the frame loop or the
  // process is gone or hung.
  const double stale_after = 3 * interval + 2;
  if (state == "stopped") {
    text += fmt::format("; stopped {} ago ({})", ago(age), j.value("stop_reason", "?"));
    out.exit_code = 1;
  } else if (age > stale_after) {
    text = fmt::format("STALE: last report {} ago (the frame loop or the process is hung or gone); ", ago(age)) + text;
    out.exit_code = 2;
  } else if (problems > 0 || state != "running") {
    out.exit_code = 1;
  }
  out.text = text;
  return out;
}

}  // namespace kumite::app
