#include "kumite/content/foot_planting.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace kumite::content {

using Eigen::Vector3d;

namespace {
double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}
/// A lifted foot sheds at most this share of the motion's own foot travel per update (on top
/// of that travel): its speed stays within (1 + this) x the source's.
constexpr double kShedPerTravel = 0.5;
}  // namespace

void FootPlanter::update(double dt, const std::array<FootSample, 2>& samples, bool may_step,
                         const Eigen::Vector2d& body_velocity_xz, FootLocks& out) {
  for (int s = 0; s < 2; ++s) {
    Foot& f = feet_[static_cast<std::size_t>(s)];
    const FootSample& in = samples[static_cast<std::size_t>(s)];
    const Foot& other = feet_[static_cast<std::size_t>(1 - s)];
    // The motion's contact counts only for a foot that is down: a cross-fade from a kick into
    // a standing motion says "planted" while the foot is still in the air.
    const auto down = [&](const Vector3d& ankle) { return ankle.y() <= in.standing_ankle_y_m + tun_.landing_height_m; };
    switch (f.phase) {
      case Phase::free:
        if (in.planted && !in.effector && down(in.drawn_ankle_m)) {
          f.phase = Phase::held;
          f.lock = in.drawn_ankle_m;  // where it is drawn now: holding it there moves nothing
        }
        break;
      case Phase::held: {
        if (!in.planted || in.effector) {
          // The motion lifts the foot: carry the gap to the motion's foot through the swing.
          f.phase = Phase::swinging;
          f.offset = f.lock - in.free_ankle_m;
          break;
        }
        // Land ahead of the body: half a step's worth of its current velocity.
        Vector3d target = in.free_ankle_m + Vector3d(body_velocity_xz.x(), 0, body_velocity_xz.y()) * (0.5 * tun_.step_time_s);
        target.y() = f.lock.y();
        const bool lagging = other.phase != Phase::stepping && (target - f.lock).norm() > tun_.step_threshold_m;
        const double stretch = (f.lock - in.hip_m).norm() / std::max(1e-6, in.leg_length_m);
        // A foot the leg cannot reach any more steps at once, whatever the fighter is doing:
        // held there it would be dragged along the floor.
        if ((may_step && (lagging || stretch > tun_.max_leg_stretch)) || !in.reached) {
          f.phase = Phase::stepping;
          f.step_t = 0;
          f.step_from = f.lock;
          f.step_to = target;
        }
        break;
      }
      case Phase::swinging: {
        // Shed the offset by the time the motion plants the foot again, but never faster than
        // a share of the motion's own foot travel (a foot the motion barely moves stays put).
        const double left = std::max(in.swing_left_s, tun_.min_swing_s);
        const double travel = (in.free_ankle_m - (f.lock - f.offset)).norm();
        const double norm = f.offset.norm();
        const double shed = std::min(norm * std::min(1.0, dt / left), kShedPerTravel * travel);
        if (norm > 1e-12) f.offset *= (norm - shed) / norm;
        f.lock = in.free_ankle_m + f.offset;
        if (in.planted && !in.effector && down(in.drawn_ankle_m)) {
          f.phase = Phase::held;  // down where it is drawn (a kicking foot was drawn off its lock)
          f.lock = in.drawn_ankle_m;
        }
        break;
      }
      case Phase::stepping:
        f.step_t += dt / tun_.step_time_s;
        f.lock = f.step_from + (f.step_to - f.step_from) * smoothstep(f.step_t) +
                 Vector3d::UnitY() * tun_.step_height_m * std::sin(std::numbers::pi * std::min(1.0, f.step_t));
        if (f.step_t >= 1) {
          f.phase = Phase::held;
          f.lock = f.step_to;
        }
        break;
    }
    if (f.phase == Phase::swinging) f.lock = in.free_ankle_m + f.offset;  // also on the update it lifts
    out.weight[static_cast<std::size_t>(s)] = f.phase == Phase::free ? 0.0 : 1.0;
    out.ankle_m[static_cast<std::size_t>(s)] = f.lock;
  }
}

}  // namespace kumite::content
