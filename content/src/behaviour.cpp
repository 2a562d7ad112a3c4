// Behaviour's decisions: orders, the state machine (resting, following, striking,
// recovering), starting a strike and its reach offset d(t), following the visitor, judging
// contact, and update() composing them. Playing sources: motion_playback.cpp; what the
// motion says of the feet and the pelvis drop: feet.cpp (Feet); holding them: foot_planting.cpp.
#include "kumite/content/behaviour.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numbers>
#include <utility>

#include "behaviour_internal.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/bvh.hpp"
#include "kumite/content/canonical.hpp"
#include "kumite/content/contact.hpp"

namespace kumite::content {

using namespace behaviour_detail;
using CJ = CanonicalJoint;
using Eigen::Vector2d;
using Eigen::Vector3d;

namespace {
/// s: the trunk fallback's weight rises from 0 to 1 over this at the quickest (AdaptJob::max_trunk_weight).
constexpr double kTrunkFallbackIn_s = 0.1;
/// s: ...and falls back to none over this at the quickest (AdaptJob::min_trunk_fallback).
constexpr double kTrunkFallbackOut_s = 0.15;
/// A punch's planned lean brings the target within this share of the arm at contact (the
/// frames' fallback: AdaptJob's default 0.95).
constexpr double kPlannedLeanShare = 0.9;
/// m: a punch's elbow stays at least this far below the head joint at contact (the head joint
/// is the base of the skull: an elbow above it is a punch thrown over one's own head).
constexpr double kElbowBelowHead_m = 0.03;
/// A punch whose target lies at least this share of the arm's length from the shoulder lands
/// with the arm (nearly) straight: its elbow lies on the line to the target.
constexpr double kStraightArmShare = 0.9;
/// Times keep_elbow_below_head lowers the aim by the planned elbow's height over the head and
/// plans again (each pass one decode and one AdaptJob at the strike's start).
constexpr int kElbowAimPasses = 3;
/// m: a strike planned anew after stepping in that falls this far short as extended as
/// captured is replaced by the strike the fighter stepped in for, where that one falls
/// shorter. The grid's 66 new plans after a step-in fell short by up to 0.28 m (p50 0.04) and
/// all reached with the straight limb and the lean; the bout's that missed by 0.33 m, 0.55.
constexpr double kReplanShortfall_m = 0.3;
/// A strike planned to land no more extended than min_strike_extension + this steps back: the
/// frames draw the limb a little off the plan (bruno's 135_06 punch planned at 0.502 of the
/// arm landed at 0.499, the wrist behind the elbow).
constexpr double kExtensionPlanMargin = 0.02;
/// rad: a stance step is taken only while the fighter faces the visitor within this (else it
/// turns first, following with procedural steps meanwhile).
constexpr double kStanceStepOffAxis_rad = 0.35;
/// m: how far the drawn head stands ahead of the root toward the visitor in the guard stance
/// (the spar demo's median at the visitor's strikes, steps off): sparring, the fighting distance
/// is kept from the head less this.
constexpr double kSparHeadLead_m = 0.08;
/// s: the spot's speed (the visitor walking) is smoothed over about this.
constexpr double kGoalSpeedSmoothing_s = 0.15;
/// m/s: below this the visitor has stopped walking toward or away (a forward stance step may go).
constexpr double kSettledGoalSpeed_mps = 0.25;
/// m (at the database actor's size): a spot this far ahead is stepped to while the visitor
/// still walks away (the stance steps travel 0.77-1.05 m in the mocap).
constexpr double kWholeStep_m = 0.9;
/// rad/s: the most a drawn knee turns about its leg's hip->ankle axis (AdaptJob::
/// max_knee_swivel_rad). A knee the motion swings round faster (its direction passing through
/// the leg's axis where a held foot keeps the ankle far from the motion's) goes round the side
/// over frames instead of flipping in one.
constexpr double kKneeSwivel_rad_s = 12;
/// s: a stance step due waits at most this for both feet to be down (then procedural steps).
constexpr double kStanceStepFeetWait_s = 0.5;
/// s: a visitor who comes closer is stepped back from with a stance step only once the spot to
/// keep has lain behind the fighter this long; before, procedural steps follow. A lunge punch
/// carries the visitor's head 0.3-0.5 m in and back within about this: a stance step back
/// (0.6-1 m, and no block while it plays) answered every lunge of the boxer and let the fists
/// after it through.
constexpr double kBackStepAfter_s = 0.5;
// m/s^2: the spot's acceleration while following (starting and stopping), and m/s: the most
// speed it arrives with, where updates are coarse (update_follow, kCoarseUpdate_s).
constexpr double kFollowAccel_mps2 = 12;
constexpr double kFollowArriveSpeed_mps = 0.25;
}  // namespace

namespace {
std::size_t most_joints_of(const std::vector<Rig>& characters) {
  std::size_t most = 0;
  for (const Rig& r : characters) most = std::max(most, static_cast<std::size_t>(r.joint_count()));
  return most;
}

/// The pose `player` will compose at segment time `at_time_s` of its current source (the same
/// sources, the blend `blend_time_s` s long as far on as the update that plays that time):
/// `cur_pose` the current source's alone, `pose` the blend.
void compose_ahead(const MotionPlayer& player, double at_time_s, double blend_time_s, MkmFrame& cur_pose, MkmFrame& pose) {
  const double ahead = at_time_s - player.current().time_s;  // segment seconds
  const double ahead_wall = ahead / player.current().rate;   // s
  PlaybackSource cur = player.current(), prev = player.previous();
  cur.time_s += ahead;
  prev.time_s += ahead_wall * prev.rate;
  player.compose(cur, prev, player.blend_elapsed_s() + ahead_wall, blend_time_s, cur_pose, pose);
}
}  // namespace

// ---- Behaviour --------------------------------------------------------------------------

Behaviour::Behaviour(std::shared_ptr<const Database> db, std::vector<Rig> characters, const FighterConfig& config)
    : db_(std::move(db)), block_planner_(std::make_shared<StrikePlanner>(db_, config.retrieval)),
      characters_(std::move(characters)), config_(config), tun_(config.behaviour), player_(db_, 1.0), feet_(db_, config.behaviour),
      switch_(most_joints_of(characters_), config.behaviour.blend_time_s) {
  validate(config.behaviour, config.retrieval);
  if (characters_.empty()) throw Error("fighter", "config", "no characters to show");
  if (db_->segments.empty()) throw Error("fighter", "database", "the motion database has no segments");
  character_ = std::clamp(config.initial_character, 0, character_count() - 1);
  player_.rescale(stride_scale());  // (nothing plays yet: the scale only)
  rest_segment_ = find_segment(*db_, SegmentKind::rest).value_or(0);
  {
    const MotionSegment& rest = db_->segments[static_cast<std::size_t>(rest_segment_)];
    for (std::size_t i = 0; i < db_->segments.size(); ++i) {
      const MotionSegment& s = db_->segments[i];
      if (s.kind == SegmentKind::walk && s.frame_count() > 1) walk_segments_.push_back(static_cast<int>(i));
      if (mirrored_rest_segment_ < 0 && rest.kind == SegmentKind::rest && s.kind == SegmentKind::rest &&
          s.mirrored != rest.mirrored && s.source_clip == rest.source_clip && s.source_first_frame == rest.source_first_frame &&
          s.frame_count() == rest.frame_count())
        mirrored_rest_segment_ = static_cast<int>(i);
    }
  }
  std::size_t max_joints = 0;
  for (const Rig& r : characters_) max_joints = std::max(max_joints, static_cast<std::size_t>(r.joint_count()));
  local_.resize(max_joints);
  global_.resize(max_joints);
  rig_positions_.resize(max_joints);
  previous_rig_positions_.resize(max_joints);
  positions_.resize(max_joints);
  // Orders swap between these two each update; an order taken again after stepping in is
  // queued from inside update(): room kept in both, so that allocates nothing.
  orders_.reserve(16);
  taking_.reserve(16);
  spot_xz_m_ = {config.home.x(), config.home.z()};
  follow_distance_m_ = config.strike_distance_m;
  facing_rad_ = 0;
  use_synchronous_planner(std::make_shared<StrikePlanner>(db_, config.retrieval));
  sync_rate_solver_ = std::make_shared<StrikeRateSolver>(db_, tun_);
  rate_channel_.submit = [this](const StrikeRateJob& job) { sync_rate_result_ = sync_rate_solver_->solve(job); };
  rate_channel_.poll = [this] { return std::exchange(sync_rate_result_, std::nullopt); };
  start_rest(0);
  player_.end_blend();
}

void Behaviour::set_planner(PlanChannel channel) { plan_channel_ = std::move(channel); }

void Behaviour::use_synchronous_planner(std::shared_ptr<const StrikePlanner> planner) {
  sync_planner_ = std::move(planner);
  plan_channel_.submit = [this](const StrikeRequest& r) { sync_results_.push_back(sync_planner_->plan(r)); };
  plan_channel_.poll = [this]() -> std::optional<StrikePlan> {
    if (sync_results_.empty()) return std::nullopt;
    StrikePlan p = sync_results_.front();
    sync_results_.pop_front();
    return p;
  };
}

void Behaviour::set_rate_solver(RateChannel channel) { rate_channel_ = std::move(channel); }

bool Behaviour::strike_pending() const { return pending() || approach() || support_step() || retaking(); }

void Behaviour::order(const Order& o) { orders_.push_back({o, std::nullopt}); }
void Behaviour::keep_away(bool on) { keep_away_ = on; }
void Behaviour::order_strike(const Order& o, const Vector3d& target) { orders_.push_back({o, target}); }

void Behaviour::enter(Action next) {
  // The action state's transitions (behaviour.hpp, action_; content/README.md, "Action
  // states"): [from][to] in the variant's order Idle, AwaitingPlan, Approaching,
  // SupportStepping, Retaking, Striking, Recovering. Anything else is a bug.
  // A block (Striking, strike_.block) may start from any alternative before a strike: the
  // strike order under way is dropped for it.
  static constexpr bool kAllowed[7][7] = {
      {false, true, false, false, false, true, false},   // Idle -> AwaitingPlan (a strike order taken), Striking (a block)
      {true, false, true, true, true, true, false},      // AwaitingPlan -> its plan's outcome (or a block)
      {false, false, false, false, true, true, false},   // Approaching -> Retaking (stepped), Striking (a block)
      {false, false, false, false, true, true, false},   // SupportStepping -> Retaking (foot set), Striking (a block)
      {true, false, false, false, false, true, false},   // Retaking -> Idle (taken: then as a new order), Striking (a block)
      {false, false, false, false, false, false, true},  // Striking -> Recovering (the clip ends)
      {true, false, false, false, false, false, false},  // Recovering -> Idle (blended, d(t) released)
  };
  [[maybe_unused]] const bool allowed = kAllowed[action_.index()][next.index()];
  assert(allowed);
  action_ = std::move(next);
  strike_.active = striking() || recovering();
}

const Behaviour::Locomotion* Behaviour::locomotion() const {
  return std::visit(
      [](const auto& a) -> const Locomotion* {
        if constexpr (requires { a.loco; }) return &a.loco;
        else return nullptr;
      },
      action_);
}

void Behaviour::set_locomotion(Locomotion loco) {
  std::visit(
      [&](auto& a) {
        if constexpr (requires { a.loco; }) a.loco = loco;
      },
      action_);
}

double Behaviour::stance_step_min_m() const {
  if (stance_step_min_m_ < 0) return tun_.stance_step_min_m;
  return stance_step_min_m_ > 0 ? std::max(stance_step_min_m_, tun_.follow_tolerance_m) : 0.0;
}

const Behaviour::StanceStep* Behaviour::stance_step() const {
  const Locomotion* l = locomotion();
  const StanceStepping* s = l ? std::get_if<StanceStepping>(l) : nullptr;
  return s ? &s->step : nullptr;
}

FighterAction Behaviour::action() const {
  struct Of {
    FighterAction operator()(const Idle&) const { return FighterAction::idle; }
    FighterAction operator()(const AwaitingPlan&) const { return FighterAction::awaiting_plan; }
    FighterAction operator()(const Approaching& a) const {
      switch (a.approach.kind) {
        case Approach::Kind::step_in: return FighterAction::stepping_in;
        case Approach::Kind::step_back: return FighterAction::stepping_back;
        case Approach::Kind::restance: return FighterAction::restance;
      }
      return FighterAction::stepping_in;
    }
    FighterAction operator()(const SupportStepping&) const { return FighterAction::support_step; }
    FighterAction operator()(const Retaking&) const { return FighterAction::retaking; }
    FighterAction operator()(const Striking&) const { return FighterAction::striking; }
    FighterAction operator()(const Recovering&) const { return FighterAction::recovering; }
  };
  if ((striking() && strike_.block) || parrying()) return FighterAction::blocking;
  return std::visit(Of{}, action_);
}

FighterLocomotion Behaviour::locomotion_kind() const {
  const Locomotion* l = locomotion();
  if (!l || std::holds_alternative<AtSpot>(*l)) return FighterLocomotion::at_spot;
  return std::holds_alternative<Walking>(*l) ? FighterLocomotion::walking : FighterLocomotion::stance_step;
}

FighterState Behaviour::state() const {
  if (striking()) return FighterState::striking;
  if (recovering()) return FighterState::recovering;
  return std::holds_alternative<AtSpot>(*locomotion()) ? FighterState::resting : FighterState::following;
}

FighterEvent& Behaviour::emit(FighterEvent::Kind kind, Timestamp t, const Order& o, FighterEvent::Reason reason,
                              double distance) {
  FighterEvent e;
  e.time = t;
  e.kind = kind;
  e.order = o;
  e.reason = reason;
  e.distance_m = distance;
  events_.push_back(e);
  return events_.back();
}

std::string Behaviour::describe(const FighterEvent& event) const {
  return content::describe(
      event,
      [&](int s) {
        return s >= 0 && s < static_cast<int>(db_->segments.size()) ? db_->segments[static_cast<std::size_t>(s)].name
                                                                     : std::string("?");
      },
      [&](int c) {
        return c >= 0 && c < character_count() ? characters_[static_cast<std::size_t>(c)].name : std::string("?");
      });
}

std::vector<FighterEvent> Behaviour::take_events() {
  std::vector<FighterEvent> out;
  out.swap(events_);
  return out;
}

void Behaviour::select_character(int index, Timestamp now) {
  if (index < 0 || index >= character_count()) {
    emit(FighterEvent::Kind::warning, now, Order{now, OrderKind::select_character, index},
         FighterEvent::Reason::no_such_character)
        .character_count = character_count();
    return;
  }
  if (index == character_) return;
  // Keep the root where it is under the new stride scale (the player re-bases each source's
  // origin; the arms' drawn poles were measured on the old body).
  character_ = index;
  player_.rescale(stride_scale());
  // The feet on the floor stay where they stand (the easing hides the rest of the change):
  // re-planted on the new legs, a lunge's held back foot came out of the new legs' reach as
  // the pelvis drop carried over was let go, and stepped with the other foot in the air (the
  // knee 5 cm, the elbow 9 cm in a frame, in the bout with stance steps on).
  feet_.keep_held_only();
  switch_.begin();  // the easing's offsets: after this update's decode
  if (striking()) {
    strike_.switched_body = true;
    compute_reach_error(strike_.contact_time_s);
    // A punch keeps the new body's elbow under its head too (aiko's head-height punch switched
    // to mei 0.23 s before contact reached full stretch with mei's elbow over her head).
    if (!strike_.effector.leg && !strike_.block) keep_elbow_below_head();
  }
  emit(FighterEvent::Kind::character_changed, now, Order{now, OrderKind::select_character, index},
       FighterEvent::Reason::none);
}

bool Behaviour::deferred(const QueuedOrder& queued) const {
  // A strike ordered while the last one still hands its reach offset back (recovering) waits
  // for that (at most release_time_s): starting now would drop the offset in one frame. So
  // does one ordered while a stance step blends in or out (a strike started mid-blend would
  // drop the motion it blends from in one frame), and one taken again after a stance step
  // while that step plays.
  return effector_of(queued.order.kind) &&
         (recovering() || (queued.after_stance_step && stance_step()) || (!striking() && player_.blend_elapsed_s() < tun_.blend_time_s));
}

void Behaviour::handle_orders(Timestamp now, const Vector3d& head) {
  // An order taken again after a step comes first (it was given before any still queued).
  if (const Retaking* r = as<Retaking>(); r && !deferred(r->order)) {
    const QueuedOrder again = r->order;
    enter(Idle{r->loco});
    take_order(again, now, head);
  }
  // Both queues keep their room from update to update: taking orders allocates nothing.
  taking_.swap(orders_);
  orders_.clear();
  for (const QueuedOrder& queued : taking_) {
    if (deferred(queued)) {
      orders_.push_back(queued);  // in order
      continue;
    }
    take_order(queued, now, head);
  }
  taking_.clear();
}

void Behaviour::take_order(const QueuedOrder& queued, Timestamp now, const Vector3d& head) {
  const Order& o = queued.order;
  const std::optional<Vector3d>& explicit_target = queued.target_room_m;
  switch (o.kind) {
    case OrderKind::select_character: select_character(o.character, now); return;
    case OrderKind::pause: paused_ = true; emit(FighterEvent::Kind::order_accepted, now, o, FighterEvent::Reason::paused); return;
    case OrderKind::resume: paused_ = false; emit(FighterEvent::Kind::order_accepted, now, o, FighterEvent::Reason::resumed); return;
    case OrderKind::recentre:
      recentre_goal_ = Vector2d(config_.home.x(), config_.home.z());
      emit(FighterEvent::Kind::order_accepted, now, o, FighterEvent::Reason::recentre);
      return;
    case OrderKind::spar:
    case OrderKind::orders_only:  // the planner's mode (Fighter::order applies it): said here, in order
      emit(FighterEvent::Kind::order_accepted, now, o, FighterEvent::Reason::none);
      return;
    default: break;
  }
  const auto eff = effector_of(o.kind);
  if (!as<Idle>()) {
    emit(FighterEvent::Kind::order_ignored, now, o, FighterEvent::Reason::mid_strike);  // the event names the order
    return;
  }
  if (paused_) {
    emit(FighterEvent::Kind::order_ignored, now, o, FighterEvent::Reason::paused);
    return;
  }
  if (keep_away_) {
    emit(FighterEvent::Kind::order_ignored, now, o, FighterEvent::Reason::near_wall);
    return;
  }
  // Freeze the target now: the visitor's head (punches) or below it (kicks: the torso).
  Vector3d target = explicit_target.value_or(head);
  if (!explicit_target && eff->leg) target.y() -= tun_.kick_target_drop_m;
  if (!eff->leg) {
    // A head the arm cannot reach (a visitor much taller than the character): aim at the
    // highest point the arm reaches at max_punch_aim_deg from a standing shoulder, on the
    // visitor's neck and chest below the head (still the visitor's body).
    const Rig& rig = characters_[static_cast<std::size_t>(character_)];
    const CJ shoulder = eff->side == kLeft ? CJ::l_shoulder : CJ::r_shoulder;
    const double top = at(rig.rest_pose, shoulder).y() - rest_floor_y(rig) + aim_rise_m(rig, eff->side, tun_.max_punch_aim_deg);
    if (target.y() > top) target.y() = top;
  }
  StrikeRequest r;
  r.id = next_request_++;
  r.group = group_of(*eff);
  r.now = pose_;
  r.before = have_pose_ ? pose_before_ : pose_;
  r.dt_s = last_dt_;
  r.target_local_m = ground().to_local(target);
  r.character_leg_length_m = characters_[static_cast<std::size_t>(character_)].morphology.leg_length_m;
  enter(AwaitingPlan{PendingStrike{r.id, o, target, queued.stepped_first, queued.support_stepped, queued.plan},
                     as<Idle>()->loco});
  // Taken again after stepping in (or a kick's support step): accepted already.
  if (!queued.stepped_first && !queued.support_stepped && !queued.after_stance_step) emit(FighterEvent::Kind::order_accepted, now, o, FighterEvent::Reason::strike).target = target;
  plan_channel_.submit(r);
}

const Vector3d* Behaviour::step_target() const {
  if (const SupportStep* s = support_step()) return &s->target_room_m;
  if (const Approach* a = approach()) return &a->target_room_m;
  return nullptr;
}

std::array<bool, 2> Behaviour::feet_locked() const { return {feet_.held(kLeft), feet_.held(kRight)}; }

HeldFeet Behaviour::held_feet() const {
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  HeldFeet f;
  for (int side = 0; side < 2; ++side) {
    f.held[static_cast<std::size_t>(side)] = feet_.held(side);
    f.stepping[static_cast<std::size_t>(side)] = feet_.step_end(side) != nullptr;
    if (const Vector3d* end = feet_.step_end(side)) f.step_end_m[static_cast<std::size_t>(side)] = *end;
    f.ankle_m[static_cast<std::size_t>(side)] =
        rig_positions_[static_cast<std::size_t>(rig.skeleton.index(side == kLeft ? CJ::l_ankle : CJ::r_ankle))];
  }
  return f;
}

Behaviour::Source Behaviour::strike_source(const StrikePlan& plan, StrikeFit& fit) const {
  return strike_source(plan, fit, pose_, held_feet());
}

Behaviour::Source Behaviour::strike_source(const StrikePlan& plan, StrikeFit& fit, const MkmFrame& from,
                                           const HeldFeet& feet) const {
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(plan.segment)];
  const GroundFrame g_char = ground_frame_of(from);
  const GroundFrame g_clip = ground_frame_of(seg.frames[static_cast<std::size_t>(plan.start_frame)]);
  Source s;
  s.segment = plan.segment;
  s.time_s = plan.start_frame * seg.frame_time_s;
  s.placement.origin_xz = g_char.origin_xz;
  s.placement.yaw_rad = wrap(g_char.yaw_rad - g_clip.yaw_rad);
  s.anchor_xz_m = g_clip.origin_xz;
  StrikePlacement in;
  in.db = db_.get();
  in.player = &player_;
  in.rig = &characters_[static_cast<std::size_t>(character_)];
  in.tunables = &tun_;
  in.target_m = strike_target_ ? &*strike_target_ : nullptr;
  in.feet = &feet;
  in.scratch = &scratch_pose_;
  StrikeFit redirect;
  const int landing_support = align_to_support_foot(in, s, plan.contact_frame * seg.frame_time_s, &redirect);
  // A foot in a procedural step that the strike stands on (put down where it is, or its step
  // sent to where the clip has it) holds the lunge back as a held one does (place_strike_travel):
  // not counted, the lunge was scaled as if that foot would follow and left it out of the leg's
  // reach (kenji's 135_06_punch_left_3 from frame 24 at 11.58 s of the scripted bout: the foot
  // stepped again under the lunge while the other swung, and the knee snapped as it landed).
  HeldFeet travel_feet = feet;
  if (landing_support >= 0) travel_feet.held[static_cast<std::size_t>(landing_support)] = true;
  if (redirect.redirect_support >= 0) {
    travel_feet.held[static_cast<std::size_t>(redirect.redirect_support)] = true;
    travel_feet.ankle_m[static_cast<std::size_t>(redirect.redirect_support)] = redirect.redirect_to_m;
  }
  in.feet = &travel_feet;
  fit = place_strike_travel(in, s, plan.contact_frame * seg.frame_time_s);
  fit.landing_support = landing_support;
  fit.redirect_support = redirect.redirect_support;
  fit.redirect_to_m = redirect.redirect_to_m;
  return s;
}

