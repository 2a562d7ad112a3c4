#pragma once
// The fighter's behaviour, engine-agnostic and single-threaded (testable without a window):
// rest, follow the visitor, strike on order, report hit/miss, switch characters at any time.
// Retrieval goes through a StrikePlanner that the caller may run on another thread: the
// behaviour sends a StrikeRequest and polls for the StrikePlan, animating meanwhile.
//
// Per update: sample the current motion (and the previous one while cross-fading) in MKM
// form, place it in the room, blend, add the reach offset d(t), hold planted feet, and
// decode onto the current character (AdaptJob).
#include <limits>
#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "kumite/common/time.hpp"
#include "kumite/common/wire.hpp"
#include "kumite/content/adaptation.hpp"
#include "kumite/content/block_retrieval.hpp"
#include "kumite/content/database.hpp"
#include "kumite/content/feet.hpp"
#include "kumite/content/fighter.hpp"
#include "kumite/content/foot_planting.hpp"
#include "kumite/content/guard.hpp"
#include "kumite/content/hit_reel.hpp"
#include "kumite/content/motion_player.hpp"
#include "kumite/content/retrieval.hpp"
#include "kumite/content/strike_placement.hpp"
#include "kumite/content/switch_easing.hpp"
#include "kumite/content/worker_channel.hpp"

namespace kumite::content {

/// A strike to plan (made on the behaviour's thread, read by the planner's).
struct StrikeRequest {
  std::uint64_t id = 0;
  int group = 1;                        ///< effector group (retrieval.hpp)
  MkmFrame now, before;                 ///< current pose and the one `dt_s` earlier (room frame)
  double dt_s = 1.0 / 60;               ///< s between `before` and `now`
  Eigen::Vector3d target_local_m{0, 0, 0};  ///< m, character ground frame of `now`
  double character_leg_length_m = 1;    ///< m, to scale the target to the actor
};

struct StrikePlan {
  std::uint64_t id = 0;
  RetrievalChoice choice;
  int segment = -1;        ///< -1: nothing fits this effector
  int start_frame = 0;     ///< segment frame where the strike starts
  int contact_frame = 0;   ///< segment frame where the hit point should meet the target
  double retrieval_us = 0; ///< µs, query features + search
};

/// A block to plan: the fighter's pose and the fist's path in its ground frame (m, m/s: the
/// character's size; scaled to the actor's here).
struct BlockRequest {
  MkmFrame now, before;                 ///< current pose and the one `dt_s` earlier (room frame)
  double dt_s = 1.0 / 60;
  Eigen::Vector3d fist_local_m{0, 0, 0};       ///< m, character ground frame of `now`
  Eigen::Vector3d fist_velocity_local_mps{0, 0, 0};
  double character_leg_length_m = 1;
};

/// Turns requests into plans: retargets the pose onto the actor, scales the target and runs
/// retrieve(). Immutable after construction; plan() is safe to call from any one thread.
class StrikePlanner {
 public:
  StrikePlanner(std::shared_ptr<const Database> db, RetrievalTunables tunables = {});
  StrikePlan plan(const StrikeRequest& request) const;
  /// The block whose forearm meets the fist's path (retrieve_block); its intercept in the
  /// actor's size (BlockChoice::intercept.point_m: actor ground frame, scaled by actor/character leg).
  BlockChoice plan_block(const BlockRequest& request) const;
  RetrievalQuery make_query(const StrikeRequest& request) const;
  const Database& database() const { return *db_; }
  const RetrievalTunables& tunables() const { return tunables_; }

 private:
  std::shared_ptr<const Database> db_;
  Rig actor_;
  RetrievalTunables tunables_;
};


/// Updates between the update that starts a strike and the one its playback rate is applied
/// on (BehaviourTunables::min_strike_rate): the rate is found off the frame (the retrieval
/// worker, or between updates in the tools), from the strike's start state, and enters at
/// exactly that update whatever the thread's timing, so the same inputs give the same frames.
/// The strike plays its first kStrikeRateDelayUpdates updates at the clip's own rate (inside
/// the blend into it, where the strike's weight is still near 0).
constexpr int kStrikeRateDelayUpdates = 1;

/// What finding a strike's playback rate needs: the strike's start state, copied.
struct StrikeRateJob {
  std::uint64_t id = 0;
  const Rig* rig = nullptr;  ///< the character (Behaviour's: immutable while it lives)
  double stride_scale = 1;   ///< character leg / actor leg
  PlaybackSource current, previous;  ///< at the strike's start (before its first advance)
  double blend_elapsed_s = 0;        ///< s into the cross-fade previous -> current
  double lead_s = 0;  ///< s played at the clip's own rate before the rate applies
  Effector effector;
  double start_time_s = 0, contact_time_s = 0, release_end_s = 0;  ///< segment times (s)
  double clip_contact_time_s = 0;  ///< s, segment time of the clip's contact frame
  double frame_dt_s = 0;           ///< s per update: the contact is drawn on the update at or past it
  Eigen::Quaterniond turn = Eigen::Quaterniond::Identity();  ///< full d(t) at contact
  double stretch = 1;
  Eigen::Vector3d target_room_m{0, 0, 0};  ///< m, the strike's frozen target
  /// The feet held through to contact, as Behaviour's plan holds them (weight 0: none), and
  /// how low a punch's shoulder may drop for them (Behaviour::feet_through_contact).
  FootLocks plan_feet;
  double plan_lowest_shoulder_y_m = -std::numeric_limits<double>::infinity();
  /// The cross-fade's pole turns as drawn at the start (Behaviour's), carried through the way
  /// as the updates will carry them.
  PoleTurns pole_turns;
};
struct StrikeRateResult {
  std::uint64_t id = 0;  ///< StrikeRateJob::id
  double rate = 1;       ///< segment seconds per second, in [min_strike_rate, 1]
  /// rate < 1: d(t) at contact found again at that rate from the state of the update the rate
  /// enters on (as Behaviour's compute_reach_error would find it there), so that update
  /// decodes nothing.
  bool has_reach = false;
  Eigen::Vector3d error_m{0, 0, 0};
  Eigen::Quaterniond turn = Eigen::Quaterniond::Identity();
  double stretch = 1;
  TrunkLean lean;        ///< a punch's trunk lean at contact (reach_correction)
  double root_drop_m = std::numeric_limits<double>::quiet_NaN();  ///< m, a punch's planned pelvis drop at contact
  double elbow_under_head_m = std::numeric_limits<double>::quiet_NaN();  ///< m, its elbow under its head joint there
  double solve_us = 0;   ///< µs the solve took (on whatever thread ran it)
};

/// Finds a strike's playback rate: the hit point's way as it will be drawn (the blend out of
/// the previous motion, the strike with its scaled travel and d(t) ramped, decoded on the
/// character: AdaptJob at 60 Hz, up to 3 times) beside the source clip's own hit path scaled
/// to the character. ~0.2-0.3 ms. One thread at a time per solver; it allocates only its
/// scratch, on the first solve (or a larger character).
class StrikeRateSolver {
 public:
  StrikeRateSolver(std::shared_ptr<const Database> db, const BehaviourTunables& tunables);
  StrikeRateResult solve(const StrikeRateJob& job);

