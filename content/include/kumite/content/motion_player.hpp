#pragma once
// The fighter's motion player (motion_playback.cpp): the database source playing now and the
// one it cross-fades from, the cross-fade's clock, the limb-pole turns drawn through it, each
// arm's drawn pole, and the eased-travel cache its sampling fills. The MotionPlayer is the only
// writer of them; Behaviour says what to play (play, place, set_rate) and when to advance, and
// asks it for poses (sample, compose, compose_update).
#include <array>
#include <memory>
#include <vector>
#include <span>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "kumite/content/adaptation.hpp"
#include "kumite/content/database.hpp"
#include "kumite/content/mkm.hpp"

namespace kumite::content {

/// A motion being played: a database segment at a segment time, placed in the room (the
/// current source and the one it cross-fades from). Plain data: a copy can be played on another
/// thread (StrikeRateSolver) with its own EasedTravelCache.
struct PlaybackSource {
  int segment = -1;
  double time_s = 0;
  GroundFrame placement;
  Eigen::Vector2d anchor_xz_m{0, 0};
  bool loop = false;
  /// Segment seconds played per second (a strike whose correction lengthens its way is
  /// played slower: StrikeRateSolver). Times inside the segment stay segment times.
  double rate = 1;
  /// A strike's floor travel scaled (a shorter or longer lunge): the root moves `scale` times
  /// the clip's own travel from `from_s` to `contact_s`, then eases back to the clip's own
  /// speed over `release_s` (position and speed continuous). 1: the clip as captured.
  struct Travel {
    double scale = 1;
    double from_s = 0;     ///< s, segment time where the scaling starts
    double contact_s = 0;  ///< s, segment time of contact
    double release_s = 0.25;
    double rise_n = 0;     ///< pelvis raised by this (/ leg length) at contact, eased in from
                           ///< `from_s` and out over `release_s` (a high target)
    bool operator==(const Travel&) const = default;
  } travel;
};

/// The strike's eased travel after contact (PlaybackSource::Travel), summed per frame: cum[0] =
/// 0 at contact, cum[i] at the i-th knot (each frame time, then the release's end). Filled by
/// the first sample of a strike that scales its travel; one per thread that samples.
struct EasedTravelCache {
  int segment = -1;
  PlaybackSource::Travel travel;
  std::vector<Eigen::Vector2d> cum;
};

class MotionPlayer {
 public:
  using Source = PlaybackSource;
  MotionPlayer(std::shared_ptr<const Database> db, double stride_scale);

  const Source& current() const { return current_; }
  const Source& previous() const { return previous_; }
  /// s since the current source started (the cross-fade from the previous one).
  double blend_elapsed_s() const { return blend_elapsed_s_; }
  /// The drawn cross-fade's limb-pole turns (PoleTurns), as carried from update to update.
  const PoleTurns& pole_turns() const { return pole_turns_; }
  /// Character leg / actor leg: the scale the sources' floor travel is played at.
  double stride_scale() const { return stride_scale_; }

  /// `next` plays from now, cross-faded from the source playing until now.
  void play(const Source& next);
  /// The cross-fade taken as done (a rest taken at once, without a blend).
  void end_blend() { blend_elapsed_s_ = 1e9; }
  /// Segment seconds per second the current source plays at from now.
  void set_rate(double rate) { current_.rate = rate; }
  /// The current source placed anew: its placement's origin and yaw (rad) in the room.
  void place(const Eigen::Vector2d& origin_xz, double yaw_rad);
  /// The current source moved on the floor by `by` (m, room).
  void shift(const Eigen::Vector2d& by) { current_.placement.origin_xz += by; }
  /// Both sources' clocks, and the cross-fade's, advanced by dt (s).
  void advance(double dt);
  /// Another character's stride scale: each source's origin re-based so that its root stays
  /// where it is drawn; the arms' drawn poles, measured on the old body, forgotten.
  void rescale(double stride_scale);

  /// A source at its segment time (ping-pong for a loop), placed in the room.
  void sample(const Source& s, MkmFrame& out) const;
  /// A strike source at one of its own frames (no blend between frames).
  void sample_frame(const Source& s, int frame, MkmFrame& out) const;
  /// The ankle (m, room) at one of the source's own frames (Playback::frame_ankle).
  Eigen::Vector3d frame_ankle(const Source& s, const Eigen::Quaterniond& placement_rotation, int frame, const Rig& rig, int side,
                              const Eigen::Vector3d& hip_local) const;
  /// `cur` cross-faded from `prev` `blend_elapsed_s` into a blend of `blend_time_s` (cur_pose:
  /// `cur` alone), as the update composes it, without carrying its pole turns.
  void compose(const Source& cur, const Source& prev, double blend_elapsed_s, double blend_time_s, MkmFrame& cur_pose,
               MkmFrame& out) const;
  /// The update's pose: the current source cross-faded from the previous one with the pole
  /// turns carried on, each folded arm's elbow swinging no farther than the source's
  /// (limit_folded_pole_turn) on a body of morphology `m`.
  void compose_update(double dt, double blend_time_s, const Morphology& m, MkmFrame& cur_pose, MkmFrame& out);
  /// Each drawn elbow's distance from its arm's line, from the joints the decode drew on `rig`
  /// (what limit_folded_pole_turn compares with at the next update).
  void note_drawn_arms(const Rig& rig, std::span<const Eigen::Vector3d> drawn);

 private:
  std::shared_ptr<const Database> db_;
  double stride_scale_ = 1;
  Source current_, previous_;
  double blend_elapsed_s_ = 1e9;  ///< s since the current source started (cross-fade)
  PoleTurns pole_turns_;
  std::array<DrawnPole, 2> arm_poles_{};  ///< per arm, its drawn pole (limit_folded_pole_turn)
  /// The strike's eased travel (EasedTravelCache) for this thread's sampling.
  mutable EasedTravelCache eased_;
};

}  // namespace kumite::content