double Behaviour::step_wanted(const StrikeFit& fit) const {
  if (tun_.max_step_in_m > 0 && fit.shortfall_m >= tun_.step_in_min_m) return fit.shortfall_m;
  if (tun_.max_step_back_m > 0 && fit.extension < tun_.min_strike_extension + kExtensionPlanMargin && fit.too_near_m >= tun_.step_in_min_m)
    return -fit.too_near_m;
  return 0;
}

std::optional<Behaviour::Restance> Behaviour::restance_for(const PendingStrike& pending, const StrikePlan& plan, double step_m) const {
  // Only from a stance a stance step left (its take's own rest: a long kata stance, 0.7 m
  // from foot to foot): a lunge placed on its back foot is held short by it, and the step-in
  // keeps the stance (content/README, "Following with stance steps"). The rest stances the
  // strikes are made for are taken instead on the way: the rest (or its mirror) placed at the
  // spot facing the target, each foot stepped to where it has it.
  if (!player_.current().loop || player_.current().segment == rest_segment_ || player_.current().segment == mirrored_rest_segment_)
    return std::nullopt;
  const Vector3d& target = pending.target_room_m;
  Vector2d dir(target.x() - spot_xz_m_.x(), target.z() - spot_xz_m_.y());
  if (dir.norm() < 1e-6) return std::nullopt;
  dir.normalize();
  const double face = std::atan2(dir.x(), dir.y());
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  std::optional<Restance> best;
  double best_cost = std::abs(step_m) - tun_.step_in_min_m;
  for (const int rest : {rest_segment_, mirrored_rest_segment_}) {
    if (rest < 0) continue;
    GroundFrame at_spot;
    at_spot.origin_xz = spot_xz_m_;
    at_spot.yaw_rad = face;
    MkmFrame f;
    player_.sample(placed_at(db_->segments[static_cast<std::size_t>(rest)], rest, at_spot), f);
    HeldFeet feet;
    for (int side = 0; side < 2; ++side) {
      feet.held[static_cast<std::size_t>(side)] = true;
      feet.ankle_m[static_cast<std::size_t>(side)] = mkm_ankle(rig, f, side);
    }
    StrikeFit fit;
    (void)strike_source(plan, fit, f, feet);
    const double step = step_wanted(fit);
    // The spot moves by that step as a step-in would (within the area); what it cannot move
    // is left short.
    const Vector2d goal = clamp_to_area(config_, spot_xz_m_ + dir * std::clamp(step, -tun_.max_step_back_m, tun_.max_step_in_m));
    const double cost = std::abs(step - (goal - spot_xz_m_).dot(dir));
    if (cost < best_cost) {
      best_cost = cost;
      best = Restance{rest, goal, step};
    }
  }
  return best;
}

