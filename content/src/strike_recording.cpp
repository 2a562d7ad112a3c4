// record_strike (one strike played from rest, frame by frame: kumite-motion strike, quality,
// bench) and loading character rigs.
#include "kumite/content/behaviour.hpp"

#include <chrono>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include "behaviour_internal.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/bvh.hpp"
#include "kumite/content/canonical.hpp"

#include <spdlog/spdlog.h>

namespace kumite::content {

using namespace behaviour_detail;
using CJ = CanonicalJoint;
using Eigen::Vector2d;
using Eigen::Vector3d;

StrikeRecording record_strike(std::shared_ptr<const Database> db, const Rig& character, OrderKind order,
                              const Vector3d& target, const FighterConfig& config_in, std::string_view rest_segment) {
  FighterConfig config = config_in;
  config.home = Vector3d::Zero();
  config.initial_character = 0;
  config.min_x_m = config.min_z_m = -1e3;
  config.max_x_m = config.max_z_m = 1e3;
  Behaviour b(db, {character}, config);
  if (!rest_segment.empty()) {
    int found = -1;
    for (std::size_t i = 0; i < db->segments.size() && found < 0; ++i)
      if (db->segments[i].name == rest_segment) found = static_cast<int>(i);
    if (found < 0) throw Error("fighter", "rest", fmt::format("no segment '{}' in the database", rest_segment));
    if (!b.rest_with(found))
      throw Error("fighter", "rest",
                  fmt::format("segment '{}' is a {}, not a rest", rest_segment,
                              to_string(db->segments[static_cast<std::size_t>(found)].kind)));
  }
  // Plan outside update() so the per-frame timings hold adaptation only.
  const StrikePlanner planner(db, config.retrieval);
  std::optional<StrikeRequest> request;
  std::optional<StrikePlan> result;
  b.set_planner([&](const StrikeRequest& r) { request = r; },
                [&]() -> std::optional<StrikePlan> { auto r = result; result.reset(); return r; });
  // The strike's playback rate too, between updates (as the Fighter's worker does it).
  StrikeRateSolver rate_solver(db, config.behaviour);
  std::optional<StrikeRateJob> rate_job;
  std::optional<StrikeRateResult> rate_result;
  b.set_rate_solver([&](const StrikeRateJob& job) { rate_job = job; },
                    [&] { return std::exchange(rate_result, std::nullopt); });
  StrikeRecording rec;
  const Rig& rig = character;
  const auto n = static_cast<std::size_t>(rig.joint_count());
  rec.motion.name = "strike";
  rec.motion.skeleton = rig.skeleton;
  rec.motion.unit_m = character.unit_m;
  // The visitor stands where the target is (a kick's target lies kick_target_drop_m below the
  // head), so the contact is judged against a visitor who did not move.
  Vector3d head = target;
  if (const auto e = effector_of(order); e && e->leg) head.y() += config.behaviour.kick_target_drop_m;
  double dt = 1.0 / 120, t = 0;
  const int ankles[2] = {rig.skeleton.index(CJ::l_ankle), rig.skeleton.index(CJ::r_ankle)};
  auto record = [&] {
    StrikeRecording::TraceRow row;
    row.state = b.state();
    row.ramp = b.reach_ramp();
    for (int s = 0; s < 2; ++s) {
      const auto us = static_cast<std::size_t>(s);
      row.phase[us] = b.foot_planter().phase(s);
      row.planted[us] = b.motion_planted()[us];
      row.lock_weight[us] = b.foot_locks().weight[us];
      row.lock_m[us] = b.foot_locks().ankle_m[us];
      row.ankle_m[us] = b.rig_positions()[static_cast<std::size_t>(ankles[s])];
    }
    row.root_drop_m = b.last_report().root_drop_m;
    rec.trace.push_back(row);
    rec.motion.root_positions.push_back(b.root_position());
    rec.motion.local_rotations.insert(rec.motion.local_rotations.end(), b.local_rotations().begin(),
                                      b.local_rotations().begin() + static_cast<std::ptrdiff_t>(n));
    ++rec.motion.frame_count;
  };
  auto timed_update = [&] {
    const auto locked_before = b.feet_locked();
    const Vector3d before[2] = {b.rig_positions()[static_cast<std::size_t>(ankles[0])],
                                b.rig_positions()[static_cast<std::size_t>(ankles[1])]};
    const auto t0 = std::chrono::steady_clock::now();
    b.update(t, dt, head);
    rec.update_us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
    const auto locked = b.feet_locked();
    for (int s = 0; s < 2; ++s)
      if (locked[static_cast<std::size_t>(s)] && locked_before[static_cast<std::size_t>(s)])
        rec.max_foot_slide_m = std::max(rec.max_foot_slide_m,
                                        (b.rig_positions()[static_cast<std::size_t>(ankles[s])] - before[s]).norm());
    for (auto& e : b.take_events())
      rec.events.push_back(std::string(to_string(e.kind)) + ": " + b.describe(e));
    record();
    t += dt;
    if (rate_job) {
      rate_result = rate_solver.solve(*rate_job);
      rec.rate_solve_us = rate_result->solve_us;
      rate_job.reset();
    }
  };
  b.update(t, 0, head);  // the rest pose at the origin
  b.take_events();
  record();
  b.order_strike(Order{t, order}, target);
  // Plans each request as the next update polls (the order's, and again after stepping in).
  const auto plan_request = [&] {
    if (!request) return;
    const StrikePlan p = planner.plan(*request);
    request.reset();
    rec.retrieval_us = p.retrieval_us;
    result = p;
    if (p.segment >= 0) dt = db->segments[static_cast<std::size_t>(p.segment)].frame_time_s;
  };
  timed_update();  // sends the request
  plan_request();
  // Recorded until the fighter rests with no foot in a procedural step (at most kStepTail_s
  // more): stopped at rest alone, a step still under way had no frame after its last one and
  // read as a one-frame jump in the judged BVH (5 of the studio grid's strikes).
  constexpr double kStepTail_s = 1.0;
  const auto foot_moving = [&] {
    for (int side = 0; side < 2; ++side) {
      const FootPlanter::Phase ph = b.foot_planter().phase(side);
      if (ph == FootPlanter::Phase::stepping || ph == FootPlanter::Phase::swinging || ph == FootPlanter::Phase::landing) return true;
    }
    return false;
  };
  double resting_s = 0;
  for (int i = 0; i < 100000; ++i) {
    timed_update();
    plan_request();
    if (b.strike().contact_done && b.state() == FighterState::resting) {
      if (!foot_moving() || resting_s >= kStepTail_s) break;
      resting_s += dt;
    }
    if (!b.strike().active && !b.strike().contact_done && !b.strike_pending() && i > 2) break;  // nothing to strike with
  }
  rec.motion.frame_time_s = dt;
  rec.strike = b.strike();
  if (rec.strike.contact_done) {
    rec.contact_frame = rec.strike.contact_update - 1;  // update k (1-based) recorded frame k-1
    const MotionSegment& seg = db->segments[static_cast<std::size_t>(rec.strike.plan.segment)];
    rec.segment_name = seg.name;
    rec.source_clip = seg.source_clip;
    rec.source_start_frame = seg.source_first_frame + rec.strike.plan.start_frame;
    rec.mirrored = seg.mirrored;
  }
  rec.effector_joint = rig.skeleton.index(effector_of(order).value_or(Effector{}).joint());
  return rec;
}

Rig load_character_rig(const std::string& name_or_path) {
  std::filesystem::path path(name_or_path);
  if (!std::filesystem::exists(path)) {
    const auto candidate = default_content_dir() / "characters" / (name_or_path + ".bvh");
    if (!std::filesystem::exists(candidate))
      throw Error("fighter", "character", fmt::format("{}: no such character file (nor {})", name_or_path, candidate.string()));
    path = candidate;
  }
  const Clip c = read_bvh(path);
  if (c.frame_count < 1) throw Error("fighter", "character", fmt::format("{}: no rest frame", path.string()));
  if (const std::string w = structural_mapping_warning(c.skeleton, path.string()); !w.empty()) spdlog::warn("{}", w);
  Rig rig = make_rig(c.skeleton, c.rotations(0), path.stem().string());
  rig.unit_m = c.unit_m;
  return rig;
}

std::vector<Rig> load_character_rigs(const FighterConfig& config) {
  std::vector<Rig> rigs;
  for (std::size_t i = 0; i < config.characters.size(); ++i) {
    rigs.push_back(load_character_rig(config.characters[i].string()));
    if (i < config.character_names.size() && !config.character_names[i].empty()) rigs.back().name = config.character_names[i];
  }
  return rigs;
}

}  // namespace kumite::content
