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
/// m/s^2: how fast a foot returning through the air to the motion's changes its velocity (a
/// kick's retraction: the swing's kSwingAccel_mps2; at 40, a kick aborted as its foot rose at
/// 4.8 m/s went on up 0.27 m).
constexpr double kReturnAccel_mps2 = 100;
/// m/s^2: the braking a returning foot's speed allows as it nears the floor's landing band:
/// half kReturnAccel_mps2, so that the updates' steps keep within it (at kReturnAccel_mps2 the
/// profile, read at the start of each update, handed a 4 m/s foot to a landing at 0.6 m/s).
constexpr double kReturnBrake_mps2 = 50;
/// m/s^2: the most a swinging foot's speed along the floor grows (FootPlanter's way to its landing).
constexpr double kSwingAccel_mps2 = 100;
/// m: the most a foot's step may grow from one update to the next, whatever the update rate. The
/// accelerations above are per second, applied as a * dt^2 on the last step: at 120 or 60 Hz
/// that is 0.3-2.8 cm, but at 30 Hz (a database of 30 fps clips, played at the clip's rate) a
/// still foot could go 11 cm in one update and stop dead in the next: a one-frame jump (the
/// motion-quality check's isolated step: > 5 cm and > 3x both neighbours). A step that grows
/// by at most 3 cm a frame is never 3x the one before it above 4.5 cm. (The pelvis drop has the
/// same bound: behaviour.cpp.)
constexpr double kMostStepGain_m = 0.03;
/// The most a step grows in an update of dt seconds at `accel_mps2`.
double step_gain(double accel_mps2, double dt) { return std::min(accel_mps2 * dt * dt, kMostStepGain_m); }
/// m: a kicking foot taken this far above its standing height (mid-step) is in the air already.
constexpr double kTakenInTheAir_m = 0.01;
/// s: a held foot the motion lifts while the other foot is still in the air where the motion
/// has it down waits this long at most for it to come down.
constexpr double kMostLiftWait_s = 0.1;
/// m: a held ankle this far above where it stands when down begins to keep its toes on the
/// floor (FootLocks::toe_floor_y_m), fully kOnToesSpan_m higher.
constexpr double kOnToesFrom_m = 0.005, kOnToesSpan_m = 0.02;
constexpr double kOnToesEase_s = 0.15;  ///< s: ...coming in and going out over this at the quickest
/// m: a foot on the floor or landing keeps its toe joint no lower than this under where it
/// stands flat (FootLocks::toe_lowest_y_m).
constexpr double kToesUnderFloor_m = 0.01;
/// m: a held foot the leg falls short of is under the hip (the shortfall is the body's height, not
/// a step's length) while it is no farther out from the hip than this beyond the motion's foot.
constexpr double kUnderHipSlack_m = 0.05;
/// m/s: a held foot's heel rises toward its floor (the heel lift the motion gives, a short
/// leg's raise) no faster than the source's own ankle plus this. At landing_speed_mps (0.6, 1 cm
/// a frame at 60 Hz) the lift read at a lunge's handover to rest (0.3 -> 1.3 cm in one update)
/// raised the held ankle 1 cm in a frame while the hip came down 1.1 cm: the nearly straight
/// knee bent 12 deg, 5.2 cm in the frame (the spar demo, planner seed 29 at 47.6 s). At 0.2 the
/// sweep's heels lagged their source (2 snaps, a folded punch).
constexpr double kHeldRise_mps = 0.3;
/// The least a step for an over-stretched leg must ease its stretch (share of the leg's length).
constexpr double kLeastStretchEased = 0.005;
/// rad/s: the most a pivoting held foot turns (FootSample::pivot).
constexpr double kPivotRate_rad_s = 4.0;
/// s: a foot taken from free (at the start, after a character switch) softens its leg's full
/// extension (FootLocks::softness) over this: the hold itself moves nothing (it is taken where
/// the foot is drawn), but with the softness at once a straight leg's knee jumped 5.7 cm in one
/// frame (viktor in the scripted bout with stance steps on). The hold's weight is whole at once:
/// eased in too, the foot followed the motion along the floor while it came (slides to 3.4 m/s).
constexpr double kTakeHold_s = 0.1;
/// m/s: the most a foot heading for its landing is raised to clear the floor (FootPlanter's
/// swing lift; the source's own foot may rise faster).
constexpr double kSwingRise_mps = 1.2;
/// m: the lowest an ankle at `at`'s place on the floor is reached by a leg `reach` long from
/// `hip` (both m, room), or `out_of_reach` where it is farther than that along the floor.
double lowest_reached_y(const Vector3d& hip, const Vector3d& at, double reach, double out_of_reach) {
  const double horiz = Eigen::Vector2d(at.x() - hip.x(), at.z() - hip.z()).norm();
  return horiz < reach ? hip.y() - std::sqrt(reach * reach - horiz * horiz) : out_of_reach;
}
/// A procedural step travels over the middle kStepTravelSpan of its time, from kStepTravelFrom:
/// the share of its way covered at step time t (0..1).
constexpr double kStepTravelFrom = 0.15;
constexpr double kStepTravelSpan = 0.7;
/// A procedural step counts as bearing weight for the pelvis drop (FootLocks::supporting) over
/// this first share of its time.
constexpr double kSupportingStepShare = 0.3;

