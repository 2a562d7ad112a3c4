// The sparring planner (planner.hpp): Touché's attack timer and counters, on explicit inputs.
#include "kumite/content/planner.hpp"

#include <cmath>

#include <fmt/format.h>

#include "kumite/content/fighter.hpp"

namespace kumite::content {

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

double unit_interval(std::uint64_t bits) { return static_cast<double>(bits >> 11) * 0x1.0p-53; }

namespace {
bool right_side(recognition::Role r) { return r == recognition::Role::right_hand || r == recognition::Role::right_foot; }
}  // namespace

std::string_view to_string(PlannerMode m) { return m == PlannerMode::spar ? "spar" : "orders"; }

std::string_view to_string(PlannerState s) {
  switch (s) {
    case PlannerState::off: return "off";
    case PlannerState::approaching: return "approaching";
    case PlannerState::guarding: return "guarding";
    case PlannerState::countering: return "countering";
  }
  return "?";
}

std::string_view to_string(PlannerCause c) { return c == PlannerCause::counter ? "counter" : "timer"; }

std::optional<PlannerTunables> planner_preset(std::string_view name) {
  PlannerTunables t;
  t.mode = PlannerMode::spar;
  if (name == "aggressive_unskilled") {
    t.attack_rate_per_s = 1.0;
    t.counter_probability = 0.0;
    t.abort_probability = 0.0;
    t.reaction_time_s = 0.6;
    return t;
  }
  if (name == "defensive_skilled") {
    t.attack_rate_per_s = 0.3;
    t.counter_probability = 0.8;
    t.abort_probability = 0.8;
    t.reaction_time_s = 0.1;
    return t;
  }
  return std::nullopt;
}

std::string validate(const PlannerTunables& t) {
  const auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  const auto range = [](std::string_view key, double v, double lo, double hi, std::string_view unit) {
    return fmt::format("{}: {} is not a number in [{}, {}]{}", key, v, lo, hi, unit.empty() ? "" : fmt::format(" {}", unit));
  };
  if (!in(t.fighting_distance_m, 0.3, 3)) return range("fighting_distance_m", t.fighting_distance_m, 0.3, 3, "m");
  if (!in(t.engage_tolerance_m, 0, 2)) return range("engage_tolerance_m", t.engage_tolerance_m, 0, 2, "m");
  if (!in(t.stance_step_min_m, 0, 2)) return range("stance_step_min_m", t.stance_step_min_m, 0, 2, "m");
  if (!in(t.follow_arc_deg, 10, 180)) return range("follow_arc_deg", t.follow_arc_deg, 10, 180, "deg");
  if (!in(t.attack_rate_per_s, 0, 10)) return range("attack_rate_per_s", t.attack_rate_per_s, 0, 10, "1/s");
  if (!in(t.counter_probability, 0, 1)) return range("counter_probability", t.counter_probability, 0, 1, "");
  if (!in(t.abort_probability, 0, 1)) return range("abort_probability", t.abort_probability, 0, 1, "");
  if (!in(t.reaction_time_s, 0, 5)) return range("reaction_time_s", t.reaction_time_s, 0, 5, "s");
  if (!in(t.counter_deadline_s, 0, 10)) return range("counter_deadline_s", t.counter_deadline_s, 0, 10, "s");
  if (!in(t.kick_share, 0, 1)) return range("kick_share", t.kick_share, 0, 1, "");
  if (!in(t.block_max_rate, 1, 4)) return range("block_max_rate", t.block_max_rate, 1, 4, "");
  if (std::string threat = validate(t.threat); !threat.empty()) return threat;
  if (!in(t.hit_min_speed_mps, 0.1, 20)) return range("hit_min_speed_mps", t.hit_min_speed_mps, 0.1, 20, "m/s");
  if (!in(t.hit_full_speed_mps, 0.2, 50)) return range("hit_full_speed_mps", t.hit_full_speed_mps, 0.2, 50, "m/s");
  if (!(t.hit_full_speed_mps > t.hit_min_speed_mps))
    return fmt::format("hit_full_speed_mps: {} must be above hit_min_speed_mps ({}) m/s", t.hit_full_speed_mps, t.hit_min_speed_mps);
  if (!in(t.hit_head_max_deg, 0, 45)) return range("hit_head_max_deg", t.hit_head_max_deg, 0, 45, "deg");
  if (!in(t.hit_trunk_max_deg, 0, 30)) return range("hit_trunk_max_deg", t.hit_trunk_max_deg, 0, 30, "deg");
  if (!in(t.hit_shoulder_max_deg, 0, 45)) return range("hit_shoulder_max_deg", t.hit_shoulder_max_deg, 0, 45, "deg");
  if (!in(t.hit_stiffness_rad_s, 4, 40)) return range("hit_stiffness_rad_s", t.hit_stiffness_rad_s, 4, 40, "rad/s");
  if (!in(t.hit_damping_ratio, 0.4, 1)) return range("hit_damping_ratio", t.hit_damping_ratio, 0.4, 1, "");
  if (!in(t.hit_step_back_m, 0, 0.8)) return range("hit_step_back_m", t.hit_step_back_m, 0, 0.8, "m");
  if (!in(t.hit_step_back_share, 0, 1)) return range("hit_step_back_share", t.hit_step_back_share, 0, 1, "");
  return "";
}

SparPlanner::SparPlanner(PlannerTunables tunables) : tun_(tunables) {}

void SparPlanner::set_tunables(const PlannerTunables& t) {
  tun_ = t;
  attack_.reset();
  counter_.reset();
  attack_left_s_ = 0;
}

double SparPlanner::uniform(std::uint64_t seed) {
  return unit_interval(splitmix64(seed ^ splitmix64(++draws_)));
}

double SparPlanner::exponential(std::uint64_t seed, double mean_s) { return -std::log1p(-uniform(seed)) * mean_s; }

std::optional<PlannerDecision> SparPlanner::next() const {
  if (counter_) return counter_;
  if (attack_) {
    PlannerDecision d = *attack_;
    d.due = last_now_ + attack_left_s_;  // as the timer stands (it runs only while the fighter is idle)
    return d;
  }
  return std::nullopt;
}

std::optional<Order> SparPlanner::step(const PlannerInput& in) {
  const double dt = have_now_ ? std::max(0.0, in.now - last_now_) : 0.0;
  have_now_ = true;
  last_now_ = in.now;
  if (tun_.mode != PlannerMode::spar) {
    state_ = PlannerState::off;
    attack_.reset();
    counter_.reset();
    return std::nullopt;
  }
  const double apart = Eigen::Vector2d(in.head_m.x() - in.fighter_root_m.x(), in.head_m.z() - in.fighter_root_m.z()).norm();
  if (!(apart <= tun_.fighting_distance_m + tun_.engage_tolerance_m)) {
    // Closing in (the fighter follows at the fighting distance): nothing drawn meanwhile.
    state_ = PlannerState::approaching;
    attack_.reset();
    counter_.reset();
    return std::nullopt;
  }
  counts_.engaged_s += dt;
  // The visitor's strikes: each one seen begin is countered with counter_probability (one
  // draw each, in the order recognised; a counter still due answers the newer strike instead),
  // and resets the attack timer (Touché: it attacks when no strike of the visitor's has come for
  // a random time).
  for (const VisitorStrikeSeen& s : in.strikes) {
    if (s.type != recognition::EventType::begin) continue;
    ++counts_.visitor_strikes;
    // Its own strike under way is aborted with abort_probability (a draw only while one is).
    if (in.fighter_attacking) {
      ++counts_.abort_draws;
      if (uniform(in.seed) < tun_.abort_probability) {
        ++counts_.aborts;
        abort_ = true;
      }
    }
    const double u = uniform(in.seed);
    attack_.reset();
    if (u < tun_.counter_probability) {
      ++counts_.counters_drawn;
      if (counter_) ++counts_.counters_superseded;
      // The arm on the side the strike leaves open: facing each other, the visitor's right
      // side is on the fighter's left.
      const OrderKind arm = right_side(s.limb) ? OrderKind::punch_left : OrderKind::punch_right;
      counter_ = PlannerDecision{arm, PlannerCause::counter, s.t + exponential(in.seed, tun_.reaction_time_s)};
      counter_strike_t_ = s.t;
    }
  }
  // A decision due at a time is taken at the update nearest it (half this update's period
  // early at most), not at the first one after it: taken at the first after, each counter came
  // half a 60 Hz frame late on average, 8 ms of a 0.1 s mean reaction (kumite-motion spar).
  const double half_period_s = 0.5 * dt;
  std::optional<Order> out;
  if (counter_) {
    state_ = PlannerState::countering;
    if (in.now + half_period_s >= counter_->due) {
      if (in.now > counter_->due + tun_.counter_deadline_s) {
        ++counts_.counters_dropped;
        counter_.reset();
      } else if (in.fighter_idle && !in.supervisor_strike) {
        out = Order{in.now, counter_->kind, -1};
        ++counts_.counters;
        counts_.reaction_sum_s += in.now - counter_strike_t_;
        counts_.reaction_drawn_sum_s += counter_->due - counter_strike_t_;
        counter_.reset();
      }
    }
    if (counter_ || out) return out;
  }
  state_ = PlannerState::guarding;
  if (tun_.attack_rate_per_s <= 0) return std::nullopt;
  if (!attack_) {
    // One draw for the kind, one for the side, one for the delay.
    const bool kick = uniform(in.seed) < tun_.kick_share;
    const bool left = uniform(in.seed) < 0.5;
    const OrderKind kind = kick ? (left ? OrderKind::kick_left : OrderKind::kick_right)
                                : (left ? OrderKind::punch_left : OrderKind::punch_right);
    attack_left_s_ = exponential(in.seed, 1.0 / tun_.attack_rate_per_s);
    attack_ = PlannerDecision{kind, PlannerCause::timer, in.now + attack_left_s_};
  }
  // The timer runs while the fighter could attack (idle, no supervisor's strike this update).
  if (!in.fighter_idle || in.supervisor_strike) return std::nullopt;
  counts_.timer_running_s += dt;
  attack_left_s_ -= dt;
  if (attack_left_s_ > half_period_s) return std::nullopt;
  ++counts_.attacks;
  out = Order{in.now, attack_->kind, -1};
  attack_.reset();
  return out;
}

}  // namespace kumite::content