void Behaviour::begin_restance(const PendingStrike& pending, const StrikePlan& plan, const Restance& r, Timestamp now) {
  const Vector3d& target = pending.target_room_m;
  const Vector2d to_target(target.x() - spot_xz_m_.x(), target.z() - spot_xz_m_.y());
  const bool back = (r.goal_xz - spot_xz_m_).dot(to_target) < 0;
  start_rest(now, r.rest);
  enter(Approaching{Approach{pending.order, target, r.goal_xz, 0, 0, plan, Approach::Kind::restance}, as<AwaitingPlan>()->loco});
  FighterEvent& e = emit(back ? FighterEvent::Kind::stepping_back : FighterEvent::Kind::stepping_in, now, pending.order,
                         FighterEvent::Reason::restance, (r.goal_xz - spot_xz_m_).norm());
  e.target = target;
}

bool Behaviour::begin_step_in(const PendingStrike& pending, const StrikePlan& plan, double step_m, Timestamp now) {
  // Toward the target by the distance missing (or away from it by the distance too near); at
  // least far enough that the feet step (a body moved over feet that stay would meet the same
  // limit), at most max_step_in_m (max_step_back_m), and never out of the fighter's area
  // ([fighter] min/max x/z): where that leaves less than step_in_min_m to gain, the strike
  // goes ahead from here (false).
  const Vector3d& target = pending.target_room_m;
  Vector2d dir(target.x() - spot_xz_m_.x(), target.z() - spot_xz_m_.y());
  const double apart = dir.norm();
  if (apart < 1e-9) return false;
  dir.normalize();
  const bool back = step_m < 0;
  if (back) dir = -dir;
  // (back: at least to the distance the fighter keeps from the visitor, strike_distance_m: a
  // visitor standing inside the fighter's stance is not answered by a half step, whose feet
  // the strike, placed by its support foot, would land on nearly as near)
  const double wanted = back ? std::max(-step_m, config_.strike_distance_m - apart) : step_m;
  const double d = std::min(std::max(wanted, feet_.tunables().step_threshold_m + 0.02),
                            back ? tun_.max_step_back_m : tun_.max_step_in_m);
  const Vector2d goal = clamp_to_area(config_, spot_xz_m_ + dir * d);
  if ((goal - spot_xz_m_).dot(dir) < tun_.step_in_min_m) return false;
  enter(Approaching{Approach{pending.order, target, goal, 0, 0, plan, back ? Approach::Kind::step_back : Approach::Kind::step_in},
                    as<AwaitingPlan>()->loco});
  FighterEvent& e = emit(back ? FighterEvent::Kind::stepping_back : FighterEvent::Kind::stepping_in, now, pending.order,
                         FighterEvent::Reason::none, (goal - spot_xz_m_).norm());
  e.target = target;
  return true;
}