 private:
  std::shared_ptr<const Database> db_;
  BehaviourTunables tun_;
  EasedTravelCache eased_;
  CanonicalPose canonical_;
  std::vector<Eigen::Quaterniond> local_, global_;
  std::vector<Eigen::Vector3d> positions_, last_positions_;
  std::vector<char> in_limb_;  ///< [joint] part of the striking limb
  std::vector<double> speeds_;  ///< m/s, every joint's speed at every sample of one way
};

/// Behaviour + adaptation for one fighter. Characters are Rigs; the database is shared.
class Behaviour {
 public:
  /// The two jobs handed to a worker (worker_channel.hpp): planning a strike, and finding its
  /// playback rate. The rate channel's poll is called on the update the job is due
  /// (kStrikeRateDelayUpdates after its submission): the job's result, waiting for it if the
  /// solver is late (nullopt: play at the clip's rate).
  using PlanChannel = WorkerChannel<StrikeRequest, StrikePlan>;
  using RateChannel = WorkerChannel<StrikeRateJob, StrikeRateResult>;
  using Submit = PlanChannel::Submit;
  using Poll = PlanChannel::Poll;
  using SubmitRate = RateChannel::Submit;
  using PollRate = RateChannel::Poll;

  /// Tunables from config.behaviour (and config.retrieval for the synchronous planner);
  /// throws kumite::Error when they are out of range (validate()).
  Behaviour(std::shared_ptr<const Database> db, std::vector<Rig> characters, const FighterConfig& config);

  /// Where plans come from. Default: synchronous planning inside update() via `planner`.
  void set_planner(PlanChannel channel);
  void set_planner(Submit submit, Poll poll) { set_planner(PlanChannel{std::move(submit), std::move(poll)}); }
  void use_synchronous_planner(std::shared_ptr<const StrikePlanner> planner);
  /// Who finds a strike's playback rate (StrikeRateJob, sent on the update the strike starts,
  /// polled kStrikeRateDelayUpdates later). Default: a StrikeRateSolver run inside update()
  /// at the submission (the frame pays ~0.2-0.3 ms); the Fighter runs it on its worker thread.
  void set_rate_solver(RateChannel channel);
  void set_rate_solver(SubmitRate submit, PollRate poll) { set_rate_solver(RateChannel{std::move(submit), std::move(poll)}); }

