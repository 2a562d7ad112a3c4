#pragma once
// Foot planting for the fighter: where each ankle is held this update (FootLocks for
// AdaptJob). A foot the motion has in contact stays exactly where it was put down; when the
// motion lifts it, the foot carries its offset from the motion's own foot through the swing
// and sheds it by the time the motion puts the foot down again, so a foot moves only where
// the source steps it, at (about) the source's pace. While resting or following, a held foot
// that lags behind the body or that the leg can no longer reach takes a procedural step.
//
// Single-threaded; no allocation. Lengths in metres (room frame), times in seconds.
#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <optional>

#include <Eigen/Core>

#include "kumite/content/adaptation.hpp"
#include "kumite/content/tunables.hpp"

namespace kumite::content {


/// What the motion says of one foot this update.
struct FootSample {
  bool planted = false;            ///< the source motion has this foot in contact now
  double swing_left_s = std::numeric_limits<double>::infinity();  ///< s until the source plants it again
  Eigen::Vector3d free_ankle_m{0, 0, 0};   ///< m, room: where the motion alone puts the ankle now
  /// m, room: how far the motion being played (not the cross-fade) moved this ankle since the
  /// last update. A lifted foot travels this much (plus a share shed toward free_ankle_m), so
  /// it moves at the source's pace even while one motion fades into another.
  Eigen::Vector3d source_step_m{0, 0, 0};
  /// m, room: the same motion's step of this ankle one update before that (its own, even where
  /// that motion began this update): how fast the source's foot gathers speed.
  Eigen::Vector3d source_step_before_m{0, 0, 0};
  /// A lifted foot's landing, where the motion being played puts this ankle down next (m, room),
  /// and how far (m, horizontally, along its path) the motion's ankle still travels to get
  /// there from where it is now. The foot covers the same share of its own way to the landing
  /// each update as the source covers of its path: it lands where the motion lands it, with
  /// the source's speed profile, whatever stance it lifted from.
  bool has_landing = false;
  Eigen::Vector3d landing_ankle_m{0, 0, 0};
  double source_path_left_m = 0;
  Eigen::Vector3d drawn_ankle_m{0, 0, 0};  ///< m, room: where the ankle was drawn at the last update
  /// Unit room x/z direction from the drawn ankle to the drawn toes at the last update (a foot
  /// put down keeps this heading while held).
  Eigen::Vector2d drawn_heading_xz{0, 1};
  /// Unit room x/z direction the motion has this foot pointing now: a held foot turned more
  /// than max_heading_lag_rad away from it steps (the body turned over it).
  Eigen::Vector2d motion_heading_xz{0, 1};
  Eigen::Vector3d hip_m{0, 0, 0};          ///< m, room: the hip drawn at the last update
  double leg_length_m = 1;         ///< m, thigh + shin
  double standing_ankle_y_m = 0.08;  ///< m, the ankle's height above the floor when standing
  /// m, the toe joint's height above the floor when the foot stands flat (+inf: unknown). A held
  /// foot's toes go no higher (FootLocks::toe_floor_y_m).
  double standing_toe_y_m = std::numeric_limits<double>::infinity();
  /// m: how much higher than standing_ankle_y_m this ankle may be held where the leg does not
  /// reach the floor (straight at max_leg_stretch or the motion's own stretch): a leg shorter
  /// than the other (every character's left, by 1.5-1.9 cm, as the CMU 135 actor's) stands
  /// its foot flat on the floor with the knee bent, and only as high as it must where straight.
  double short_leg_m = 0;
  /// m: how far the motion has this ankle above its standing height while the foot is in
  /// contact (a heel raised onto the toes, as the back foot of a lunge): a held foot's ankle
  /// rises and comes down with it, instead of the pelvis dropping to keep a flat foot.
  double source_lift_m = 0;
  bool reached = true;             ///< the held ankle was within the leg's reach at the last solve
  bool effector = false;           ///< the kicking foot while d(t) acts on it: never held down anew
  /// Held, and turning with the motion (a stance step's support foot, which the mocap turns on
  /// its ball): its heading follows motion_heading_xz at most at kPivotRate_rad_s, in place,
  /// instead of lagging until the foot has to step to turn.
  bool pivot = false;
  /// A lifted foot heading for its landing covers its way along the floor by the time the
  /// source has this share of its own path left (0: with the source, to the end), then only
  /// comes down: a stance step's stepping foot, whose source glides in along the floor (135_03's
  /// karate steps), came down over the last centimetres of its way and slid onto its landing.
  double landing_lead = 0;
};

/// A held leg may stretch this much (share of its length) beyond the motion's own: a
/// stance's straight leg is the motion, not a reason to step (FootPlanter), nor a limit on a
/// lunge's travel (Behaviour::place_strike_travel).
constexpr double kLegStretchMargin = 0.01;
/// How straight a held leg may be (hip to ankle / leg length): `max_leg_stretch`, or the
/// motion's own leg (`motion_stretch`) + kLegStretchMargin where the motion holds it straighter,
/// never beyond 1.
inline double allowed_leg_stretch(double max_leg_stretch, double motion_stretch) {
  return std::max(max_leg_stretch, std::min(1.0, motion_stretch + kLegStretchMargin));
}

class FootPlanter {
 public:
  /// free: not held (no hold yet); held: still where it was put down; swinging: lifted by the
  /// motion, carrying its offset; landing: the motion has it down but it is still in the air,
  /// coming straight down where it is; stepping: a procedural step.
  enum class Phase : std::uint8_t { free, held, swinging, stepping, landing };