void Behaviour::update_step_in(double dt) {
  // Stepped in once the spot is reached and both feet stand where they should (each step
  // done); a fighter turning to follow a moving visitor may keep stepping, so after
  // kSettle_s at the spot both feet on the floor will do, and after kStepInWait_s anything:
  // the order is taken again, with its frozen target, as if just given (it does not step in
  // or back twice).
  constexpr double kStepInWait_s = 1.5, kSettle_s = 0.15;
  Approaching* ap = as<Approaching>();
  if (!ap) return;
  Approach& a = ap->approach;
  const bool restance = a.kind == Approach::Kind::restance;
  a.elapsed_s += dt;
  // (a rest stance taken on the way: once it has blended in, the feet may want to step)
  const bool at_spot = state() == FighterState::resting && (spot_xz_m_ - a.goal_xz).norm() <= tun_.arrive_tolerance_m &&
                       (!restance || player_.blend_elapsed_s() >= tun_.blend_time_s);
  a.at_spot_s = at_spot ? a.at_spot_s + dt : 0;
  // (a rest stance taken on the way: both feet where it has them)
  const bool arrived = at_spot && ((feet_.settled(kLeft) && feet_.settled(kRight)) ||
                                   (!restance && a.at_spot_s >= kSettle_s && feet_.held(kLeft) && feet_.held(kRight)));
  if (!arrived && a.elapsed_s < kStepInWait_s) return;
  enter(Retaking{QueuedOrder{a.order, a.target_room_m, true, false, a.plan}, ap->loco});
}

bool Behaviour::begin_support_step(const PendingStrike& pending, const StrikePlan& plan, const Source& source, Timestamp now) {
  // A kick's support foot is the other foot. Where the clip, placed as it will be played, has
  // that foot down first from the strike's start (the start itself, or where the clip sets it
  // down a few frames in: a kick from a step) -- if that is more than kick_support_step_m
  // from where the foot is held, the foot steps there first, at a procedural step's pace, while
  // the kicking foot stands. Otherwise the leg would lose the held foot as the kick rises and
  // the foot would be stepped with the kicking foot in the air (a hop), or carried faster than
  // the clip's own foot. A punch likewise on the foot its clip stands on (punch_support_step_m):
  // in the 120-order sweep, lunges started while their back foot was still in a procedural step
  // had both feet off the floor where the mocap stands on one.
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(plan.segment)];
  const auto eff = seg.effector();
  if (!eff) return false;
  const double threshold = eff->leg ? tun_.kick_support_step_m : tun_.punch_support_step_m;
  if (threshold <= 0) return false;
  // The clip's frames from the strike's start to its contact.
  const int first = std::clamp(plan.start_frame, 0, seg.frame_count() - 1);
  const int last = std::clamp(plan.contact_frame, first, seg.frame_count() - 1);
  int side = 1 - eff->side;
  if (!eff->leg) {
    // A punch's support foot: the one its clip keeps down longest from its start (a lunge's
    // back foot), down at the start itself.
    const std::array<int, 2> down{planted_run(seg, kLeft, first, last), planted_run(seg, kRight, first, last)};
    if (down[0] == 0 && down[1] == 0) return false;
    // Both down to contact (no lunge): no foot lifts with the other in the air, so the punch
    // starts at once (a foot still stepping lands where start_strike puts it).
    if (down[0] == down[1]) return false;
    side = down[0] > down[1] ? 0 : 1;
  }
  const int other = 1 - side;  // (a kick's kicking foot)
  // (A kick planned with a foot still stepping starts from where that step lands. After a
  // step-in that arrived, none is: no step begins while a strike is planned (update_feet);
  // one that gave up waiting, kStepInWait_s, may still leave one stepping.)
  // A support foot in a procedural step of its own (it lagged, and stepped the update the plan
  // came back) has that step sent on to where the strike stands on it, and the strike waits for
  // it to land: started, the kick lifted its foot with the support foot still in the air, and the
  // support foot's step went on to its old target 0.39 m from where the clip has it, out of the
  // leg's reach (bruno's HDM_bk_010 kick at 15.0 s of the scripted bout: both feet off 14 frames).
  const bool stepping = feet_.step_end(side) != nullptr;
  if ((!feet_.held(side) && !stepping) || !feet_.held(other)) return false;
  int k = first;
  while (k < last && !clip_planted(seg, k, side)) ++k;
  if (!clip_planted(seg, k, side)) return false;
  Source at_down = source;
  at_down.time_s = k * seg.frame_time_s;
  MkmFrame placed;
  player_.sample(at_down, placed);
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  CanonicalPose& c = scratch_pose_;
  decode_canonical(rig, placed, c);
  const CJ ankle = side == kLeft ? CJ::l_ankle : CJ::r_ankle;
  const Vector3d held = stepping ? *feet_.step_end(side) : rig_positions_[static_cast<std::size_t>(rig.skeleton.index(ankle))];
  const Vector3d goal(at(c, ankle).x(), held.y(), at(c, ankle).z());
  if (stepping) {
    if (!feet_.redirect(side, goal, kRedirectPeakSpeed_mps)) return false;
  } else {
    if (Vector2d(goal.x() - held.x(), goal.z() - held.z()).norm() <= threshold) return false;
    if (!feet_.step_to(side, goal)) return false;
  }
  enter(SupportStepping{SupportStep{pending.order, pending.target_room_m, pending.stepped_first, side, 0}, as<AwaitingPlan>()->loco});
  FighterEvent& e = emit(FighterEvent::Kind::support_step, now, pending.order, FighterEvent::Reason::none,
                         Vector2d(goal.x() - held.x(), goal.z() - held.z()).norm());
  e.target = pending.target_room_m;
  e.side = side;
  return true;
}

void Behaviour::update_support_step(double dt) {
  // Done when the foot is down again (the step's own time), or after kWait_s in any case: the
  // order is then taken again with its frozen target, as if just given (no second support step).
  constexpr double kWait_s = 1.0;
  SupportStepping* ss = as<SupportStepping>();
  if (!ss) return;
  SupportStep& st = ss->step;
  st.elapsed_s += dt;
  if (!feet_.held(st.side) && st.elapsed_s < kWait_s) return;
  enter(Retaking{QueuedOrder{st.order, st.target_room_m, st.stepped_first, true}, ss->loco});
}

void Behaviour::start_strike(const PendingStrike& pending, const StrikePlan& plan, const Source& source, const StrikeFit& fit, Timestamp now, double dt) {
  const int landing_support = fit.landing_support;
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(plan.segment)];
  player_.play(source);  // (a strike ordered mid-step starts from the step)
  // The foot the clip is aligned on where it comes down: a procedural step it is in ends here
  // (down where it is), not at its old target while the clip stands on it.
  if (landing_support >= 0) feet_.land(landing_support);
  // ...or, too far from it for the clip to be carried there, goes on to where the clip has it.
  if (fit.redirect_support >= 0) feet_.redirect(fit.redirect_support, fit.redirect_to_m, kRedirectPeakSpeed_mps);
  strike_ = StrikeInfo{};
  strike_.order = pending.order;
  strike_.target_room_m = pending.target_room_m;
  strike_.plan = plan;
  strike_.effector = *seg.effector();
  strike_.start_time_s = plan.start_frame * seg.frame_time_s;
  strike_.clip_contact_time_s = plan.contact_frame * seg.frame_time_s;
  strike_.contact_time_s = contact_frame_time(player_.current().time_s, strike_.clip_contact_time_s, dt * player_.current().rate);
  strike_.end_time_s = (seg.frame_count() - 1) * seg.frame_time_s;
  strike_.release_end_s = release_end_s(strike_.contact_time_s);
  strike_.start_update = updates_;
  enter(Striking{});  // (a stance step under way ends here)
  if (!strike_.effector.leg) strike_.plan_feet = feet_through_contact(player_.current(), strike_.contact_time_s);
  compute_reach_error(strike_.contact_time_s);
  if (!strike_.effector.leg) keep_elbow_below_head();
  // A correction that lengthens the hit point's way plays the strike slower. Finding how much
  // slower decodes the whole way (~0.2-0.3 ms): it is a job for the solver (the Fighter's
  // worker thread), applied kStrikeRateDelayUpdates updates from now (apply_strike_rate()).
  if (tun_.min_strike_rate < 1) {
    StrikeRateJob job;
    job.id = next_rate_job_++;
    job.rig = &characters_[static_cast<std::size_t>(character_)];
    job.stride_scale = stride_scale();
    job.current = player_.current();
    job.previous = player_.previous();
    job.blend_elapsed_s = player_.blend_elapsed_s();
    job.lead_s = kStrikeRateDelayUpdates * std::max(0.0, dt);
    job.effector = strike_.effector;
    job.start_time_s = strike_.start_time_s;
    job.contact_time_s = strike_.contact_time_s;
    job.clip_contact_time_s = strike_.clip_contact_time_s;
    job.frame_dt_s = std::max(0.0, dt);
    job.release_end_s = strike_.release_end_s;
    job.turn = strike_.turn;
    job.stretch = strike_.stretch;
    job.target_room_m = strike_.target_room_m;
    job.plan_feet = strike_.plan_feet;
    job.plan_lowest_shoulder_y_m = lowest_shoulder_y_m();
    job.pole_turns = player_.pole_turns();
    as<Striking>()->rate = PendingRate{job.id, updates_ + kStrikeRateDelayUpdates, plan.segment, character_};
    rate_channel_.submit(job);
  }
  (void)now;
}

void Behaviour::apply_strike_rate(double dt) {
  // The rate found for this strike (a late solver is waited for: the update it enters on
  // depends on the inputs alone). The blend into the strike eases the change of rate in;
  // then d(t) and its release are those at that rate: d(t) as the solver found it from this
  // update's state (the same operations compute_reach_error() does here, so the same
  // numbers), unless the character changed since the strike started.
  std::optional<PendingRate>& rate = as<Striking>()->rate;
  const PendingRate due = *rate;
  rate.reset();
  const std::optional<StrikeRateResult> r = rate_channel_.poll();
  if (!r || r->id != due.job || !(r->rate > 0) || r->rate >= 1) return;
  if (strike_.contact_done || player_.current().segment != due.segment) return;
  player_.set_rate(r->rate);
  strike_.rate = r->rate;
  strike_.rate_update = updates_;
  strike_.rate_lead_updates = updates_ - strike_.start_update;
  strike_.contact_time_s = contact_frame_time(player_.current().time_s, strike_.clip_contact_time_s, dt * player_.current().rate);
  strike_.release_end_s = release_end_s(strike_.contact_time_s);
  if (r->has_reach && character_ == due.character) {
    strike_.error_m = r->error_m;
    strike_.turn = r->turn;
    strike_.stretch = r->stretch;
    strike_.lean = r->lean;
    strike_.plan_drop_m = r->root_drop_m;
    strike_.plan_elbow_under_head_m = r->elbow_under_head_m;
    // (The solver's d(t) is found at contact alone, as compute_reach_error's; after a switch the
    // way there is held to the lockout too: taken as found, a rate solved after the switch put
    // the stretch back from 1.01 to 1.30 in one update, the knee 9 cm.)
    if (strike_.switched_body) cap_kick_stretch_over_way(strike_.contact_time_s);
  } else {
    compute_reach_error(strike_.contact_time_s);
  }
}