  /// Queue an order (processed at the next update).
  void order(const Order& order);
  /// A block against a fist seen coming (the Fighter's defence, spar mode; guard.hpp).
  using BlockOrder = content::BlockOrder;
  /// A block can start now: not paused, no strike or block playing or blending out, no
  /// cross-fade under way (a block cuts no blend: the pose would jump).
  bool can_block() const;
  /// Starts a block now (at this update, before update()): the block whose forearm meets the
  /// fist's path, placed where the fighter stands, played fast enough (up to max_rate) to be
  /// in place before the fist, its forearm's middle brought onto the path by d(t) and held
  /// there until the fist has passed. A strike order under way before its strike is dropped
  /// (order_ignored, blocking). False: it cannot (can_block) or no block fits.
  bool block(const BlockOrder& order, Timestamp now);
  /// Spar with blocks on (the Fighter sets it every update): the fighter keeps its guard up,
  /// both forearms raised before its face and chest, whenever it is not striking; the guard
  /// eases in over 0.4 s and out over 0.15 s as a strike starts (behaviour_guard.cpp).
  void set_guard(bool on) { guard_.want(on); }
  /// The guard's weight at the last update (0: the motion's own arms, 1: the guard).
  double guard_weight() const;
  /// The guard is up (spar, blocks on, no strike of its own): a fist seen coming is parried.
  bool guarding() const;
  /// A parry can start now: guarding, and an arm free (not moving to a parry or holding one).
  bool can_parry() const;
  /// A parry is moving to its place or held there.
  bool parrying() const;
  /// A parry from the guard: the free forearm that can be across the fist's path soonest is brought there where
  /// the fist will be once the forearm can be there (a minimum-jerk move of the wrist, its
  /// peak speed at most 6 m/s), held until the fist has passed, then eased back to the guard.
  /// Emits `block` once the forearm is in place (its margin over the fist's arrival at the
  /// forearm, negative when late). False: it cannot (can_parry) or the order is not finite.
  bool parry(const BlockOrder& order, Timestamp now);
  /// The parry under way against `order.limb` re-aimed at `order`'s path (a `switch` of the
  /// recognised strike): its targets move to the new crossing from where they are, the arm's
  /// way continuing without a restart (Guard::reaim). False: no parry of that limb is moving
  /// or held, or no place on the new path is within its arm's reach.
  bool reaim_parry(const BlockOrder& order, Timestamp now);
  /// The block clip under way against `order.limb`, not yet in place, re-aimed at `order`'s
  /// path (a `switch` of the recognised strike, while the guard is down): d(t) moves from
  /// its old correction to the one for the new crossing by a minimum-jerk shift that ends as
  /// the clip reaches its intercept, so the arm goes on from where it is, no restart. False: no
  /// such block, it is in place already, or the shift would move the wrist faster than 6 m/s.
  bool reaim_block(const BlockOrder& order, Timestamp now);
  /// A slip: where no forearm can be sent across the fist's path (both busy, or none reaches
  /// it), the trunk leans the head off the path (sideways, away from it, and back), a damped
  /// spring laid on the motion as a blow's reel is (HitReel), peaking about 0.1 s later; no
  /// strike is aborted, nothing is scored. False: striking, paused, no pose yet, or the order
  /// is not finite.
  bool slip(const BlockOrder& order, Timestamp now);
  /// A blow the fighter took (the Fighter's contact judgement, spar mode): the visitor's fist
  /// or foot entered its drawn head or torso. The struck chain reels (a damped spring on the
  /// head about the neck, the trunk about the pelvis, the struck side's shoulder when the
  /// blow lands off the midline) on top of whatever the fighter plays, starting with this
  /// update; a strike of its own under way before its contact is aborted (a blend into rest,
  /// once its own cross-fade in is done); a large blow steps it back.
  using HitOrder = content::HitOrder;  ///< hit_reel.hpp
  /// False (nothing changed): a share of 0, a point or velocity not finite, or no pose yet.
  bool hit(const HitOrder& order, Timestamp now);
  /// The reel under way: the head, trunk and shoulders' rotation vectors (rad, room frame:
  /// axis times angle) at the last update; all zero when none is.
  using ReelState = content::ReelState;  ///< hit_reel.hpp
  ReelState reel() const;
  /// Strikes aborted so far (by a blow, or by abort_strike).
  int strikes_aborted() const { return strikes_aborted_; }
  /// A strike of its own is under way before its contact (not a block).
  bool attacking() const;
  /// Aborts its strike under way before contact (the sparring planner's abort_probability): it
  /// leaves for rest as from a blow, once its own cross-fade in is done (within 0.3 s).
  void abort_strike(Timestamp now);
  /// Strike toward an explicit room-frame target (tools, tests); same rules as order().
  void order_strike(const Order& order, const Eigen::Vector3d& target_room_m);
  /// Visitor safety: while on, the fighter backs off to keep_away_extra_m beyond its strike
  /// distance and strike orders are ignored with a reason (the app sets it while the visitor
  /// is near a wall or lost near one). Takes effect at the next update.
  void keep_away(bool on);
  bool keeping_away() const { return keep_away_; }
  bool paused() const { return paused_; }
  /// m: the horizontal distance it keeps from the visitor's head while following (from the next
  /// update; the config's strike_distance_m until set: the sparring planner's fighting distance).
  /// `close`: a spot off by less than a stance step (stance_step_min_m) is walked to with
  /// procedural steps rather than waited out (sparring: its fighting distance is kept, not
  /// stance_step_min_m beyond it, where the planner no longer counts it engaged).
  /// `stance_step_min_m` (m): stance steps from the mocap once the spot is this far ahead (the
  /// tunable's meaning; 0 off, any other value at least follow_tolerance_m); negative: the
  /// tunable's own value (BehaviourTunables::stance_step_min_m). Sparring passes the planner's.
  /// `follow_arc_deg`: the spot kept lies within this angle either side of the way from the
  /// visitor's head to home (BehaviourTunables::follow_arc_deg); negative: the tunable's.
  void follow_at(double distance_m, bool close = false, double stance_step_min_m = -1, double follow_arc_deg = -1) {
    follow_distance_m_ = distance_m;
    follow_close_ = close;
    stance_step_min_m_ = stance_step_min_m;
    follow_arc_deg_ = follow_arc_deg;
  }
  /// m: the stance steps' forward threshold in effect (0: procedural steps only).
  double stance_step_min_m() const;
  void update(Timestamp now, double dt, const Eigen::Vector3d& head);

  FighterFrame frame() const;
  std::vector<FighterEvent> take_events();
  /// The event's line for people (content::describe with this database's clip names and the
  /// characters' names).
  std::string describe(const FighterEvent& event) const;
  int character_count() const { return static_cast<int>(characters_.size()); }
  /// The most joints any of its characters has (its per-joint buffers are sized to it).
  std::size_t most_joints() const { return positions_.size(); }
  const Rig& character(int i) const { return characters_[static_cast<std::size_t>(i)]; }
  int current_character() const { return character_; }
  /// The frame's state, from the action state (action_).
  FighterState state() const;
  /// The action state and the body's locomotion, as the frame carries them.
  FighterAction action() const;
  FighterLocomotion locomotion_kind() const;
  /// A strike order is under way before its strike: waiting for its plan, stepping in, or
  /// stepped in and queued to be taken again.
  bool strike_pending() const;
  /// The walk segment of the stance step playing now (-1: none), and how many were begun.
  int stance_step_segment() const { return stance_step() ? stance_step()->segment : -1; }
  int stance_steps_begun() const { return stance_steps_; }
  /// Rests with this rest segment from now (tools and tests: strikes from another stance), at
  /// once, without a blend. False (nothing changed) if it is not a rest segment.
  bool rest_with(int segment);
  double stance_step_scale() const { return stance_step() ? stance_step()->scale : 1.0; }  ///< its floor travel's scale

