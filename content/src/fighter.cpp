// The Fighter facade: Behaviour (single-threaded) + a retrieval worker thread. A request
// goes into a one-slot mailbox at update N; its plan is taken at update N + delay exactly
// (kRetrievalDelayUpdates), waiting for the worker only if it is late, so the frame a strike
// starts on depends on the inputs, never on thread timing. The behaviour keeps animating
// rest / blends meanwhile. The same worker finds a started strike's playback rate
// (StrikeRateJob, sent on the update the strike starts, applied kStrikeRateDelayUpdates later
// by Behaviour, again waiting only if the worker is late): the frame never decodes the whole
// strike's way.
#include "kumite/content/fighter.hpp"

#include <algorithm>
#include <array>
#include <limits>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include <fmt/format.h>

#include "kumite/content/threat.hpp"

#include "kumite/common/error.hpp"
#include "behaviour_internal.hpp"
#include "kumite/content/behaviour.hpp"

namespace kumite::content {

std::string_view to_string(FighterState s) {
  switch (s) {
    case FighterState::resting: return "resting";
    case FighterState::following: return "following";
    case FighterState::striking: return "striking";
    case FighterState::recovering: return "recovering";
  }
  return "?";
}

std::string_view to_string(FighterAction a) {
  switch (a) {
    case FighterAction::idle: return "idle";
    case FighterAction::awaiting_plan: return "awaiting_plan";
    case FighterAction::stepping_in: return "stepping_in";
    case FighterAction::stepping_back: return "stepping_back";
    case FighterAction::restance: return "restance";
    case FighterAction::support_step: return "support_step";
    case FighterAction::retaking: return "retaking";
    case FighterAction::striking: return "striking";
    case FighterAction::recovering: return "recovering";
    case FighterAction::blocking: return "blocking";
  }
  return "?";
}

std::string_view to_string(FighterLocomotion l) {
  switch (l) {
    case FighterLocomotion::at_spot: return "at_spot";
    case FighterLocomotion::walking: return "walking";
    case FighterLocomotion::stance_step: return "stance_step";
  }
  return "?";
}

std::string describe(const FighterEvent& e, const std::function<std::string(int)>& segment_name,
                     const std::function<std::string(int)>& character_name) {
  using R = FighterEvent::Reason;
  using K = FighterEvent::Kind;
  switch (e.kind) {
    case K::hit:
    case K::dodged:
    case K::miss: {
      const std::string what = fmt::format("{} (frames {}->{})", segment_name(e.segment), e.start_frame, e.contact_frame);
      if (e.kind == K::hit)
        return fmt::format("{}: touched the visitor ({:.1f} cm from the target)", what, e.contact_distance_m * 100);
      if (e.kind == K::dodged)
        return fmt::format("{}: the visitor had moved, {:.1f} cm clear of the hit point", what, e.distance_m * 100);
      return fmt::format("{}: {:.1f} cm short of the target{}, {:.1f} cm clear of the visitor", what,
                         e.contact_distance_m * 100, e.out_of_reach ? " (out of reach)" : "", e.distance_m * 100);
    }
    case K::character_changed:
      return fmt::format("character {} ({})", e.order.character + 1, character_name(e.order.character));
    case K::stepping_in:
      if (e.reason == R::restance)
        return fmt::format("{:.0f} cm in first, into the fighting stance: the target at ({:.2f}, {:.2f}, {:.2f}) m is beyond "
                           "the strike's reach from this long stance",
                           e.distance_m * 100, e.target.x(), e.target.y(), e.target.z());
      return fmt::format("{:.0f} cm in first: the target at ({:.2f}, {:.2f}, {:.2f}) m is beyond the strike's reach from here",
                         e.distance_m * 100, e.target.x(), e.target.y(), e.target.z());
    case K::stepping_back:
      if (e.reason == R::restance)
        return fmt::format("{:.0f} cm back first, into the fighting stance: the target at ({:.2f}, {:.2f}, {:.2f}) m is too "
                           "near for the strike from this long stance",
                           e.distance_m * 100, e.target.x(), e.target.y(), e.target.z());
      return fmt::format("{:.0f} cm back first: the target at ({:.2f}, {:.2f}, {:.2f}) m is too near for the strike to land "
                         "with its limb extended",
                         e.distance_m * 100, e.target.x(), e.target.y(), e.target.z());
    case K::support_step:
      return fmt::format("the {} foot steps {:.0f} cm first, to where the {} stands on it; the target at ({:.2f}, {:.2f}, {:.2f}) m",
                         e.side == 1 ? "right" : e.side == 0 ? "left" : e.order.kind == OrderKind::kick_left ? "right" : "left",
                         e.distance_m * 100,
                         e.order.kind == OrderKind::kick_left || e.order.kind == OrderKind::kick_right ? "kick" : "punch",
                         e.target.x(), e.target.y(), e.target.z());
    case K::block: {
      const char* arm = e.side == 0 ? "left" : "right";
      const std::string clip = e.segment < 0 ? std::string("a parry from the guard")
                                             : fmt::format("{} (frames {}->{})", segment_name(e.segment), e.start_frame, e.contact_frame);
      const std::string what = fmt::format("{} against the visitor's {}{} ({:.1f} m/s)", clip, recognition::to_string(e.limb),
                                           e.recognised ? ", recognised" : ", seen coming", e.speed_mps);
      if (e.margin_s < 0) return fmt::format("{}: late, the {} forearm in place {:.0f} ms after the fist", what, arm, -e.margin_s * 1000);
      return fmt::format("{}: the {} forearm in place {:.0f} ms before the fist", what, arm, e.margin_s * 1000);
    }
    case K::blocked:
      return fmt::format("the visitor's {} met the {} forearm at {:.1f} m/s", recognition::to_string(e.limb),
                         e.side == 0 ? "left" : "right", e.speed_mps);
    case K::visitor_hit:
      return fmt::format("the visitor's {} hit the fighter at {:.1f} m/s, ({:.2f}, {:.2f}, {:.2f}) m", recognition::to_string(e.limb),
                         e.speed_mps, e.target.x(), e.target.y(), e.target.z());
    default: break;
  }
  switch (e.reason) {
    case R::none: return "";
    case R::paused: return "paused";
    case R::resumed: return "resumed";
    case R::recentre: return "recentre: walking home";
    case R::strike: return fmt::format("target at ({:.2f}, {:.2f}, {:.2f}) m", e.target.x(), e.target.y(), e.target.z());
    case R::mid_strike: return "mid-strike";
    case R::near_wall: return "the visitor is near a wall: the fighter keeps away";
    case R::no_such_character: return fmt::format("no character {} (have {})", e.order.character + 1, e.character_count);
    case R::no_strike: return "no strike in the database for this order";
    case R::restance: return "into the fighting stance";
    case R::blocking: return "blocking";
  }
  return "?";
}

namespace {

/// One job kind's one-slot mailbox on the worker: the job handed over and its result (guarded
/// by the worker's mutex), and the job awaited and the update its result is due on (the update
/// thread's own).
template <class Job, class Result>
struct WorkerSlot {
  std::optional<Job> job;        // guarded by RetrievalWorker::mutex_
  std::optional<Result> result;  // guarded by RetrievalWorker::mutex_
  std::optional<std::uint64_t> outstanding;
  std::uint64_t due = 0;
};

/// Plans strikes and finds their playback rates on its own thread, one WorkerSlot per job
/// kind, each handed to Behaviour as a WorkerChannel. A request submitted at update N is handed
/// back at update N + delay exactly: its poll returns nothing before, and at N + delay waits
/// for the plan if the worker is not done yet (retrieval takes ~20 us; a frame is ~16 ms). One
/// request at a time: Behaviour waits for a plan before it asks for the next. A strike's rate
/// job is handed back on the first poll after it (Behaviour polls on the update it is due,
/// before the strike can end), one at a time as well.
class RetrievalWorker {
 public:
  using PlanFn = std::function<StrikePlan(const StrikeRequest&)>;
  using RateFn = std::function<StrikeRateResult(const StrikeRateJob&)>;
  RetrievalWorker(PlanFn plan, RateFn rate, int delay_updates)
      : plan_(std::move(plan)), rate_(std::move(rate)), delay_(delay_updates), thread_([this] { run(); }) {}
  ~RetrievalWorker() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  /// The update counter of the behaviour's thread (called before each update).
  void set_update(std::uint64_t update) { update_ = update; }
  /// The two channels (called from the update thread): a short critical section to copy a job
  /// in, nothing allocated.
  Behaviour::PlanChannel plan_channel() {
    return {[this](const StrikeRequest& r) {
              submit(plans_, r, r.id, delay_);
              ++stats_.requests;
            },
            [this] { return poll(plans_); }};
  }
  Behaviour::RateChannel rate_channel() {
    return {[this](const StrikeRateJob& job) {
              submit(rates_, job, job.id, 0);
              ++stats_.rate_jobs;
            },
            [this] {
              std::optional<StrikeRateResult> r = poll(rates_);
              if (r) stats_.rate_solve_max_us = std::max(stats_.rate_solve_max_us, r->solve_us);
              return r;
            }};
  }
  const RetrievalTiming& stats() const { return stats_; }