double Behaviour::ramp_in(double t) const { return reach_ramp_in(strike_.start_time_s, strike_.contact_time_s, t); }

double Behaviour::ramp_out(double t) const {
  return reach_ramp_out(strike_.contact_time_s + strike_.hold_s, strike_.release_end_s, t);
}

double Behaviour::pin_drop_max_m() const {
  if (strike_.effector.leg || strike_.block || !std::isfinite(strike_.plan_drop_m) || !std::isfinite(strike_.plan_elbow_under_head_m))
    return std::numeric_limits<double>::infinity();
  return strike_.plan_drop_m + std::max(0.0, strike_.plan_elbow_under_head_m - kElbowBelowHead_m);
}

void Behaviour::correction_at(double t, Eigen::Quaterniond& turn, double& stretch) const {
  turn = strike_.turn;
  stretch = strike_.stretch;
  if (strike_.reaim_from_s < 0 || t >= strike_.reaim_to_s) return;
  // A block re-aimed on its way: from the old correction to the new one (reaim_block).
  const double u = min_jerk((t - strike_.reaim_from_s) / std::max(1e-6, strike_.reaim_to_s - strike_.reaim_from_s));
  turn = strike_.reaim_turn_from.slerp(u, strike_.turn);
  stretch = strike_.reaim_stretch_from + u * (strike_.stretch - strike_.reaim_stretch_from);
}

ReachGoal Behaviour::reach_goal(double ramp, double t) const {
  Eigen::Quaterniond turn;
  double stretch = 1;
  correction_at(t, turn, stretch);
  ReachGoal g = reach_goal_at(strike_.effector, turn, stretch, ramp, strike_.lean);
  // A punch's fist goes down with a pelvis dropped deeper than its plan had it (a back foot
  // held where it landed, a wider stance than planned) by more than the room its elbow had
  // under the head: kept at the target, kenji's arm rose 6.7 cm steeper and his elbow came over
  // his head at contact (the sweep's folded strike; the elbow rises about as far as the body
  // drops against a fist held still).
  g.pin_drop_max_m = pin_drop_max_m();
  return g;
}

double Behaviour::release_end_s(double contact_time_s) const {
  return std::max(contact_time_s + strike_.hold_s + tun_.release_time_s, strike_.end_time_s - tun_.blend_time_s * player_.current().rate);
}

void Behaviour::compute_reach_error(double at_time_s, bool plan_lean) {
  // The pose at segment time `at_time_s`, composed exactly as update() will compose it then
  // (same sources, same blend weight), decoded without the offset: d(t) must close exactly
  // that gap.
  const Source* strike_src = player_.current().segment == strike_.plan.segment && striking() ? &player_.current() : nullptr;
  if (!strike_src) return;
  MkmFrame b, pose;
  compose_ahead(player_, at_time_s, tun_.blend_time_s, b, pose);
  // scratch_pose_ keeps its room: a strike's start allocates nothing.
  const ReachCorrection r = reach_correction(characters_[static_cast<std::size_t>(character_)], strike_.effector,
                                             strike_.target_room_m, pose, scratch_pose_, plan_lean, &strike_.plan_feet,
                                             lowest_shoulder_y_m());
  strike_.error_m = r.error_m;
  strike_.turn = r.turn;
  strike_.stretch = r.stretch;
  strike_.out_of_reach = r.capped;
  if (strike_.switched_body) cap_kick_stretch_over_way(at_time_s);
  if (plan_lean) strike_.lean = r.lean;
  contact_shoulder_m_ = r.shoulder_m;
  contact_head_m_ = r.head_m;
  contact_elbow_m_ = r.elbow_m;
  if (plan_lean) {
    strike_.plan_drop_m = r.root_drop_m;
    strike_.plan_elbow_under_head_m = r.elbow_under_head_m;
  }
}

void Behaviour::cap_kick_stretch_over_way(double until_s) {
  // A kick planned on one body and switched to a shorter one mid-way: stretched so that the
  // leg locks out at contact, it went past full length on the way wherever the source's leg
  // is straighter there than at contact (135_07_kick_right_1 switched from kenji to mei 0.25 s
  // after the order: the stretch 1.30, the knee 11.6 cm in a frame).
  if (!strike_.effector.leg || !striking()) return;
  const Source& cur_src = player_.current();
  if (cur_src.segment != strike_.plan.segment || !(cur_src.rate > 0)) return;
  const auto side = static_cast<std::size_t>(strike_.effector.side);
  const double step = cur_src.rate / 120;  // segment seconds: finer than any update
  double most = 0;
  MkmFrame b, pose;
  for (double t = cur_src.time_s; t <= std::max(until_s, cur_src.time_s) + 1e-9; t += step) {
    compose_ahead(player_, t, tun_.blend_time_s, b, pose);
    most = std::max(most, pose.leg_n[side].norm());
  }
  if (most > 1e-6) strike_.max_stretch = std::min(strike_.max_stretch, std::max(1.0, kKickLockOutShare / most));
  if (strike_.stretch > strike_.max_stretch) {
    strike_.stretch = strike_.max_stretch;
    strike_.out_of_reach = true;
  }
}

FootLocks Behaviour::feet_through_contact(const Source& s, double contact_time_s) const {
  FootLocks f = feet_.locks();  // as the last update held them
  f.min_root_drop_m = 0;
  f.max_root_drop_m = tun_.max_root_drop_m;
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(s.segment)];
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  const int n = seg.frame_count();
  const int first = std::clamp(static_cast<int>(std::floor(s.time_s / seg.frame_time_s)), 0, n - 1);
  const int contact = std::clamp(static_cast<int>(std::lround(contact_time_s / seg.frame_time_s)), first, n - 1);
  for (int side = 0; side < 2; ++side) {
    const auto us = static_cast<std::size_t>(side);
    if (!have_pose_ || !clip_planted(seg, contact, side)) {
      f.weight[us] = 0;
      continue;
    }
    // The frame the clip puts this foot down for contact (its run of planted frames' first).
    const int down = planted_since(seg, side, first, contact);
    if (down == first) {
      // Down from now to contact: held where it stands; where its procedural step puts it
      // down; coming straight down where it is (a step cut short at the strike's start), onto
      // the floor the clip has it on. A foot lifted now is not counted.
      if (const Vector3d* end = feet_.step_end(side)) {
        f.supporting[us] = true;
        f.heading_weight[us] = 0;
        f.ankle_m[us] = *end;
      } else if (feet_.phase(side) == FootPlanter::Phase::landing) {
        MkmFrame g;
        player_.sample_frame(s, down, g);
        f.supporting[us] = true;
        f.heading_weight[us] = 0;
        f.ankle_m[us].y() = std::min(f.ankle_m[us].y(), mkm_ankle(rig, g, side).y());
      } else if (!feet_.held(side)) {
        f.weight[us] = 0;
      }
      continue;
    }
    // Put down on the way: the planter holds it where the clip has it at contact
    // (Feet's hold_frame: down from there through contact).
    MkmFrame g;
    player_.sample_frame(s, contact, g);
    f.weight[us] = 1;
    f.supporting[us] = true;
    f.heading_weight[us] = 0;
    f.ankle_m[us] = mkm_ankle(rig, g, side);
  }
  return f;
}

double Behaviour::lowest_shoulder_y_m() const {
  if (strike_.effector.leg) return -std::numeric_limits<double>::infinity();
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  const Vector3d target = strike_target_ ? *strike_target_ : strike_.target_room_m;
  return target.y() - aim_rise_m(rig, strike_.effector.side, tun_.max_punch_aim_deg);
}

void Behaviour::keep_elbow_below_head() {
  aim_straight_arm_below_head();
  // The elbow where the plan puts it (a bent arm's is not on the line from the shoulder, and a
  // straight arm's moves with the lean the lowered aim changes): still above the head, the aim
  // comes down by as much and is planned again. A near head-height target with the arm bent
  // (kenji after a stance step) held the elbow 7 cm above his head.
  for (int pass = 0; pass < kElbowAimPasses; ++pass) {
    if (!contact_elbow_m_.allFinite() || !contact_head_m_.allFinite()) break;
    const double over = contact_elbow_m_.y() - (contact_head_m_.y() - kElbowBelowHead_m);
    if (over <= 0) break;
    strike_.aim_lowered_m += over;
    strike_.target_room_m.y() -= over;
    compute_reach_error(strike_.contact_time_s);
  }
}

void Behaviour::aim_straight_arm_below_head() {
  // The straight arm from the contact pose's shoulder toward the target: its elbow rises
  // upper_arm * sin(elevation) above the shoulder. The most elevation that keeps it
  // kElbowBelowHead_m under the head joint sets the highest aim at this horizontal distance.
  // The pose is the one with the planned lean (a far target leans the trunk, the head dips);
  // a target nearer than the straight arm bends the arm (the elbow is not on the line).
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  const int side = strike_.effector.side;
  const Vector3d shoulder = contact_shoulder_m_, head = contact_head_m_;
  const double upper = rig.morphology.upper_arm_m[static_cast<std::size_t>(side)];
  if (!shoulder.allFinite() || !head.allFinite() || !(upper > 0)) return;
  const Vector3d to = strike_.target_room_m - shoulder;
  if (to.norm() < kStraightArmShare * rig.morphology.arm_length(side)) return;
  const double rise = head.y() - kElbowBelowHead_m - shoulder.y();  // m the elbow may rise
  if (rise >= upper) return;                                         // any elevation keeps it under
  const double horizontal = Vector2d(to.x(), to.z()).norm();
  const double s = std::max(0.0, rise / upper);
  const double highest = horizontal * s / std::sqrt(1 - s * s);  // m above the shoulder
  if (to.y() <= highest) return;
  strike_.aim_lowered_m = to.y() - highest;
  strike_.target_room_m.y() = shoulder.y() + highest;
  compute_reach_error(strike_.contact_time_s);
}

