// kumite: the installation. Reads the installation file, starts tracking, the fighter and the
// orders script, then renders the walls in windows (with a display) or headless.
//
//   kumite --config config/demo.toml                      # windows, or headless without a display
//   kumite --config config/demo.toml --headless --frames 300 --out out/demo --save-every 30
#include <CLI/CLI.hpp>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <iostream>
#include <limits>


#include "kumite/app/cluster_source.hpp"
#include "kumite/app/config.hpp"
#include "kumite/app/export.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/run.hpp"
#include "kumite/app/service.hpp"
#include "kumite/app/session.hpp"
#include "kumite/app/tracking_input.hpp"
#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/log.hpp"
#include "kumite/common/realtime.hpp"

namespace {

struct Args {
  std::string config = "config/demo.toml";
  std::string node;            ///< --node NAME: a render node of the file's [cluster]
  std::string cluster_timing;  ///< --cluster-timing FILE: CSV of every frame's cluster times
  bool headless = false;
  int frames = 300;
  std::string out = "out/kumite";
  int save_every = 30;
  std::string orders;
  std::string resolution;
  std::string stereo;
  double seconds = 0;
  bool no_console = false;
  bool simulated = false;
  std::string screenshot;
  std::string log;
  std::string data_dir;
  int render_nice = 5;
  int verbosity = 1;
  std::string record, replay, replay_from;
  double record_budget_mb = 0;
  bool record_budget_given = false;
  bool replay_real_time = false;
  bool replay_windows = false;
  bool retrack = false;
  bool replay_out_given = false, frames_given = false;
  bool config_given = false;
  // kumite export
  std::string export_log, export_bvh, export_head_csv;
  double export_from = 0, export_to = 1e300;
  // unattended operation
  std::string health_file;
  std::uint64_t debug_hang_after_frames = 0;
  std::string status_file;
};



std::optional<std::array<int, 2>> parse_resolution(const std::string& s) {
  if (s.empty()) return std::nullopt;
  int w = 0, h = 0;
  char x = 0;
  std::istringstream in(s);
  if (!(in >> w >> x >> h) || x != 'x' || w <= 0 || h <= 0)
    throw kumite::Error("cli", "resolution", "--resolution: expected WIDTHxHEIGHT, got \"" + s + "\"");
  return std::array<int, 2>{w, h};
}

/// A number of seconds, megabytes ... on the command line: finite and within [lo, hi] (CLI11's
/// Range lets NaN through: neither below nor above).
CLI::Validator finite_in(double lo, double hi) {
  return CLI::Validator(
      [lo, hi](std::string& s) -> std::string {
        double v = 0;
        std::size_t used = 0;
        try {
          v = std::stod(s, &used);
        } catch (const std::exception&) {
          used = 0;
        }
        if (used == 0 || used != s.size()) return "\"" + s + "\" is not a number";
        if (!(v >= lo && v <= hi)) return fmt::format("{} is not in [{}, {}]", s, lo, hi);
        return {};
      },
      fmt::format("[{} - {}]", lo, hi));
}

/// Raises the calling thread's nice value by `n` (threads it starts later inherit it).
void lower_render_priority(int n) {
  if (const auto nice = kumite::lower_this_thread_priority(n)) spdlog::debug("render thread: nice {}", *nice);
}

/// The folder a file option writes into ("" for the current one).
std::filesystem::path folder_of(const std::string& file) {
  return std::filesystem::path(file).parent_path();
}

int run_export(const Args& a) {
  auto config = kumite::app::load_installation_config(
      a.config, a.data_dir.empty() ? std::nullopt : std::optional<std::filesystem::path>(a.data_dir));
  kumite::app::ExportOptions eo;
  eo.log = a.export_log;
  eo.from_s = a.export_from;
  eo.to_s = a.export_to;
  if (!a.export_bvh.empty()) eo.bvh = a.export_bvh;
  if (!a.export_head_csv.empty()) eo.head_csv = a.export_head_csv;
  if (!eo.bvh && !eo.head_csv) throw kumite::Error("cli", "export", "export: nothing to write (--out FILE.bvh and/or --head-csv FILE)");
  for (const auto& f : {a.export_bvh, a.export_head_csv})
    if (!f.empty()) kumite::app::make_output_folder(folder_of(f).empty() ? "." : folder_of(f), f);
  const auto rep = kumite::app::export_log(config, eo);
  spdlog::info("export: frames {}..{} ({:.3f}..{:.3f} s, {} frames){}", rep.first_frame, rep.last_frame, rep.first_time_s,
               rep.last_time_s, rep.frames, rep.truncated_last_line ? "; the log's last line was cut short" : "");
  if (rep.runs.size() > 1)
    spdlog::info("export: the interval holds {} character runs (a character switch): one BVH each", rep.runs.size());
  for (const auto& run : rep.runs)
    spdlog::info("export: {} (character {} \"{}\", frames {}..{}, {:.3f}..{:.3f} s, frame time {:.6f} s)", run.bvh.string(),
                 run.character + 1, run.character_name, run.first_frame, run.last_frame, run.first_time_s, run.last_time_s,
                 run.frame_time_s);
  if (eo.head_csv) spdlog::info("export: {} (head poses)", eo.head_csv->string());
  return 0;
}

/// Leftovers of runs killed before they could clean up (SIGKILL, a power cut): temporary files
/// of processes that are gone, in the folders this run writes or reads (its outputs, the
/// calibration's). One line per folder that had any.
void remove_leftovers(const std::vector<std::filesystem::path>& folders) {
  std::vector<std::filesystem::path> seen;
  for (const auto& f : folders) {
    const auto dir = f.empty() ? std::filesystem::path(".") : f;
    std::error_code ec;
    const auto canonical = std::filesystem::weakly_canonical(dir, ec);
    if (std::find(seen.begin(), seen.end(), canonical) != seen.end()) continue;
    seen.push_back(canonical);
    const auto removed = kumite::remove_stale_temporaries(dir);
    if (removed.empty()) continue;
    std::string names;
    for (const auto& r : removed) names += (names.empty() ? "" : ", ") + r.filename().string();
    spdlog::warn("removed {} temporary file{} left by killed runs in {}: {}", removed.size(),
                 removed.size() == 1 ? "" : "s", dir.string(), names);
  }
}

int run_status(const Args& a) {
  std::filesystem::path file = a.status_file;
  if (file.empty()) {
    const auto config = kumite::app::load_installation_config(a.config);
    if (!config.health.file)
      throw kumite::Error("cli", "status",
                          fmt::format("status: {} has no [health] file (give one, or --file FILE)", a.config));
    file = config.resolve(*config.health.file);
  }
  const auto line = kumite::app::read_status(file, kumite::app::unix_now());
  std::cout << line.text << "\n";
  return line.exit_code;
}

int run(const Args& a, const std::atomic<int>& stop, kumite::Timestamp process_started) {
  auto config = kumite::app::load_installation_config(
      a.config, a.data_dir.empty() ? std::nullopt : std::optional<std::filesystem::path>(a.data_dir));
  // Output folders are made (or refused, in one line) before anything starts, not found
  // missing at the end of a run.
  const bool headless = a.headless || !kumite::app::display_available();
  if (headless) {
    kumite::app::make_output_folder(a.out, "--out " + a.out);
    // Window options asked of a headless run (--headless, or no display) are not silently
    // dropped: said once, with where the frames go instead.
    for (const auto& [option, file] : {std::pair{"--log", a.log}, std::pair{"--screenshot", a.screenshot}})
      if (!file.empty())
        spdlog::warn("{} {}: for windowed runs; this run is headless and writes frames.jsonl and PNGs in --out {}",
                     option, file, a.out);
  } else {
    for (const auto& [option, file] : {std::pair{"--log", a.log}, std::pair{"--screenshot", a.screenshot}}) {
      if (file.empty()) continue;
      const std::string what = std::string(option) + " " + file;
      if (std::filesystem::is_directory(file)) throw kumite::Error("io", "folder", what + ": is a folder, not a file");
      kumite::app::make_output_folder(folder_of(file).empty() ? "." : folder_of(file), what);
    }
  }
  // A render node draws the master's frames: no tracker, no fighter, no installation of its own.
  kumite::app::ClusterRunOptions cluster_run;
  cluster_run.stop = &stop;
  if (!a.cluster_timing.empty()) cluster_run.timing_log = a.cluster_timing;
  if (!a.node.empty()) {
    // In windows, a node waiting for its master keeps its last picture and its windows answer.
    cluster_run.repeat_while_waiting = !headless;
    kumite::app::ClusterNodeSource source(config, a.node, cluster_run);
    if (headless) {
      kumite::app::HeadlessOptions ho;
      ho.frames = a.frames_given ? a.frames : std::numeric_limits<int>::max();
      ho.out = a.out;
      ho.save_every = a.save_every;
      ho.resolution = parse_resolution(a.resolution);
      ho.real_time = false;  // paced by the master: every PNG asked for is written
      ho.stop = &stop;
      return kumite::app::present_headless(source, ho);
    }
    kumite::app::WindowOptions wo;
    if (a.seconds > 0) wo.seconds = a.seconds;
    if (!a.screenshot.empty()) wo.screenshot = a.screenshot;
    if (!a.log.empty()) wo.log = a.log;
    wo.stop = &stop;
    if (const auto* n = config.cluster->node(a.node); n && n->swap_group)
      wo.swap_group = kumite::app::SwapGroupRequest{a.node, *n->swap_group, n->swap_barrier};
    return kumite::app::present_windows(source, wo);
  }
  // The health report: --health-file, else the config's [health] file (made like an output).
  std::optional<std::filesystem::path> health_file;
  if (!a.health_file.empty()) health_file = a.health_file;
  else if (config.health.file) health_file = config.resolve(*config.health.file);
  // A health report that cannot be written (its folder cannot be made: a file in the way, no
  // permission) takes out the report alone: one error line, a console problem; the show runs.
  std::vector<std::string> start_problems;
  if (health_file) {
    const std::string what = "health report " + health_file->string();
    try {
      if (std::filesystem::is_directory(*health_file)) throw kumite::Error("io", "folder", what + ": is a folder, not a file");
      kumite::app::make_output_folder(folder_of(health_file->string()).empty() ? "." : folder_of(health_file->string()), what);
    } catch (const kumite::Error& e) {
      start_problems.push_back(std::string("health report off: ") + e.what());
      spdlog::error("{}", start_problems.back());
      health_file.reset();
    }
  }
  {
    std::vector<std::filesystem::path> folders;
    if (headless) folders.push_back(a.out);
    for (const auto& f : {a.log, a.screenshot})
      if (!headless && !f.empty()) folders.push_back(folder_of(f));
    if (health_file) folders.push_back(health_file->parent_path());
    if (!a.record.empty()) folders.push_back(std::filesystem::path(a.record).parent_path());
    if (!config.tracking.calibration.empty()) folders.push_back(config.resolve(config.tracking.calibration).parent_path());
    remove_leftovers(folders);
  }
  if (!config.data_root().empty()) spdlog::info("data folder ${{data_dir}}: {}", config.data_root().string());
  if (!a.stereo.empty()) {
    const auto m = kumite::app::stereo_mode_from_string(a.stereo);
    if (!m) throw kumite::Error("cli", "stereo", "--stereo: unknown stereo mode \"" + a.stereo + "\"");
    config.stereo.mode = *m;
    config.lines.erase("stereo.mode");  // errors about the mode then name --stereo, not the file's line
  }
  kumite::app::InstallationOptions io;
  if (!a.orders.empty()) io.orders_script = a.orders;
  io.mono_eyes = config.stereo.mode == kumite::app::StereoMode::mono;
  io.problems = start_problems;
  // A tracker that cannot start (missing recording, calibration, cameras) is not a stop: the
  // walls draw from the default head and the console says why. A tracking.toml that is there
  // but wrong (a bad value, nan or inf, a TOML error) is bad config like the installation
  // file's, and stops start-up with its file, line and key.
  std::unique_ptr<kumite::app::TrackingInput> tracking;
  try {
    kumite::app::TrackingInputOptions to;
    to.simulated_clock = headless && a.simulated;
    tracking = kumite::app::make_tracking_input(config, to);
  } catch (const kumite::Error& e) {
    if (e.component() == "config" && e.code() != "missing") throw;
    spdlog::error("tracking unavailable: {}", e.what());
    tracking = kumite::app::make_fixed_head_input(std::string("tracking unavailable: ") + e.what());
  }
  kumite::app::Installation inst(config, std::move(tracking), io);
  // --record DIR records from the start; the record key (if bound) starts and stops a
  // recording into --record's folder (default out/session; "-2", "-3"... when taken).
  kumite::app::RecordSwitch recording(
      inst,
      kumite::app::session_info(config, io, a.record_budget_given ? std::optional<double>(a.record_budget_mb) : std::nullopt),
      a.record.empty() ? "out/session" : a.record);
  if (!a.record.empty()) recording.start();
  inst.on_record_key([&recording] { recording.toggle(); });
  kumite::app::RunInfo info;
  info.config = std::filesystem::absolute(a.config);
  info.mode = headless ? "headless" : "windows";
  if (headless) info.frames_log = std::filesystem::path(a.out) / "frames.jsonl";
  else if (!a.log.empty()) info.frames_log = a.log;
  if (!a.record.empty()) info.session = a.record;
  kumite::app::RunMonitorOptions mo;
  mo.health_file = health_file;
  mo.health_interval_s = config.health.interval_s;
  mo.debug_hang_after_frames = a.debug_hang_after_frames;
  mo.stop = &stop;
  mo.process_started = process_started;
  kumite::app::RunMonitor monitor(info, mo);
  const auto finish = [&](int rc) {
    recording.finish();
    return rc;
  };
  // The tracker's threads are running (at the process's priority); the render thread and the
  // GL driver's threads it starts from here on (llvmpipe) yield to them when the cores are short.
  lower_render_priority(a.render_nice);
  if (headless) {
    if (!a.headless) spdlog::info("no display ($DISPLAY unset): rendering headless into {}", a.out);
    kumite::app::HeadlessOptions ho;
    ho.frames = a.frames;
    ho.out = a.out;
    ho.save_every = a.save_every;
    ho.resolution = parse_resolution(a.resolution);
    ho.real_time = !a.simulated;
    ho.stop = &stop;
    ho.monitor = &monitor;
    if (config.cluster) {
      // The cluster's master: the live step, its state to every node, the swap barrier.
      kumite::app::ClusterMasterSource master(
          inst, a.simulated ? kumite::app::LivePacing::simulated : kumite::app::LivePacing::real_time, cluster_run);
      const int rc = kumite::app::present_headless(master, ho);
      kumite::app::log_retrieval_timing(inst);
      kumite::app::log_spar_summary(inst);
      return finish(rc);
    }
    return finish(kumite::app::run_headless(inst, ho));
  }
  kumite::app::WindowOptions wo;
  if (a.seconds > 0) wo.seconds = a.seconds;
  wo.console = !a.no_console;
  if (!a.screenshot.empty()) wo.screenshot = a.screenshot;
  if (!a.log.empty()) wo.log = a.log;
  wo.stop = &stop;
  wo.monitor = &monitor;
  if (config.cluster) {
    kumite::app::ClusterMasterSource master(inst, kumite::app::LivePacing::display, cluster_run);
    const int rc = kumite::app::present_windows(master, wo);
    kumite::app::log_retrieval_timing(inst);
    kumite::app::log_spar_summary(inst);
    return finish(rc);
  }
  return finish(kumite::app::run_windows(inst, wo));
}

int run_replay(const Args& a, const std::atomic<int>& stop) {
  kumite::app::ReplayOptions ro;
  if (a.config_given) ro.config_override = a.config;
  if (!a.data_dir.empty()) ro.data_dir = a.data_dir;
  if (!a.replay_from.empty()) ro.from = a.replay_from;
  ro.real_time = a.replay_real_time;
  ro.retrack = a.retrack;
  // --out with --replay draws the replayed frames headless (from --from on, at most --frames
  // of them when given): the walls as the visitor saw them at that moment, and frames.jsonl.
  kumite::app::ReplayReport rep;
  if (a.replay_windows) {
    // In the installation's windows and its console, at the pace it was recorded unless asked
    // otherwise: a technician watching what happened at that moment.
    if (a.replay_out_given)
      throw kumite::Error("cli", "replay", "--replay: --windows and --out: one of them (windows, or PNGs headless)");
    kumite::app::WindowOptions wo;
    wo.console = !a.no_console;
    wo.stop = &stop;
    if (!a.screenshot.empty()) wo.screenshot = a.screenshot;
    ro.real_time = true;
    ro.show_recorded = true;  // what the visitors saw, even where this build makes other frames
    kumite::app::replay_windows(a.replay, ro, wo, rep);
  } else if (a.replay_out_given) {
    kumite::app::HeadlessOptions ho;
    ho.frames = a.frames_given ? a.frames : std::numeric_limits<int>::max();
    ho.out = a.out;
    ho.save_every = a.save_every;
    ho.resolution = parse_resolution(a.resolution);
    ro.show_recorded = true;  // draw what the visitors saw, even where this build makes other frames
    kumite::app::replay_headless(a.replay, ro, ho, rep);
  } else {
    rep = kumite::app::replay_session(a.replay, ro);
  }
  for (const auto& n : rep.notes) spdlog::warn("replay: {}", n);
  const double speed = rep.wall_s > 0 ? rep.session_s / rep.wall_s : 0;
  if (rep.retrack) {
    // Re-tracked: a report, not a check (the tracker of this build may differ on purpose).
    const auto& t = *rep.retrack;
    spdlog::info("replay --retrack: {} frames from {} camera frame sets ({:.2f} s of session in {:.2f} s: {:.1f}x real "
                 "time); the re-tracked head is {:.2f} / {:.2f} / {:.2f} mm (p50 / p95 / max) from the recorded one; "
                 "tracked in one and not the other in {} frames; {} of {} frames identical to the recording{}",
                 rep.frames_replayed, t.sets, rep.session_s, rep.wall_s, speed, t.head_p50_m * 1e3, t.head_p95_m * 1e3,
                 t.head_max_m * 1e3, t.status_differs, t.frames_identical, t.frames_compared,
                 rep.first_difference_frame
                     ? fmt::format(" (the first to differ: frame {}, {})", *rep.first_difference_frame,
                                   rep.first_difference_detail.empty() ? rep.first_difference_field
                                                                       : rep.first_difference_detail)
                                            : "");
    return rep.notes.empty() ? 0 : 2;
  }
  if (!rep.identical) {
    std::cerr << fmt::format("kumite: {}: frame {}: {} differs from the recording (frames before it identical){}\n",
                             (std::filesystem::path(a.replay) / "session.jsonl").string(), *rep.first_difference_frame,
                             rep.first_difference_field,
                             rep.first_difference_detail.empty() ? "" : ": " + rep.first_difference_detail);
    return 1;
  }
  if (rep.from_frame && !a.replay_from.empty())
    spdlog::info("replay: shown from frame {} ({:.3f} s into the session){}", *rep.from_frame, rep.from_s,
                 a.replay_real_time ? ", in real time" : "");
  if (rep.stopped_after_frame)
    spdlog::info("replay: ended by the viewer after frame {} (the frames up to it compared)", *rep.stopped_after_frame);
  if (!rep.compared) {
    spdlog::info("replay: {} of {} recorded frames re-run, not compared ({:.2f} s of session in {:.2f} s)",
                 rep.frames_replayed, rep.frames_recorded, rep.session_s, rep.wall_s);
    return 2;
  }
  spdlog::info("replay: {} of {} recorded frames replayed, {} ({:.2f} s of session in {:.2f} s: {:.0f}x real time)",
               rep.frames_replayed, rep.frames_recorded,
               rep.states_compared ? "every state identical to the recording"
                                   : "every frame's state hashes identical to the recording (states not compared by "
                                     "value: see the warnings)",
               rep.session_s, rep.wall_s, speed);
  return rep.notes.empty() ? 0 : 2;
}

}  // namespace