 private:
  template <class Job, class Result>
  void submit(WorkerSlot<Job, Result>& slot, const Job& job, std::uint64_t id, int delay_updates) {
    {
      std::lock_guard lock(mutex_);
      slot.job = job;
      slot.result.reset();
    }
    slot.outstanding = id;
    slot.due = update_ + static_cast<std::uint64_t>(delay_updates);
    cv_.notify_all();
  }
  /// The result of the job awaited, from the update it is due on, waiting if the worker is late.
  template <class Job, class Result>
  std::optional<Result> poll(WorkerSlot<Job, Result>& slot) {
    if (!slot.outstanding || update_ < slot.due) return std::nullopt;
    std::unique_lock lock(mutex_);
    const auto ready = [&] { return slot.result && slot.result->id == *slot.outstanding; };
    wait_counted(lock, ready);
    std::optional<Result> r = std::move(slot.result);
    slot.result.reset();
    slot.outstanding.reset();
    return r;
  }
  /// Waits (lock held) until `ready`, counting a wait in stats_ when it was not ready at once.
  template <class Ready>
  void wait_counted(std::unique_lock<std::mutex>& lock, Ready ready) {
    if (ready()) return;
    const auto t0 = std::chrono::steady_clock::now();
    done_.wait(lock, ready);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    ++stats_.waits;
    stats_.wait_total_ms += ms;
    stats_.wait_max_ms = std::max(stats_.wait_max_ms, ms);
  }
  /// The worker thread: one job of each kind taken at a time, the rate job first.
  void run() {
    for (;;) {
      std::optional<StrikeRequest> r;
      std::optional<StrikeRateJob> job;
      {
        std::unique_lock lock(mutex_);
        cv_.wait(lock, [&] { return stop_ || plans_.job.has_value() || rates_.job.has_value(); });
        if (stop_) return;
        std::swap(r, plans_.job);
        std::swap(job, rates_.job);
      }
      if (job) {
        StrikeRateResult res = rate_(*job);
        {
          std::lock_guard lock(mutex_);
          rates_.result = res;
        }
        done_.notify_all();
      }
      if (r) {
        StrikePlan p = plan_(*r);
        {
          std::lock_guard lock(mutex_);
          plans_.result = std::move(p);
        }
        done_.notify_all();
      }
    }
  }
  PlanFn plan_;
  RateFn rate_;
  int delay_;
  std::mutex mutex_;
  std::condition_variable cv_, done_;
  WorkerSlot<StrikeRequest, StrikePlan> plans_;
  WorkerSlot<StrikeRateJob, StrikeRateResult> rates_;
  bool stop_ = false;  // guarded by mutex_
  std::uint64_t update_ = 0;  // the update thread's own
  RetrievalTiming stats_;     // the update thread's own
  std::thread thread_;  // last: starts after the members above exist
};

class FighterImpl final : public Fighter {
 public:
  FighterImpl(std::shared_ptr<const Database> db, std::vector<Rig> rigs, const FighterConfig& config,
              FighterOptions options)
      : behaviour_(db, std::move(rigs), config), planner_(std::make_shared<StrikePlanner>(db, config.retrieval)),
        rate_solver_(std::make_shared<StrikeRateSolver>(db, config.behaviour)), spar_(config.planner),
        strike_distance_m_(config.strike_distance_m) {
    if (const std::string problem = validate(config.planner); !problem.empty())
      throw Error("fighter", "config", "fighter.planner." + problem);
    if (options.retrieval_delay_updates < 0)
      throw Error("fighter", "config", "fighter: retrieval_delay_updates must be >= 0");
    RetrievalWorker::PlanFn plan = [planner = planner_, hook = std::move(options.plan)](const StrikeRequest& r) {
      return hook ? hook(*planner, r) : planner->plan(r);
    };
    RetrievalWorker::RateFn rate = [solver = rate_solver_, hook = std::move(options.rate)](const StrikeRateJob& job) {
      return hook ? hook(*solver, job) : solver->solve(job);
    };
    worker_ = std::make_unique<RetrievalWorker>(std::move(plan), std::move(rate), options.retrieval_delay_updates);
    behaviour_.set_planner(worker_->plan_channel());
    behaviour_.set_rate_solver(worker_->rate_channel());
  }
  void order(const Order& order) override {
    if (order.kind == OrderKind::spar || order.kind == OrderKind::orders_only) {
      PlannerTunables t = spar_.tunables();
      t.mode = order.kind == OrderKind::spar ? PlannerMode::spar : PlannerMode::orders;
      if (t.mode != spar_.tunables().mode) spar_.set_tunables(t);
    }
    behaviour_.order(order);
  }
  void keep_away(bool on) override { behaviour_.keep_away(on); }
  void decide(const FighterInput& in) override {
    const PlannerTunables& t = spar_.tunables();
    PlannerInput p;
    p.now = in.now;
    p.seed = in.seed;
    p.head_m = in.head_m;
    const FighterFrame f = behaviour_.frame();
    p.fighter_root_m = f.root;
    p.fighter_idle = f.action == FighterAction::idle && !behaviour_.paused() && !behaviour_.keeping_away();
    p.supervisor_strike = std::any_of(in.orders.begin(), in.orders.end(), [](const Order& o) { return behaviour_detail::effector_of(o.kind).has_value(); });
    p.strikes = in.strikes;
    p.fighter_attacking = behaviour_.attacking();
    if (const std::optional<Order> o = spar_.step(p)) behaviour_.order(*o);
    if (spar_.take_abort()) behaviour_.abort_strike(in.now);
    // Sparring, it keeps the fighting distance (the visitor's fist reaches it), with stance
    // steps from the mocap (the planner's stance_step_min_m; orders mode: the behaviour's own).
    if (t.mode == PlannerMode::spar) behaviour_.follow_at(t.fighting_distance_m, true, t.stance_step_min_m, t.follow_arc_deg);
    else behaviour_.follow_at(strike_distance_m_);
    // Sparring with blocks on, it keeps its guard up (behaviour_guard.cpp).
    behaviour_.set_guard(t.mode == PlannerMode::spar && t.block);
    if (t.mode == PlannerMode::spar) defend(in, f);
  }
  void set_planner(const PlannerTunables& tunables) override { spar_.set_tunables(tunables); }
  PlannerStatus planner_status() const override {
    const PlannerTunables& t = spar_.tunables();
    return PlannerStatus{t.mode, t.block, spar_.state(), spar_.next(), spar_.counts(), score_};
  }
  PlannerTunables planner_tunables() const override { return spar_.tunables(); }
  void update(Timestamp now, double dt, const Eigen::Vector3d& head) override {
    worker_->set_update(++updates_);
    behaviour_.update(now, dt, head);
  }
  RetrievalTiming retrieval_timing() const override { return worker_->stats(); }
  FighterFrame frame() const override {
    FighterFrame f = behaviour_.frame();
    const Rig& rig = behaviour_.character(f.character);
    f.joint_names = rig.skeleton.names;
    f.local_rotations = behaviour_.local_rotations().first(f.joints.size());
    f.root_joint = behaviour_.root_position();
    return f;
  }
  std::vector<FighterEvent> take_events() override {
    std::vector<FighterEvent> out = behaviour_.take_events();
    if (!own_events_.empty()) {
      out.insert(out.begin(), own_events_.begin(), own_events_.end());
      own_events_.clear();
    }
    for (const FighterEvent& e : out) {
      switch (e.kind) {
        case EventKind::hit: ++score_.fighter_hits; break;
        case EventKind::dodged: ++score_.visitor_dodges; break;
        case EventKind::block:
          ++score_.blocks;
          if (e.margin_s < 0) ++score_.blocks_late;
          break;
        case EventKind::blocked: ++score_.blocked; break;
        case EventKind::visitor_hit: ++score_.visitor_hits; break;
        default: break;
      }
    }
    return out;
  }
  std::string describe(const FighterEvent& event) const override { return behaviour_.describe(event); }
  int character_count() const override { return behaviour_.character_count(); }
  std::size_t most_joints() const override { return behaviour_.most_joints(); }
  std::string character_name(int index) const override {
    if (index < 0 || index >= character_count()) return {};
    return behaviour_.character(index).name;
  }

