// kumite_app_strike_latency (issue 14): the visitor's strikes end to end, camera frame to event.
// A mocap visitor (a poses.csv: config/visitor-135_06.poses.csv by default, CMU 135_06 placed in
// the room) drawn as a SYNTHETIC camera recording (every body with its own markers,
// config/tracking-gloves.toml: glasses, two gloves, two shoes; written once to --recording),
// preloaded into memory and handed over at 60 Hz on the real clock as cameras deliver (as the
// demo plays its recording: drawing the images live takes ~30 ms a set here, slower than a
// camera); the real tracker; the recognition thread; a frame loop polling at 60 Hz as the
// installation does. Prints JSON: per event, camera time of the frame set that
// decided it -> published by the recognition thread ("decided") and -> taken by a frame
// ("taken"), p50/p99/max, beside the head pose's own latency (frame set -> pose published:
// what the synthetic rendering and the tracker take); the bodies' tracked share and error against the mocap; the events
// beside the recogniser run on the mocap poses themselves (what tracking changed).
//
//   kumite_app_strike_latency [--poses FILE] [--seconds S] [--recording DIR] [--out report.json]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "kumite/app/config.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/tracking_input.hpp"
#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/recognition/poses_file.hpp"
#include "kumite/tracking/calibration_file.hpp"
#include "kumite/tracking/config.hpp"
#include "kumite/tracking/synth.hpp"
#include "kumite/tracking/tracker.hpp"

using namespace kumite;
namespace rec = kumite::recognition;

namespace {

double pct(std::vector<double> v, double p) {
  if (v.empty()) return -1;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::min<double>(static_cast<double>(v.size()) - 1, std::floor(p * static_cast<double>(v.size()))))];
}

/// Per role, the mocap samples in time order, sampled by linear interpolation (nullopt where
/// the file has the body lost, or before/after it).
struct Visitor {
  std::array<std::vector<rec::PoseSample>, rec::kRoleCount> by_role;
  double first = 0, last = 0;
  std::optional<tracking::TrajectoryPoint> at(rec::Role r, double t) const {
    const auto& v = by_role[static_cast<std::size_t>(r)];
    if (v.size() < 2 || t < v.front().t || t > v.back().t) return std::nullopt;
    const auto it = std::upper_bound(v.begin(), v.end(), t, [](double x, const rec::PoseSample& s) { return x < s.t; });
    const auto& b = it == v.end() ? v.back() : *it;
    const auto& a = it == v.begin() ? v.front() : *(it - 1);
    if (!a.tracked || !b.tracked) return std::nullopt;
    const double s = b.t > a.t ? (t - a.t) / (b.t - a.t) : 0;
    tracking::TrajectoryPoint p;
    p.t = t;
    for (int k = 0; k < 3; ++k) p.position[k] = a.position[static_cast<std::size_t>(k)] + s * (b.position[static_cast<std::size_t>(k)] - a.position[static_cast<std::size_t>(k)]);
    const Eigen::Quaterniond qa(a.orientation[0], a.orientation[1], a.orientation[2], a.orientation[3]);
    const Eigen::Quaterniond qb(b.orientation[0], b.orientation[1], b.orientation[2], b.orientation[3]);
    p.orientation = qa.normalized().slerp(s, qb.normalized());
    return p;
  }
};

}  // namespace