double step_travel_share(double t) { return smoothstep((t - kStepTravelFrom) / kStepTravelSpan); }
/// The share of its way a foot heading for its landing has covered when the source has covered
/// `s` of its path, done `lead` early (FootSample::landing_lead): at a steady 1 / (1 - 2 lead)
/// times the source's share (1.11 at lead 0.05) up to 3 leads before the end, then slowing
/// evenly to no speed with `lead` of the source's path left. (Catching up over a shorter
/// stretch near the end instead, at up to 1.6x the source's speed where the source still moves
/// fast, put the stance steps' stepping foot's peak at 1.10-1.32x the source's.)
double landing_share(double s, double lead) {
  const double b = 1 - lead, a = std::max(0.0, 1 - 3 * lead);
  const double k = 2 / (a + b);  // k a + k (b - a) / 2 = 1
  s = std::clamp(s, 0.0, 1.0);
  if (s <= a) return k * s;
  if (s >= b) return 1;
  const double u = s - a;
  return k * a + k * u - 0.5 * k * u * u / (b - a);
}
/// The share of a procedural step's travel beyond which it is not redirected (FootPlanter::redirect):
/// re-based from nearly its end, the way left would be crossed in the last frames.
constexpr double kMostRedirectedShare = 0.8;
/// A held foot (FootPlanter's Foot) lifted into a procedural step of `time_s` to `to`.
constexpr auto begin_step = [](auto& f, const Vector3d& to, double time_s) {
  f.phase = FootPlanter::Phase::stepping;
  f.step_t = 0;
  f.step_from_hold = true;
  f.step_time_s = time_s;
  f.step_from = f.lock;
  f.step_to = to;
};
}  // namespace

bool FootPlanter::step_to(int side, const Vector3d& to) {
  Foot& f = feet_[static_cast<std::size_t>(side)];
  if (f.phase != Phase::held || feet_[static_cast<std::size_t>(1 - side)].phase != Phase::held) return false;
  begin_step(f, to, tun_.step_time_s);
  return true;
}

bool FootPlanter::redirect(int side, const Vector3d& to, double peak_speed_mps) {
  Foot& f = feet_[static_cast<std::size_t>(side)];
  if (f.phase != Phase::stepping || peak_speed_mps <= 0) return false;
  // The step's travel share now (the lock's way along from -> to, its lift aside).
  const double a = step_travel_share(f.step_t);
  const Vector3d lock_flat = f.step_from + (f.step_to - f.step_from) * a;
  const double way = Eigen::Vector2d(to.x() - lock_flat.x(), to.z() - lock_flat.z()).norm();
  // The travel left eases out as a smoothstep does: its peak speed is about twice its mean.
  const double needed_s = 2 * way / peak_speed_mps;
  if (a < kMostRedirectedShare) {
    // Re-based so the foot is where it is (lock = from + (to - from) a), the rest of the step
    // slowed where the new way wants more time than is left.
    const double left_s = std::max((1 - f.step_t) * f.step_time_s, needed_s);
    f.step_time_s = left_s / std::max(1e-6, 1 - f.step_t);
    f.step_from = (lock_flat - a * to) / (1 - a);
  } else {
    // Its travel all but done: a new step from where the foot is (its lift carried in its from).
    f.step_from = f.lock;
    f.step_t = 0;
    f.step_from_hold = false;  // (in the air: not counted for the pelvis drop, FootLocks::supporting)
    f.step_time_s = std::max(tun_.step_time_s, needed_s / kStepTravelSpan);
  }
  f.step_to = to;
  return true;
}

