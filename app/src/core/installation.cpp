#include "kumite/app/installation.hpp"

#include "kumite/app/run_control.hpp"
#include "kumite/app/session.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "kumite/common/error.hpp"
#include "kumite/content/behaviour.hpp"
#include "kumite/content/fighter.hpp"

namespace kumite::app {

namespace {

/// Recent events the console keeps.
constexpr std::size_t kRecentEvents = 12;
/// s, how often a late-latching frame looks for a pose that is late (frame_pacer.hpp).
constexpr double kLatchPoll_s = 0.00025;

class FixedHeadInput final : public TrackingInput {
 public:
  explicit FixedHeadInput(std::string why) : why_(std::move(why)) {}
  void poll(Timestamp, Timestamp, TrackingSnapshot& out) override {
    out.head.reset();
    out.measured_at = out.measured_ready_at = -1;
    out.state = TrackerState::none;
    out.frame_sets = 0;
    out.cameras.clear();
    out.source = {};
    out.bodies = {};
  }
  Timestamp clock() const override { return now(); }
  std::string describe() const override { return "none (" + why_ + ")"; }
  std::string none_why() const override { return why_; }
  bool has_tracker() const override { return false; }

 private:
  std::string why_;
};

glm::dvec3 to_glm(const Vec3& v) { return {v[0], v[1], v[2]}; }

/// The fighter's config with the characters whose files exist (`loaded`: config indices).
content::FighterConfig fighter_config(const InstallationConfig& c, const std::vector<int>& loaded) {
  content::FighterConfig f;
  f.database = c.resolve(c.fighter.database);
  for (const int i : loaded) {
    const auto& ch = c.characters[static_cast<std::size_t>(i)];
    f.characters.push_back(c.resolve(ch.bvh));
    f.character_names.push_back(ch.name);
  }
  const auto initial = std::find(loaded.begin(), loaded.end(), c.fighter.initial_character);
  f.initial_character = initial == loaded.end() ? 0 : static_cast<int>(initial - loaded.begin());
  f.home = {c.fighter.home_m[0], c.fighter.home_m[1], c.fighter.home_m[2]};
  f.strike_distance_m = c.fighter.strike_distance_m;
  f.hit_radius_m = c.fighter.hit_radius_m;
  f.visitor_head_radius_m = c.fighter.visitor_head_radius_m;
  f.visitor_body_radius_m = c.fighter.visitor_body_radius_m;
  f.min_x_m = c.fighter.x_limits_m[0];
  f.max_x_m = c.fighter.x_limits_m[1];
  f.min_z_m = c.fighter.z_limits_m[0];
  f.max_z_m = c.fighter.z_limits_m[1];
  f.behaviour = *c.fighter.behaviour;
  f.retrieval = *c.fighter.retrieval;
  f.planner = *c.fighter.planner;
  return f;
}

/// `order`: the event's order in the config's numbering (a character switch's mapped back).
FrameEvent to_frame_event(const content::FighterEvent& e, const Order& order, Timestamp start) {
  FrameEvent f;
  f.time_s = e.time - start;
  f.distance_m = e.distance_m;
  f.cause = EventCause::fighter;
  f.fighter = e;
  f.order = order;  // a strike's outcome: the strike's order
  f.type = e.kind;  // one enum: the fighter's kind is the frame event's type
  // (a warning, and the visitor's strikes met by the fighter, concern no order)
  if (e.kind == EventType::warning || e.kind == EventType::block || e.kind == EventType::blocked ||
      e.kind == EventType::visitor_hit)
    f.order.reset();
  return f;
}

/// Says which file is missing before the content module gets to it (the operator's view):
/// throws for a missing database or when no character file exists; returns one line per
/// missing character (that character is left out, its key ignored).
std::vector<std::string> check_fighter_files(const InstallationConfig& c, std::vector<int>& loaded) {
  if (c.fighter.database.empty())
    throw file_error("config", "missing_key", c.file.string(), c.line_of("fighter"),
                     "fighter.database", "no fighter database configured");
  const auto db = c.resolve(c.fighter.database);
  if (!std::filesystem::exists(db))
    throw file_error("config", "missing_file", c.file.string(), c.line_of("fighter.database"),
                     "fighter.database",
                     fmt::format("{} does not exist (made at set-up: scripts/make-demo-data.sh)",
                                 db.string()));
  if (c.characters.empty())
    throw file_error("config", "missing_key", c.file.string(), 0, "characters",
                     "no [[characters]] configured");
  std::vector<std::string> missing;
  for (std::size_t i = 0; i < c.characters.size(); ++i) {
    const auto bvh = c.resolve(c.characters[i].bvh);
    if (std::filesystem::exists(bvh)) {
      loaded.push_back(static_cast<int>(i));
      continue;
    }
    missing.push_back(file_error("config", "missing_file", c.file.string(),
                                 c.line_of(fmt::format("characters[{}].bvh", i)),
                                 fmt::format("characters[{}].bvh", i),
                                 fmt::format("character {} \"{}\": {} does not exist: left out", i + 1,
                                             c.characters[i].name, bvh.string()))
                          .what());
  }
  if (loaded.empty())
    throw file_error("config", "missing_file", c.file.string(), c.line_of("characters"), "characters",
                     "none of the character files exists");
  return missing;
}

}  // namespace

std::unique_ptr<TrackingInput> make_fixed_head_input(std::string why) {
  return std::make_unique<FixedHeadInput>(std::move(why));
}

Installation::Installation(InstallationConfig config, std::unique_ptr<TrackingInput> tracking,
                           const InstallationOptions& options)
    : config_(std::move(config)), tracking_(std::move(tracking)), start_problems_(options.problems),
      pacer_(config_.late_latch), mono_(options.mono_eyes) {
  for (const auto& w : config_.walls) walls_.push_back(wall_frame(w));
  last_good_head_.position = to_glm(config_.viewer.default_head_m);
  frame_.head = last_good_head_;
  if (!tracking_) tracking_ = make_fixed_head_input("tracking.source = \"none\"");
  // An orders script that cannot be read (missing, unreadable, a bad row) takes out the
  // scripted orders alone: one error line naming its file and line, a console problem; the
  // supervisor's keys, the walls and the fighter go on.
  std::optional<std::filesystem::path> script = options.orders_script;
  if (!script && config_.orders_script) script = config_.resolve(*config_.orders_script);
  if (script) {
    try {
      script_ = OrderScript(load_orders_script(*script), 0);
    } catch (const Error& e) {
      script_problem_ = std::string("orders script off: ") + e.what();
      spdlog::error("{}", script_problem_);
    }
  }
  // A missing database or character is not: the walls still draw, the console says why.
  try {
    std::vector<int> loaded;
    missing_characters_ = check_fighter_files(config_, loaded);
    for (const auto& m : missing_characters_) spdlog::error("{}", m);
    // A character file that is there but cannot be read (cut, damaged) leaves that character
    // out, as a missing one does: the others fight.
    content::FighterOptions fo;
    std::vector<std::size_t> unreadable;  // indices into `loaded`
    fo.on_unreadable_character = [&](std::size_t k, const std::string& why) {
      const int i = loaded[k];
      missing_characters_.push_back(file_error("config", "character", config_.file.string(),
                                               config_.line_of(fmt::format("characters[{}].bvh", i)),
                                               fmt::format("characters[{}].bvh", i),
                                               fmt::format("character {} \"{}\" left out: {}", i + 1,
                                                           config_.characters[static_cast<std::size_t>(i)].name, why))
                                        .what());
      spdlog::error("{}", missing_characters_.back());
      unreadable.push_back(k);
    };
    fighter_ = content::Fighter::create(fighter_config(config_, loaded), std::move(fo));
    fighter_orders_.reserve(16);
    visitor_bodies_.reserve(recognition::kRoleCount);
    visitor_strikes_.reserve(FrameCapacity{}.strikes);
    for (auto k = unreadable.rbegin(); k != unreadable.rend(); ++k) loaded.erase(loaded.begin() + static_cast<std::ptrdiff_t>(*k));
    fighter_of_config_.assign(config_.characters.size(), -1);
    for (std::size_t k = 0; k < loaded.size(); ++k) {
      fighter_of_config_[static_cast<std::size_t>(loaded[k])] = static_cast<int>(k);
      config_of_fighter_.push_back(loaded[k]);
    }
    skeletons_.resize(loaded.size());
  } catch (const std::exception& e) {
    fighter_problem_ = std::string("no fighter: ") + e.what();
    spdlog::error("{}", fighter_problem_);
  }
  frame_.views.resize(walls_.size());
  kept_walls_.assign(walls_.size(), 0);
}

Installation::~Installation() = default;

std::optional<content::PlannerStatus> Installation::planner_status() const {
  if (!fighter_) return std::nullopt;
  return fighter_->planner_status();
}

int Installation::character_count() const { return static_cast<int>(config_.characters.size()); }

std::string Installation::character_name(int index) const {
  return index >= 0 && index < static_cast<int>(config_.characters.size())
             ? config_.characters[static_cast<std::size_t>(index)].name
             : "?";
}

void Installation::start(Timestamp t) {
  start_ = t;
  last_step_ = t;
  if (recorder_) recorder_->started(t, tracking_->has_tracker(), 0, tracking_->camera_names());
  tracking_->record_frame_sets(recorder_);  // ends the tracker's pre-roll of camera frames
  script_.restart(t);
  started_ = true;
  script_waits_ = tracking_->has_tracker() && script_.remaining() > 0;
  if (script_waits_)
    spdlog::info("orders script: its times count from the first frame with the head tracked (at most {:.0f} s)",
                 kScriptWaitForHead_s);
}

void Installation::order(const Order& o) { pending_.push_back(o); }

FrameCapacity Installation::frame_capacity() const {
  FrameCapacity c;
  c.joints = fighter_ ? fighter_->most_joints() : 0;
  c.items = most_fighter_items(c.joints) + kMostWallGlowItems;
  c.walls = walls_.size();
  c.cameras = tracking_->camera_names().size();
  return c;
}

void Installation::record_to(SessionRecorder* recorder) {
  if (recorder && recorder != recorder_) recorder->reserve(frame_capacity());
  if (recorder && recorder != recorder_ && started_) recorder->started(start_, tracking_->has_tracker(), steps_, tracking_->camera_names());
  tracking_->record_frame_sets(recorder);
  recorder_ = recorder;
}

Timestamp Installation::latch(Timestamp start, Timestamp deadline) {
  const PoseTiming at_start = tracking_->pose_timing(start);
  last_window_ = pacer_.window(start, deadline, at_start);
  if (const auto& w = last_window_) {
    // Until the pose looked for is out (poses may be skipped: any as new will do), or
    // drawing must begin.
    const std::uint64_t wanted = at_start.newest + static_cast<std::uint64_t>(w->poses);
    sleep_until(w->first);
    for (Timestamp t = kumite::now(); t < w->last && tracking_->pose_timing(t).newest < wanted; t = kumite::now())
      std::this_thread::sleep_for(std::chrono::duration<double>(std::min(kLatchPoll_s, w->last - t)));
  }
  const Timestamp t = kumite::now();
  latch_ms_ = std::max(0.0, t - start) * 1e3;
  return t;
}

void Installation::note(const FrameEvent& e) {
  frame_.events.push_back(e);
  // Events are rare (orders, contacts, character switches): kept whole for the console.
  recent_.push_back(e);
  while (recent_.size() > kRecentEvents) recent_.pop_front();
  // The console's last order and its outcome: an order (accepted or ignored), or a strike's
  // outcome with the strike's own order (an order ignored meanwhile must not take it).
  if (e.type == EventType::order_accepted || e.type == EventType::order_ignored || is_strike_outcome(e.type)) last_order_ = e;
  // The service log's line (an event is rare: a few a minute).
  if (e.type == EventType::warning || e.type == EventType::order_ignored || e.type == EventType::visitor_near_wall)
    spdlog::warn("{}", event_line(e));
  else
    spdlog::info("{}", event_line(e));
}

void Installation::update_head(Timestamp now, Timestamp shown_at) {
  // The head as it will be when the visitor sees this frame: at its vsync, plus the time
  // the projectors take to show it.
  const Timestamp seen_at = std::max(now, shown_at) + config_.display_latency_ms * 1e-3;
  frame_.predicted_ahead_ms = (seen_at - now) * 1e3;
  if (replaying_) {
    input_.tracking = replaying_->tracking;
    input_.tracking_clock = replaying_->tracking_clock;
  } else {
    tracking_->poll(now, seen_at, input_.tracking);
  }
  const TrackingSnapshot& snap = input_.tracking;
  // Pose age: the newest head measurement's camera time to now, the moment this frame takes
  // the head for rendering (the draw follows at once), tracked or not.
  if (!replaying_) input_.tracking_clock = snap.measured_at >= 0 ? tracking_->clock() : -1;
  const double age_s = snap.measured_at >= 0 ? input_.tracking_clock - snap.measured_at : -1;
  frame_.pose_age_ms = age_s >= 0 ? age_s * 1e3 : -1;
  frame_.pose_measured_at = snap.measured_at;
  // Split only while the head is tracked: a coasting pose's age also holds the sets that
  // missed it, which is neither tracking latency nor waiting for the display.
  const bool tracked_now = snap.head && snap.head->status == TrackingStatus::tracked;
  frame_.tracking_latency_ms = tracked_now && age_s >= 0 && snap.measured_ready_at >= snap.measured_at
                                   ? (snap.measured_ready_at - snap.measured_at) * 1e3
                                   : -1;
  bool live = false;
  if (snap.head && snap.head->status != TrackingStatus::lost && age_s >= 0) {
    markers_seen_ = snap.head->markers;
    if (age_s <= config_.tracking.lost_after_s) {
      const auto& p = snap.head->position;
      const auto& q = snap.head->orientation;
      last_good_head_.position = {p[0], p[1], p[2]};
      last_good_head_.orientation = glm::normalize(glm::dquat(q[0], q[1], q[2], q[3]));
      live = true;
    }
  } else {
    markers_seen_ = snap.head ? snap.head->markers : 0;
  }
  frame_.head_live = live;
  // While the source loads (a recording's preload) no camera has given a frame yet: that is
  // loading, not a camera fault. The log says when a camera's state changes (a black or
  // covered camera, one that stops or comes back): one line each way, not one per frame.
  if (!tracking_->loading()) {
    camera_states_.resize(snap.cameras.size());
    for (std::size_t i = 0; i < snap.cameras.size(); ++i) {
      const CameraState c = snap.cameras[i].state;
      if (camera_states_[i] == c) continue;
      if (c != CameraState::ok)
        spdlog::warn("camera {}: {}", camera_name(i), to_string(c));  // e.g. "sees no markers while others see the head"
      else if (camera_states_[i])
        spdlog::info("camera {}: ok again", camera_name(i));
      camera_states_[i] = c;
    }
  }
  frame_.head = last_good_head_;
  const double ipd = mono_ ? 0.0 : config_.viewer.interpupillary_distance_m;
  frame_.eyes = eyes_from_head(frame_.head, ipd, to_glm(config_.viewer.eye_offset_m));
}

void Installation::apply_orders(Timestamp now) {
  due_.clear();
  if (script_waits_) {
    const double waited = now - start_;
    if (frame_.head_live || waited >= kScriptWaitForHead_s) {
      script_waits_ = false;
      script_waited_s_.reset();
      script_.restart(now);
      spdlog::info("orders script: starts {:.2f} s into the run ({})", waited,
                   frame_.head_live ? "head tracked" : "the head is still not tracked");
    } else {
      script_waited_s_ = waited;
    }
  }
  if (!script_waits_) script_.due(now, due_);
  due_.insert(due_.end(), pending_.begin(), pending_.end());
  pending_.clear();
  for (const Order& o : due_) {
    FrameEvent e;
    e.time_s = now - start_;
    e.order = o;
    if (o.kind == OrderKind::pause) paused_ = true;
    if (o.kind == OrderKind::resume) paused_ = false;
    if (!fighter_) {
      e.type = EventType::order_ignored;
      e.cause = EventCause::no_fighter;
      note(e);
      continue;
    }
    if (o.kind == OrderKind::select_character &&
        (o.character < 0 || o.character >= character_count())) {
      e.type = EventType::order_ignored;
      e.cause = EventCause::no_such_character;
      note(e);
      continue;
    }
    Order timed = o;
    timed.time = now;
    if (o.kind == OrderKind::select_character) {  // config numbering -> the fighter's
      timed.character = fighter_of_config_[static_cast<std::size_t>(o.character)];
      if (timed.character < 0) {
        e.type = EventType::order_ignored;
        e.cause = EventCause::character_not_loaded;
        note(e);
        continue;
      }
    }
    fighter_orders_.push_back(timed);  // the fighter takes them with its update (FighterInput)
  }
}

void Installation::update_fighter(Timestamp now, double dt) {
  frame_.items.clear();
  FighterPose& pose = frame_.fighter;
  pose.present = static_cast<bool>(fighter_);
  if (!fighter_) {
    pose.joints.clear();
    pose.local_rotations.clear();
    pose.skeleton.reset();
    pose.target.reset();
    frame_.spar.reset();
    return;
  }
  // The fighter's whole input as plain data: the orders this frame took, the eyes' midpoint,
  // visitor safety as of the last frame (update_safety runs after the fighter: back off), the
  // visitor's tracked head and the strikes recognised since the last frame.
  const glm::dvec3 mid = (frame_.eyes.left + frame_.eyes.right) * 0.5;
  content::FighterInput in;
  in.now = now;
  in.dt_s = dt;
  in.head_m = Eigen::Vector3d(mid.x, mid.y, mid.z);
  in.keep_away = near_wall_.has_value();
  in.orders = fighter_orders_;
  in.seed = config_.fighter.planner_seed;
  // Every body the source has (glasses, gloves, shoes), in role order, as measured: its pose
  // and the time it was measured; a body lost goes on with its last pose, tracked = false.
  visitor_bodies_.clear();
  for (std::size_t r = 0; r < input_.tracking.bodies.size(); ++r) {
    const auto& p = input_.tracking.bodies[r];
    if (!p) continue;
    content::VisitorBody b;
    b.role = static_cast<recognition::Role>(r);
    b.position_m = Eigen::Vector3d(p->position[0], p->position[1], p->position[2]);
    b.orientation = Eigen::Quaterniond(p->orientation[0], p->orientation[1], p->orientation[2], p->orientation[3]);
    b.tracked = p->status != TrackingStatus::lost;
    b.t = p->timestamp;
    visitor_bodies_.push_back(b);
  }
  in.bodies = visitor_bodies_;
  visitor_strikes_.clear();
  for (const VisitorStrike& st : input_.tracking.strikes) {
    content::VisitorStrikeSeen v;
    v.t = st.t;
    v.type = st.type;
    v.limb = st.limb;
    v.action = st.action;
    v.progress = st.progress;
    v.confidence = st.confidence;
    v.impact_m = Eigen::Vector3d(st.impact[0], st.impact[1], st.impact[2]);
    visitor_strikes_.push_back(v);
  }
  in.strikes = visitor_strikes_;
  const bool leaving_spar = std::any_of(fighter_orders_.begin(), fighter_orders_.end(),
                                        [](const Order& o) { return o.kind == OrderKind::orders_only; }) &&
                            fighter_->planner_status().mode == content::PlannerMode::spar;
  fighter_->step(in, fighter_out_);
  fighter_orders_.clear();
  if (leaving_spar) log_spar_summary(*this);  // the round ends
  note_spar(fighter_->planner_status());
  const content::FighterFrame& f = fighter_out_.frame;
  const int character = config_of_fighter_.at(static_cast<std::size_t>(f.character));
  plan_fighter(f, character_colour(character), frame_.items);
  copy_pose(f, character, pose);
  for (const auto& e : fighter_out_.events) {
    Order order = e.order;
    if (order.kind == OrderKind::select_character && order.character >= 0 &&
        order.character < static_cast<int>(config_of_fighter_.size()))  // back to config numbering
      order.character = config_of_fighter_[static_cast<std::size_t>(order.character)];
    note(to_frame_event(e, order, start_));
  }
}

void Installation::note_spar(const content::PlannerStatus& st) {
  if (st.mode != content::PlannerMode::spar) {
    frame_.spar.reset();
    return;
  }
  const auto& sc = st.score;
  frame_.spar = SparFrame{.state = st.state,
                          .visitor_hits = sc.visitor_hits,
                          .visitor_dodges = sc.visitor_dodges,
                          .fighter_hits = sc.fighter_hits,
                          .blocks = sc.blocks,
                          .blocks_late = sc.blocks_late,
                          .blocked = sc.blocked,
                          .unanswered = sc.unanswered};
}

void Installation::copy_pose(const content::FighterFrame& f, int character, FighterPose& pose) {
  auto& skeleton = skeletons_.at(static_cast<std::size_t>(f.character));
  if (!skeleton) {  // once per character
    auto s = std::make_shared<FighterSkeleton>();
    s->character = character;
    s->character_name = character_name(character);
    s->joint_names.assign(f.joint_names.begin(), f.joint_names.end());
    // The log keys joints by name: a name a skeleton repeats gets "#<index>" added.
    for (std::size_t j = 0; j < s->joint_names.size(); ++j)
      if (std::count(s->joint_names.begin(), s->joint_names.end(), s->joint_names[j]) > 1)
        s->joint_names[j] += fmt::format("#{}", j);
    s->parents.assign(f.parents.begin(), f.parents.end());
    skeleton = std::move(s);
  }
  if (pose.skeleton != skeleton) {  // a switch: room for the largest character once
    pose.skeleton = skeleton;
    const std::size_t most = std::max(fighter_ ? fighter_->most_joints() : 0, f.joints.size());
    pose.joints.reserve(most);
    pose.local_rotations.reserve(most);
  }
  pose.state = f.state;
  pose.character = character;
  pose.joints.resize(f.joints.size());
  for (std::size_t j = 0; j < f.joints.size(); ++j) pose.joints[j] = {f.joints[j].x(), f.joints[j].y(), f.joints[j].z()};
  pose.local_rotations.resize(f.local_rotations.size());
  for (std::size_t j = 0; j < f.local_rotations.size(); ++j) {
    const auto& q = f.local_rotations[j];
    pose.local_rotations[j] = glm::dquat(q.w(), q.x(), q.y(), q.z());
  }
  pose.root_joint = {f.root_joint.x(), f.root_joint.y(), f.root_joint.z()};
  if (f.target)
    pose.target = glm::dvec3(f.target->x(), f.target->y(), f.target->z());
  else
    pose.target.reset();
  pose.root = glm::dvec3(f.root.x(), f.root.y(), f.root.z());
  pose.heading_rad = f.heading_rad;
}

void log_retrieval_timing(const Installation& inst) {
  const content::RetrievalTiming t = inst.retrieval_timing();
  spdlog::info("fighter: {} strike plan(s), each applied {} update(s) after its order; {} playback rate(s), each {} "
               "update(s) after its strike began (longest solve {:.0f} µs); {} update(s) waited for the retrieval "
               "worker (longest {:.3f} ms, {:.3f} ms in all)",
               t.requests, content::kRetrievalDelayUpdates, t.rate_jobs, content::kStrikeRateDelayUpdates,
               t.rate_solve_max_us, t.waits, t.wait_max_ms, t.wait_total_ms);
}

void log_spar_summary(const Installation& inst) {
  const auto st = inst.planner_status();
  if (!st) return;
  const auto& sc = st->score;
  const auto& c = st->counts;
  if (st->mode != content::PlannerMode::spar && c.engaged_s <= 0 && sc == content::SparScore{}) return;
  spdlog::info("spar round: {:.0f} s engaged; the visitor hit {} time(s), dodged {}; the fighter hit {} time(s), attacked {}, "
               "countered {}; blocks {} ({} late, {} met the fist{}), threats unanswered {}",
               c.engaged_s, sc.visitor_hits, sc.visitor_dodges, sc.fighter_hits, c.attacks, c.counters, sc.blocks, sc.blocks_late,
               sc.blocked, st->block ? "" : "; blocks off", sc.unanswered);
}

content::RetrievalTiming Installation::retrieval_timing() const {
  return fighter_ ? fighter_->retrieval_timing() : content::RetrievalTiming{};
}

const FrameData& Installation::step(Timestamp now, Timestamp shown_at) {
  if (!started_) start(now);
  const double dt = std::max(0.0, now - last_step_);
  last_step_ = now;
  const Timestamp cpu0 = kumite::now();
  frame_.frame = steps_++;
  input_.now = now;
  input_.shown_at = shown_at;
  input_.keyed.assign(pending_.begin(), pending_.end());
  if (replaying_) latch_ms_ = replaying_->latch_ms;
  input_.latch_ms = latch_ms_;
  frame_.events.clear();
  frame_.now = now;
  frame_.time_s = now - start_;
  update_head(now, shown_at);
  // The visitor's strikes the recognition thread published since the last frame (issue 14):
  // events of this frame, for the log, the console and, next, the fighter's answers.
  for (const VisitorStrike& k : input_.tracking.strikes) {
    FrameEvent e;
    e.type = EventType::visitor_strike;
    e.cause = EventCause::visitor;
    e.time_s = now - start_;
    e.strike = k;
    note(e);
  }
  // A wall whose plane an eye is on or behind keeps its last good view (kept_walls_: said
  // by the console).
  plan_views(walls_, frame_.eyes, config_.projection.near_m, config_.projection.far_m, frame_.views, kept_walls_);
  apply_orders(now);
  update_fighter(now, dt);
  update_safety(now);
  // Frame rate from the smoothed frame time (the first step after start() has no interval).
  if (frame_.frame > 0 && dt > 0)
    dt_filtered_ = dt_filtered_ == 0 ? dt : 0.9 * dt_filtered_ + 0.1 * dt;
  frame_.latch_ms = latch_ms_;
  latch_ms_ = 0;  // a loop that does not call latch() takes the pose at the frame's start
  // Recording (when on) counts in the step's CPU time: hashing the state and queueing a copy.
  if (recorder_) recorder_->push(frame_.frame, input_, state_hashes(frame_), frame_);
  frame_cpu_ms_ = (kumite::now() - cpu0) * 1e3;
  return frame_;
}

const FrameData& Installation::replay(const FrameInput& input) {
  pending_ = input.keyed;
  replaying_ = &input;
  try {
    step(input.now, input.shown_at);
  } catch (...) {
    replaying_ = nullptr;
    throw;
  }
  replaying_ = nullptr;
  return frame_;
}

void Installation::update_safety(Timestamp now) {
  frame_.visitor_near_wall.reset();
  if (!config_.safety.enabled) return;
  const double limit = config_.safety.wall_distance_m;
  constexpr double kClearMargin_m = 0.10;  // hysteresis: clear only this much further out
  const auto event = [&](EventType type, int wall, double distance, bool outside, bool lost) {
    FrameEvent e;
    e.type = type;
    e.cause = EventCause::visitor;
    e.wall = wall;
    e.distance_m = distance;
    e.outside = outside;
    e.lost = lost;
    e.time_s = now - start_;
    note(e);
  };
  if (!frame_.head_live) {
    // Lost near a wall: the visitor most likely walked out of the cameras' view there.
    if (near_wall_ && !near_wall_->lost) {
      near_wall_->lost = true;
      event(EventType::visitor_near_wall, near_wall_->wall, near_wall_->distance_m, near_wall_->outside, true);
    }
  } else {
    // The nearest vertical wall, by the head's signed distance to its plane (positive on the
    // room's side: the side the default head position is on).
    const glm::dvec3 head = frame_.head.position;
    const glm::dvec3 inside{config_.viewer.default_head_m[0], config_.viewer.default_head_m[1],
                            config_.viewer.default_head_m[2]};
    int best = -1;
    double best_d = 0;
    for (std::size_t w = 0; w < walls_.size(); ++w) {
      const WallFrame& wf = walls_[w];
      if (std::abs(wf.vn.y) > 0.5) continue;  // the floor (or a ceiling): not a wall to walk into
      const double side = glm::dot(inside - wf.pa, wf.vn) >= 0 ? 1.0 : -1.0;
      const double d = side * glm::dot(head - wf.pa, wf.vn);
      if (best < 0 || d < best_d) {
        best = static_cast<int>(w);
        best_d = d;
      }
    }
    const bool was = near_wall_.has_value();
    const bool near = best >= 0 && (best_d < limit || (was && best_d < limit + kClearMargin_m));
    if (near) {
      const bool changed = !was || near_wall_->wall != best || near_wall_->lost || near_wall_->outside != (best_d < 0);
      near_wall_ = VisitorNearWall{best, best_d, best_d < 0, false};
      if (changed) event(EventType::visitor_near_wall, best, best_d, best_d < 0, false);
    } else if (was) {
      event(EventType::visitor_clear, best, best_d, false, false);
      near_wall_.reset();
    }
  }
  frame_.visitor_near_wall = near_wall_;
  if (!near_wall_) return;
  const auto& v = *near_wall_;
  // The glow on that wall, brighter the closer (full at the wall, or when out or lost).
  const double strength = v.lost || v.outside ? 1.0 : std::clamp(1.0 - v.distance_m / limit, 0.25, 1.0);
  plan_wall_glow(walls_[static_cast<std::size_t>(v.wall)], frame_.head.position, strength, frame_.items);
}

std::string Installation::event_text(const FrameEvent& e) const {
  const auto wall_name = [&](int w) {
    return w >= 0 && w < static_cast<int>(config_.walls.size()) ? config_.walls[static_cast<std::size_t>(w)].name
                                                                 : std::string("-");
  };
  const int character = e.order ? e.order->character : -1;
  switch (e.cause) {
    case EventCause::no_fighter: return fighter_problem_;
    case EventCause::no_such_character:
      return fmt::format("character {} does not exist ({} characters)", character + 1, character_count());
    case EventCause::character_not_loaded:
      return fmt::format("character {} \"{}\" is not loaded (its file is missing)", character + 1,
                         character_name(character));
    case EventCause::visitor:
      if (e.type == EventType::visitor_strike) return describe(e.strike);
      if (e.type == EventType::visitor_clear)
        return fmt::format("the visitor is clear of the walls again ({:.2f} m from the nearest, {})", e.distance_m,
                           wall_name(e.wall));
      if (e.lost)
        return fmt::format("the visitor left the tracked area near wall {} (last seen {:.2f} m from it)",
                           wall_name(e.wall), e.distance_m);
      if (e.outside)
        return fmt::format("the visitor is beyond wall {} ({:.2f} m): out of the room", wall_name(e.wall), -e.distance_m);
      return fmt::format("the visitor is {:.2f} m from wall {} (limit {:.2f} m)", e.distance_m, wall_name(e.wall),
                         config_.safety.wall_distance_m);
    case EventCause::fighter:
      if (e.type == EventType::character_changed)  // the config's numbering and names
        return fmt::format("character {} ({})", character + 1, character_name(character));
      return fighter_ ? fighter_->describe(e.fighter) : std::string();
  }
  return "?";
}

std::string Installation::event_line(const FrameEvent& e) const {
  std::string line = fmt::format("{:7.2f} s  {}", e.time_s, to_string(e.type));
  if (e.order) line += " " + to_string(*e.order);
  if (const std::string text = event_text(e); !text.empty()) line += ": " + text;
  return line;
}

std::string Installation::camera_name(std::size_t i) const {
  const auto& names = tracking_->camera_names();
  return i < names.size() ? names[i] : fmt::format("cam{}", i);
}

ConsoleState Installation::console(const FrameData& shown) const {
  ConsoleState c;
  const TrackingSnapshot& snap = input_.tracking;
  c.fps = dt_filtered_ > 0 ? 1.0 / dt_filtered_ : 0;
  c.frame_cpu_ms = frame_cpu_ms_;
  c.tracking = describe(snap, tracking_->none_why());
  c.tracking_source = describe(snap.source);
  if (c.tracking_source.empty()) c.tracking_source = tracking_->source_line();
  if (const RecognitionStats& r = snap.recognition; r.running)
    c.recognition = fmt::format("strike recognition: {} pose samples, {} events{}", r.samples, r.events,
                                r.dropped + r.events_dropped > 0
                                    ? fmt::format(" ({} samples, {} events dropped)", r.dropped, r.events_dropped)
                                    : std::string());
  for (std::size_t i = 0; i < snap.cameras.size(); ++i) {
    const CameraView& v = snap.cameras[i];
    c.cameras.push_back({camera_name(i), v.state, std::string(to_string(v.state)), v.blobs, v.since_last_ms});
  }
  c.markers_seen = markers_seen_;
  c.head_live = frame_.head_live;
  c.pose_age_ms = frame_.pose_age_ms;
  c.tracking_latency_ms = frame_.tracking_latency_ms;
  c.latch_ms = frame_.latch_ms;
  c.late_latch = pacer_.enabled();
  const auto budget = pacer_.draw_budget_s();
  c.draw_budget_ms = budget ? *budget * 1e3 : -1;
  c.fighter_state = frame_.fighter.present ? std::string(content::to_string(frame_.fighter.state)) : "none";
  c.character = frame_.fighter.character;
  c.character_name = character_name(frame_.fighter.character);
  c.paused = paused_;
  if (const auto& last = last_order_) {
    c.last_order = last->order ? to_string(*last->order) : std::string();
    c.last_outcome = last->type == EventType::order_accepted           ? std::string("accepted")
                     : last->type == EventType::order_ignored ? "ignored: " + event_text(*last)
                                                              : fmt::format("{} ({:.2f} m)", to_string(last->type),
                                                                            last->distance_m);
  }
  if (fighter_) c.planner = planner_line();
  for (const auto& e : recent_) c.recent.push_back(event_line(e));
  for (const auto& e : shown.events) c.frame_events.push_back(event_text(e));

  c.problems = problems();
  return c;
}

std::vector<std::string> Installation::problems() const {
  std::vector<std::string> p;
  const TrackingSnapshot& snap = input_.tracking;
  const bool loading = tracking_->loading();
  if (const auto s = source_problem(snap.source)) p.push_back(*s);
  if (!frame_.head_live && config_.tracking.source != TrackingSource::none && !loading)
    p.push_back(fmt::format("head not tracked ({}): walls drawn from the last good head position",
                            describe(snap, tracking_->none_why())));
  if (!loading)
    for (std::size_t i = 0; i < snap.cameras.size(); ++i)
      if (snap.cameras[i].state != CameraState::ok)
        p.push_back(fmt::format("camera {}: {}", camera_name(i), to_string(snap.cameras[i].state)));
  std::vector<std::string> past;  // rare: the eye went through these walls
  for (std::size_t w = 0; w < walls_.size() && w < kept_walls_.size(); ++w)
    if (kept_walls_[w]) past.push_back(config_.walls[w].name);
  if (!past.empty())
    p.push_back(fmt::format("an eye is on or behind the plane of wall(s) {}: drawn from their last good view",
                            fmt::join(past, ", ")));
  if (script_waited_s_)
    p.push_back(fmt::format("orders script waits for the head to be tracked ({:.0f} s of at most {:.0f} s)",
                            *script_waited_s_, kScriptWaitForHead_s));
  for (const auto& f : tracking_->faults()) p.push_back(f);
  if (!script_problem_.empty()) p.push_back(script_problem_);
  p.insert(p.end(), start_problems_.begin(), start_problems_.end());
  if (!fighter_) p.push_back(fighter_problem_);
  if (fighter_)
    for (const auto& m : missing_characters_) p.push_back(m);
  if (const auto& v = frame_.visitor_near_wall) {
    const std::string& wall = config_.walls[static_cast<std::size_t>(v->wall)].name;
    p.push_back(v->lost      ? fmt::format("visitor: left the tracked area near wall {}", wall)
                : v->outside ? fmt::format("visitor: beyond wall {} ({:.2f} m)", wall, -v->distance_m)
                             : fmt::format("visitor: {:.2f} m from wall {}", v->distance_m, wall));
  }
  if (recorder_ && (recorder_->dropped() > 0 || recorder_->budget_reached())) p.push_back(recorder_->status_line());
  if (const RecognitionStats& r = snap.recognition; r.running && (r.dropped > 0 || r.events_dropped > 0))
    p.push_back(fmt::format("recognition: behind: {} pose samples and {} events dropped of {} and {}", r.dropped,
                            r.events_dropped, r.samples + r.dropped, r.events + r.events_dropped));
  return p;
}

bool Installation::has_tracker() const { return tracking_->has_tracker(); }
bool Installation::tracking_follows_frames() const { return tracking_->follows_simulated_clock(); }
bool Installation::tracking_loading() const { return tracking_->loading(); }

bool Installation::quit_key(Timestamp now) {
  if (config_.console.quit_confirm_s <= 0 || (quit_armed_until_ && now <= *quit_armed_until_)) {
    quit_ = true;
    quit_armed_until_.reset();
    spdlog::info("quit: by the supervisor");
    return true;
  }
  quit_armed_until_ = now + config_.console.quit_confirm_s;
  spdlog::info("quit: armed; press the quit key again within {:g} s to end the show", config_.console.quit_confirm_s);
  return false;
}

std::optional<Timestamp> Installation::quit_armed_until(Timestamp now) const {
  if (quit_armed_until_ && now <= *quit_armed_until_) return quit_armed_until_;
  return std::nullopt;
}

std::string Installation::planner_line() const {
  const auto st = planner_status();
  if (!st) return "no fighter";
  if (st->mode == content::PlannerMode::orders) return "orders: only what the supervisor orders";
  std::string line = fmt::format("spar  {}", content::to_string(st->state));
  if (st->next)
    line += fmt::format("  next {} ({}) in {:.1f} s", to_string(st->next->kind), content::to_string(st->next->cause),
                        std::max(0.0, st->next->due - fighter_out_.frame.time));
  line += fmt::format("  attacks {}  counters {}", st->counts.attacks, st->counts.counters);
  // The score: the visitor's hits and dodges, the fighter's hits and blocks (blocked: fists met).
  const auto& sc = st->score;
  line += fmt::format("  score: visitor hits {} dodges {}, fighter hits {} blocks {}{}", sc.visitor_hits, sc.visitor_dodges,
                      sc.fighter_hits, sc.blocks, st->block ? fmt::format(" (met {})", sc.blocked) : " (off)");
  return line;
}

}  // namespace kumite::app