  explicit FootPlanter(FootPlantingTunables tunables = {}) : tun_(tunables) {}
  /// Forget every foot (a new body: character switch, first frame).
  void reset() { feet_ = {}; }
  /// A new body with the same feet on the floor (a character switch): a held foot stays held
  /// where it stands (a foot its new leg cannot reach steps, as any does); a foot in a
  /// procedural step goes on with it (its way is in the room: the foot does not move for the
  /// switch); the others are forgotten (free). Forgotten, a stepping support foot went to the
  /// new body's motion in one frame (5.5 cm: mei's, kenji switched in mid-kick with stance steps
  /// on), the easing being an offset fixed at the switch. Put down where it was instead (until
  /// session 37), a foot mid-step stood where neither body's motion has it: bruno's left foot
  /// at the 6.0 s switch of the scripted bout, 0.45 m from aiko's motion and 6.4 cm up, was
  /// held there while the other foot stepped (13 frames with both feet off the floor).
  /// The next update puts a foot held below the new body's floor onto it at once (hidden by the
  /// switch's easing), not at a landing's pace over the frames after.
  void keep_held_only() {
    for (auto& f : feet_) {
      if (f.phase != Phase::held && f.phase != Phase::stepping) f = Foot{};
      f.new_body = true;
    }
  }
  /// `may_step`: steps for a lagging or over-stretched foot allowed (resting, following); a foot
  /// the leg cannot reach steps in any case. `body_velocity_xz` (m/s) is
  /// where the body is going, so a step lands ahead of it.
  void update(double dt, const std::array<FootSample, 2>& samples, bool may_step,
              const Eigen::Vector2d& body_velocity_xz, FootLocks& out);
  Phase phase(int side) const { return feet_[static_cast<std::size_t>(side)].phase; }
  /// The ankle is held still this update (held, not lifted or stepping).
  bool held(int side) const { return phase(side) == Phase::held; }
  /// Held where it should stand: not lagging behind the body, within the leg's reach (a foot
  /// that would step if it could is not settled).
  bool settled(int side) const { return held(side) && !feet_[static_cast<std::size_t>(side)].wants_step; }
  const FootPlantingTunables& tunables() const { return tun_; }
  /// A procedural step of a held foot to `to` (m, room; the floor height of the step's end),
  /// starting now, while the other foot stands: the support foot set under a kick's body before
  /// the kick (Behaviour). False, and nothing changes, unless both feet are held.
  bool step_to(int side, const Eigen::Vector3d& to);
  /// Where this foot's procedural step puts it down (m, room), nullptr when it is not stepping.
  const Eigen::Vector3d* step_end(int side) const {
    const Foot& f = feet_[static_cast<std::size_t>(side)];
    return f.phase == Phase::stepping ? &f.step_to : nullptr;
  }
  /// s until this foot's procedural step puts it down (0 when it is not stepping).
  double step_left_s(int side) const {
    const Foot& f = feet_[static_cast<std::size_t>(side)];
    return f.phase == Phase::stepping ? std::max(0.0, 1 - f.step_t) * f.step_time_s : 0.0;
  }
  /// A procedural step of this foot goes on to `to` (m, room, on the floor) instead, from where
  /// the foot is now (re-based: it does not move this update), over what is left of the step
  /// or longer, so that its travel peaks at no more than about `peak_speed_mps`; a step whose
  /// travel is all but done is taken again from where the foot is. False, and nothing
  /// changes, for a foot not stepping.
  bool redirect(int side, const Eigen::Vector3d& to, double peak_speed_mps);
  /// A procedural step of this foot ends now: it comes straight down where it is (landing).
  /// Nothing changes for a foot not stepping.
  void land(int side) {
    Foot& f = feet_[static_cast<std::size_t>(side)];
    if (f.phase == Phase::stepping) f.phase = Phase::landing;
  }

