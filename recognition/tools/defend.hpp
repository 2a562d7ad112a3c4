#pragma once
// kumite-recognise defend (defend.cpp): the sparring fighter's defence against development mocap.
#include <array>
#include <cstdint>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "kumite/content/planner.hpp"
#include "kumite/content/threat.hpp"
#include "offline.hpp"

namespace kumite::recognition::offline {

struct DefenceArgs {
  std::filesystem::path db;         ///< fighter.kdb
  std::filesystem::path character;  ///< character BVH
  std::filesystem::path mocap;      ///< ../shared/data/mocap
  std::filesystem::path out;        ///< folder: <recording>.fighter.bvh, <recording>.trace.json, defence.json
  double tracker_hz = 120;
  double place_x = 0, place_z = -0.9;  ///< m: where the visitor's head stands on average
  double lead_in_s = 3;
  double ease_in_s = 0;  ///< s over which the visitor's motion starts from the lead-in's stillness (0: at once)
  std::uint64_t seed = 1;
  content::ThreatTunables threat;   ///< what counts as a fist coming (the planner's threat_* keys)
  double fighting_distance_m = content::PlannerTunables{}.fighting_distance_m;  ///< m, the planner's fighting_distance_m
  double stance_step_min_m = content::PlannerTunables{}.stance_step_min_m;      ///< m, the planner's stance_step_min_m (0: off)
  double follow_arc_deg = content::PlannerTunables{}.follow_arc_deg;            ///< deg, the planner's follow_arc_deg
  /// m, room frame: where the fighter may stand, as the shipped installation's [fighter]
  /// x_limits_m / z_limits_m (config/demo-spar.toml: it may step into the room). Not
  /// FighterConfig's own defaults, whose front edge (z -1.7, behind the front wall) keeps the
  /// fighter 0.8 m from a visitor's head at z -0.9: out of the reach of most punches.
  std::array<double, 2> area_x_m{-1.4, 1.4};
  std::array<double, 2> area_z_m{-4.0, 0.6};
};
/// Wall time (s from the motion's start) at which an eased-in clip shows its clip time clip_s:
/// its first ease_s / 2 played over ease_s with the speed rising as a smoothstep, then at speed.
double eased_time(double clip_s, double ease_s);
/// Runs every recording; writes the files; returns the summary.
nlohmann::json run_defence(const DefenceArgs& a);

}  // namespace kumite::recognition::offline
