// kumite-recognise: train the DTW strike recogniser, export the learned recogniser's training set,
// run either over a poses.csv, evaluate both side by side across actors, and turn a BVH clip
// into a mocap visitor's poses.csv. See recognition/README.md.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/bvh.hpp"
#include "kumite/recognition/learned.hpp"
#include "kumite/recognition/recognition.hpp"
#include "defend.hpp"
#include "offline.hpp"

namespace fs = std::filesystem;
using namespace kumite;
using namespace kumite::recognition;

namespace {
/// The checkout the tools were built in, found from where this tool is (build/bin/NAME -> the
/// folder above build/), not from a path compiled in: a copied build/bin finds the files beside
/// it, or nothing (then a default it needs is an error that says where it looked).
fs::path source_dir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec || exe.empty()) return fs::current_path(ec);
  return exe.parent_path().parent_path().parent_path();
}
fs::path default_motions() { return source_dir() / "content" / "motions" / "motions.toml"; }
fs::path default_model() { return source_dir() / "recognition" / "models" / "strikes.krec"; }
fs::path default_learned_model() { return source_dir() / "recognition" / "models" / "strikes.klearn"; }
fs::path default_learned_folds() { return source_dir() / "build" / "touche"; }
fs::path default_mocap() { return source_dir() / ".." / "shared" / "data" / "mocap"; }
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"kumite-recognise: the visitor's strikes from tracked poses (dual-buffer DTW, or the learned recogniser)"};
  app.require_subcommand(1);

  auto* train = app.add_subcommand("train", "build mean templates from annotated mocap -> a model file");
  fs::path motions = default_motions(), out_model;
  double threshold_factor = TrainSettings{}.threshold_factor;
  train->add_option("--motions", motions, "annotations (motions.toml)")->check(CLI::ExistingFile);
  train->add_option("--out", out_model, "model file to write (.krec)")->required();
  train->add_option("--threshold-factor", threshold_factor, "template threshold / worst training distance")
      ->check(CLI::Range(1.0, 10.0));

  auto* run = app.add_subcommand("run", "recognise strikes in a poses.csv -> events (JSON lines)");
  fs::path poses, events_out, model_path = default_model();
  run->add_option("--poses", poses, "poses.csv")->required();
  run->add_option("--out", events_out, "events.jsonl")->required();
  std::string recogniser = "dtw";
  run->add_option("--recogniser", recogniser, "dtw (dual-buffer DTW) or learned (Touche network)")
      ->check(CLI::IsMember({"dtw", "learned"}));
  fs::path given_model;
  run->add_option("--model", given_model,
                  "model file (default: the shipped recognition/models/strikes.krec, or strikes.klearn for learned)");

  auto* eval = app.add_subcommand("eval", "cross-actor evaluation -> JSON report");
  fs::path mocap = default_mocap(), report_out;
  eval->add_option("--motions", motions, "annotations (motions.toml)")->check(CLI::ExistingFile);
  eval->add_option("--mocap", mocap, "development mocap folder (boxer, Sony, walks); skipped when absent");
  eval->add_option("--out", report_out, "report (JSON)")->required();
  double test_hz = 0;
  eval->add_option("--tracker-hz", test_hz,
                   "resample every recording's pose stream at exactly this rate before training and testing (as a "
                   "tracker at that rate delivers: samples on a fixed grid), instead of the mocap's own frames")
      ->check(CLI::Range(10.0, 1000.0));
  bool development_actors = false;
  eval->add_flag("--train-on-development-actors", development_actors,
                 "also train on the development-only boxer and Sony punches (tests only, never shipped): they join "
                 "the leave-one-actor-out folds as actors of their own, so every punch actor is tested against a "
                 "model of the others (DTW only; the shipped model never holds them)");
  fs::path learned_folds = default_learned_folds();
  eval->add_option("--learned", learned_folds, "the learned recogniser's fold models (train_touche.py --eval-dir); "
                   "the learned side is left out when absent");
  offline::LearnedOverrides lov;
  eval->add_option("--begin-probability", lov.begin_probability, "learned: class probability that begins a strike")
      ->check(CLI::Range(0.01, 1.0));
  eval->add_option("--begin-progress", lov.begin_progress, "learned: predicted progress that begins a strike")
      ->check(CLI::Range(0.0, 1.0));
  eval->add_option("--end-frames", lov.end_frames, "learned: loops of none that end a strike")->check(CLI::Range(1, 1000));
  eval->add_option("--confirm-frames", lov.confirm_frames, "learned: loops of the same strike class before begin")
      ->check(CLI::Range(1, 1000));
  eval->add_option("--min-speed", lov.min_speed, "learned: m/s, begin only while the limb moves this fast")
      ->check(CLI::Range(0.0, 20.0));
  eval->add_option("--threshold-factor", threshold_factor, "template threshold / worst training distance")
      ->check(CLI::Range(1.0, 10.0));
  bool per_style = false;
  eval->add_flag("--template-per-style", per_style,
                 "hand strikes: one template per action and actor (style) instead of one mean per action "
                 "(evaluation only: a model file holds one template per action)");
  RecogniserSettings rs;
  for (auto* sc : {train, eval}) {
    sc->add_option("--velocity-weight", rs.frontend.velocity_weight, "feature weight of velocity")->check(CLI::Range(0.0, 10.0));
    sc->add_option("--absolute-weight", rs.absolute_weight, "feature weight of the head-relative position")->check(CLI::Range(0.0, 10.0));
    sc->add_option("--none-margin", rs.none_margin, "begin only when closer than margin x the nearest none")->check(CLI::Range(0.0, 10.0));
    sc->add_option("--one-at-a-time", rs.one_at_a_time, "no begin while another limb's strike is active (0/1)");
    sc->add_option("--lead-frames", rs.lead_frames, "0 or 1: the buffer also holds the loop before the onset")->check(CLI::Range(0, 1));
    sc->add_option("--onset-speed", rs.onset_speed, "m/s, a limb faster than this starts a motion")->check(CLI::Range(0.1, 20.0));
    sc->add_option("--null-speed", rs.null_speed, "m/s, the null signal's speed")->check(CLI::Range(0.0, 20.0));
    sc->add_option("--smoothing-tau", rs.frontend.smoothing_tau_s, "s, position smoothing")->check(CLI::Range(1e-4, 1.0));
  }

  auto* ds = app.add_subcommand("dataset", "the learned recogniser's training set (JSON) for recognition/train/train_touche.py");
  fs::path dataset_out;
  ds->add_option("--motions", motions, "annotations (motions.toml)")->check(CLI::ExistingFile);
  ds->add_option("--out", dataset_out, "dataset (JSON)")->required();

  auto* pz = app.add_subcommand("poses", "a BVH clip as a mocap visitor's poses.csv (head, wrists, ankles)");
  fs::path bvh, poses_out;
  pz->add_option("--bvh", bvh, "BVH clip")->required()->check(CLI::ExistingFile);
  pz->add_option("--out", poses_out, "poses.csv")->required();
  double stop_at = -1;
  pz->add_option("--stop-at", stop_at, "s: cut the recording here (a stream that stops mid-strike)");
  double from_s = 0;
  pz->add_option("--from", from_s, "s: start the recording here (times then count from 0)")->check(CLI::NonNegativeNumber);
  std::vector<double> place;
  pz->add_option("--place", place, "x,z (m): where the head stands on average (every body moved with it)")
      ->expected(2)->delimiter(',');
  double hz = 0;
  pz->add_option("--hz", hz, "Hz: rows at this rate (as a tracker at that rate would give them; 0 = every clip frame)")
      ->check(CLI::Range(1.0, 1000.0));
  double stay_s = 0;
  pz->add_option("--stay", stay_s,
                 "s: keep the visitor near its place: the head's floor travel averaged over this window is taken "
                 "out of every body (a lunging clip punching on the spot; labelled in the file)")
      ->check(CLI::Range(0.0, 60.0));

  auto* df = app.add_subcommand("defend", "the sparring fighter's defence (blocks) against development mocap visitors "
                                          "-> per recording a fighter BVH and a trace for scripts/judge-blocks.py, and defence.json");
  offline::DefenceArgs da;
  da.mocap = default_mocap();
  da.character = source_dir() / "content" / "characters" / "kenji.bvh";
  df->add_option("--db", da.db, "fighter.kdb")->required()->check(CLI::ExistingFile);
  df->add_option("--character", da.character, "character BVH")->check(CLI::ExistingFile)->capture_default_str();
  df->add_option("--mocap", da.mocap, "development mocap folder (boxer, Sony, HDM05, CMU walks)")->capture_default_str();
  df->add_option("--out", da.out, "output folder")->required();
  df->add_option("--tracker-hz", da.tracker_hz, "Hz the visitor's bodies are measured at")->check(CLI::Range(10.0, 1000.0))
      ->capture_default_str();
  df->add_option("--threat-speed", da.threat.min_speed_mps, "m/s: threat_min_speed_mps")->capture_default_str();
  df->add_option("--threat-aim", da.threat.aim_radius_m, "m: threat_aim_radius_m")->capture_default_str();
  df->add_option("--threat-horizon", da.threat.horizon_s, "s: threat_horizon_s")->capture_default_str();
  df->add_option("--threat-window", da.threat.velocity_window_s, "s: threat_velocity_window_s")->capture_default_str();
  df->add_option("--threat-extension", da.threat.min_extension, "share: threat_min_extension")->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  df->add_option("--threat-two-hand-mirror", da.threat.two_hand_mirror, "share: threat_two_hand_mirror (0: off)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  df->add_option("--fighting-distance", da.fighting_distance_m, "m: fighting_distance_m")->check(CLI::Range(0.3, 3.0))
      ->capture_default_str();
  df->add_option("--stance-steps", da.stance_step_min_m, "m: stance_step_min_m, sparring's stance steps from the mocap (0: off)")
      ->check(CLI::Range(0.0, 2.0))
      ->capture_default_str();
  df->add_option("--follow-arc", da.follow_arc_deg,
                 "deg: follow_arc_deg, the spot kept lies this far either side of the way from the visitor to home (180: anywhere)")
      ->check(CLI::Range(10.0, 180.0))
      ->capture_default_str();
  df->add_option("--place-z", da.place_z, "m: the visitor's head's mean z")->capture_default_str();
  df->add_option("--area-x", da.area_x_m, "m: where the fighter may stand, room x (min max; as config/demo-spar.toml's [fighter] x_limits_m)")
      ->capture_default_str();
  df->add_option("--area-z", da.area_z_m, "m: where the fighter may stand, room z (min max; as config/demo-spar.toml's [fighter] z_limits_m)")
      ->capture_default_str();
  df->add_option("--lead-in", da.lead_in_s, "s the visitor stands still first")->check(CLI::Range(0.0, 30.0))->capture_default_str();
  df->add_option("--ease-in", da.ease_in_s, "s over which the visitor's motion starts from stillness (SYNTHETIC; 0: at full speed at once)")
      ->check(CLI::Range(0.0, 2.0))
      ->capture_default_str();

  CLI11_PARSE(app, argc, argv);
  try {
    TrainSettings ts;
    ts.threshold_factor = threshold_factor;
    ts.template_per_style = per_style;
    if (df->parsed()) {
      std::cout << offline::run_defence(da).dump(2) << "\n";
      return 0;
    }
    if (train->parsed()) {
      const auto recs = offline::load_motions(motions);
      std::vector<const offline::Recording*> p;
      for (const auto& r : recs)
        if (!r.strikes.empty() || r.negative) p.push_back(&r);
      int strikes = 0, negatives = 0;
      for (const auto* r : p) (r->negative ? negatives : strikes)++;
      const Model m = offline::train(
          p, rs, ts,
          fmt::format("trained on {}: {} recordings with strikes, {} without (none templates); templates derived from "
                      "CMU mocap (CMU terms, acknowledgement requested) and HDM05 (CC BY-SA 3.0, Mueller et al. 2007)",
                      motions.filename().string(), strikes, negatives));
      write_model(out_model, m);
      nlohmann::json j = nlohmann::json::array();
      std::map<std::string, int> nones;
      for (const auto& t : m.templates) {
        if (t.action == kNoneAction) {
          ++nones[std::string(to_string(t.kind))];
          continue;
        }
        j.push_back({{"action", t.action}, {"kind", to_string(t.kind)}, {"trials", t.trials}, {"frames", t.frames.size()},
                     {"hit", t.hit}, {"threshold_main_buffer", t.threshold_at(rs.main_frames)}, {"threshold_full", t.threshold}});
      }
      std::cout << nlohmann::json{{"model", out_model.string()}, {"templates", j}, {"none_templates", nones}}.dump() << "\n";
    } else if (run->parsed()) {
      const bool learned = recogniser == "learned";
      if (given_model.empty()) {
        given_model = learned ? default_learned_model() : model_path;
        if (!fs::exists(given_model))
          throw Error("cli", "model",
                      fmt::format("run: no --model given and no shipped model beside the tools ({} does not exist): "
                                  "give --model FILE",
                                  given_model.string()));
      }
      std::cerr << "kumite-recognise run: model " << given_model.string() << "\n";
      const recognition::PosesFile pf = recognition::read_poses_csv(poses);
      if (std::none_of(pf.samples.begin(), pf.samples.end(), [](const PoseSample& s) { return s.role == Role::head; }))
        std::cerr << "kumite-recognise run: " << poses.string()
                  << " has no row of a body named head: a limb is read relative to the head, so no strike can be "
                     "recognised\n";
      std::vector<Event> ev;
      long loops = 0;
      auto feed = [&](auto& rec) {
        const auto& v = pf.samples;
        for (std::size_t i = 0; i < v.size(); ++i) {
          rec.push(v[i], ev);
          if (i + 1 == v.size() || v[i + 1].t != v[i].t) rec.end_of_set(v[i].t, ev);  // a frame set is whole
        }
        rec.finish(v.empty() ? 0 : v.back().t, ev);
        loops = rec.loops();
      };
      if (learned) {
        LearnedRecogniser rec(read_learned_model(given_model));
        feed(rec);
      } else {
        Recogniser rec(read_model(given_model));
        feed(rec);
      }
      std::string text;
      for (const Event& e : ev) text += to_json(e) + "\n";
      write_file_atomically(events_out, text);
      std::cout << nlohmann::json{{"events", ev.size()}, {"samples", pf.samples.size()}, {"ignored_rows", pf.ignored_rows},
                                  {"loops", loops}, {"recogniser", recogniser}, {"model", given_model.string()},
                                  {"out", events_out.string()}}
                       .dump()
                << "\n";
    } else if (eval->parsed()) {
      auto trainable = offline::load_motions(motions);
      std::vector<offline::Recording> external;
      if (fs::exists(mocap)) external = offline::load_external(mocap);
      else std::cerr << "eval: no development mocap at " << mocap.string() << ": boxer, Sony and walks left out\n";
      if (development_actors) {
        // Their strikes join the folds (each of boxer, sony an actor of its own); the strike-free
        // external recordings (walk, run) stay external, scored by the model of every actor.
        std::vector<offline::Recording> rest;
        int moved = 0;
        for (auto& r : external) {
          if (r.strikes.empty()) {
            rest.push_back(std::move(r));
          } else {
            trainable.push_back(std::move(r));
            ++moved;
          }
        }
        external = std::move(rest);
        if (moved == 0) {
          std::cerr << "eval: --train-on-development-actors: no boxer or Sony recordings under " << mocap.string() << "\n";
          return 1;
        }
      }
      if (test_hz > 0) {
        for (auto& r : trainable) r.samples = offline::resample(r.samples, test_hz);
        for (auto& r : external) r.samples = offline::resample(r.samples, test_hz);
      }
      nlohmann::json report;
      if (test_hz > 0) report["tracker_hz"] = test_hz;
      report["what"] = "the two strike recognisers side by side, on the same held-out actors (see recognition/README.md)";
      report["dtw"] = offline::evaluate(trainable, external, rs, ts);
      if (development_actors) {
        report["development_actors_trained_on"] = true;
        report["dtw"]["what"] = std::string(report["dtw"]["what"]) +
                                "; --train-on-development-actors: the boxer and Sony punches are actors of the folds "
                                "too (trained on when another actor is held out; never in a shipped model)";
        std::cerr << "eval: --train-on-development-actors: the learned side is left out (its fold models are of "
                     "content/motions only)\n";
      } else if (fs::exists(learned_folds / "all.klearn")) report["learned"] = offline::evaluate_learned(trainable, external, learned_folds, lov);
      else std::cerr << "eval: no learned fold models in " << learned_folds.string()
                     << " (recognition/train/train_touche.py --eval-dir): the learned side is left out\n";
      report["motions"] = motions.string();
      report["mocap"] = fs::exists(mocap) ? mocap.string() : "";
      nlohmann::json summary;
      for (const char* k : {"dtw", "learned"}) {
        if (!report.contains(k)) continue;
        const auto& r = report[k];
        const auto& h = r["held_out_total"];
        summary[k] = {{"held_out_strikes", h["strikes"]}, {"right_limb_pct", h["right_limb_pct"]},
                      {"right_kind_pct", h["right_kind_pct"]}, {"latency_p50_ms", h["latency_from_onset_ms"]["p50"]},
                      {"latency_p90_ms", h["latency_from_onset_ms"]["p90"]},
                      {"false_triggers_per_idle_minute", r["false_triggers"]["per_idle_minute"]},
                      {"correct_pct_at_progress", h["correct_pct_at_progress"]},
                      {"loop_cpu_us_p50", r["loop_cpu_us"]["p50"]}, {"loop_cpu_us_p99", r["loop_cpu_us"]["p99"]}};
      }
      report["side_by_side"] = summary;
      write_file_atomically(report_out, report.dump(2) + "\n");
      std::cout << nlohmann::json{{"report", report_out.string()}, {"side_by_side", summary}}.dump() << "\n";
    } else if (ds->parsed()) {
      // Shippable data only (content/motions): the development-only recordings are never trained on.
      const auto recs = offline::load_motions(motions);
      std::vector<offline::Recording> used;
      for (const auto& r : recs)
        if (!r.strikes.empty() || r.negative) used.push_back(r);
      nlohmann::json j = offline::learned_dataset(used, rs.frontend);
      j["motions"] = motions.string();
      write_file_atomically(dataset_out, j.dump() + "\n");
      std::cout << nlohmann::json{{"out", dataset_out.string()}, {"recordings", used.size()}, {"classes", j["classes"]}}.dump()
                << "\n";
    } else if (pz->parsed()) {
      const auto clip = content::read_bvh(bvh);
      auto r = offline::recording_from_clip(clip);
      if (stop_at >= 0)
        std::erase_if(r.samples, [&](const PoseSample& s) { return s.t > stop_at; });
      std::erase_if(r.samples, [&](const PoseSample& s) { return s.t < from_s - 1e-9; });
      for (PoseSample& s : r.samples) s.t -= from_s;
      if (hz > 0) {  // per role, the first sample at or after each tick
        std::array<double, kRoleCount> due{};
        std::erase_if(r.samples, [&](const PoseSample& s) {
          double& d = due[static_cast<std::size_t>(s.role)];
          if (s.t < d - 1e-6) return true;
          d = std::max(d + 1 / hz, s.t + 0.5 / hz);
          return false;
        });
      }
      std::string note = fmt::format("# {}: {}{}\n", bvh.filename().string(),
                                     from_s > 0 || stop_at >= 0 ? fmt::format("{:.2f} s to {}, ", from_s, stop_at >= 0 ? fmt::format("{:.2f} s", stop_at) : std::string("the end")) : std::string(),
                                     "the head, wrists (hands) and ankles (feet) of the clip as tracked bodies");
      offline::place_visitor(r.samples, place.size() == 2 ? std::optional<std::array<double, 2>>({place[0], place[1]}) : std::nullopt, stay_s);
      if (stay_s > 0)
        note += fmt::format("# SYNTHETIC placement: the head's floor travel averaged over {:.1f} s taken out of every body\n", stay_s);
      if (place.size() == 2) note += fmt::format("# placed: the head on average at x = {:.2f}, z = {:.2f} m\n", place[0], place[1]);
      write_file_atomically(poses_out, note + recognition::format_poses_csv(r.samples));
      std::cout << nlohmann::json{{"out", poses_out.string()}, {"samples", r.samples.size()}}.dump() << "\n";
    }
  } catch (const kumite::Error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kumite-recognise: %s\n", e.what());
    return 1;
  }
  return 0;
}