namespace behaviour_detail {
ReachCorrection reach_correction(const Rig& rig, const Effector& eff, const Vector3d& target, const MkmFrame& pose,
                                 CanonicalPose& c, bool plan_lean, const FootLocks* feet, double lowest_shoulder_y_m) {
  decode_canonical(rig, pose, c);
  ReachCorrection r;
  r.error_m = target - at(c, eff.joint());
  // The correction turns and stretches the limb about its root (shoulder or hip) so that it
  // points at the target: the whole limb aims, instead of the wrist alone being pushed.
  const CJ root = eff.leg ? (eff.side == kLeft ? CJ::l_hip : CJ::r_hip) : (eff.side == kLeft ? CJ::l_shoulder : CJ::r_shoulder);
  // The limb vector as AdaptJob turns it: the motion's own (root -> root + limb_n * length),
  // not the decoded end, which IK clamps where the motion over-extends the limb by a hair.
  const int side = eff.side;
  const Vector3d from = eff.leg ? Vector3d(pose.leg_n[static_cast<std::size_t>(side)] * rig.morphology.limb_leg_length(side))
                                : Vector3d(pose.arm_n[static_cast<std::size_t>(side)] * rig.morphology.arm_length(side));
  const Vector3d to = target - at(c, root);
  if (from.norm() > 1e-6 && to.norm() > 1e-6) {
    r.turn = Eigen::Quaterniond::FromTwoVectors(from, to);
    double want = to.norm();
    // A kick whose target lies beyond the leg's reach from the hip at contact stops short of
    // locking the knee (kKickLockOutShare of the leg): stretched onto the target the leg hit
    // full extension on the way in, a bent knee straight in one frame (a character switched
    // mid-kick to a shorter one: knees 6-14 cm in a frame, 15 of the shipped 120-order sweep's
    // 26 snaps). It is out of reach either way (contact_reached false).
    const double leg = rig.morphology.limb_leg_length(side);
    if (eff.leg && want > leg) {
      want = kKickLockOutShare * leg;
      r.capped = true;
    }
    r.stretch = want / from.norm();
  }
  if (plan_lean && !eff.leg) {
    // The trunk lean the contact needs: the pose at contact adapted with the whole d(t), its
    // trunk fallback's rotations kept. Played eased in and out with d(t), the body leans into
    // the punch over its way; found each frame at full stretch instead, it came in and went
    // out in one frame (the head 10 cm in a frame in the bout).
    const auto n = static_cast<std::size_t>(rig.joint_count());
    thread_local std::vector<Eigen::Quaterniond> local, global;
    thread_local std::vector<Vector3d> pos;
    local.resize(n);
    global.resize(n);
    pos.resize(n);
    const ReachGoal goal = reach_goal_at(eff, r.turn, r.stretch, 1.0);
    AdaptReport report;
    AdaptJob job;
    job.rig = &rig;
    job.pose = &pose;
    job.reach = &goal;
    job.local_rotations = local;
    job.global_positions = pos;
    job.global_rotations = global;
    job.report = &report;
    // With a margin: the frames' poses differ from this one (held feet lower the body), and
    // what the plan leaves the frames' fallback must still bring in, over frames.
    job.trunk_target_share = kPlannedLeanShare;
    // Feet held through to contact lower the pelvis there (a lunge's back foot held where it
    // landed while the clip drags it 14 cm on: kenji's pelvis 4.5 cm down at contact after a
    // stance step); planned without them, the lean was too small and the arm rose higher than
    // planned (the elbow 7 cm over his head).
    FootLocks held;
    if (feet && (feet->weight[0] > 0 || feet->weight[1] > 0)) {
      held = *feet;
      held.min_root_drop_m = 0;
      held.max_root_drop_m = std::clamp(at(c, root).y() - lowest_shoulder_y_m, 0.0, std::max(0.0, feet->max_root_drop_m));
      job.feet = &held;
    }
    if (job.Run()) {
      if (report.trunk_used) r.lean = report.trunk;
      r.shoulder_m = pos[static_cast<std::size_t>(rig.skeleton.index(root))];
      r.head_m = pos[static_cast<std::size_t>(rig.skeleton.index(CJ::head))];
      r.elbow_m = pos[static_cast<std::size_t>(rig.skeleton.index(eff.side == kLeft ? CJ::l_elbow : CJ::r_elbow))];
      r.root_drop_m = report.root_drop_m;
      r.elbow_under_head_m = r.head_m.y() - r.elbow_m.y();
    }
  }
  return r;
}
}  // namespace behaviour_detail