  /// The pose of the last update on the current character (for tools/tests).
  std::span<const Eigen::Quaterniond> local_rotations() const { return local_; }
  Eigen::Vector3d root_position() const { return root_joint_; }
  std::span<const Eigen::Vector3d> joint_positions() const { return positions_; }
  /// Raw positions without the character-switch easing (what the current rig really does).
  std::span<const Eigen::Vector3d> rig_positions() const { return rig_positions_; }
  const AdaptReport& last_report() const { return report_; }
  /// Feet held still this update [side] (not lifted by the motion, not stepping).
  std::array<bool, 2> feet_locked() const;
  /// Foot planting as of the last update (for tools/tests).
  const FootPlanter& foot_planter() const { return feet_.planter(); }
  const FootLocks& foot_locks() const { return feet_.locks(); }
  /// d(t)'s weight at the last update: 0 none, 1 the full correction (contact).
  double reach_ramp() const { return ramp_; }
  /// The source motion's contacts at the last update [side] (the motion being blended to).
  const std::array<double, 2>& motion_planted() const { return motion_planted_; }

  /// The strike in progress or the last one (for reports).
  struct StrikeInfo {
    bool active = false;
    Order order{};
    Eigen::Vector3d target_room_m{0, 0, 0};
    StrikePlan plan;
    Effector effector;
    double start_time_s = 0;       ///< segment time at the start (s)
    double contact_time_s = 0;     ///< segment time of contact (s): the update's that draws it (contact_frame_time), then the contact frame's
    double clip_contact_time_s = 0;  ///< segment time of the clip's contact frame (s)
    double end_time_s = 0;         ///< segment time of the last frame (s)
    double release_end_s = 0;      ///< segment time at which d(t) is back to zero (s)
    Eigen::Vector3d error_m{0, 0, 0};  ///< m: target - effector at contact, before d(t)
    Eigen::Quaterniond turn = Eigen::Quaterniond::Identity();  ///< full d(t): limb turn at contact
    double stretch = 1;                ///< full d(t): limb length factor at contact
    bool out_of_reach = false;         ///< a kick's target beyond the leg's reach: d(t) stops short (kKickLockOutShare)
    /// A character switch since the strike began: a kick's d(t) then stretches the leg no further
    /// than kKickLockOutShare anywhere on its way to contact (cap_kick_stretch_over_way), and
    /// `stretch` stays at most `max_stretch` (lowered only, so a d(t) found anew never jumps back).
    bool switched_body = false;
    double max_stretch = std::numeric_limits<double>::infinity();
    TrunkLean lean;                    ///< full d(t): a punch's trunk lean at contact
    double rate = 1;                   ///< segment seconds played per second (StrikeRateSolver)
    int start_update = -1;             ///< update counter at the strike's start
    int rate_update = -1;              ///< update counter the rate was applied on (-1: not)
    /// Updates played at the clip's own rate after the start before `rate` applied (0 when
    /// rate == 1): the quality comparison maps output frames to source frames through it.
    int rate_lead_updates = 0;
    bool contact_done = false;
    double contact_distance_m = -1;
    bool contact_reached = true;   ///< the limb (after the trunk fallback) could reach
    bool hit = false;              ///< the hit point touched the visitor's body as tracked at contact
    bool target_reached = false;   ///< the hit point ended within hit_radius_m of the frozen target
    double body_distance_m = -1;   ///< m, hit point to the tracked body's surface at contact (<= 0: touching)
    /// m the punch aims below the target frozen at the order (0: at it): a straight arm to it
    /// would lift the elbow above the fighter's own head at contact (keep_elbow_below_head).
    double aim_lowered_m = 0;
    /// m the pelvis drops for held feet at contact in the punch's plan, and its elbow under its
    /// head joint there (NaN: none planned). A deeper drop on the way than the elbow's room
    /// under the head allows takes the fist down with the body (ReachGoal::pin_drop_max_m).
    double plan_drop_m = std::numeric_limits<double>::quiet_NaN();
    double plan_elbow_under_head_m = std::numeric_limits<double>::quiet_NaN();
    int contact_update = -1;       ///< update counter at contact
    /// The feet the plan holds at contact (feet_through_contact; weight 0: not held): the
    /// punch's planned lean is found with the pelvis lowered for them, as the frames draw it.
    FootLocks plan_feet;
    /// Segment s d(t) stays whole after contact before its release (a block held across the
    /// fist's path until it has passed; 0 for strikes).
    double hold_s = 0;
    // A block (spar): the strike machinery plays it; "contact" is the forearm in place.
    bool block = false;
    recognition::Role block_limb = recognition::Role::right_hand;  ///< the visitor's limb it answers
    bool block_recognised = false;
    Timestamp fist_arrival_t = 0;   ///< s: when the fist was predicted at the guard
    Timestamp in_place_t = -1;      ///< s: when the forearm was in place (-1: not yet)
    double fist_speed_mps = 0;
    Eigen::Vector3d intercept_m{0, 0, 0};  ///< m, room: the forearm's middle is brought here
    /// A block re-aimed on its way (reaim_block): d(t)'s turn and stretch go from these to
    /// `turn` / `stretch` by a minimum-jerk shift over segment times [reaim_from_s, reaim_to_s]
    /// (reaim_from_s < 0: never re-aimed).
    Eigen::Quaterniond reaim_turn_from = Eigen::Quaterniond::Identity();
    double reaim_stretch_from = 1;
    double reaim_from_s = -1, reaim_to_s = -1;
    // Aborted by a blow before its contact: d(t) goes from its weight then to none over
    // release_time_s (segment s from abort_s to release_end_s) while the clip blends into rest.
    bool aborted = false;
    double abort_s = 0;       ///< segment s at the abort
    double abort_ramp = 0;    ///< d(t)'s weight at the abort
  };
  const StrikeInfo& strike() const { return strike_; }
  int update_count() const { return updates_; }
  /// Room placement of the character's ground frame now (pelvis on the floor, facing).
  GroundFrame ground() const;