void FootPlanter::update(double dt, const std::array<FootSample, 2>& samples, bool may_step,
                         const Eigen::Vector2d& body_velocity_xz, FootLocks& out) {
  // A foot the motion has down but that is still in the air drops vertically: at least at
  // landing_speed_mps, as fast as the motion lowers it if that is faster, and never faster
  // than max_landing_speed_mps (the last centimetres are not a jump).
  const auto come_down = [&](Foot& f, const FootSample& in, double step_dt) {
    const double motion_fall = -in.source_step_m.y();
    const double fall = std::clamp(motion_fall, tun_.landing_speed_mps * step_dt, tun_.max_landing_speed_mps * step_dt);
    f.lock.y() = std::max(in.standing_ankle_y_m + in.source_lift_m, f.lock.y() - fall);
    f.offset = f.lock - in.free_ankle_m;
  };
  const auto hold = [&](Foot& f, const Vector3d& at, const Eigen::Vector2d& heading) {
    f.phase = Phase::held;
    f.lock = at;
    f.heading = heading;
  };
  // Lifted (by the motion or a kick) from wherever the foot is: it carries its gap to the
  // motion's foot, and starts a new way to its landing.
  const auto start_swing = [&](Foot& f, const FootSample& in) {
    f.phase = Phase::swinging;
    f.offset = f.lock - in.free_ankle_m;
    f.swing_way_m = -1;
    f.swing_source_way_m = -1;
    f.swing_progress = 0;
    f.swing_from = f.lock;
    f.source_rise_m = 0;
    f.kicking = in.effector;
    f.gather_rise.reset();
    f.kick_airborne = false;
  };
  // A held foot the leg no longer reaches must step now; the other foot's step that is only
  // due (behind its spot, a leg stretched past the motion's) waits for it to land: both
  // starting in one update is a hop (the walk bout's, 13 frames with both feet off at 3.42 s).
  // Not where the leg falls short straight above the foot (the pelvis high over it, as a kick's
  // support leg after a hop): a step there lands where the foot stands, after a swing through
  // the air (kenji's HDM_bd_001 kick: a 9 cm step up for 2 cm, both feet off 0.3 s); the foot
  // is held until the body comes down to it.
  const auto must = [&](int s) {
    const Foot& f = feet_[static_cast<std::size_t>(s)];
    const FootSample& in = samples[static_cast<std::size_t>(s)];
    if (f.phase != Phase::held || in.reached) return false;
    const Eigen::Vector2d from_hip(f.lock.x() - in.hip_m.x(), f.lock.z() - in.hip_m.z());
    const Eigen::Vector2d motion(in.free_ankle_m.x() - in.hip_m.x(), in.free_ankle_m.z() - in.hip_m.z());
    // Out of reach along the floor: farther from the hip than the motion's foot (a body moved
    // away: held, it would be dragged), or far from where the motion has it.
    return from_hip.norm() > motion.norm() + kUnderHipSlack_m || (from_hip - motion).norm() > tun_.step_threshold_m;
  };
  const bool must_step[2] = {must(0), must(1)};
  for (int s = 0; s < 2; ++s) {
    Foot& f = feet_[static_cast<std::size_t>(s)];
    // A short leg's foot stands on the floor, raised (up to short_leg_m) only where the leg,
    // at the stretch it may have, does not reach down to it from the hip as drawn.
    FootSample in = samples[static_cast<std::size_t>(s)];
    // How straight the leg may be: max_leg_stretch, or the motion's own leg where straighter.
    const double motion_stretch = (in.free_ankle_m - in.hip_m).norm() / std::max(1e-6, in.leg_length_m);
    const double max_stretch = allowed_leg_stretch(tun_.max_leg_stretch, motion_stretch);
    if (in.short_leg_m > 0) {
      const Vector3d& at = f.phase == Phase::held ? f.lock : in.drawn_ankle_m;
      const double lowest = lowest_reached_y(in.hip_m, at, max_stretch * in.leg_length_m, in.hip_m.y());
      in.standing_ankle_y_m += std::clamp(lowest - (in.standing_ankle_y_m + in.source_lift_m), 0.0, in.short_leg_m);
    }
    const Foot& other = feet_[static_cast<std::size_t>(1 - s)];
    f.wants_step = false;
    const Vector3d lock_before = f.lock;
    // The motion's contact counts only for a foot that is down: a cross-fade from a kick into
    // a standing motion says "planted" while the foot is still in the air.
    const double floor_y = in.standing_ankle_y_m + in.source_lift_m;  // the ankle's height when down now
    const auto down = [&](const Vector3d& ankle) { return ankle.y() <= floor_y + tun_.landing_height_m; };
    const auto near_floor = [&](const Vector3d& ankle) { return ankle.y() <= floor_y + tun_.landing_window_m; };
    switch (f.phase) {
      case Phase::free:
        if (in.planted && !in.effector && down(in.drawn_ankle_m)) {
          hold(f, in.drawn_ankle_m, in.drawn_heading_xz);  // moves nothing
          // ...but on a new body's first update the old body's ankle may stand below this one's
          // floor: up onto it now, under the switch's easing (at a landing's pace after it, a
          // near-straight leg's knee moved 5 cm in the first frame: mei after bruno mid-kick).
          if (f.new_body) f.lock.y() = std::max(f.lock.y(), floor_y);
        }
        break;
      case Phase::held: {
        // The motion lifts the foot while the other is still in the air where the motion has it
        // down (its procedural step or its landing not done: a strike begun as the fighter
        // stepped in lifts the back foot for its lunge): it stays on the floor until the other
        // is down, kMostLiftWait_s at most. Lifted at once, both feet were off the floor where
        // the mocap stands on one (mei stepping in at 18.55 s of the 120-order sweep's bout 7,
        // 26 frames).
        const FootSample& other_in = samples[static_cast<std::size_t>(1 - s)];
        const bool other_up = other_in.planted && !other_in.effector &&
                              (other.phase == Phase::stepping || other.phase == Phase::landing);
        const bool lifted = !in.planted || in.effector;
        const bool waits = lifted && !in.effector && other_up && f.lift_wait_s < kMostLiftWait_s;
        f.lift_wait_s = waits ? f.lift_wait_s + dt : 0.0;
        if (lifted && !waits) {
          // The motion lifts the foot: carry the gap to the motion's foot through the swing.
          start_swing(f, in);
          break;
        }
        // The heel rises and comes down with the motion's (toes stay put), at a foot's pace; a
        // foot put down a little above the floor settles onto it.
        // It comes down only as far as the leg reaches with its knee still bent (a straight
        // knee moves centimetres per millimetre of ankle): else it waits on its toes.
        // It rises and comes down no faster than the source's own ankle plus kHeldRise_mps
        // (rising) or landing_speed_mps (coming down):
        // a foot put down flat where the motion has the heel raised (a kick's support foot set
        // down on its toes) lifts its heel at a foot's pace, not up to the raised heel in two
        // frames, and a heel the blend into another motion lowers comes down as gently.
        const double rise = std::min(tun_.max_landing_speed_mps * dt, std::max(0.0, in.source_step_m.y()) + kHeldRise_mps * dt);
        const double fall = std::min(tun_.max_landing_speed_mps * dt, std::max(0.0, -in.source_step_m.y()) + tun_.landing_speed_mps * dt);
        double new_y = f.lock.y() + std::clamp(floor_y - f.lock.y(), -fall, rise);
        if (f.new_body) new_y = std::max(new_y, floor_y);  // as a foot taken anew (above)
        if (new_y < f.lock.y()) {
          const double lowest = lowest_reached_y(in.hip_m, f.lock, tun_.max_leg_stretch * in.leg_length_m, f.lock.y());
          new_y = std::min(f.lock.y(), std::max(new_y, lowest));
        }
        f.lock.y() = new_y;
        if (in.pivot) {
          // Turning on the spot with the motion's foot, at most kPivotRate_rad_s.
          const double have = std::atan2(f.heading.x(), f.heading.y());
          const double want = std::atan2(in.motion_heading_xz.x(), in.motion_heading_xz.y());
          const double turn = std::clamp(std::remainder(want - have, 2 * std::numbers::pi), -kPivotRate_rad_s * dt, kPivotRate_rad_s * dt);
          f.heading = Eigen::Vector2d(std::sin(have + turn), std::cos(have + turn));
        }
        // Land ahead of the body: half a step's worth of its current velocity.
        Vector3d target = in.free_ankle_m + Vector3d(body_velocity_xz.x(), 0, body_velocity_xz.y()) * (0.5 * tun_.step_time_s);
        target.y() = floor_y;
        const double turned = std::abs(std::remainder(std::atan2(in.motion_heading_xz.x(), in.motion_heading_xz.y()) -
                                                          std::atan2(f.heading.x(), f.heading.y()),
                                                      2 * std::numbers::pi));
        // Out of place: behind where it should land, or turned away from the motion's heading.
        const bool out_of_place = (target - f.lock).norm() > tun_.step_threshold_m || turned > tun_.max_heading_lag_rad;
        const bool lagging = other.phase != Phase::stepping && out_of_place;
        const double stretch = (f.lock - in.hip_m).norm() / std::max(1e-6, in.leg_length_m);
        // Over-stretched beyond max_leg_stretch, or beyond the motion's own leg if the motion
        // holds it straighter (max_stretch: a front stance's straight back leg is the stance,
        // not a reason to step the foot in place again and again).
        // (A step for the stretch alone is taken only where it straightens the leg less: to a
        // target as far from the hip, the leg at the motion's own stretch, it stepped 1 mm
        // again and again, the drawn hip held lower than the motion's by the held feet.)
        const bool eases_stretch = (target - in.hip_m).norm() / std::max(1e-6, in.leg_length_m) < stretch - kLeastStretchEased;
        f.wants_step = out_of_place || stretch > max_stretch || !in.reached;
        // A foot the leg cannot reach any more steps at once, whatever the fighter is doing:
        // held there it would be dragged along the floor. Otherwise a foot steps only while the
        // other stands on the floor (both off it is a hop).
        if (!waits && ((other.phase == Phase::held && !must_step[1 - s] && may_step && (lagging || (stretch > max_stretch && eases_stretch))) ||
                       must_step[s])) {
          begin_step(f, target, tun_.step_time_s);
        }
        break;
      }
      case Phase::swinging: {
        // Shed the offset by the time the motion plants the foot again, but never faster than
        // a share of the motion's own foot travel (a foot the motion barely moves stays put).
        if (in.planted && !in.effector && down(in.drawn_ankle_m)) {
          hold(f, in.drawn_ankle_m, in.drawn_heading_xz);  // down where it is drawn (a kicking foot was drawn off its lock)
          break;
        }
        if (in.planted && !in.effector && !near_floor(f.lock)) {
          // The motion has the foot down but it is still well up (a kick handing over to the
          // rest motion, or aborted as it rose): it goes back to where the motion has it at
          // up to return_speed_mps, braking and turning from the way it was going at
          // kReturnAccel_mps2 (not at once: the knee follows the ankle's turn several times
          // over), and slowing as it nears the floor (kReturnBrake_mps2) so that it reaches the
          // landing band at about landing_speed_mps, the pace it comes down at from there.
          const Vector3d to = in.free_ankle_m - f.lock;
          const double above_band = std::max(0.0, f.lock.y() - (floor_y + tun_.landing_window_m));
          const double down_speed = std::min(tun_.return_speed_mps, std::sqrt(tun_.landing_speed_mps * tun_.landing_speed_mps +
                                                                               2 * kReturnBrake_mps2 * above_band));
          // ...and along the floor slowing to a stop over the way left (a foot handed to the
          // landing still moving along the floor at 0.8 m/s was stopped in one frame: the
          // landing comes straight down).
          const Eigen::Vector2d along(to.x(), to.z());
          const double way = along.norm();
          const double along_step = std::min(way, std::min(tun_.return_speed_mps, std::sqrt(2 * kReturnBrake_mps2 * way)) * dt);
          const double up_step = std::min(std::abs(to.y()), down_speed * dt);
          Vector3d want(way > 1e-9 ? along.x() * along_step / way : 0.0, to.y() < 0 ? -up_step : up_step,
                        way > 1e-9 ? along.y() * along_step / way : 0.0);
          if (want.norm() > tun_.return_speed_mps * dt) want *= tun_.return_speed_mps * dt / want.norm();
          Vector3d change = want - f.last_move;
          const double most = step_gain(kReturnAccel_mps2, dt);
          if (change.norm() > most) change *= most / change.norm();
          f.lock += f.last_move + change;
          f.lock.y() = std::max(f.lock.y(), floor_y);
          f.offset = f.lock - in.free_ankle_m;
          break;
        }
        if (in.planted && !in.effector && near_floor(f.lock)) {
          // The motion has put the foot down (or is fading into a motion that has it down)
          // while it is still a little above the floor: it comes straight down where it is.
          // Following the fade instead would carry it across the floor to where the new
          // motion stands; a foot left out of place is fixed by a real step once held.
          f.phase = Phase::landing;
          come_down(f, in, dt);
          break;
        }
        // The foot moves as the source moves it, and closes its gap to where the composed
        // motion has it by the time the source plants it again, never faster than a share of
        // the source's own travel (a foot the source barely moves stays put).
        // A kick that takes a foot already in the air (lifted by a stance step) starts its swing
        // from here: carried on, the step's lift-off spot and its way since held the kick's foot
        // "as high as it had gone along the floor" (16 cm up in its first frame, the knee 17 cm).
        if (in.effector && !f.kicking) start_swing(f, in);
        const double left = std::max(in.swing_left_s, tun_.min_swing_s);
        f.source_rise_m += in.source_step_m.y();
        if (in.effector) {
          // (Its source caught rising faster than a foot from rest can: the rise below gathers.)
          if (!f.gather_rise) f.gather_rise = in.source_step_m.y() > step_gain(kSwingAccel_mps2, dt);
          // The kicking foot goes where the composed motion and d(t) send it; only the gap it
          // had when it left its hold is carried and shed.
          const double norm = f.offset.norm();
          const double travel = (in.free_ankle_m - (f.lock - f.offset)).norm();
          const double shed = std::min(norm * std::min(1.0, dt / left), kShedPerTravel * travel);
          if (norm > 1e-12) f.offset *= (norm - shed) / norm;
          Vector3d next = in.free_ankle_m + f.offset;
          // The floor it left (its hold's height: a heel raised on the toes, a character whose
          // standing ankle sits higher than its rest pose's), or the standing height when it was
          // taken from the air.
          const bool from_floor = f.swing_from.y() <= in.standing_ankle_y_m + tun_.landing_height_m;
          const double left_floor_y = from_floor ? std::max(in.standing_ankle_y_m, f.swing_from.y()) : in.standing_ankle_y_m;
          if (std::min(next.y(), f.lock.y()) < left_floor_y + tun_.landing_height_m) {
            // Still on the floor: it moves along it no faster than the source's own foot (a
            // kick lifts the foot before it drives it forward; d(t) and a scaled travel pushed
            // it along the floor first). The way held back is carried as offset and shed in the air.
            Eigen::Vector2d along(next.x() - f.lock.x(), next.z() - f.lock.z());
            const double cap = Eigen::Vector2d(in.source_step_m.x(), in.source_step_m.z()).norm();
            if (along.norm() > cap) {
              along *= cap / along.norm();
              next.x() = f.lock.x() + along.x();
              next.z() = f.lock.z() + along.y();
            }
            // ...and it leaves the floor before it travels (kept low by the blend from a standing
            // motion, it slid flat along it): it rises at least as far as the source's ankle has
            // since it was lifted, and at least as far as it has gone along the floor.
            // Not as it comes down again (its way along the floor then is the kick's, and the
            // rule lifted a retracting foot 41 cm in one update: spar demo seed 2 at 21.88 s).
            const double gone = Eigen::Vector2d(next.x() - f.swing_from.x(), next.z() - f.swing_from.z()).norm();
            if (from_floor && !f.kick_airborne) {
              double y = std::max(next.y(), f.swing_from.y() + std::max(f.source_rise_m, gone));
              // ...gathering that rise at a foot's pace (kSwingAccel_mps2 on its last move) where
              // the kick took the foot off the floor mid-step, or where its clip starts with the
              // source's ankle already rising faster than a foot from rest can: from a clip frame
              // where it rises 5 cm per update, the rule lifted a still foot 5.4 cm in one update
              // while the composed ankle rose 0.4 cm (viktor's HDM_dg_017 kick taking a foot
              // mid-step, the knee 7 cm; the spar demo's kick at frame 606 with stance steps on,
              // taking a standing foot, 5.2 cm, the knee 5.1). A foot whose source lifts it from
              // rest keeps the rule whole, however fast that rise then gathers (held back, it
              // stayed flat on the floor while it travelled: the grid's kicks slid).
              if (y > next.y() && (*f.gather_rise || f.swing_from.y() > in.standing_ankle_y_m + kTakenInTheAir_m)) {
                const double wanted = y;
                y = std::min(y, std::max(next.y(), f.lock.y() + std::max(0.0, f.last_move.y()) + step_gain(kSwingAccel_mps2, dt)));
                // ...and travelling along the floor no more than in that share.
                if (y < wanted && wanted > f.lock.y()) {
                  const double share = std::clamp((y - f.lock.y()) / (wanted - f.lock.y()), 0.0, 1.0);
                  next.x() = f.lock.x() + share * (next.x() - f.lock.x());
                  next.z() = f.lock.z() + share * (next.z() - f.lock.z());
                }
              }
              next.y() = y;
            }
          }
          // Never under the floor: the composed motion's ankle may pass below it as a kick
          // comes down (a pelvis adapted lower than the clip's; HDM_bk_kickLFront1Reps_009's
          // retraction, 6.7 cm under, the foot drawn 3 cm into the floor at 3.5 m/s).
          next.y() = std::max(next.y(), floor_y);
          f.lock = next;
          f.offset = f.lock - in.free_ankle_m;
          if (f.lock.y() >= left_floor_y + tun_.landing_height_m) f.kick_airborne = true;
          break;
        }
        const double step_h = Eigen::Vector2d(in.source_step_m.x(), in.source_step_m.z()).norm();
        const double path = in.source_path_left_m + step_h;
        // A swing already heading for its landing keeps heading there to the end of the source's
        // path: handed to the source's own step once that path was under min_swing_path_m, the
        // gap left was never shed (mei's lunge back foot landed 7 cm short of where the clip has
        // it, out of the leg's reach by contact).
        if (in.has_landing && (path > tun_.min_swing_path_m || (f.swing_way_m >= 0 && path > 1e-6))) {
          // Toward the landing: the share of the remaining way the source covers this update,
          // at most max_swing_speed_ratio x the source's own speed.
          Vector3d to = in.landing_ankle_m - f.lock;
          to.y() = 0;
          if (f.swing_way_m < 0) {
            f.swing_way_m = to.norm();
            f.swing_source_way_m = path;
            f.follow_y = f.lock.y();
          }
          // The share of what is left that it covers now: the source's share (its path's), or
          // ahead of it where the way is to be done early (landing_lead: landing_share).
          double share = std::min(1.0, step_h / path);
          if (in.landing_lead > 0 && f.swing_source_way_m > 1e-6) {
            const double before = landing_share(1 - path / f.swing_source_way_m, in.landing_lead);
            const double now = landing_share(1 - in.source_path_left_m / f.swing_source_way_m, in.landing_lead);
            share = before < 1 ? std::clamp((now - before) / (1 - before), 0.0, 1.0) : 1.0;
          }
          Vector3d move = to * share;
          const double cap = tun_.max_swing_speed_ratio * step_h;
          if (move.norm() > cap) move *= cap / move.norm();
          // ...gathering speed no faster than the source's foot does, or kSwingAccel_mps2: a
          // strike started mid-stride lifts a still foot whose source already moves at 5 m/s
          // (viktor's lunge from its frame 11: the foot 8 cm in its first frame, the knee 9 cm).
          const double source_gain = step_h - Eigen::Vector2d(in.source_step_before_m.x(), in.source_step_before_m.z()).norm();
          const double most = Eigen::Vector2d(f.last_move.x(), f.last_move.z()).norm() + std::max(step_gain(kSwingAccel_mps2, dt), source_gain);
          if (move.norm() > most) move *= most / move.norm();
          f.lock += move;
          // The height follows the source's own; the lift below is a floor above it, never
          // added to it (the source's rise followed on top of a lifted foot put bruno's support
          // foot, which the source slides forward under a 135_07 kick, 5.4 cm up for 4.3).
          f.follow_y += in.source_step_m.y();
          f.follow_y = std::max(f.follow_y, std::min(in.standing_ankle_y_m, in.free_ankle_m.y()));
          f.lock.y() = f.follow_y;
          // Clear the floor over the way (the source may start this foot mid-air, higher than
          // ours, and bring it down while ours still has its whole way to go).
          if (f.swing_way_m > 1e-6) {
            const double way_left = Eigen::Vector2d(in.landing_ankle_m.x() - f.lock.x(), in.landing_ankle_m.z() - f.lock.z()).norm();
            const double progress_before = f.swing_progress;
            f.swing_progress = std::max(f.swing_progress, std::clamp(1 - way_left / f.swing_way_m, 0.0, 1.0));
            // ...or the source's, if further: a foot gathering speed (kSwingAccel_mps2) behind
            // its source still leaves the floor when the source's does (held low, it slid along
            // it at 0.6 m/s for the first frames of a strike started mid-stride).
            if (f.swing_source_way_m > 1e-6)
              f.swing_progress = std::max(f.swing_progress, std::clamp(1 - in.source_path_left_m / f.swing_source_way_m, 0.0, 1.0));
            // Up off the floor over the first sixth of the way, down over the second half (a
            // sine over the whole way left a foot the source lifts mid-stride 1.2 cm up after
            // 7 cm along the floor: a lunge's back foot dragged at 2.7 m/s; held up to the last
            // sixth, a foot landing after the source's flew where the source stands).
            const double arc = std::sin(std::numbers::pi * f.swing_progress);
            const double lift = std::min(tun_.swing_lift_m, 0.25 * f.swing_way_m) * (f.swing_progress < 0.5 ? std::min(1.0, 2 * arc) : arc);
            // ...rising no faster than kSwingRise_mps (a foot lifted again just after it landed,
            // its way short, went 3.9 cm up in one frame on a straight leg: the knee 9.7 cm).
            const double want = in.standing_ankle_y_m + lift;
            // Down over the second half with the source: height carried above the source's
            // foot is shed by the landing as the way is, so the foot lands when the source's does.
            const double above = f.follow_y - std::max(in.free_ankle_m.y(), in.standing_ankle_y_m);
            if (progress_before >= 0.5 && progress_before < 1 && above > 0)
              f.follow_y -= above * std::clamp((f.swing_progress - progress_before) / (1 - progress_before), 0.0, 1.0);
            f.lock.y() = f.follow_y;
            if (want > f.lock.y()) f.lock.y() = std::min(want, std::max(f.lock.y(), lock_before.y() + kSwingRise_mps * dt));
          }
          // ...and gathering speed no faster in the air than along the floor: the lift's rise
          // and the way along it together (each within the cap alone, a foot still the update
          // before went 2 cm up and 2.8 cm along in its first frame: the knee of aiko's
          // near-straight leg 5 cm, a 135_06 punch started from frame 20 after a step-in).
          {
            const Vector3d moved = f.lock - lock_before;
            const double most_3d = f.last_move.norm() + std::max(step_gain(kSwingAccel_mps2, dt), source_gain);
            if (moved.norm() > most_3d) {
              f.lock = lock_before + moved * (most_3d / moved.norm());
              f.follow_y = std::min(f.follow_y, f.lock.y());
            }
          }
          f.offset = f.lock - in.free_ankle_m;
          break;
        }
        const double travel = in.source_step_m.norm();
        f.lock += in.source_step_m;
        Vector3d gap = in.free_ankle_m - f.lock;
        const double norm = gap.norm();
        const double shed = std::min(norm * std::min(1.0, dt / left), kShedPerTravel * travel);
        if (norm > 1e-12) f.lock += gap * (shed / norm);
        // The source may lift this foot from a height ours is not at (a strike starting
        // mid-step): never through the floor.
        f.lock.y() = std::max(f.lock.y(), std::min(in.standing_ankle_y_m, in.free_ankle_m.y()));
        f.offset = f.lock - in.free_ankle_m;
        break;
      }
      case Phase::landing: {
        if (!in.planted || in.effector) {  // lifted again before it touched down
          start_swing(f, in);
          break;
        }
        come_down(f, in, dt);
        if (f.lock.y() <= floor_y + 1e-9 || down(in.drawn_ankle_m)) hold(f, Vector3d(f.lock.x(), std::min(f.lock.y(), in.drawn_ankle_m.y()), f.lock.z()), in.drawn_heading_xz);
        break;
      }
      case Phase::stepping:
        if (in.effector) {
          // A kick takes the foot from wherever the step has it: a step carried on through the
          // kick's approach would hold the foot on the floor at contact.
          start_swing(f, in);
          break;
        }
        f.step_t += dt / f.step_time_s;
        // The foot leaves the floor before it travels and is down before it stops: a step,
        // not a slide (travel over the middle 70 % of the step, lift over all of it).
        f.lock = f.step_from + (f.step_to - f.step_from) * step_travel_share(f.step_t) +
                 Vector3d::UnitY() * tun_.step_height_m * std::sin(std::numbers::pi * std::min(1.0, f.step_t));
        if (f.step_t >= 1) hold(f, f.step_to, in.drawn_heading_xz);
        break;
    }
    f.new_body = false;
    f.last_move = f.phase == Phase::free ? Vector3d::Zero() : Vector3d(f.lock - lock_before);
    f.softness = f.phase == Phase::free ? 0.0 : std::min(1.0, f.softness + (dt > 0 ? dt / kTakeHold_s : 1.0));
    out.weight[static_cast<std::size_t>(s)] = f.phase == Phase::free ? 0.0 : 1.0;
    out.softness[static_cast<std::size_t>(s)] = f.softness;
    // (A step's first kSupportingStepShare too: lifted from a leg the pelvis drop stretched it
    // onto, the foot let the pelvis rise 6 cm in four updates away from its step's way, which
    // the leg then could not follow, and the knee jumped 11 cm as the way came back in reach.
    // Counted over the whole step, a far step's way crouched the pelvis 30 cm.)
    out.supporting[static_cast<std::size_t>(s)] = f.phase == Phase::held || f.phase == Phase::landing ||
                                                  (f.phase == Phase::stepping && f.step_from_hold && f.step_t < kSupportingStepShare);
    out.ankle_m[static_cast<std::size_t>(s)] = f.lock;
    // A held ankle above where it stands when down (the leg does not reach the floor flat: it
    // waits on its toes) keeps its toes on the floor, coming in over kOnToesSpan_m of height.
    out.toe_floor_y_m[static_cast<std::size_t>(s)] = std::isfinite(in.standing_toe_y_m) ? in.standing_toe_y_m : 0.0;
    // (Eased over kOnToesEase_s: the floor under a raised heel moves with the source's heel, and
    // the toes went 6 cm in a frame as the weight followed it at once.)
    const double on_toes = f.phase == Phase::held && std::isfinite(in.standing_toe_y_m)
                               ? std::clamp((f.lock.y() - (in.standing_ankle_y_m + in.source_lift_m) - kOnToesFrom_m) / kOnToesSpan_m, 0.0, 1.0)
                               : 0.0;
    const double ease = dt > 0 ? dt / kOnToesEase_s : 1.0;
    f.on_toes = std::clamp(on_toes, f.on_toes - ease, f.on_toes + ease);
    out.toe_floor_weight[static_cast<std::size_t>(s)] = f.phase == Phase::free ? 0.0 : f.on_toes;
    // Held or coming down, its toes go no lower than kToesUnderFloor_m under where they stand
    // (eased in and out as the weight above).
    const double keep_up = (f.phase == Phase::held || f.phase == Phase::landing) && std::isfinite(in.standing_toe_y_m) ? 1.0 : 0.0;
    f.toes_kept_up = std::clamp(keep_up, f.toes_kept_up - ease, f.toes_kept_up + ease);
    out.toe_lowest_y_m[static_cast<std::size_t>(s)] = std::isfinite(in.standing_toe_y_m) ? in.standing_toe_y_m - kToesUnderFloor_m : 0.0;
    out.toe_lowest_weight[static_cast<std::size_t>(s)] = f.phase == Phase::free ? 0.0 : f.toes_kept_up;
    // The heading is kept whole while held; lifted, the foot turns to the motion's heading
    // over heading_release_s (a procedural step: over the step), never in one frame.
    if (f.phase == Phase::held) {
      f.heading_hold = 1;
    } else if (f.phase == Phase::stepping) {
      f.heading_hold = std::min(f.heading_hold, 1 - smoothstep(f.step_t));
    } else {
      f.heading_hold = std::max(0.0, f.heading_hold - dt / tun_.heading_release_s);
    }
    out.heading_weight[static_cast<std::size_t>(s)] = f.phase == Phase::stepping ? f.heading_hold : smoothstep(f.heading_hold);
    out.heading_xz[static_cast<std::size_t>(s)] = f.heading;
  }
}

}  // namespace kumite::content
