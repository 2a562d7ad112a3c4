#include "kumite/content/tunables.hpp"

#include <cmath>

#include <fmt/format.h>

#include "kumite/common/error.hpp"

namespace kumite::content {

namespace {

using B = BehaviourTunables;
using F = FootPlantingTunables;
using R = RetrievalTunables;

TunableKey b(std::string_view key, std::string_view unit, double min, double max, double B::*m) {
  return {"behaviour", key, unit, min, max, m, nullptr, nullptr};
}
TunableKey f(std::string_view key, std::string_view unit, double min, double max, double F::*m) {
  return {"behaviour.feet", key, unit, min, max, nullptr, m, nullptr};
}
TunableKey r(std::string_view key, std::string_view unit, double min, double max, double R::*m) {
  return {"retrieval", key, unit, min, max, nullptr, nullptr, m};
}

}  // namespace

const std::vector<TunableKey>& fighter_tunable_keys() {
  // Ranges: what still gives a fighter that works (not what looks best; the defaults are
  // that). release_time_s >= 0.15 s: issue 12's shortest release of a strike's reach offset.
  static const std::vector<TunableKey> keys = {
      b("follow_tolerance_m", "m", 0.02, 2, &B::follow_tolerance_m),
      b("arrive_tolerance_m", "m", 0.005, 1, &B::arrive_tolerance_m),
      b("walk_speed_mps", "m/s", 0.05, 3, &B::walk_speed_mps),
      b("turn_speed_rad_s", "rad/s", 0.1, 20, &B::turn_speed_rad_s),
      b("follow_arc_deg", "deg", 10, 180, &B::follow_arc_deg),
      b("kick_target_drop_m", "m", 0, 1.5, &B::kick_target_drop_m),
      b("max_root_drop_m", "m", 0, 0.8, &B::max_root_drop_m),
      b("max_drop_rate_mps", "m/s", 0.1, 20, &B::max_drop_rate_mps),
      b("max_drop_accel_mps2", "m/s^2", 1, 1000, &B::max_drop_accel_mps2),
      b("keep_away_extra_m", "m", 0, 4, &B::keep_away_extra_m),
      b("release_time_s", "s", 0.15, 2, &B::release_time_s),
      b("max_support_shift_m", "m", 0, 2, &B::max_support_shift_m),
      b("min_contact_distance_m", "m", 0, 2, &B::min_contact_distance_m),
      b("min_travel_scale", "", 0.05, 1, &B::min_travel_scale),
      b("max_travel_scale", "", 1, 5, &B::max_travel_scale),
      b("step_in_min_m", "m", 0, 1, &B::step_in_min_m),
      b("max_step_in_m", "m", 0, 2, &B::max_step_in_m),
      b("step_in_speed_mps", "m/s", 0.05, 5, &B::step_in_speed_mps),
      b("min_strike_extension", "", 0, 0.95, &B::min_strike_extension),
      b("max_step_back_m", "m", 0, 2, &B::max_step_back_m),
      b("stance_step_min_m", "m", 0, 2, &B::stance_step_min_m),
      b("min_stance_step_scale", "", 0.3, 1, &B::min_stance_step_scale),
      b("max_stance_step_scale", "", 1, 3, &B::max_stance_step_scale),
      b("kick_support_step_m", "m", 0, 1, &B::kick_support_step_m),
      b("punch_support_step_m", "m", 0, 1, &B::punch_support_step_m),
      b("min_scaled_travel_m", "m", 0, 2, &B::min_scaled_travel_m),
      b("max_strike_rise_m", "m", 0, 0.5, &B::max_strike_rise_m),
      b("max_punch_elevation_deg", "deg", 0, 89, &B::max_punch_elevation_deg),
      b("max_punch_aim_deg", "deg", 0, 89, &B::max_punch_aim_deg),
      b("blend_time_s", "s", 0.02, 2, &B::blend_time_s),
      b("max_strike_speed_ratio", "", 1, 5, &B::max_strike_speed_ratio),
      b("min_strike_rate", "", 0.2, 1, &B::min_strike_rate),
      f("max_heading_lag_rad", "rad", 0.05, 3.2, &F::max_heading_lag_rad),
      f("heading_release_s", "s", 0.01, 2, &F::heading_release_s),
      f("step_threshold_m", "m", 0.01, 1, &F::step_threshold_m),
      f("max_leg_stretch", "", 0.5, 1, &F::max_leg_stretch),
      f("step_time_s", "s", 0.05, 2, &F::step_time_s),
      f("step_height_m", "m", 0, 0.5, &F::step_height_m),
      f("min_swing_s", "s", 0.01, 2, &F::min_swing_s),
      f("landing_height_m", "m", 0, 0.5, &F::landing_height_m),
      f("landing_window_m", "m", 0, 0.5, &F::landing_window_m),
      f("landing_speed_mps", "m/s", 0.01, 10, &F::landing_speed_mps),
      f("max_landing_speed_mps", "m/s", 0.01, 20, &F::max_landing_speed_mps),
      f("return_speed_mps", "m/s", 0.01, 20, &F::return_speed_mps),
      f("min_swing_path_m", "m", 0, 1, &F::min_swing_path_m),
      f("max_swing_speed_ratio", "", 0.1, 10, &F::max_swing_speed_ratio),
      f("swing_lift_m", "m", 0, 0.5, &F::swing_lift_m),
      r("pose_weight", "", 0, 100, &R::pose_weight),
      r("trajectory_weight_per_m", "1/m", 0, 1000, &R::trajectory_weight_per_m),
      r("box_margin_m", "m", 0, 2, &R::box_margin_m),
  };
  return keys;
}

double tunable_value(const TunableKey& key, const BehaviourTunables& bt, const RetrievalTunables& rt) {
  if (key.behaviour) return bt.*key.behaviour;
  if (key.feet) return bt.feet.*key.feet;
  return rt.*key.retrieval;
}

std::string format_fighter_tunables(const BehaviourTunables& bt, const RetrievalTunables& rt) {
  std::string out;
  std::string_view table;
  for (const TunableKey& k : fighter_tunable_keys()) {
    if (k.table != table) {
      table = k.table;
      out += fmt::format("{}[fighter.{}]\n", out.empty() ? "" : "\n", table);
    }
    const std::string value = fmt::format("{}", tunable_value(k, bt, rt));
    const std::string shown = value.find_first_of(".e") == std::string::npos ? value + ".0" : value;
    out += fmt::format("{:<24} = {:<8} # {}[{}, {}]\n", k.key, shown, k.unit.empty() ? "" : std::string(k.unit) + " ",
                       k.min, k.max);
  }
  return out;
}

std::optional<TunableProblem> tunables_problem(const BehaviourTunables& bt, const RetrievalTunables& rt) {
  for (const TunableKey& k : fighter_tunable_keys()) {
    const double v = tunable_value(k, bt, rt);
    const std::string key = fmt::format("{}.{}", k.table, k.key);
    if (!std::isfinite(v)) return TunableProblem{key, "not_finite", "must be a finite number"};
    if (v < k.min || v > k.max) {
      return TunableProblem{key, "range",
                            fmt::format("must be in [{}, {}]{}, found {}", k.min, k.max,
                                        k.unit.empty() ? "" : " " + std::string(k.unit), v)};
    }
  }
  if (bt.arrive_tolerance_m >= bt.follow_tolerance_m) {
    return TunableProblem{"behaviour.arrive_tolerance_m", "range",
                          "must be less than follow_tolerance_m (it would start following and never arrive)"};
  }
  if (bt.min_travel_scale > bt.max_travel_scale) {
    return TunableProblem{"behaviour.min_travel_scale", "range", "must not exceed max_travel_scale"};
  }
  if (bt.stance_step_min_m > 0 && bt.stance_step_min_m < bt.follow_tolerance_m) {
    return TunableProblem{"behaviour.stance_step_min_m", "range",
                          "must be 0 (no stance steps) or at least follow_tolerance_m"};
  }
  if (bt.feet.landing_speed_mps > bt.feet.max_landing_speed_mps) {
    return TunableProblem{"behaviour.feet.landing_speed_mps", "range", "must not exceed max_landing_speed_mps"};
  }
  if (rt.pose_weight + rt.trajectory_weight_per_m <= 0) {
    return TunableProblem{"retrieval.pose_weight", "range",
                          "pose_weight and trajectory_weight_per_m cannot both be 0"};
  }
  return std::nullopt;
}

void validate(const BehaviourTunables& bt, const RetrievalTunables& rt) {
  if (const auto p = tunables_problem(bt, rt)) {
    throw Error("config", p->code, fmt::format("fighter.{}: {}", p->key, p->message));
  }
}

}  // namespace kumite::content