 private:
  using Source = PlaybackSource;
  struct QueuedOrder;
  struct PendingStrike;
  /// Takes the orders queued for this update (an order taken again after a step first): each
  /// deferred() stays queued, in order; the others take_order().
  void handle_orders(Timestamp now, const Eigen::Vector3d& head);
  /// A strike order that waits (queued) rather than being taken at this update.
  bool deferred(const QueuedOrder& queued) const;
  void take_order(const QueuedOrder& queued, Timestamp now, const Eigen::Vector3d& head);
  void start_strike(const PendingStrike& pending, const StrikePlan& plan, const PlaybackSource& source, const StrikeFit& fit, Timestamp now, double dt);
  /// The feet a strike is placed on, as drawn now (strike_placement.hpp).
  HeldFeet held_feet() const;
  /// The target (frozen at the order) of the step in progress before a strike: a step in or
  /// back, into the fighting stance, or a strike's support step; nullptr when none is.
  const Eigen::Vector3d* step_target() const;
  /// A step before the strike: `step_m` > 0 in toward the target, < 0 back from it. False
  /// (strike from here) where the fighter's area leaves less than step_in_min_m to step.
  bool begin_step_in(const PendingStrike& pending, const StrikePlan& plan, double step_m, Timestamp now);
  /// After a stance step (a long kata stance, its take's own rest), a strike that wants a step
  /// first: the rest stance (rest_segment_ or its mirror) to take instead, placed at the spot
  /// facing the target, and the spot to step to (the step the strike wants from that stance,
  /// within the area), where the strike then falls short (or too near) by less -- by
  /// step_in_min_m -- than from the feet as they stand (`step_m`), else nullopt.
  struct Restance {
    int rest = -1;
    Eigen::Vector2d goal_xz{0, 0};  ///< m, room: the spot stepped to
    double step_m = 0;              ///< the step the strike wants from the rest stance at the spot (signed)
  };
  std::optional<Restance> restance_for(const PendingStrike& pending, const StrikePlan& plan, double step_m) const;
  /// The rest stance taken: its rest blends in and the spot moves to its goal (an approach,
  /// as a step-in: the order is taken again once the feet stand).
  void begin_restance(const PendingStrike& pending, const StrikePlan& plan, const Restance& r, Timestamp now);
  /// The step a strike placed with `fit` wants first (m, signed as begin_step_in's; 0: none).
  double step_wanted(const StrikeFit& fit) const;
  void update_step_in(double dt);
  /// A strike's support foot (a kick's standing foot, a punch's longest down) stepped to where
  /// the clip puts it down, if it stands more than kick_support_step_m (punch_support_step_m)
  /// from there or is still in a step (true: the strike waits for the step).
  bool begin_support_step(const PendingStrike& pending, const StrikePlan& plan, const Source& source, Timestamp now);
  void update_support_step(double dt);
  void apply_strike_rate(double dt);
  /// The strike's source as start_strike() plays it: placed on the character, aligned to the
  /// support foot, its travel fitted to strike_target_ (strike_placement.hpp); `fit`: how it lands.
  Source strike_source(const StrikePlan& plan, StrikeFit& fit) const;
  /// The same from another pose and feet (a stance the fighter would take first).
  Source strike_source(const StrikePlan& plan, StrikeFit& fit, const MkmFrame& from, const HeldFeet& feet) const;
  void select_character(int index, Timestamp now);
  double stride_scale() const;
  void start_rest(Timestamp now, int segment = -1);
  void update_follow(double dt, const Eigen::Vector3d& head);
  /// Following `off` (m, room, from the spot) with a stance step from the mocap: the walk
  /// segment whose start stance fits the feet drawn now and whose scaled travel fits `off`
  /// along the facing direction; false where none fits (behaviour_steps.cpp).
  bool begin_stance_step(const Eigen::Vector2d& off);
  /// The stance step's clip is ending: the rest motion (or its mirror, whichever fits the
  /// stance the step ends in) takes over where the body stands.
  void end_stance_step(Timestamp now);
  /// The rest segment (rest_segment_ or its mirror) whose stance fits the feet drawn now best.
  int rest_for_stance() const;
  /// d(t) at contact from the pose at segment time `at_time_s`; `plan_lean`: also the punch's
  /// trunk lean (not at the contact frame itself: the lean eased in since the start stays).
  void compute_reach_error(double at_time_s, bool plan_lean = true);
  /// A kick switched to another body: its stretch lowered so that the leg, stretched by d(t),
  /// reaches at most kKickLockOutShare of its length at any point from now to `until_s`
  /// (segment time; the source's leg may be straighter on the way than at contact).
  void cap_kick_stretch_over_way(double until_s);
  /// The feet the strike source `s` has planted at `contact_time_s`: where held now if the
  /// clip keeps them planted from its time on (a foot not held now is left out), else where the
  /// clip puts them down on the way; the others at weight 0. Pelvis drop 0..max_root_drop_m.
  FootLocks feet_through_contact(const Source& s, double contact_time_s) const;
  /// m, room: how low a punch's shoulder may drop for held feet (the target within the arm's
  /// reach at max_punch_aim_deg from it; -inf for kicks).
  double lowest_shoulder_y_m() const;
  /// A punch at a target so high above the shoulder that the arm, straight toward it, would
  /// hold the elbow above the fighter's own head at contact aims lower (the visitor's neck or
  /// chest): on the pose compute_reach_error() last planned (contact_shoulder_m_, contact_head_m_).
  void keep_elbow_below_head();
  /// m: the most pelvis drop a punch's fist is held at its target against (its plan's drop and
  /// its elbow's room under the head; infinite for kicks, blocks and unplanned punches).
  double pin_drop_max_m() const;
  /// The straight arm's part of it: the highest aim at the target's horizontal distance.
  void aim_straight_arm_below_head();
  double ramp_in(double t) const;   ///< d(t)'s weight at segment time t before contact
  double ramp_out(double t) const;  ///< ... and after it, until release_end_s
  ReachGoal reach_goal(double ramp, double t) const;  ///< d(t) at that weight, segment time t (a block's re-aim)
  /// d(t)'s full turn and stretch at segment time t: strike_'s, or on the way to them from a
  /// block's re-aim (reaim_block).
  void correction_at(double t, Eigen::Quaterniond& turn, double& stretch) const;
  /// A block's d(t) aimed so that the forearm's middle lies on `intercept` (m, room) at the
  /// clip's intercept (block, reaim_block): target_room_m and compute_reach_error's fields.
  void aim_block_at(const Eigen::Vector3d& intercept);
  double release_end_s(double contact_time_s) const;  ///< segment time d(t) is back to 0
  /// The feet's inputs for this update: the motion alone (`cur`), d(t) (`reach`, at weight
  /// `ramp`), the strike under way and whether a foot may step.
  FeetInput feet_input(double dt, const ReachGoal* reach, double ramp, const MkmFrame& cur) const;
  void judge_contact(Timestamp now, const Eigen::Vector3d& head);
  /// A blow's abort (behaviour_hit.cpp): a strike of its own aborted if one is due and can leave now.
  void abort_strike_for_blow(Timestamp now);
  void judge_block_in_place(Timestamp now);
  FighterEvent& emit(FighterEvent::Kind kind, Timestamp t, const Order& o, FighterEvent::Reason reason,
                     double distance = 0);