 private:
  Behaviour behaviour_;
  std::shared_ptr<const StrikePlanner> planner_;
  std::shared_ptr<StrikeRateSolver> rate_solver_;  // the worker's alone
  /// Spar: judges the visitor's fists and feet against the fighter as drawn last frame (the
  /// frame the visitor saw), then blocks the soonest threat it can.
  void defend(const FighterInput& in, const FighterFrame& f) {
    const PlannerTunables& t = spar_.tunables();
    threats_.set_tunables(t.threat);
    threats_.observe(in.bodies, in.strikes);
    const Rig& rig = behaviour_.character(f.character);
    const auto joint = [&](CanonicalJoint j) -> std::optional<Eigen::Vector3d> {
      const int i = rig.skeleton.index(j);
      if (i < 0 || static_cast<std::size_t>(i) >= f.joints.size()) return std::nullopt;
      return f.joints[static_cast<std::size_t>(i)];
    };
    const auto head = joint(CanonicalJoint::head), neck = joint(CanonicalJoint::neck), pelvis = joint(CanonicalJoint::pelvis);
    if (!head || !pelvis) return;
    judge_contacts(in, *head, neck.value_or(*head), *pelvis, joint);
    if (!t.block) return;
    const auto order_of = [&](const Threat& th) {
      Behaviour::BlockOrder b;
      b.limb = th.limb;
      b.fist_m = th.point_m;
      b.velocity_mps = th.velocity_mps;
      b.arrival_s = th.arrival_s;
      b.recognised = th.recognised;
      b.max_rate = t.block_max_rate;
      return b;
    };
    // A switch of a recognised strike already answered by a parry or a block clip re-aims it
    // (the dual-buffer boxer's action switching): the same arm, from where it is, to the path
    // the limb takes now.
    for (const VisitorStrikeSeen& s : in.strikes) {
      const auto l = static_cast<std::size_t>(s.limb);
      if (s.type != recognition::EventType::switch_ || l >= answered_until_.size() || !(in.now < answered_until_[l])) continue;
      const std::optional<Threat> th = threats_.soonest(*head, *pelvis, in.now, s.limb);
      if (th && (behaviour_.reaim_parry(order_of(*th), in.now) || behaviour_.reaim_block(order_of(*th), in.now)))
        answered_until_[l] = in.now + th->arrival_s + kStrikeOver_s;
    }
    const std::optional<Threat> th = threats_.soonest(*head, *pelvis, in.now);
    if (!th) return;
    const auto limb = static_cast<std::size_t>(th->limb);
    if (in.now < answered_until_[limb]) return;
    const Behaviour::BlockOrder b = order_of(*th);
    // Answered (or not) once per strike: the next block for this limb after it has passed.
    answered_until_[limb] = in.now + th->arrival_s + kStrikeOver_s;
    // From the guard a parry (none when both arms are busy with one); a block clip while the
    // guard is not up (it comes up over 0.4 s after a strike of its own).
    const bool guarding = behaviour_.guarding();
    const bool answered = guarding ? behaviour_.parry(b, in.now) : behaviour_.block(b, in.now);
    if (!answered) ++score_.unanswered;
    // Where no forearm can be sent across the fist's path, the fighter slips it instead.
    if (!answered) behaviour_.slip(b, in.now);
  }
  /// The visitor's fist or foot meeting the fighter's forearm (blocked) or body (visitor_hit):
  /// the way it moved since its last measurement against capsules on the drawn joints.
  template <class Joint>
  void judge_contacts(const FighterInput& in, const Eigen::Vector3d& head, const Eigen::Vector3d& neck,
                      const Eigen::Vector3d& pelvis, const Joint& joint) {
    const PlannerTunables& t = spar_.tunables();
    for (const VisitorBody& b : in.bodies) {
      const auto r = static_cast<std::size_t>(b.role);
      if (b.role == recognition::Role::head || r >= last_seen_.size()) continue;
      LastSeen& ls = last_seen_[r];
      if (!b.tracked || !b.position_m.allFinite() || !std::isfinite(b.t)) {
        ls.valid = false;
        continue;
      }
      if (ls.valid && !(b.t > ls.t)) continue;
      const bool had = ls.valid;
      const Eigen::Vector3d from = ls.p;
      const double dt = b.t - ls.t;
      ls = LastSeen{b.position_m, b.t, true};
      if (!had || dt <= 0 || dt > 0.1 || in.now < contact_until_[r]) continue;
      const double speed = (b.position_m - from).norm() / dt;
      if (speed < t.hit_min_speed_mps) continue;  // a touch, not a blow
      int side = -1;
      for (int s = 0; s < 2; ++s) {
        const auto el = joint(s == 0 ? CanonicalJoint::l_elbow : CanonicalJoint::r_elbow);
        const auto wr = joint(s == 0 ? CanonicalJoint::l_wrist : CanonicalJoint::r_wrist);
        if (el && wr && segment_distance(from, b.position_m, *el, *wr) <= kFistRadius_m + kForearmRadius_m) side = s;
      }
      const bool body = segment_distance(from, b.position_m, head, head) <= kFistRadius_m + kHeadRadius_m ||
                        segment_distance(from, b.position_m, neck, pelvis) <= kFistRadius_m + kTorsoRadius_m;
      if (side < 0 && !body) continue;
      FighterEvent e;
      e.time = in.now;
      e.kind = side >= 0 ? EventKind::blocked : EventKind::visitor_hit;
      e.limb = b.role;
      e.side = side;
      e.speed_mps = speed;
      e.target = b.position_m;
      own_events_.push_back(e);
      contact_until_[r] = in.now + kStrikeOver_s;
      if (side < 0) reel(t, from, b.position_m, dt, head, neck, pelvis, in.now);
    }
  }
  /// A blow to the body: the fighter reels from the next drawn frame (this update's), at the
  /// place the fist's way first entered the head or torso, along the fist's velocity.
  void reel(const PlannerTunables& t, const Eigen::Vector3d& from, const Eigen::Vector3d& to, double dt,
            const Eigen::Vector3d& head, const Eigen::Vector3d& neck, const Eigen::Vector3d& pelvis, Timestamp now) {
    const int n = std::clamp(static_cast<int>((to - from).norm() / 0.005), 1, 64);
    Behaviour::HitOrder h;
    h.point_m = to;
    for (int i = 0; i <= n; ++i) {
      const Eigen::Vector3d p = from + (to - from) * (static_cast<double>(i) / n);
      const bool in_head = segment_distance(p, p, head, head) <= kFistRadius_m + kHeadRadius_m;
      if (in_head || segment_distance(p, p, neck, pelvis) <= kFistRadius_m + kTorsoRadius_m) {
        h.point_m = p;
        h.head = in_head;
        break;
      }
    }
    h.velocity_mps = (to - from) / dt;
    const double speed = h.velocity_mps.norm();
    h.share = std::clamp((speed - t.hit_min_speed_mps) / (t.hit_full_speed_mps - t.hit_min_speed_mps), 0.0, 1.0);
    constexpr double kRad = 3.14159265358979323846 / 180;
    h.head_max_rad = t.hit_head_max_deg * kRad;
    h.trunk_max_rad = t.hit_trunk_max_deg * kRad;
    h.shoulder_max_rad = t.hit_shoulder_max_deg * kRad;
    h.stiffness_rad_s = t.hit_stiffness_rad_s;
    h.damping_ratio = t.hit_damping_ratio;
    h.step_back_m = h.share >= t.hit_step_back_share ? t.hit_step_back_m : 0.0;
    behaviour_.hit(h, now);
  }
  /// m: the least distance between segments a0-a1 and b0-b1 (sampled finely enough for a
  /// fist's way in one frame against a bone: 1 mm steps up to 64 samples, then exact on b).
  static double segment_distance(const Eigen::Vector3d& a0, const Eigen::Vector3d& a1, const Eigen::Vector3d& b0,
                                 const Eigen::Vector3d& b1) {
    const int n = std::clamp(static_cast<int>((a1 - a0).norm() / 0.005), 1, 64);
    double best = std::numeric_limits<double>::infinity();
    const Eigen::Vector3d bb = b1 - b0;
    const double len2 = bb.squaredNorm();
    for (int i = 0; i <= n; ++i) {
      const Eigen::Vector3d p = a0 + (a1 - a0) * (static_cast<double>(i) / n);
      const double s = len2 > 1e-12 ? std::clamp((p - b0).dot(bb) / len2, 0.0, 1.0) : 0.0;
      best = std::min(best, (p - (b0 + s * bb)).norm());
    }
    return best;
  }
  static constexpr double kStrikeOver_s = 0.3;        ///< s after a strike's arrival before the same limb counts again
  static constexpr double kFistRadius_m = 0.05;       ///< m, a glove or shoe round its tracked point
  static constexpr double kForearmRadius_m = 0.05;    ///< m, the fighter's forearm capsule
  static constexpr double kHeadRadius_m = 0.12;       ///< m, round the fighter's head joint
  static constexpr double kTorsoRadius_m = 0.15;      ///< m, neck to pelvis
  struct LastSeen {
    Eigen::Vector3d p{0, 0, 0};
    Timestamp t = 0;
    bool valid = false;
  };
  ThreatWatch threats_;
  std::array<Timestamp, recognition::kRoleCount> answered_until_{};
  std::array<Timestamp, recognition::kRoleCount> contact_until_{};
  std::array<LastSeen, recognition::kRoleCount> last_seen_{};
  std::vector<FighterEvent> own_events_;
  SparScore score_;
  SparPlanner spar_;
  double strike_distance_m_ = 0.9;
  std::uint64_t updates_ = 0;
  std::unique_ptr<RetrievalWorker> worker_;  // declared last: joins first on destruction
};

}  // namespace

std::unique_ptr<Fighter> Fighter::create(const FighterConfig& config, FighterOptions options) {
  auto db = std::make_shared<const Database>(load_database(config.database));
  std::vector<Rig> rigs;
  if (!options.on_unreadable_character) {
    rigs = load_character_rigs(config);
  } else {
    FighterConfig readable = config;  // the names of the characters kept, in step with their files
    readable.characters.clear();
    readable.character_names.clear();
    readable.initial_character = 0;
    for (std::size_t i = 0; i < config.characters.size(); ++i) {
      try {
        rigs.push_back(load_character_rig(config.characters[i].string()));
      } catch (const Error& e) {
        options.on_unreadable_character(i, e.what());
        continue;
      }
      if (i < config.character_names.size() && !config.character_names[i].empty()) rigs.back().name = config.character_names[i];
      if (static_cast<int>(i) == config.initial_character)
        readable.initial_character = static_cast<int>(readable.characters.size());
      readable.characters.push_back(config.characters[i]);
      if (i < config.character_names.size()) readable.character_names.push_back(config.character_names[i]);
    }
    if (rigs.empty()) throw Error("fighter", "config", "fighter: none of its characters could be read");
    options.on_unreadable_character = nullptr;  // called during create() alone
    return std::make_unique<FighterImpl>(std::move(db), std::move(rigs), readable, std::move(options));
  }
  if (rigs.empty()) throw Error("fighter", "config", "fighter: no characters configured");
  return std::make_unique<FighterImpl>(std::move(db), std::move(rigs), config, std::move(options));
}

}  // namespace kumite::content