int main(int argc, char** argv) {
  std::string poses = KUMITE_SOURCE_DIR + "/config/visitor-135_06.poses.csv";
  std::string out, recording = "/tmp/kumite-strike-latency-recording";
  double seconds = 12;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--poses" && i + 1 < argc) poses = argv[++i];
    else if (a == "--seconds" && i + 1 < argc) seconds = std::atof(argv[++i]);
    else if (a == "--out" && i + 1 < argc) out = argv[++i];
    else if (a == "--recording" && i + 1 < argc) recording = argv[++i];
    else {
      std::fprintf(stderr, "usage: kumite_app_strike_latency [--poses FILE] [--seconds S] [--recording DIR] [--out report.json]\n");
      return 2;
    }
  }
  if (!(seconds > 0 && seconds < 3600)) {
    std::fprintf(stderr, "kumite_app_strike_latency: --seconds %g: must be in (0, 3600)\n", seconds);
    return 2;
  }
  try {
    // The demo's room and rig, the gloves' tracking config, the shipped model.
    auto cfg = app::load_installation_config(KUMITE_SOURCE_DIR + "/config/demo.toml");
    cfg.tracking.source = app::TrackingSource::recording;
    cfg.tracking.tracking = KUMITE_SOURCE_DIR + "/config/tracking-gloves.toml";
    cfg.tracking.recording = recording;
    cfg.recognition.model = KUMITE_SOURCE_DIR + "/recognition/models/strikes.krec";
    const auto rig = tracking::read_calibration(cfg.resolve(cfg.tracking.calibration));
    const auto tc = tracking::read_tracking_config(cfg.tracking.tracking);
    const auto file = rec::read_poses_csv(poses);
    Visitor v;
    for (const auto& s : file.samples) v.by_role[static_cast<std::size_t>(s.role)].push_back(s);
    if (file.samples.empty()) throw Error("bench", "poses", poses + ": no sample");
    v.first = file.samples.front().t;
    v.last = file.samples.back().t;
    std::vector<std::optional<rec::Role>> roles;
    for (const auto& b : tc.bodies) roles.push_back(rec::role_from_string(b.name));
    const int sets = static_cast<int>(std::min(seconds, v.last - v.first) * 60);
    if (!std::filesystem::exists(recording / std::filesystem::path("frames.csv"))) {
      std::fprintf(stderr, "writing the SYNTHETIC recording %s (%d frame sets; once)\n", recording.c_str(), sets);
      std::vector<Timestamp> times;
      std::vector<std::vector<std::optional<tracking::TrajectoryPoint>>> drawn;
      for (int i = 0; i < sets; ++i) {
        times.push_back(i / 60.0);
        auto& row = drawn.emplace_back(roles.size());
        for (std::size_t b = 0; b < roles.size(); ++b)
          if (roles[b]) row[b] = v.at(*roles[b], v.first + i / 60.0);
      }
      // As the demo's recording (scripts/make-demo-data.sh): no sensor noise, so the preload
      // packs each image to its spots and playback keeps up at 60 Hz (with noise 2 the
      // unpacking alone took ~60 ms a set here); spot centres still jitter 0.3 px.
      tracking::SynthOptions o;
      o.image_noise = 0;
      tracking::write_synthetic_recording(recording, rig, tc.bodies, times, drawn, o,
                                          "mocap visitor " + poses + " (kumite_app_strike_latency)");
    }
    cfg.tracking.recording_preload = sets;
    cfg.tracking.decode_threads = 2;
    cfg.tracking.realtime_priority = 0;
    auto input = app::make_tracking_input(cfg);
    while (input->loading()) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    std::fprintf(stderr, "preloaded; playing %.1f s\n", sets / 60.0);
    seconds = sets / 60.0;
    app::TrackingSnapshot snap;
    std::vector<app::VisitorStrike> events;
    std::vector<double> taken_ms, tracking_ms;
    Timestamp last_measured = -1;
    const Timestamp t0 = now();
    Timestamp first_set = -1;
    for (Timestamp t = t0; t - t0 < seconds; t = now()) {
      input->poll(t, t, snap);
      if (first_set < 0 && snap.head) first_set = snap.head->timestamp;
      if (snap.measured_at > last_measured && snap.measured_ready_at >= snap.measured_at) {
        last_measured = snap.measured_at;
        tracking_ms.push_back((snap.measured_ready_at - snap.measured_at) * 1e3);
      }
      for (const auto& e : snap.strikes) {
        events.push_back(e);
        taken_ms.push_back((t - e.t) * 1e3);
      }
      std::this_thread::sleep_for(std::chrono::microseconds(16667));
    }
    const app::RecognitionStats stats = snap.recognition;
    const std::uint64_t sets_tracked = snap.frame_sets;
    const app::SourceStats source_stats = snap.source;
    input.reset();  // stops the tracker and the recognition thread
    // The recogniser on the mocap poses themselves, over the same span of the file.
    std::vector<rec::PoseSample> truth;
    for (const auto& smp : file.samples)
      if (smp.t - v.first <= seconds) truth.push_back(smp);
    const auto batch = rec::recognise(rec::read_model(cfg.recognition.model), truth);
    std::vector<double> decided_ms;
    nlohmann::json ev = nlohmann::json::array();
    for (std::size_t k = 0; k < events.size(); ++k) {
      const auto& e = events[k];
      decided_ms.push_back((e.decided_at - e.t) * 1e3);
      ev.push_back({{"t_s", first_set >= 0 ? e.t - first_set : e.t}, {"type", rec::to_string(e.type)}, {"limb", rec::to_string(e.limb)},
                    {"action", rec::to_string(e.action)}, {"progress", e.progress},
                    {"decided_ms", decided_ms.back()}, {"taken_ms", taken_ms[k]}});
    }
    nlohmann::json truth_ev = nlohmann::json::array();
    for (const auto& e : batch)
      truth_ev.push_back({{"t_s", e.t - v.first}, {"type", rec::to_string(e.type)}, {"limb", rec::to_string(e.limb)},
                          {"action", e.action}, {"progress", e.progress}});
    const auto begins = [](const auto& list, auto type_of) {
      return std::count_if(list.begin(), list.end(), [&](const auto& e) { return type_of(e) == rec::EventType::begin; });
    };
    nlohmann::json j = {
        {"what", "SYNTHETIC cameras of a mocap visitor (" + poses + ", " + std::to_string(seconds) +
                     " s) -> tracker (5 bodies) -> recognition thread -> a 60 Hz frame loop's poll"},
        {"events", events.size()},
        {"begins", begins(events, [](const app::VisitorStrike& e) { return e.type; })},
        {"begins_on_the_mocap_itself", begins(batch, [](const rec::Event& e) { return e.type; })},
        {"camera_to_decided_ms", {{"p50", pct(decided_ms, 0.5)}, {"p99", pct(decided_ms, 0.99)}, {"max", pct(decided_ms, 1.0)}}},
        {"frame_sets_tracked_per_s", static_cast<double>(sets_tracked) / seconds},
        {"recording_sets_delivered_skipped_dropped", source_stats.totals},
        {"decode_ms_per_set", source_stats.decode_ms},
        {"camera_to_head_pose_ms", {{"p50", pct(tracking_ms, 0.5)}, {"p99", pct(tracking_ms, 0.99)}, {"max", pct(tracking_ms, 1.0)}}},
        {"camera_to_frame_ms", {{"p50", pct(taken_ms, 0.5)}, {"p99", pct(taken_ms, 0.99)}, {"max", pct(taken_ms, 1.0)}}},
        {"recognition", {{"samples", stats.samples}, {"dropped", stats.dropped}, {"events_dropped", stats.events_dropped}}},
        {"event_list", ev},
        {"event_list_on_the_mocap_itself", truth_ev}};
    if (!out.empty()) write_file_atomically(out, j.dump(1) + "\n");
    nlohmann::json brief = j;
    brief.erase("event_list");
    brief.erase("event_list_on_the_mocap_itself");
    std::printf("%s\n", brief.dump().c_str());
  } catch (const Error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