  std::shared_ptr<const Database> db_;
  std::shared_ptr<const StrikePlanner> block_planner_;  ///< blocks are planned in the update (~20 µs)
  std::vector<Rig> characters_;
  FighterConfig config_;
  BehaviourTunables tun_;
  PlanChannel plan_channel_;  ///< strikes planned (set_planner; synchronous by default)
  std::shared_ptr<const StrikePlanner> sync_planner_;
  std::deque<StrikePlan> sync_results_;

  int character_ = 0;
  bool paused_ = false;
  bool keep_away_ = false;
  double follow_distance_m_ = 0;  ///< m, follow_at() (set from the config at construction)
  bool follow_close_ = false;     ///< follow_at()'s `close`
  double stance_step_min_m_ = -1;  ///< m, follow_at()'s `stance_step_min_m` (negative: the tunable's)
  double follow_arc_deg_ = -1;     ///< deg, follow_at()'s `follow_arc_deg` (negative: the tunable's)
  int rest_segment_ = 0;
  /// The sources playing (the current one and the one it cross-fades from), the cross-fade
  /// and the arms' drawn poles (motion_player.hpp, motion_playback.cpp).
  MotionPlayer player_;
  double facing_rad_ = 0;  ///< rad: the way the fighter faces (toward the visitor)
  /// rad: the rest motion's hips (its first frame's ground yaw) turned this far off facing_rad_
  /// (0: the default rest; after a stance step, its stance's own hips).
  double rest_yaw_rad_ = 0;
  Eigen::Vector2d spot_xz_m_{0, 0};  ///< m, where the rest motion is anchored (room)
  Eigen::Vector2d spot_velocity_{0, 0};  ///< m/s of the rest spot while following
  std::optional<Eigen::Vector2d> recentre_goal_;
  /// rest_segment_'s mirrored copy (the other foot leading; -1: none in the database), and the
  /// `walk` segments stance steps are cut from.
  int mirrored_rest_segment_ = -1;
  std::vector<int> walk_segments_;
  std::optional<Eigen::Vector2d> last_goal_;   ///< m, room: the spot to keep at the last follow update
  double stance_wait_s_ = 0;                   ///< s a stance step due has waited for both feet down
  double closer_s_ = 0;                        ///< s the spot to keep has lain behind the fighter (a back step due)
  int last_goal_update_ = -1;                  ///< the update it was taken (following resumed: speed anew)
  Eigen::Vector2d goal_velocity_{0, 0};        ///< m/s: how fast it moves (smoothed)
  int stance_steps_ = 0;  ///< stance steps begun so far