void Behaviour::update_follow(double dt, const Vector3d& head) {
  const Vector2d head_xz(head.x(), head.z());
  const Vector2d to_head = head_xz - spot_xz_m_;
  const double dist = to_head.norm();
  Vector2d goal = spot_xz_m_;
  // The way from the visitor's head to the spot it keeps: toward where the fighter stands, but
  // within follow_arc_deg of the way to its home (the walls' side; sparring's 45, orders mode's
  // 180). Along the line to where it stands alone, the spar demo's fighter was beside or behind
  // its visitor (over 90 degrees from straight ahead) in 916 of 3600 frames (seed 1): its lunge
  // carried it past a visitor walking forward through its kata, and it then kept its distance
  // from there, at the visitor's back. An arc's edge is taken on the side the fighter is on.
  Vector2d away = dist > 1e-6 ? Vector2d(-to_head / dist) : Vector2d::Zero();
  if (const Vector2d to_home = Vector2d(config_.home.x(), config_.home.z()) - head_xz; dist > 1e-6 && to_home.norm() > 1e-6) {
    const double arc = (follow_arc_deg_ < 0 ? tun_.follow_arc_deg : follow_arc_deg_) * std::numbers::pi / 180;
    const double home_rad = std::atan2(to_home.x(), to_home.y());
    const double off = std::remainder(std::atan2(away.x(), away.y()) - home_rad, 2 * std::numbers::pi);
    if (std::abs(off) > arc) {
      const double a = home_rad + std::copysign(arc, off);
      away = Vector2d(std::sin(a), std::cos(a));
    }
  }
  if (dist > 1e-6) goal = head_xz + away * follow_distance_m_;
  // Sparring (follow_close_), the distance is the drawn head's, not the root's: a stance that
  // carries the head back (the rest after a stance step keeps the step's turned hips: the head
  // 4 cm behind the root, against 8 cm ahead in the guard stance) stood the head out of the
  // visitor's reach. The spot moves by how far the head stands off its usual lead.
  if (follow_close_ && have_pose_ && dist > 1e-6) {
    const Rig& rig = characters_[static_cast<std::size_t>(character_)];
    const Vector3d drawn_head = rig_positions_[static_cast<std::size_t>(rig.skeleton.index(CJ::head))];
    const double ahead = (Vector2d(drawn_head.x(), drawn_head.z()) - spot_xz_m_).dot(to_head / dist);
    goal = head_xz + away * (follow_distance_m_ + ahead - kSparHeadLead_m);
  }
  if (recentre_goal_) goal = *recentre_goal_;
  if (reel_.step_back()) goal = *reel_.step_back();  // stepping back from a large blow
  if (const Approach* a = approach()) {
    goal = a->goal_xz;  // stepping in before a strike
  } else if (strike_pending()) {
    goal = spot_xz_m_;  // a strike about to start (its plan placed from where the feet stand now)
  }
  // A visitor near a wall: back off (further from the visitor than the strike distance), so
  // nobody is drawn toward the wall by the fighter.
  if (keep_away_ && dist > 1e-6) goal = head_xz + away * (config_.strike_distance_m + tun_.keep_away_extra_m);
  goal = clamp_to_area(config_, goal);
  if (paused_) goal = spot_xz_m_;
  // (the spot's velocity of the last update: zero unless it was following)
  const Vector2d last_spot_velocity = spot_velocity_;
  spot_velocity_.setZero();
  // How fast the spot to keep moves (the visitor walking), over ~kGoalSpeedSmoothing_s.
  if (last_goal_ && last_goal_update_ == updates_ - 1 && dt > 0) {
    const double a = std::min(1.0, dt / kGoalSpeedSmoothing_s);
    goal_velocity_ += a * ((goal - *last_goal_) / dt - goal_velocity_);
  }
  last_goal_ = goal;
  last_goal_update_ = updates_;
  // A stance step from the mocap plays: its clip carries the body (and turns it); the rest
  // motion takes over where it ends (end_stance_step).
  if (stance_step()) return;
  const Vector2d off = goal - spot_xz_m_;
  bool following = state() == FighterState::following;
  if (recentre_goal_ && !following && off.norm() <= tun_.follow_tolerance_m) recentre_goal_.reset();  // home already
  // Forward or back: a stance step from the mocap where one fits (begin_stance_step); until
  // the visitor stands stance_step_min_m farther than the strike distance, the fighter waits.
  bool wait = false;
  const double stance_step_min_m = this->stance_step_min_m();
  const double closer_s = closer_s_;
  closer_s_ = 0;
  if (stance_step_min_m > 0 && !walk_segments_.empty() && !approach() && !strike_pending() && !paused_ &&
      !reel_.step_back() && dist > 0.05) {
    const Vector2d fwd(std::sin(facing_rad_), std::cos(facing_rad_));
    const double along = off.dot(fwd);
    const double sideways = (off - along * fwd).norm();
    const double off_axis = std::abs(wrap(std::atan2(to_head.x(), to_head.y()) - facing_rad_));
    if (sideways <= tun_.follow_tolerance_m && off_axis <= kStanceStepOffAxis_rad) {
      // Forward once the visitor stops walking away (one step for the whole way, not one
      // begun mid-walk and a wait after), or once the spot is a whole step ahead; back once the
      // visitor has come closer and stayed.
      const bool settled = std::abs(goal_velocity_.dot(fwd)) < kSettledGoalSpeed_mps;
      const bool forward = along >= stance_step_min_m && (settled || along >= kWholeStep_m * stride_scale());
      // Back once the visitor has stayed closer a while (kBackStepAfter_s), not from a lunge.
      const bool closer = along < 0 && off.norm() > tun_.follow_tolerance_m;
      if (closer) closer_s_ = closer_s + dt;
      const bool back = closer && closer_s_ >= kBackStepAfter_s;
      // A step starts from both feet on the floor: one still stepping (or landing) is waited
      // for, a little (kStanceStepFeetWait_s), rather than following with procedural steps.
      // (and from a blend done: one begun mid-blend would drop the motion blended from)
      const bool feet_down = feet_.held(kLeft) && feet_.held(kRight) && player_.blend_elapsed_s() >= tun_.blend_time_s;
      stance_wait_s_ = (forward || back) && !feet_down ? stance_wait_s_ + dt : 0;
      if ((forward || back) && feet_down && begin_stance_step(goal)) return;

      // Until then it waits for a forward step (a visitor a little farther, or still walking).
      // (Sparring, follow_close_, a spot short of a stance step is walked to, not waited out.)
      wait = !following && ((along > 0 && !forward && !recentre_goal_ && !follow_close_) ||  // (walking home goes all the way)
                            ((forward || back) && !feet_down && stance_wait_s_ < kStanceStepFeetWait_s));
      // A visitor who stayed closer: the procedural steps following meanwhile stop (their feet
      // land) and the stance step back goes from there.
      if (back && !feet_down && stance_wait_s_ < kStanceStepFeetWait_s) {
        following = false;
        wait = true;
      }
    }
  }
  // A fighter outside its area (a lunge or a kick carries the body on past where it stood)
  // walks back in, however near the visitor would have it: the area keeps it off the front
  // wall. (Not while a strike's plan is awaited: that strike is placed from where it stands.)
  const bool outside_area = !strike_pending() && (clamp_to_area(config_, spot_xz_m_) - spot_xz_m_).lpNorm<Eigen::Infinity>() >
                                                       tun_.arrive_tolerance_m;
  if (outside_area && !paused_) wait = false;
  if (!wait && !following &&
      (off.norm() > tun_.follow_tolerance_m || ((approach() || reel_.step_back()) && off.norm() > tun_.arrive_tolerance_m) ||
       (outside_area && !paused_)))
    following = true;
  if (following) {
    const double speed = approach() ? tun_.step_in_speed_mps : tun_.walk_speed_mps;
    const double r = off.norm();
    const bool coarse = dt >= kCoarseUpdate_s;
    Vector2d v = Vector2d::Zero();
    if (r > 1e-9 && dt > 0) {
      if (coarse) {
        // Updated coarsely, the spot speeds up and slows down by kFollowAccel_mps2 rather than
        // taking the whole speed from standing and stopping dead (a 10 cm step-in at 30 Hz
        // moved the pelvis 5 cm in each of two frames, a knee 6 cm in one). The most speed
        // from which it still stops at the goal, moving this update at it and then slowing by
        // a * dt an update: v * dt + v^2 / (2a) = r.
        const double a = kFollowAccel_mps2;
        const double stop = -a * dt + std::sqrt(a * dt * a * dt + 2 * a * r);
        const Vector2d want = off / r * std::min(speed, stop);
        const Vector2d change = want - last_spot_velocity;
        v = change.norm() <= a * dt ? want : Vector2d(last_spot_velocity + change / change.norm() * (a * dt));
        if (v.norm() * dt > r) v *= r / (v.norm() * dt);
        spot_xz_m_ += v * dt;
      } else {
        const double step = std::min(r, speed * dt);
        v = off / r * step / dt;
        spot_xz_m_ += off / r * step;
      }
      spot_velocity_ = v;
    }
    if ((goal - spot_xz_m_).norm() < tun_.arrive_tolerance_m && (!coarse || v.norm() <= kFollowArriveSpeed_mps)) {
      following = false;
      recentre_goal_.reset();
      reel_.end_step_back();
    }
  }
  // Face the visitor; while stepping in or back before a strike, or setting a kick's support
  // foot, its target (frozen at the order): the strike is planned again facing it once the
  // feet stand, and a visitor moving meanwhile does not turn the feet into more steps the
  // strike waits for (or away from where the support foot was set).
  Vector2d to_face = to_head;
  if (const Vector3d* t = step_target()) to_face = Vector2d(t->x(), t->z()) - spot_xz_m_;
  if (to_face.norm() > 0.05 && !paused_) {
    const double want = std::atan2(to_face.x(), to_face.y());
    const double turn = std::clamp(wrap(want - facing_rad_), -tun_.turn_speed_rad_s * dt, tun_.turn_speed_rad_s * dt);
    facing_rad_ = wrap(facing_rad_ + turn);
  }
  const MotionSegment& rest = db_->segments[static_cast<std::size_t>(player_.current().segment)];
  player_.place(spot_xz_m_, wrap(facing_rad_ + rest_yaw_rad_ - ground_frame_of(rest.frames[0]).yaw_rad));
  set_locomotion(following ? Locomotion{Walking{}} : Locomotion{AtSpot{}});
}

void Behaviour::judge_contact(Timestamp now, const Vector3d& head) {
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  ContactInput in;
  in.hit_point_m = rig_positions_[static_cast<std::size_t>(rig.skeleton.index(strike_.effector.joint()))];
  in.target_m = strike_.target_room_m;
  in.hit_radius_m = config_.hit_radius_m;
  in.visitor = VisitorShape::of(config_, head);
  const ContactJudgement j = judge_strike_contact(in);
  strike_.contact_done = true;
  strike_.contact_update = updates_;
  strike_.contact_distance_m = j.target_distance_m;
  strike_.contact_reached = report_.reached && !strike_.out_of_reach;
  strike_.target_reached = j.target_reached;
  strike_.body_distance_m = j.body_distance_m;
  strike_.hit = j.hit;
  FighterEvent& e = emit(j.kind(), now, strike_.order, FighterEvent::Reason::none, j.event_distance_m());
  describe_contact(strike_, e);
}

FeetInput Behaviour::feet_input(double dt, const ReachGoal* reach, double ramp, const MkmFrame& cur) const {
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  FeetInput in;
  in.dt_s = dt;
  in.have_pose = have_pose_;
  in.rig = &rig;
  in.character = character_;
  in.player = &player_;
  in.motion = &cur;
  in.pose = &pose_;
  in.drawn_m = rig_positions_;
  in.report = &report_;
  in.switched = switch_.due();
  in.stance_support = stance_step() ? stance_step()->support : -1;
  in.before_contact = striking() && !strike_.contact_done;
  in.effector = strike_.effector;
  in.clip_contact_time_s = strike_.clip_contact_time_s;
  in.kick_side = reach && strike_.effector.leg ? strike_.effector.side : -1;
  in.kick_striking = striking();
  in.reach_ramp = ramp;
  if (reach && !reach->effector.leg && strike_target_) {
    in.punch_side = reach->effector.side;
    in.lowest_shoulder_y_m = strike_target_->y() - aim_rise_m(rig, reach->effector.side, tun_.max_punch_aim_deg);
  }
  // Steps also while recovering: a strike that ends in a long stance steps back under the
  // body instead of squatting into the rest motion's narrower one.
  // Not while d(t) still acts: the strike holds its stance until it has been taken back.
  // Nor while a kick's support foot is set (its step and the kick it waits for): the other foot
  // stands, and the set foot stays where the kick will turn on it.
  const bool support_set = support_step() || (pending() && pending()->support_stepped) || (retaking() && retaking()->support_stepped);
  // Nor while a stance step plays: the clip steps the feet.
  // Nor while a strike is being planned (its plan in flight, or an order taken again after
  // stepping in): it is planned around the feet as they stand. A step begun between a
  // step-in's arrival and the plan left the back foot of kenji's lunge punch on the grid
  // 13 cm ahead of where the lunge holds it: out of reach, it stepped back and forth in the air.
  const bool planning = pending() || (retaking() && retaking()->stepped_first);
  in.may_step = !striking() && ramp_ <= 0 && !support_set && !stance_step() && !planning;
  in.spot_velocity_mps = spot_velocity_;
  return in;
}

