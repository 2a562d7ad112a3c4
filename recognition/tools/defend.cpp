// kumite-recognise defend: the sparring fighter against mocap visitors (development mocap:
// the assimp boxer, the Sony crosses, CMU walks, the HDM05 everyday clips), its defence alone
// (no attacks, no counters, no recognised strikes: blocks only from what the tracked wrists
// and ankles do). Writes per recording the fighter's BVH and a trace (the visitor's tracked
// path, the labelled punches) for the independent judge scripts/judge-blocks.py, and a JSON
// summary of what the fighter says it did (its events: a unit-level figure, not the judgement).
#include "defend.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <numbers>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/behaviour.hpp"
#include "kumite/content/bvh.hpp"
#include "kumite/content/character.hpp"
#include "kumite/content/fighter.hpp"

namespace kumite::recognition::offline {

namespace fs = std::filesystem;
using content::FighterFrame;
using content::FighterInput;
using content::FighterOutput;

namespace {

/// The HDM05 everyday clips (strike-free) of ../shared/data/mocap/hdm05 and the CMU walks.
std::vector<Recording> load_negatives(const fs::path& mocap) {
  std::vector<Recording> out;
  std::vector<fs::path> files;
  if (fs::is_directory(mocap / "hdm05"))
    for (const auto& e : fs::directory_iterator(mocap / "hdm05")) {
      const std::string n = e.path().filename().string();
      if (e.path().extension() == ".bvh" && n.find("kick") == std::string::npos) files.push_back(e.path());
    }
  std::sort(files.begin(), files.end());
  for (const fs::path& p : files) {
    Recording r = recording_from_clip(content::read_bvh(p));
    r.actor = actor_of_clip(r.name);
    r.source = p.string() + " (HDM05, CC BY-SA 3.0)";
    r.negative = true;
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace

double eased_time(double clip_s, double ease_s) {
  if (!(ease_s > 0)) return clip_s;
  // Clip time at wall time u: ease_s * (x^3 - x^4 / 2), x = u / ease_s, for u < ease_s (its speed
  // 3x^2 - 2x^3, a smoothstep from 0 to 1); u - ease_s / 2 after. Inverted by bisection.
  if (clip_s >= ease_s / 2) return clip_s + ease_s / 2;
  if (!(clip_s > 0)) return 0;
  double lo = 0, hi = 1;
  for (int i = 0; i < 60; ++i) {
    const double x = (lo + hi) / 2;
    (ease_s * (x * x * x - x * x * x * x / 2) < clip_s ? lo : hi) = x;
  }
  return ease_s * (lo + hi) / 2;
}

nlohmann::json run_defence(const DefenceArgs& a) {
  for (const auto& lim : {a.area_x_m, a.area_z_m})
    if (!(std::isfinite(lim[0]) && std::isfinite(lim[1]) && lim[0] < lim[1]))
      throw Error("defend", "area", "defend: --area-x / --area-z: each two finite numbers, the first below the second (m)");
  std::vector<Recording> recs;
  for (Recording& r : load_external(a.mocap))
    if (!r.strikes.empty() || r.negative) recs.push_back(std::move(r));
  for (Recording& r : load_negatives(a.mocap)) recs.push_back(std::move(r));
  if (recs.empty()) throw Error("defend", "mocap", fmt::format("defend: no recordings under {}", a.mocap.string()));
  fs::create_directories(a.out);

  content::FighterConfig cfg;
  cfg.database = a.db;
  cfg.characters = {a.character};
  cfg.character_names = {a.character.stem().string()};
  cfg.planner.mode = content::PlannerMode::spar;
  cfg.planner.attack_rate_per_s = 0;   // defence alone: no attacks of its own
  cfg.planner.counter_probability = 0; // and no counters
  cfg.planner.block = true;
  cfg.planner.threat = a.threat;
  cfg.planner.fighting_distance_m = a.fighting_distance_m;
  cfg.planner.stance_step_min_m = a.stance_step_min_m;
  cfg.planner.follow_arc_deg = a.follow_arc_deg;
  cfg.min_x_m = a.area_x_m[0];
  cfg.max_x_m = a.area_x_m[1];
  cfg.min_z_m = a.area_z_m[0];
  cfg.max_z_m = a.area_z_m[1];
  const content::Rig rig = content::load_character_rig(a.character.string());

  nlohmann::json report = {
      {"what", "the sparring fighter's defence against development mocap visitors (never shipped, never tuned on "
               "for the recogniser); blocks from the tracked wrists and ankles alone: no recognised strikes fed, no "
               "attacks, no counters"},
      {"visitor", fmt::format("each recording turned to face the fighter (-Z), head placed at ({}, {}) m on average, "
                              "preceded by {} s standing still in its first pose (SYNTHETIC padding) so the fighter "
                              "takes its distance, then eased into motion over {} s (SYNTHETIC: the clip's first "
                              "half of that played with its speed rising from 0 by a smoothstep; 0 = none, the clip "
                              "starts at full speed); bodies as a {} Hz tracker gives them (resampled)",
                              a.place_x, a.place_z, a.lead_in_s, a.ease_in_s, a.tracker_hz)},
      {"fighter_area_m", {{"x", {a.area_x_m[0], a.area_x_m[1]}}, {"z", {a.area_z_m[0], a.area_z_m[1]}}}},
      {"planner", {{"fighting_distance_m", a.fighting_distance_m}, {"stance_step_min_m", a.stance_step_min_m},
                   {"follow_arc_deg", a.follow_arc_deg}}},
      {"db", a.db.string()},
      {"character", a.character.string()},
      {"recordings", nlohmann::json::array()}};
  int punches = 0, negatives_s_count = 0;
  double negative_s = 0;
  int phantom = 0;
  std::vector<double> step_us;
  for (const Recording& rec : recs) {
    std::vector<PoseSample> samples = resample(rec.samples, a.tracker_hz);
    // A recording with punches is turned so that they go toward the fighter (-Z): the mean
    // horizontal way of the fist from each punch's first frame to its hit (boxers stand
    // bladed: facing the shoulders or hips forward sent their punches past the fighter).
    if (!rec.strikes.empty()) {
      Eigen::Vector2d way(0, 0);
      for (const Strike& s : rec.strikes) {
        const int l = static_cast<int>(s.limb) - 1;
        const Vec3& p0 = rec.limb_positions[static_cast<std::size_t>(s.first)][static_cast<std::size_t>(l)];
        const Vec3& p1 = rec.limb_positions[static_cast<std::size_t>(s.hit)][static_cast<std::size_t>(l)];
        Eigen::Vector2d d(p1[0] - p0[0], p1[2] - p0[2]);
        if (d.norm() > 1e-6) way += d.normalized();
      }
      if (way.norm() > 1e-6) {
        const double phi = std::atan2(way.x(), way.y());
        const Eigen::Quaterniond turn(Eigen::AngleAxisd(std::numbers::pi - phi, Eigen::Vector3d::UnitY()));
        for (PoseSample& s : samples) {
          const Eigen::Vector3d p = turn * Eigen::Vector3d(s.position[0], s.position[1], s.position[2]);
          s.position = {p.x(), p.y(), p.z()};
          const Eigen::Quaterniond q = turn * Eigen::Quaterniond(s.orientation[0], s.orientation[1], s.orientation[2], s.orientation[3]);
          s.orientation = {q.w(), q.x(), q.y(), q.z()};
        }
      }
    }
    place_visitor(samples, std::array<double, 2>{a.place_x, a.place_z}, 0);
    const double t0 = samples.empty() ? 0 : samples.front().t;
    // Ease-in: the clip's first ease_in_s / 2 of motion played over ease_in_s, its speed rising
    // from 0 to 1 as a smoothstep (SYNTHETIC: a clip that begins mid-motion would otherwise jump
    // from the still lead-in to full speed in one frame, which no visitor does); re-sampled.
    if (a.ease_in_s > 0 && !samples.empty()) {
      for (PoseSample& s : samples) s.t = t0 + eased_time(s.t - t0, a.ease_in_s);
      samples = resample(samples, a.tracker_hz);
    }
    // Lead-in: the first frame set held for lead_in_s (times shifted).
    std::vector<PoseSample> v;
    const int lead_sets = static_cast<int>(std::lround(a.lead_in_s * a.tracker_hz));
    for (int k = 0; k < lead_sets; ++k)
      for (const PoseSample& s : samples) {
        if (s.t != t0) break;
        PoseSample c = s;
        c.t = k / a.tracker_hz;
        v.push_back(c);
      }
    for (const PoseSample& s : samples) {
      PoseSample c = s;
      c.t = s.t - t0 + lead_sets / a.tracker_hz;
      v.push_back(c);
    }
    auto fighter = content::Fighter::create(cfg);
    const double dt = 1.0 / 60;
    const double end_t = v.empty() ? 0 : v.back().t;
    const int updates = static_cast<int>(std::floor(end_t / dt)) + 1;
    std::array<content::VisitorBody, kRoleCount> bodies{};
    for (int r = 0; r < kRoleCount; ++r) bodies[static_cast<std::size_t>(r)].role = static_cast<Role>(r);
    std::size_t next = 0;
    FighterOutput out;
    content::Clip clip;
    clip.name = rec.name;
    clip.skeleton = rig.skeleton;
    clip.unit_m = rig.unit_m;
    clip.frame_time_s = 1.0 / 60;
    nlohmann::json frames = nlohmann::json::array();
    nlohmann::json events = nlohmann::json::array();
    std::map<std::string, int> counts;
    for (int k = 0; k < updates; ++k) {
      FighterInput in;
      in.now = k * dt;
      in.dt_s = k == 0 ? 0.0 : dt;
      in.seed = a.seed;
      while (next < v.size() && v[next].t <= in.now + 1e-9) {
        const PoseSample& s = v[next++];
        content::VisitorBody& b = bodies[static_cast<std::size_t>(s.role)];
        b.position_m = Eigen::Vector3d(s.position[0], s.position[1], s.position[2]);
        b.orientation = Eigen::Quaterniond(s.orientation[0], s.orientation[1], s.orientation[2], s.orientation[3]);
        b.tracked = s.tracked;
        b.t = s.t;
      }
      in.head_m = bodies[0].position_m;
      in.bodies = bodies;
      const auto step_start = std::chrono::steady_clock::now();
      fighter->step(in, out);
      step_us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - step_start).count());
      const FighterFrame& f = out.frame;
      clip.root_positions.push_back(f.root_joint);
      clip.local_rotations.insert(clip.local_rotations.end(), f.local_rotations.begin(), f.local_rotations.end());
      ++clip.frame_count;
      nlohmann::json limbs = nlohmann::json::array();
      for (int r = 1; r < kRoleCount; ++r) {
        const auto& b = bodies[static_cast<std::size_t>(r)];
        limbs.push_back({b.position_m.x(), b.position_m.y(), b.position_m.z(), b.t});
      }
      nlohmann::json target = nullptr;
      if (f.target) target = {f.target->x(), f.target->y(), f.target->z()};
      frames.push_back({{"t", in.now}, {"limbs", limbs}, {"action", content::to_string(f.action)}, {"target", target}});
      for (const content::FighterEvent& e : out.events) {
        ++counts[std::string(content::to_string(e.kind))];
        events.push_back({{"t", in.now}, {"frame", k}, {"kind", content::to_string(e.kind)}, {"text", fighter->describe(e)},
                          {"limb", to_string(e.limb)}, {"side", e.side}, {"margin_s", e.margin_s}});
      }
    }
    const std::string stem = rec.name;
    content::write_bvh(a.out / (stem + ".fighter.bvh"), clip);
    // Labelled punches in the fighter's update frames (the recording's frame -> its time -> update).
    nlohmann::json strikes = nlohmann::json::array();
    const double lead = lead_sets / a.tracker_hz;
    for (const Strike& s : rec.strikes) {
      const auto upd = [&](int f) {
        const double tc = f / rec.fps;
        return static_cast<int>(std::lround(((a.ease_in_s > 0 ? eased_time(tc, a.ease_in_s) : tc) + lead) / dt));
      };
      strikes.push_back({{"name", s.name}, {"limb", to_string(s.limb)}, {"first", upd(s.first)}, {"hit", upd(s.hit)},
                         {"last", upd(s.last)}});
      ++punches;
    }
    nlohmann::json trace = {{"recording", rec.name}, {"source", rec.source}, {"negative", rec.negative},
                            {"dt_s", dt}, {"lead_in_s", lead}, {"ease_in_s", a.ease_in_s}, {"limb_order", {"left_hand", "right_hand", "left_foot", "right_foot"}},
                            {"fighter_bvh", stem + ".fighter.bvh"}, {"strikes", strikes}, {"frames", frames}};
    write_file_atomically(a.out / (stem + ".trace.json"), trace.dump() + "\n");
    const auto status = fighter->planner_status();
    const double seconds = end_t - lead;
    if (rec.negative) {
      negative_s += seconds;
      ++negatives_s_count;
      phantom += status.score.blocks;
    }
    report["recordings"].push_back({{"name", rec.name}, {"negative", rec.negative}, {"seconds", seconds},
                                    {"labelled_strikes", rec.strikes.size()}, {"events", counts},
                                    {"score", {{"blocks", status.score.blocks}, {"blocks_late", status.score.blocks_late},
                                               {"blocked", status.score.blocked}, {"visitor_hits", status.score.visitor_hits},
                                               {"unanswered", status.score.unanswered}}},
                                    {"event_list", events}});
  }
  report["summary"] = {{"labelled_punches", punches},
                       {"negative_recordings", negatives_s_count},
                       {"negative_minutes", negative_s / 60},
                       {"blocks_on_negatives", phantom},
                       {"phantom_blocks_per_minute", negative_s > 0 ? phantom / (negative_s / 60) : 0.0},
                       {"note", "the fighter's own events; the judgement of each punch is scripts/judge-blocks.py's"}};
  // The whole fighter update (planner, threats, contacts, blocks, behaviour) per update, all
  // recordings: on a shared machine the tail carries the machine's interruptions.
  std::sort(step_us.begin(), step_us.end());
  const auto pct = [&](double q) {
    return step_us.empty() ? 0.0 : step_us[std::min(step_us.size() - 1, static_cast<std::size_t>(q * step_us.size()))];
  };
  report["summary"]["fighter_step_us"] = {{"updates", step_us.size()}, {"p50", pct(0.5)}, {"p99", pct(0.99)}, {"max", step_us.empty() ? 0.0 : step_us.back()}};
  write_file_atomically(a.out / "defence.json", report.dump(2) + "\n");
  return report["summary"];
}

}  // namespace kumite::recognition::offline