  /// An order queued for the next update; a strike's explicit room target (tools, tests) or
  /// none (the visitor's head at that update).
  struct QueuedOrder {
    Order order{};
    std::optional<Eigen::Vector3d> target_room_m;
    bool stepped_first = false;  ///< taken again after a step in or back (or into the fighting stance) for it (never steps twice)
    bool support_stepped = false;  ///< taken again after a strike's support step (never twice)
    /// Taken again after stepping in: the plan it stepped in for, played instead of the new
    /// plan where the new one falls shorter (another window, whose lunge the feet hold back).
    std::optional<StrikePlan> plan{};
    /// Accepted and planned while a stance step played, short of its target: planned again
    /// once the step has ended (from where it ends, not from mid-step; accepted once).
    bool after_stance_step = false;
  };
  std::vector<QueuedOrder> orders_;  ///< queued for the next update (deferred ones first)
  std::vector<QueuedOrder> taking_;  ///< the orders handle_orders() is taking (room kept)
  /// A decoded pose for the strike's start (reach error, traversal, support foot): one at a
  /// time, reused so that starting a strike allocates nothing once warm.
  mutable CanonicalPose scratch_pose_;
  /// m, room: a punch's striking shoulder, elbow and head at contact with the whole d(t) and the planned
  /// lean, as compute_reach_error() last planned them (NaN when it planned no lean).
  Eigen::Vector3d contact_shoulder_m_ = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d contact_elbow_m_ = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d contact_head_m_ = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  std::uint64_t next_request_ = 1;
  /// A strike order sent to the planner, waiting for its plan.
  struct PendingStrike {
    std::uint64_t request = 0;               ///< StrikeRequest::id
    Order order{};
    Eigen::Vector3d target_room_m{0, 0, 0};  ///< m, frozen at the order
    bool stepped_first = false;              ///< QueuedOrder::stepped_first
    bool support_stepped = false;            ///< QueuedOrder::support_stepped
    std::optional<StrikePlan> plan;          ///< QueuedOrder::plan
  };
  /// A strike order whose target the strike would not reach from where the fighter stands:
  /// the fighter walks (steps) to goal_xz, then the order is taken again (update_step_in).
  struct Approach {
    Order order{};
    Eigen::Vector3d target_room_m{0, 0, 0};  ///< m, frozen at the order
    Eigen::Vector2d goal_xz{0, 0};           ///< m, room: the spot stepped to
    double elapsed_s = 0;  ///< s since the step-in began
    double at_spot_s = 0;  ///< s the spot has been at goal_xz (the feet may still be stepping)
    StrikePlan plan;       ///< the strike stepped in for
    /// A step in toward the target, back from it, or into a rest stance taken on the way
    /// (begin_restance: done once both feet stand in it).
    enum class Kind { step_in, step_back, restance } kind = Kind::step_in;
  };
  /// A strike whose clip puts its support foot down out of where that foot stands (or with
  /// that foot still in a step): the foot steps there first (FootPlanter::step_to), then the order is taken again
  /// (update_support_step); no foot steps on its own meanwhile.
  struct SupportStep {
    Order order{};
    Eigen::Vector3d target_room_m{0, 0, 0};  ///< m, frozen at the order
    bool stepped_first = false;              ///< QueuedOrder::stepped_first
    int side = 0;                            ///< the support foot
    double elapsed_s = 0;                    ///< s since the step began
  };
  std::optional<Eigen::Vector3d> strike_target_;  ///< m, room: the target of the strike being started
  StrikeInfo strike_;

  MkmFrame pose_, pose_before_;  ///< blended, placed pose this and the previous update
  bool have_pose_ = false;
  double last_dt_ = 1.0 / 60;

  /// The feet: where each is held, the held feet handed to the decode and the pelvis drop's
  /// bounds (feet.hpp, feet.cpp).
  Feet feet_;

  /// A character switch's easing of the drawn joints (switch_easing.hpp).
  SwitchEasing switch_;

  std::vector<Eigen::Quaterniond> local_, global_;
  std::vector<Eigen::Vector3d> rig_positions_, positions_;
  /// The last update's rig_positions_ (AdaptJob::previous_positions: each knee turns at most
  /// kKneeSwivel_rad_s about its leg from there), and whose character they were (-1: none yet).
  std::vector<Eigen::Vector3d> previous_rig_positions_;
  int previous_rig_character_ = -1;
  // The strike's playback rate (StrikeRateJob): who solves it, and the job out.
  RateChannel rate_channel_;
  std::shared_ptr<StrikeRateSolver> sync_rate_solver_;
  std::optional<StrikeRateResult> sync_rate_result_;
  std::uint64_t next_rate_job_ = 1;
  struct PendingRate {
    std::uint64_t job = 0;
    int due_update = 0;
    int segment = -1;
    int character = 0;  ///< the character the job was made for
  };

