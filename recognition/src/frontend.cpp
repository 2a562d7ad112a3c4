// Frontend: smoothing, 60 Hz resampling and the head frame (see recognition.hpp).
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "kumite/recognition/recognition.hpp"

namespace kumite::recognition {

namespace {
constexpr std::array<std::string_view, kRoleCount> kRoleNames = {"head", "left_hand", "right_hand",
                                                                 "left_foot", "right_foot"};

bool finite3(const Vec3& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

/// q (w,x,y,z) applied to (0,0,-1).
Vec3 rotate_forward(const std::array<double, 4>& q) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  // Third column of the rotation matrix, negated.
  return {-(2 * (x * z + w * y)), -(2 * (y * z - w * x)), -(1 - 2 * (x * x + y * y))};
}
}  // namespace

std::string_view to_string(Role r) { return kRoleNames[static_cast<std::size_t>(r)]; }
std::optional<Role> role_from_string(std::string_view name) {
  for (int i = 0; i < kRoleCount; ++i)
    if (kRoleNames[static_cast<std::size_t>(i)] == name) return static_cast<Role>(i);
  return std::nullopt;
}
std::string_view to_string(LimbKind k) { return k == LimbKind::hand ? "hand" : "foot"; }
std::optional<LimbKind> limb_kind_from_string(std::string_view s) {
  if (s == "hand") return LimbKind::hand;
  if (s == "foot") return LimbKind::foot;
  return std::nullopt;
}
std::string_view to_string(Action a) {
  switch (a) {
    case Action::other: return "other";
    case Action::straight_punch: return "straight_punch";
    case Action::hook: return "hook";
    case Action::uppercut: return "uppercut";
    case Action::front_kick: return "front_kick";
    case Action::side_kick: return "side_kick";
    case Action::roundhouse_kick: return "roundhouse_kick";
  }
  return "other";
}
Action action_from_string(std::string_view name) {
  for (Action a : {Action::straight_punch, Action::hook, Action::uppercut, Action::front_kick, Action::side_kick,
                   Action::roundhouse_kick})
    if (to_string(a) == name) return a;
  return Action::other;
}

std::string_view to_string(EventType t) {
  switch (t) {
    case EventType::begin: return "begin";
    case EventType::switch_: return "switch";
    case EventType::end: return "end";
    case EventType::cancel: return "cancel";
  }
  return "?";
}

std::string to_json(const Event& e) {
  return fmt::format(
      R"({{"t":{:.6f},"type":"{}","limb":"{}","action":"{}","progress":{:.4f},"confidence":{:.4f},"impact":[{:.4f},{:.4f},{:.4f}]}})",
      e.t, to_string(e.type), to_string(e.limb), e.action, e.progress, e.confidence, e.impact[0],
      e.impact[1], e.impact[2]);
}

Vec3 to_room_displacement(const Frame& f, const std::array<float, 3>& local, bool left) {
  const double x = left ? -local[0] : local[0];
  const double y = local[1], z = local[2];
  const Vec3 r{-f.forward[2], 0, f.forward[0]};
  const Vec3 b{-f.forward[0], -f.forward[1], -f.forward[2]};
  const double h = f.head_height;
  return {h * (x * r[0] + z * b[0]), h * (y + x * r[1] + z * b[1]), h * (x * r[2] + z * b[2])};
}

Frontend::Frontend(FrontendSettings s) : s_(s) {}

void Frontend::run_through(Timestamp u, std::vector<Frame>& out) {
  const double period = 1.0 / s_.loop_hz;
  // At most ~loop_hz loops here; the bound also stops times so large that adding a period
  // no longer changes them. A tick up to 0.1 ms after u counts as at u (times written with 6
  // decimals, clocks on another origin: the same stream gives the same loops).
  constexpr double kSame_s = 1e-4;
  int n = 0;
  for (; next_tick_ <= u + kSame_s && n <= static_cast<int>(s_.loop_hz) + 1; ++n) {
    out.push_back(make_frame(next_tick_));
    next_tick_ += period;
  }
  if (next_tick_ <= u + kSame_s) next_tick_ = u + period;
}

void Frontend::end_of_set(Timestamp t, std::vector<Frame>& out) {
  if (!started_ || !std::isfinite(t)) return;
  run_through(std::min(t, newest_), out);
}

void Frontend::push(const PoseSample& s, std::vector<Frame>& out) {
  if (!std::isfinite(s.t)) return;
  if (!started_) {
    started_ = true;
    next_tick_ = s.t;
    newest_ = s.t;
  }
  if (s.t > newest_) {
    // Every sample up to the newest time before this one is in: the loops up to it.
    run_through(newest_, out);
    if (s.t - next_tick_ > 1.0) {  // a jump in time: one loop (everything goes stale), then resync
      out.push_back(make_frame(next_tick_));
      next_tick_ = s.t;
    }
    newest_ = s.t;
  }
  RoleState& r = roles_[static_cast<std::size_t>(s.role)];
  if (r.have && s.t < r.last_t) return;  // out of order: ignored
  const bool ok = s.tracked && finite3(s.position) &&
                  std::all_of(s.orientation.begin(), s.orientation.end(),
                              [](double v) { return std::isfinite(v); });
  if (!ok) {
    r.tracked = false;
    r.last_t = s.t;
    r.have = true;
    return;
  }
  if (!r.have || !r.tracked || s.t - r.last_t > s_.max_gap_s) {
    r.smoothed = s.position;
    r.has_prev = false;
  } else if (s.t > r.last_t) {
    r.prev = r.smoothed;
    r.prev_t = r.last_t;
    r.has_prev = true;
    const double a = 1 - std::exp(-(s.t - r.last_t) / s_.smoothing_tau_s);
    for (int i = 0; i < 3; ++i) r.smoothed[i] += a * (s.position[i] - r.smoothed[i]);
  }  // the same time again: as before (the smoothing weight of no time is 0)
  r.q = s.orientation;
  r.tracked = true;
  r.have = true;
  r.last_t = s.t;
}

Vec3 Frontend::position_at(const RoleState& r, Timestamp t) const {
  if (!r.has_prev || !(r.last_t > r.prev_t)) return r.smoothed;
  const double f = std::clamp((t - r.prev_t) / (r.last_t - r.prev_t), 0.0, 2.0);
  return {r.prev[0] + f * (r.smoothed[0] - r.prev[0]), r.prev[1] + f * (r.smoothed[1] - r.prev[1]),
          r.prev[2] + f * (r.smoothed[2] - r.prev[2])};
}

Frame Frontend::make_frame(Timestamp t) {
  Frame f;
  f.t = t;
  const double period = 1.0 / s_.loop_hz;
  auto live = [&](const RoleState& r) { return r.have && r.tracked && t - r.last_t <= s_.max_gap_s; };
  const RoleState& head = roles_[0];
  f.head_valid = live(head);
  if (f.head_valid) {
    f.head = position_at(head, t);
    Vec3 fw = rotate_forward(head.q);
    const double n = std::hypot(fw[0], fw[2]);
    if (n > 0.2) {
      Vec3 h{fw[0] / n, 0, fw[2] / n};
      if (!have_heading_) {
        forward_ = h;
        have_heading_ = true;
      } else {
        const double a = 1 - std::exp(-period / s_.heading_tau_s);
        forward_[0] += a * (h[0] - forward_[0]);
        forward_[2] += a * (h[2] - forward_[2]);
        const double m = std::hypot(forward_[0], forward_[2]);
        if (m > 1e-6) {
          forward_[0] /= m;
          forward_[2] /= m;
        } else {
          forward_ = h;
        }
      }
    }
    const double y = std::clamp(f.head[1], 0.8, 2.3);
    if (!have_height_) {
      head_height_ = y;
      have_height_ = true;
    } else {
      head_height_ += (1 - std::exp(-period / s_.height_tau_s)) * (y - head_height_);
    }
  }
  f.forward = forward_;
  f.head_height = head_height_;
  const Vec3 r{-forward_[2], 0, forward_[0]};
  const Vec3 b{-forward_[0], 0, -forward_[2]};
  for (int l = 0; l < kLimbCount; ++l) {
    const RoleState& rs = roles_[static_cast<std::size_t>(l + 1)];
    LimbFrame& lf = f.limbs[static_cast<std::size_t>(l)];
    lf.valid = f.head_valid && live(rs);
    if (!lf.valid) {
      last_valid_[static_cast<std::size_t>(l)] = false;
      continue;
    }
    lf.room = position_at(rs, t);
    const Vec3 d{lf.room[0] - f.head[0], lf.room[1] - f.head[1], lf.room[2] - f.head[2]};
    const Vec3 local{d[0] * r[0] + d[2] * r[2], d[1], d[0] * b[0] + d[2] * b[2]};
    Vec3 vel{0, 0, 0};
    if (last_valid_[static_cast<std::size_t>(l)]) {
      const Vec3& p = last_local_[static_cast<std::size_t>(l)];
      for (int i = 0; i < 3; ++i) vel[i] = (local[i] - p[i]) / period;
    }
    last_local_[static_cast<std::size_t>(l)] = local;
    last_valid_[static_cast<std::size_t>(l)] = true;
    lf.speed = std::sqrt(vel[0] * vel[0] + vel[1] * vel[1] + vel[2] * vel[2]);
    const double mirror = is_left(static_cast<Role>(l + 1)) ? -1.0 : 1.0;
    const double inv = 1.0 / head_height_;
    const double w = s_.velocity_weight * inv;
    lf.pos = {static_cast<float>(mirror * local[0] * inv), static_cast<float>(local[1] * inv),
              static_cast<float>(local[2] * inv)};
    lf.vel = {static_cast<float>(mirror * vel[0] * w), static_cast<float>(vel[1] * w), static_cast<float>(vel[2] * w)};
  }
  return f;
}

}  // namespace kumite::recognition