 private:
  struct Foot {
    Phase phase = Phase::free;
    Eigen::Vector3d lock{0, 0, 0};    ///< m, room: where the ankle is held
    Eigen::Vector2d heading{0, 1};    ///< room x/z unit: the held foot's heading (put down with it)
    double heading_hold = 0;          ///< 0..1: how far that heading is still kept (eased out when lifted)
    Eigen::Vector3d offset{0, 0, 0};  ///< m: swinging: lock - free ankle, shed over the swing
    double step_t = 0;                ///< stepping: 0..1
    bool step_from_hold = true;       ///< stepping: this step began from a held foot (not taken again in the air)
    double step_time_s = 0.30;        ///< s: stepping: this step's time (step_time_s, or longer where redirected)
    double swing_way_m = -1;          ///< swinging toward a landing: its way along the floor (m), -1 unknown
    double swing_progress = 0;        ///< swinging: share of that way covered, 0..1 (never decreases)
    double swing_source_way_m = -1;   ///< ...and the source's own path to its landing then (m)
    Eigen::Vector3d swing_from{0, 0, 0};  ///< m, room: swinging: the lock when it was lifted
    bool kicking = false;             ///< swinging: lifted as a kick's effector (FootSample::effector)
    bool new_body = false;            ///< a character switch this update (keep_held_only)
    double source_rise_m = 0;         ///< m: swinging: how far the source has raised this ankle since then
    /// swinging as a kick's effector: whether its source rose faster than a foot from rest can at
    /// its first update (its rise then gathers); unset before that update
    std::optional<bool> gather_rise;
    bool kick_airborne = false;       ///< swinging as a kick's effector: it has been off the floor it left since it was lifted
    double follow_y = 0;              ///< m: swinging toward a landing: the ankle's height as the source moves it (the lift is a floor above it, not added to it)
    Eigen::Vector3d step_from{0, 0, 0}, step_to{0, 0, 0};
    bool wants_step = false;          ///< held: lagging or over-stretched at the last update
    Eigen::Vector3d last_move{0, 0, 0};  ///< m: how far the lock moved at the last update
    double softness = 0;              ///< 0..1: FootLocks::softness, eased in when taken from free
    double lift_wait_s = 0;           ///< s: held: how long the motion has lifted it while it waits for the other foot
    double on_toes = 0;               ///< 0..1: FootLocks::toe_floor_weight, eased toward how far up the held ankle waits
    double toes_kept_up = 0;          ///< 0..1: FootLocks::toe_lowest_weight, eased (1 held or landing)
  };
  FootPlantingTunables tun_;
  std::array<Foot, 2> feet_{};
};

}  // namespace kumite::content