  // ---- The action state: what the fighter is doing, one alternative at a time ----------
  // (content/README.md, "Action states", has the table.) A strike order goes Idle ->
  // AwaitingPlan -> [Approaching | SupportStepping -> Retaking -> AwaitingPlan ...] ->
  // Striking -> Recovering -> Idle. Until it strikes, the body keeps its Locomotion (at its
  // spot, walking it, or carried by a stance step from the mocap), carried over from one
  // alternative to the next. paused_, keep_away_ and recentre_goal_ are standing orders, not
  // modes. Every change of alternative goes through enter(), which allows only the table's.
  /// A stance step from the mocap playing while following: the player's current source plays
  /// `segment` from its first frame (floor travel scaled by Source::Travel); at `end_s`
  /// (segment s) the rest motion blends in.
  struct StanceStep {
    int segment = -1;
    double end_s = 0;  ///< s, segment time the rest motion starts blending in
    double scale = 1;  ///< its floor travel's scale
    int support = 0;   ///< the foot it stands on (held throughout: the clip steps the other)
  };
  struct AtSpot {};        ///< stands at its spot (FighterState::resting)
  struct Walking {};       ///< walks its spot toward the spot to keep (following)
  struct StanceStepping {  ///< a stance step from the mocap carries it (following)
    StanceStep step;
  };
  using Locomotion = std::variant<AtSpot, Walking, StanceStepping>;
  struct Idle {            ///< no strike under way
    Locomotion loco;
  };
  struct AwaitingPlan {    ///< a strike order sent to the planner
    PendingStrike strike;
    Locomotion loco;
  };
  struct Approaching {     ///< stepping in, back, or into a rest stance before the strike
    Approach approach;
    Locomotion loco;
  };
  struct SupportStepping { ///< a kick's support foot stepping to where the kick stands on it
    SupportStep step;
    Locomotion loco;
  };
  struct Retaking {        ///< the order is taken again at the next update (after a step)
    QueuedOrder order;
    Locomotion loco;
  };
  struct Striking {        ///< the strike's clip plays (strike_); its playback rate may be due
    std::optional<PendingRate> rate;
  };
  struct Recovering {};    ///< blending into rest while d(t) goes back to zero
  using Action = std::variant<Idle, AwaitingPlan, Approaching, SupportStepping, Retaking, Striking, Recovering>;
  Action action_{Idle{}};
  /// The only way action_ changes alternative (asserts the table's transitions).
  void enter(Action next);
  /// The body's locomotion now (AtSpot while striking or recovering), and setting it (only
  /// in the alternatives that have one).
  const Locomotion* locomotion() const;
  void set_locomotion(Locomotion loco);
  template <class T> T* as() { return std::get_if<T>(&action_); }
  template <class T> const T* as() const { return std::get_if<T>(&action_); }
  const PendingStrike* pending() const { return as<AwaitingPlan>() ? &as<AwaitingPlan>()->strike : nullptr; }
  const Approach* approach() const { return as<Approaching>() ? &as<Approaching>()->approach : nullptr; }
  const SupportStep* support_step() const { return as<SupportStepping>() ? &as<SupportStepping>()->step : nullptr; }
  const QueuedOrder* retaking() const { return as<Retaking>() ? &as<Retaking>()->order : nullptr; }
  const StanceStep* stance_step() const;
  bool striking() const { return as<Striking>() != nullptr; }
  bool recovering() const { return as<Recovering>() != nullptr; }
  Eigen::Vector3d root_joint_{0, 0, 0};
  AdaptReport report_;
  TrunkLean trunk_floor_;  ///< the least trunk fallback this frame (the last frame's, easing out)
  int trunk_floor_side_ = -1;  ///< the arm whose strike made it (-1: no punch yet)
  std::vector<FighterEvent> events_;
  HitReel reel_;  ///< a blow's reel and step back (hit_reel.hpp, behaviour_hit.cpp)
  Guard guard_;   ///< the guard and parries (guard.hpp, behaviour_guard.cpp)
  Timestamp abort_until_ = -1;             ///< s: a strike of its own before contact is aborted until then
  int strikes_aborted_ = 0;
  Timestamp time_ = 0;
  int updates_ = 0;
  double ramp_ = 0;
  std::array<double, 2> motion_planted_{0, 0};
};

/// One strike played from rest on one character, frame by frame at the strike clip's frame
/// rate (what `kumite-motion strike` writes and `bench` times). The character starts at
/// rest with its ground frame at the room origin facing +Z; the target is in that frame.
struct StrikeRecording {
  Clip motion;                  ///< the adapted motion on the character's skeleton (m)
  int contact_frame = -1;       ///< frame of `motion` at contact (-1: no strike happened)
  int effector_joint = -1;      ///< skeleton joint whose position is the hit point
  Behaviour::StrikeInfo strike; ///< plan, target, contact distance, reach flag
  std::string segment_name;     ///< chosen database segment
  std::string source_clip;      ///< clip it came from
  int source_start_frame = 0;   ///< frame of the source clip where the strike starts
  bool mirrored = false;
  double retrieval_us = 0;               ///< µs, planning (features + search)
  std::vector<double> update_us;         ///< µs per frame: blend + retarget + reach + feet
  double rate_solve_us = 0;              ///< µs, finding the playback rate (between updates; 0: none)
  double max_foot_slide_m = 0;           ///< m per frame, held ankles
  std::vector<std::string> events;       ///< event texts in order
  /// One row per recorded frame: what drove it (for `kumite-motion strike --trace`).
  struct TraceRow {
    FighterState state = FighterState::resting;
    double ramp = 0;                                  ///< d(t) weight
    std::array<FootPlanter::Phase, 2> phase{};        ///< foot planting phase [side]
    std::array<double, 2> planted{0, 0};              ///< the motion's contact [side]
    std::array<double, 2> lock_weight{0, 0};          ///< the hold's weight in AdaptJob [side]
    std::array<Eigen::Vector3d, 2> lock_m{};          ///< m, room: the hold [side]
    std::array<Eigen::Vector3d, 2> ankle_m{};         ///< m, room: the drawn ankle [side]
    double root_drop_m = 0;                           ///< m, pelvis lowered by the solver
  };
  std::vector<TraceRow> trace;
};
/// `rest_segment`: the rest segment (by name) it starts from, instead of the database's first
/// (a strike from another stance: the mirrored rest, the rest after a stance step); an unknown
/// name or one that is not a rest throws kumite::Error.
StrikeRecording record_strike(std::shared_ptr<const Database> db, const Rig& character, OrderKind order,
                              const Eigen::Vector3d& target_ground_m, const FighterConfig& config = {},
                              std::string_view rest_segment = {});

/// Loads the characters of a FighterConfig (BVH, first frame = rest pose) into rigs.
std::vector<Rig> load_character_rigs(const FighterConfig& config);
/// Loads one character: a file path, or a name looked up as
/// <content>/characters/<name>.bvh.
Rig load_character_rig(const std::string& name_or_path);

}  // namespace kumite::content