void Behaviour::update(Timestamp now, double dt, const Vector3d& head) {
  time_ = now;
  ++updates_;
  dt = std::max(0.0, dt);
  // A switch needs the old drawn pose; kept before handle_orders changes character.
  const bool switch_pending = std::any_of(orders_.begin(), orders_.end(), [](const QueuedOrder& q) {
    return q.order.kind == OrderKind::select_character;
  });
  if (switch_pending && have_pose_) switch_.keep_drawn(characters_[static_cast<std::size_t>(character_)], positions_);

  handle_orders(now, head);
  if (const AwaitingPlan* w = as<AwaitingPlan>()) {
    if (auto p = plan_channel_.poll(); p && p->id == w->strike.request) {
      // (copies: the plan's outcome replaces the alternative they live in)
      const PendingStrike pending = w->strike;
      const Locomotion loco = w->loco;
      if (p->segment < 0) {
        emit(FighterEvent::Kind::warning, now, pending.order, FighterEvent::Reason::no_strike);
        enter(Idle{loco});
      } else {
        strike_target_ = pending.target_room_m;
        StrikeFit fit;
        Source s = strike_source(*p, fit);
        if (pending.plan && fit.shortfall_m >= kReplanShortfall_m) {
          // Planned anew after stepping in and still far short (another window, whose lunge
          // the feet the step left hold back): the strike it stepped in for, if that falls
          // shorter from here.
          StrikeFit old_fit;
          const Source old = strike_source(*pending.plan, old_fit);
          if (old_fit.shortfall_m < fit.shortfall_m) {
            const std::uint64_t id = p->id;
            *p = *pending.plan;
            p->id = id;
            s = old;
            fit = old_fit;
          }
        }
        // A step first (once per order): in, by the distance the strike falls short; or back,
        // where the target is so near that the limb would land folded (min_strike_extension),
        // by as much as brings it to the clip's own extension (begin_step_in: at least to
        // strike_distance_m).
        const double step_m = pending.stepped_first ? 0.0 : step_wanted(fit);
        // From a stance step's long stance, a strike that wants a step takes a rest stance on
        // the way (restance_for), if the strike needs a shorter step from there.
        std::optional<Restance> restance;
        if (step_m != 0 && !stance_step()) restance = restance_for(pending, *p, step_m);
        if (restance) {
          begin_restance(pending, *p, *restance, now);
        } else if (step_m != 0 && stance_step()) {
          // Short of its target from mid-step: planned again where the step ends (a step-in
          // measured from here would be walked from there, the wrong way).
          QueuedOrder again{pending.order, pending.target_room_m, false, pending.support_stepped};
          again.after_stance_step = true;
          enter(Retaking{again, loco});
        } else if ((step_m == 0 || !begin_step_in(pending, *p, step_m, now)) &&
                   (pending.support_stepped || !begin_support_step(pending, *p, s, now))) {
          start_strike(pending, *p, s, fit, now, dt);
        }
      }
    }
  }

  if (const Striking* st = as<Striking>(); st && st->rate && updates_ >= st->rate->due_update) apply_strike_rate(dt);

  // Advance the clocks by the whole frame: the contact frame is the first frame at or past the
  // planned contact time, a real frame of motion (no sub-frame hold, no copy of the last).
  player_.advance(dt);
  switch_.advance(dt);
  // A blow (hit()): a strike of its own before its contact leaves for rest (behaviour_hit.cpp).
  if (abort_until_ >= 0) abort_strike_for_blow(now);
  const bool contact_now = striking() && !strike_.contact_done && player_.current().time_s >= strike_.contact_time_s;
  // (a block, in place before its cross-fade in is done, holds its clip until it is: leaving
  // mid-blend would drop the motion it blends from, and the body jumped 25 cm in one frame)
  if (striking() && strike_.contact_done && player_.current().time_s >= strike_.end_time_s - tun_.blend_time_s * player_.current().rate &&
      (!strike_.block || player_.blend_elapsed_s() >= tun_.blend_time_s)) {
    start_rest(now);
    enter(Recovering{});
  }
  // Recovering lasts until the blend into rest is done and d(t) is back to zero.
  if (recovering() && player_.blend_elapsed_s() >= tun_.blend_time_s && player_.previous().time_s >= strike_.release_end_s) enter(Idle{AtSpot{}});
  // (not while a strike's plan is awaited: it starts from the step, not from a blend out of it)
  if (stance_step() && !pending() && player_.current().time_s >= stance_step()->end_s) end_stance_step(now);
  reel_.give_up_step_back(now);  // a large blow's step back, given up
  if (locomotion()) update_follow(dt, head);
  update_step_in(dt);
  update_support_step(dt);

  // Compose the pose: cross-fade previous -> current.
  pose_before_ = pose_;
  MkmFrame cur;
  // (a folded arm's elbow swinging no farther than the source's: limit_folded_pole_turn)
  player_.compose_update(dt, tun_.blend_time_s, characters_[static_cast<std::size_t>(character_)].morphology, cur, pose_);
  // Sparring with blocks on: the guard and a parry laid on the arms (behaviour_guard.cpp).
  guard_.lay(dt, now, !paused_ && !(striking() && !strike_.block), have_pose_, characters_[static_cast<std::size_t>(character_)],
             rig_positions_, pose_, events_);
  if (!have_pose_) pose_before_ = pose_;

  // d(t): zero at the strike start, the full error at contact, then back to zero over at least
  // release_time_s, carrying on through the blend into rest (leaving the strike never jumps).
  ReachGoal goal;
  const ReachGoal* reach = nullptr;
  double ramp = 0;
  if (strike_.active) {
    const Source& s = striking() ? player_.current() : player_.previous();
    const double t = s.time_s;
    if (contact_now) {
      // The error of this very frame, so the contact frame lands on the target. The trunk lean
      // stays the one planned (eased in since the start: found anew here it would jump; the
      // trunk fallback takes what is left).
      compute_reach_error(player_.current().time_s, false);
      strike_.contact_time_s = player_.current().time_s;
      strike_.release_end_s = release_end_s(strike_.contact_time_s);
      ramp = 1;
    } else if (strike_.aborted) {
      // Aborted by a blow: from its weight then to none over release_time_s.
      ramp = strike_.abort_ramp * (1 - smoothstep((t - strike_.abort_s) / std::max(1e-6, strike_.release_end_s - strike_.abort_s)));
    } else {
      ramp = strike_.contact_done ? ramp_out(t) : ramp_in(t);
    }
    goal = reach_goal(ramp, t);
    reach = &goal;
  }
  ramp_ = ramp;
  motion_planted_ = cur.planted;
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  const auto n = static_cast<std::size_t>(rig.joint_count());
  feet_.update(feet_input(dt, reach, ramp, cur));
  // A blow's reel laid on the pose (hit(): none in orders mode, nor before a blow).
  reel_.advance(dt);
  const MkmFrame* reeled = reel_.lay(pose_);
  AdaptJob job;
  job.rig = &rig;
  job.pose = reeled ? reeled : &pose_;
  job.reach = reach;
  job.feet = have_pose_ ? &feet_.locks() : nullptr;
  job.local_rotations = std::span(local_).first(n);
  job.global_rotations = std::span(global_).first(n);
  job.global_positions = std::span(rig_positions_).first(n);
  job.root_position = &root_joint_;
  // The trunk fallback comes in over kTrunkFallbackIn_s at the quickest (a planned lean carries
  // a punch's lean; this is the rest, which jumped from nothing to full in one frame at 60 Hz).
  job.max_trunk_weight = have_pose_ && dt > 0 ? report_.trunk_weight + dt / kTrunkFallbackIn_s : 1.0;
  // ...and goes out over kTrunkFallbackOut_s at the quickest: the last frame's rotations eased
  // toward none are the least applied (a punch's only).
  trunk_floor_ = report_.trunk_fallback.scaled(dt > 0 ? std::max(0.0, 1 - dt / kTrunkFallbackOut_s) : 0.0);
  // A strike whose d(t) has been released while the fallback is still going out keeps its arm
  // as the effector (d(t) at nothing) until it is out.
  ReachGoal released;
  // A kick started while it goes out carries it on too (on the punch's side), and so does the
  // kick's own release: dropped at the kick's start, the trunk sprang up 7 cm at the head in
  // one frame (found in the bout).
  if (!reach && have_pose_ && !trunk_floor_.identity() && trunk_floor_side_ >= 0) {
    released = reach_goal_at(Effector{trunk_floor_side_, false}, Eigen::Quaterniond::Identity(), 1.0, 0.0);
    job.reach = &released;
  }
  job.min_trunk_fallback = have_pose_ && job.reach && trunk_floor_side_ >= 0 ? &trunk_floor_ : nullptr;
  job.min_trunk_fallback_side = trunk_floor_side_;
  job.report = &report_;
  job.fist_neutral = {guard_.weight(), guard_.weight()};  // the guard's fists (AdaptJob::fist_neutral)
  if (have_pose_) job.previous_heading_delta_rad = report_.heading_delta_rad;  // (report_: the last frame's)
  // Each knee turns about its leg at most kKneeSwivel_rad_s from where the last update drew it
  // (the same character's).
  if (have_pose_ && dt > 0 && previous_rig_character_ == character_) {
    std::copy_n(rig_positions_.begin(), n, previous_rig_positions_.begin());
    job.previous_positions = std::span<const Vector3d>(previous_rig_positions_).first(n);
    job.max_knee_swivel_rad = kKneeSwivel_rad_s * dt;
  }
  job.Run();
  previous_rig_character_ = character_;
  if (job.reach && !job.reach->effector.leg) trunk_floor_side_ = job.reach->effector.side;  // the fallback's arm
  player_.note_drawn_arms(rig, rig_positions_);  // each drawn elbow's distance from its arm's line
  feet_.drew(have_pose_, dt, report_.root_drop_m);
  have_pose_ = true;
  last_dt_ = dt > 0 ? dt : last_dt_;

  if (contact_now) {
    // (The fist went down with a pelvis dropped deeper than planned: the aim is that much lower.)
    strike_.aim_lowered_m += std::max(0.0, report_.root_drop_m - pin_drop_max_m());
    if (strike_.block) judge_block_in_place(now);
    else judge_contact(now, head);
  }
  // A character switch's easing: the drawn joints from the old drawn pose, the offsets fading.
  switch_.ease(rig, rig_positions_, positions_);
}

FighterFrame Behaviour::frame() const {
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  const auto n = static_cast<std::size_t>(rig.joint_count());
  FighterFrame f;
  f.time = time_;
  f.state = state();
  f.action = action();
  f.locomotion = locomotion_kind();
  f.character = character_;
  f.joints = std::span<const Vector3d>(positions_).first(n);
  f.parents = rig.skeleton.parents;
  f.joint_radii_m = rig.joint_radii_m;
  if (const Vector3d* t = step_target()) f.target = *t;
  if (strike_.active || pending()) f.target = pending() ? pending()->target_room_m : strike_.target_room_m;
  f.root = Vector3d(pose_.root_xz_m.x(), 0, pose_.root_xz_m.y());
  f.heading_rad = facing_rad_;
  return f;
}

}  // namespace kumite::content