int main(int argc, char** argv) {
  const kumite::Timestamp process_started = kumite::now();  // uptime and the time to READY count from here
  kumite::keep_freed_memory();  // before any thread: frame-sized buffers are reused, not remapped
  CLI::App app{"kumite: the installation (walls in stereo, the fighter, the supervisor console)"};
  Args a;
  app.add_option("--config", a.config, "installation file (TOML)")->capture_default_str();
  app.add_flag("--headless", a.headless, "render off-screen (EGL) even with a display");
  app.add_option("--node", a.node,
                 "run as this render node of the file's [cluster] (draws its walls from the master's frames); "
                 "without it, a file with [cluster] makes this process the master");
  app.add_option("--cluster-timing", a.cluster_timing,
                 "cluster: CSV of every frame's times (master: barrier; node: STATE received, READY sent, GO received)");
  app.add_option("--frames", a.frames, "headless: frames to render")
      ->check(CLI::Range(1, std::numeric_limits<int>::max()))
      ->capture_default_str();
  app.add_option("--out", a.out, "headless: output folder (PNGs, frames.jsonl)")->capture_default_str();
  app.add_option("--save-every", a.save_every, "headless: PNGs every K-th frame and at each strike's hit or miss (0 = none)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--orders", a.orders, "orders script (rows time_s,order); overrides the config's");
  app.add_option("--resolution", a.resolution, "headless: WIDTHxHEIGHT for every wall (overrides config)");
  app.add_option("--stereo", a.stereo, "override stereo mode: quad_buffer side_by_side top_bottom anaglyph mono");
  app.add_flag("--simulated-time", a.simulated, "headless: step time by 1/rate without waiting for real time");
  app.add_option("--seconds", a.seconds, "windows: stop after this many seconds")->check(finite_in(0.0, 1e9));
  app.add_flag("--no-console", a.no_console, "windows: no supervisor console window");
  app.add_option("--screenshot", a.screenshot, "windows: PNG of the first window at the end");
  app.add_option("--log", a.log, "windows: write frames.jsonl here");
  app.add_option("--data-dir", a.data_dir,
                 "folder of the data made at set-up (what ${data_dir} means in the config; "
                 "default $KUMITE_DATA_DIR, else the config's data_dir)");
  app.add_option("--render-nice", a.render_nice,
                 "nice value added to the render thread (and GL threads it starts), so tracking wins the cores; 0 = off")
      ->check(CLI::Range(0, 19))
      ->capture_default_str();
  app.add_option("-v,--verbosity", a.verbosity, "0 warnings, 1 info, 2 debug")->check(CLI::Range(0, 2))->capture_default_str();
  app.add_option("--record", a.record,
                 "record the session into this folder: every frame's inputs and state hashes (kumite --replay)");
  app.add_option("--record-budget-mb", a.record_budget_mb,
                 "MB a recording may take on disk, then it stops with a warning (default: [record] budget_mb, 2048)")
      ->check(finite_in(1e-3, 1e7));
  app.add_option("--replay", a.replay,
                 "re-run a recorded session from its inputs and check every frame against it; with --out, also draw "
                 "the replayed frames headless there (PNGs, frames.jsonl), from --from on, at most --frames of them");
  app.add_option("--from", a.replay_from,
                 "replay: show from this time: seconds into the session (12.5) or the time of day (21:14:05)");
  app.add_flag("--windows", a.replay_windows,
               "replay: show the replayed frames in the installation's windows and its console (buttons greyed), at "
               "the pace they were recorded; the quit key or closing a window ends it");
  app.add_flag("--real-time", a.replay_real_time, "replay: frames at the pace they were recorded (default: as fast as possible)");
  app.add_flag("--retrack", a.retrack,
               "replay: re-track the head from the session's camera frames (cameras.bin) with this build's tracker, in "
               "step with the recorded frames, and report how far it is from the recorded head (not a bit-for-bit check)");
  CLI::App* exp = app.add_subcommand(
      "export", "from a frames.jsonl: the fighter's performance as BVH on its character's skeleton, the head poses as CSV");
  exp->add_option("--log", a.export_log, "frames.jsonl of a run")->required();
  exp->add_option("--from", a.export_from, "s, first time_s taken (default: the start)")->check(finite_in(0, 1e12));
  exp->add_option("--to", a.export_to, "s, last time_s taken (default: the end)")->check(finite_in(0, 1e300));
  exp->add_option("--out", a.export_bvh, "BVH file of the fighter (characters from --config)");
  exp->add_option("--head-csv", a.export_head_csv, "CSV of the head poses: frame,time_s,x_m,y_m,z_m,qw,qx,qy,qz,live");
  exp->add_option("--config", a.config, "installation file the run used (its characters)");
  exp->add_option("--data-dir", a.data_dir, "as for the run");
  app.add_option("--health-file", a.health_file,
                 "write the health report (JSON, about once a second) here; overrides the config's [health] file");
  app.add_option("--debug-hang-after-frames", a.debug_hang_after_frames,
                 "TEST AID: after N frames the frame loop stops advancing (no frames, no watchdog pings) until "
                 "SIGINT/SIGTERM, as a hung render or tracker would; 0 = off")
      ->capture_default_str();
  CLI::App* status = app.add_subcommand(
      "status", "one line from the health report of a running kumite; exit 0 all well, 1 problems or stopped, "
                "2 stale (hung or gone), 3 unreadable");
  status->add_option("--file", a.status_file, "health report (default: the [health] file of --config)");
  status->add_option("--config", a.config, "installation file whose [health] file to read");
  CLI11_PARSE(app, argc, argv);
  kumite::init_logging(a.verbosity);
  // SIGINT (Ctrl-C) and SIGTERM end the run at its next frame with its outputs complete; the
  // exit status then says which: 128 + the signal's number (130, 143), as a shell reports a
  // process the signal killed. A second one kills at once.
  const std::atomic<int>& stop = kumite::app::stop_on_signals();
  try {
    if (exp->parsed()) return run_export(a);
    if (status->parsed()) return run_status(a);
    a.config_given = app.count("--config") > 0;
    a.record_budget_given = app.count("--record-budget-mb") > 0;
    a.replay_out_given = app.count("--out") > 0;
    a.frames_given = app.count("--frames") > 0;
    if (!a.replay.empty()) return run_replay(a, stop);
    const int rc = run(a, stop, process_started);
    if (const int sig = stop.load(); sig != 0) {
      spdlog::info("stopped by {}: outputs complete, exit status {}", sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : "a signal",
                   128 + sig);
      return rc != 0 ? rc : 128 + sig;
    }
    return rc;
  } catch (const kumite::Error& e) {
    std::cerr << "kumite: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "kumite: " << e.what() << "\n";
    return 1;
  }
}
