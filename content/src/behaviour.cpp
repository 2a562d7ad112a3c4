#include "kumite/content/behaviour.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>

#include "kumite/common/error.hpp"
#include "kumite/content/bvh.hpp"
#include "kumite/content/canonical.hpp"

namespace kumite::content {

using CJ = CanonicalJoint;
using Eigen::Vector2d;
using Eigen::Vector3d;

namespace {
double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}
double wrap(double a) { return std::remainder(a, 2 * std::numbers::pi); }
/// Segment time t as the frame before it and the share of the way to the next (clamped to the clip).
struct FramePair {
  std::size_t i0;
  double a;
};
FramePair frame_pair(const MotionSegment& seg, double t) {
  const double x = std::clamp(t / seg.frame_time_s, 0.0, static_cast<double>(seg.frame_count() - 1));
  const int i0 = std::min(static_cast<int>(x), seg.frame_count() - 2);
  return {static_cast<std::size_t>(i0), x - i0};
}
/// The clip's root on the floor at segment time t (clip coordinates, linear between frames).
Vector2d root_at(const MotionSegment& seg, double t) {
  const auto [i0, a] = frame_pair(seg, t);
  return (1 - a) * seg.frames[i0].root_xz_m + a * seg.frames[i0 + 1].root_xz_m;
}
/// The floor under a rig's rest pose: its lowest ankle or toe joint (m, rig frame).
double rest_floor_y(const Rig& rig) {
  const CanonicalPose& r = rig.rest_pose;
  return std::min({at(r, CanonicalJoint::l_ankle).y(), at(r, CanonicalJoint::l_toe).y(), at(r, CanonicalJoint::r_ankle).y(),
                   at(r, CanonicalJoint::r_toe).y()});
}
/// The integral of the release weight 1 - smoothstep(x) from 0 to x (x in [0, 1]).
double eased_integral(double x) { return x - x * x * x + 0.5 * x * x * x * x; }
int group_of(const Effector& e) { return e.side + 2 * (e.leg ? 1 : 0); }
std::optional<Effector> effector_of(OrderKind k) {
  switch (k) {
    case OrderKind::punch_left: return Effector{kLeft, false};
    case OrderKind::punch_right: return Effector{kRight, false};
    case OrderKind::kick_left: return Effector{kLeft, true};
    case OrderKind::kick_right: return Effector{kRight, true};
    default: return std::nullopt;
  }
}
Rig actor_rig(const Database& db) { return make_rig(db.actor_skeleton, {}, db.actor_name); }
}  // namespace

// ---- StrikePlanner ----------------------------------------------------------------------

StrikePlanner::StrikePlanner(std::shared_ptr<const Database> db, RetrievalTunables tunables)
    : db_(std::move(db)), actor_(actor_rig(*db_)), tunables_(tunables) {}

RetrievalQuery StrikePlanner::make_query(const StrikeRequest& r) const {
  const double k = db_->actor.leg_length_m / r.character_leg_length_m;
  // Retarget onto the actor: MKM is normalised already except the root's horizontal
  // displacement, which scales with leg length (about the current root).
  MkmFrame now = r.now, before = r.before;
  before.root_xz_m = now.root_xz_m + (before.root_xz_m - now.root_xz_m) * k;
  CanonicalPose pn, pb;
  decode_canonical(actor_, now, pn);
  decode_canonical(actor_, before, pb);
  RetrievalQuery q;
  q.group = r.group;
  pose_features(pn, pb, r.dt_s, ground_frame_of(pn), db_->actor.leg_length_m, db_->velocity_weight_s, q.features);
  q.target_m = (r.target_local_m * k).cast<float>();
  return q;
}

StrikePlan StrikePlanner::plan(const StrikeRequest& r) const {
  const auto t0 = std::chrono::steady_clock::now();
  const RetrievalQuery q = make_query(r);
  StrikePlan p;
  p.id = r.id;
  p.choice = retrieve(db_->index, q, tunables_);
  if (p.choice.row >= 0) {
    const auto row = static_cast<std::size_t>(p.choice.row);
    p.segment = db_->index.segment[row];
    p.start_frame = db_->index.start_frame[row];
    p.contact_frame = db_->index.window_first[row] + p.choice.window_sample * db_->index.window_stride[row];
  }
  p.retrieval_us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
  return p;
}

// ---- Behaviour --------------------------------------------------------------------------

Behaviour::Behaviour(std::shared_ptr<const Database> db, std::vector<Rig> characters, const FighterConfig& config)
    : db_(std::move(db)), characters_(std::move(characters)), config_(config), tun_(config.behaviour),
      feet_(config.behaviour.feet) {
  validate(config.behaviour, config.retrieval);
  if (characters_.empty()) throw Error("fighter", "config", "no characters to show");
  if (db_->segments.empty()) throw Error("fighter", "database", "the motion database has no segments");
  character_ = std::clamp(config.initial_character, 0, character_count() - 1);
  rest_segment_ = find_segment(*db_, SegmentKind::rest).value_or(0);
  std::size_t max_joints = 0;
  for (const Rig& r : characters_) max_joints = std::max(max_joints, static_cast<std::size_t>(r.joint_count()));
  local_.resize(max_joints);
  global_.resize(max_joints);
  rig_positions_.resize(max_joints);
  positions_.resize(max_joints);
  switch_offset_.assign(max_joints, Vector3d::Zero());
  eased_.cum.reserve(256);  // a release of 0.25 s holds ~32 frames: no allocation while playing
  spot_xz_m_ = {config.home.x(), config.home.z()};
  facing_rad_ = 0;
  use_synchronous_planner(std::make_shared<StrikePlanner>(db_, config.retrieval));
  start_rest(0);
  blend_elapsed_s_ = 1e9;
}

void Behaviour::set_planner(Submit submit, Poll poll) {
  submit_ = std::move(submit);
  poll_ = std::move(poll);
}

void Behaviour::use_synchronous_planner(std::shared_ptr<const StrikePlanner> planner) {
  sync_planner_ = std::move(planner);
  submit_ = [this](const StrikeRequest& r) { sync_results_.push_back(sync_planner_->plan(r)); };
  poll_ = [this]() -> std::optional<StrikePlan> {
    if (sync_results_.empty()) return std::nullopt;
    StrikePlan p = sync_results_.front();
    sync_results_.pop_front();
    return p;
  };
}

void Behaviour::order(const Order& o) { orders_.emplace_back(o, std::nullopt); }
void Behaviour::keep_away(bool on) { keep_away_ = on; }
void Behaviour::order_strike(const Order& o, const Vector3d& target) { orders_.emplace_back(o, target); }

void Behaviour::emit(FighterEvent::Kind kind, Timestamp t, const Order& o, std::string text, double distance) {
  FighterEvent e;
  e.time = t;
  e.kind = kind;
  e.order = o;
  e.text = std::move(text);
  e.distance_m = distance;
  events_.push_back(std::move(e));
}

std::vector<FighterEvent> Behaviour::take_events() {
  std::vector<FighterEvent> out;
  out.swap(events_);
  return out;
}

double Behaviour::stride_scale() const {
  return characters_[static_cast<std::size_t>(character_)].morphology.leg_length_m / db_->actor.leg_length_m;
}

GroundFrame Behaviour::ground() const { return ground_frame_of(pose_); }

std::array<bool, 2> Behaviour::feet_locked() const { return {feet_.held(kLeft), feet_.held(kRight)}; }

Vector2d Behaviour::scaled_travel(const Source& s, const MotionSegment& seg, double t) const {
  // The part of the clip's root travel that Source::Travel scales, at segment time t: all of it
  // from `from_s` to contact, then weighted by 1 - smoothstep over `release_s` (the extra
  // travel stops smoothly, with the clip's own motion, not at once). The root is linear within
  // a frame, so the weighted travel is exact per frame; its running sums at contact and at each
  // frame after it are kept for the strike being played (one pass per strike, O(1) per call).
  const Source::Travel& tr = s.travel;
  if (t <= tr.from_s) return Vector2d::Zero();
  const double tc = std::max(tr.from_s, tr.contact_s);
  Vector2d g = root_at(seg, std::min(t, tc)) - root_at(seg, tr.from_s);
  if (t <= tc || tr.release_s <= 0) return g;
  const double h = seg.frame_time_s, end = tc + tr.release_s;
  const double first = std::ceil(tc / h - 1e-9) * h;  // the first frame at or after contact
  // Knots: contact, then every frame time before the end of the release, then its end.
  const auto knot = [&](std::size_t i) { return i == 0 ? tc : std::min(end, first + static_cast<double>(i - 1) * h); };
  const auto part = [&](double a, double b) {  // weighted travel over [a, b] within one frame
    if (b <= a) return Vector2d(Vector2d::Zero());
    const Vector2d v = (root_at(seg, b) - root_at(seg, a)) / (b - a);
    return Vector2d(v * tr.release_s * (eased_integral((b - tc) / tr.release_s) - eased_integral((a - tc) / tr.release_s)));
  };
  if (eased_.segment != s.segment || !(eased_.travel == tr)) {
    eased_.segment = s.segment;
    eased_.travel = tr;
    eased_.cum.clear();
    eased_.cum.push_back(Vector2d::Zero());
    for (std::size_t i = 1; knot(i - 1) < end; ++i) eased_.cum.push_back(eased_.cum.back() + part(knot(i - 1), knot(i)));
  }
  if (t >= end) return g + eased_.cum.back();
  const std::size_t i = t < first ? 0 : std::min(eased_.cum.size() - 1, 1 + static_cast<std::size_t>((t - first) / h));
  return g + eased_.cum[i] + part(knot(i), t);
}

void Behaviour::sample(const Source& s, MkmFrame& out) const {
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(s.segment)];
  const double period = (seg.frame_count() - 1) * seg.frame_time_s;
  double t = s.time_s;
  if (s.loop && seg.kind != SegmentKind::rest) t = 0;  // no rest clip: hold the first frame
  if (s.loop && period > 0) {
    t = std::fmod(std::max(0.0, t), 2 * period);  // ping-pong: no seam to blend over
    if (t > period) t = 2 * period - t;
  }
  const auto [i0, a] = frame_pair(seg, t);
  MkmFrame mixed;
  blend_mkm(seg.frames[i0], seg.frames[i0 + 1], a, mixed);
  place_sample(s, seg, t, mixed, out);
}

void Behaviour::sample_frame(const Source& s, int frame, MkmFrame& out) const {
  // A strike source at one of its own frames: the frame itself, no blend (s.loop is false).
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(s.segment)];
  MkmFrame f = seg.frames[static_cast<std::size_t>(std::clamp(frame, 0, seg.frame_count() - 1))];
  place_sample(s, seg, frame * seg.frame_time_s, f, out);
}

void Behaviour::place_sample(const Source& s, const MotionSegment& seg, double t, MkmFrame& mixed, MkmFrame& out) const {
  if (!s.loop && s.travel.scale != 1) mixed.root_xz_m += (s.travel.scale - 1) * scaled_travel(s, seg, t);
  if (!s.loop && s.travel.rise_n != 0) {
    const Source::Travel& tr = s.travel;
    const double w = t <= tr.contact_s ? smoothstep((t - tr.from_s) / std::max(1e-6, tr.contact_s - tr.from_s))
                                       : 1 - smoothstep((t - tr.contact_s) / std::max(1e-6, tr.release_s));
    mixed.root_height_n += w * tr.rise_n;
  }
  place_mkm(mixed, s.placement, s.anchor_xz_m, stride_scale(), out);
}

void Behaviour::start_rest(Timestamp) {
  const MotionSegment& rest = db_->segments[static_cast<std::size_t>(rest_segment_)];
  if (have_pose_) spot_xz_m_ = pose_.root_xz_m;
  previous_ = current_;
  blend_elapsed_s_ = 0;
  current_ = Source{};
  current_.segment = rest_segment_;
  current_.loop = true;
  current_.anchor_xz_m = rest.frames[0].root_xz_m;
  current_.placement.origin_xz = spot_xz_m_;
  current_.placement.yaw_rad = wrap(facing_rad_ - ground_frame_of(rest.frames[0]).yaw_rad);
}

void Behaviour::select_character(int index, Timestamp now) {
  if (index < 0 || index >= character_count()) {
    emit(FighterEvent::Kind::warning, now, Order{now, OrderKind::select_character, index},
         fmt::format("no character {} (have {})", index + 1, character_count()));
    return;
  }
  if (index == character_) return;
  // Keep the root where it is under the new stride scale (re-base each source's origin).
  const double old_scale = stride_scale();
  character_ = index;
  const double new_scale = stride_scale();
  for (Source* s : {&current_, &previous_}) {
    if (s->segment < 0) continue;
    MkmFrame f;
    const MotionSegment& seg = db_->segments[static_cast<std::size_t>(s->segment)];
    (void)seg;
    Source probe = *s;
    sample(probe, f);  // with the new scale
    const Vector2d d_new = f.root_xz_m;
    // Root under the old scale: origin + R (old * (root - anchor)) == what was shown.
    const Vector2d rel = (d_new - s->placement.origin_xz) / new_scale;
    const Vector2d d_old = s->placement.origin_xz + rel * old_scale;
    s->placement.origin_xz += d_old - d_new;
  }
  feet_.reset();           // re-plant on the new legs (the easing hides the change)
  switch_elapsed_s_ = -1;  // marks "compute offsets after this update's solve"
  if (strike_.active) compute_reach_error(strike_.contact_time_s);
  emit(FighterEvent::Kind::character_changed, now, Order{now, OrderKind::select_character, index},
       fmt::format("character {} ({})", index + 1, characters_[static_cast<std::size_t>(index)].name));
}

void Behaviour::handle_orders(Timestamp now, const Vector3d& head) {
  // A strike ordered while the last one still hands its reach offset back (recovering) waits
  // for that (at most release_time_s): starting now would drop the offset in one frame.
  decltype(orders_) deferred;
  while (!orders_.empty()) {
    auto [o, explicit_target] = orders_.front();
    orders_.pop_front();
    if (effector_of(o.kind) && state_ == FighterState::recovering && strike_.active) {
      deferred.emplace_back(o, explicit_target);
      continue;
    }
    switch (o.kind) {
      case OrderKind::select_character: select_character(o.character, now); continue;
      case OrderKind::pause: paused_ = true; emit(FighterEvent::Kind::order_accepted, now, o, "paused"); continue;
      case OrderKind::resume: paused_ = false; emit(FighterEvent::Kind::order_accepted, now, o, "resumed"); continue;
      case OrderKind::recentre:
        recentre_goal_ = Vector2d(config_.home.x(), config_.home.z());
        emit(FighterEvent::Kind::order_accepted, now, o, "recentre: walking home");
        continue;
      default: break;
    }
    const auto eff = effector_of(o.kind);
    if (state_ == FighterState::striking || pending_) {
      emit(FighterEvent::Kind::order_ignored, now, o, "mid-strike");  // the event names the order
      continue;
    }
    if (paused_) {
      emit(FighterEvent::Kind::order_ignored, now, o, "paused");
      continue;
    }
    if (keep_away_) {
      emit(FighterEvent::Kind::order_ignored, now, o, "the visitor is near a wall: the fighter keeps away");
      continue;
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
      const double top = at(rig.rest_pose, shoulder).y() - rest_floor_y(rig) +
                         rig.morphology.arm_length(eff->side) * std::sin(tun_.max_punch_aim_deg * std::numbers::pi / 180);
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
    pending_ = PendingStrike{r.id, o, target};
    emit(FighterEvent::Kind::order_accepted, now, o,
         fmt::format("target at ({:.2f}, {:.2f}, {:.2f}) m", target.x(), target.y(), target.z()));
    submit_(r);
  }
  orders_.swap(deferred);
}

void Behaviour::align_to_support_foot(Source& s) const {
  // The clip is placed by its pelvis; shift it on the floor so that its support foot (planted
  // at the start and staying down longest) lands where that foot is held now: the motion then
  // swings its other foot and moves its body around a foot that does not have to move, as in
  // the mocap, instead of dragging a held foot the clip has elsewhere out of the leg's reach.
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(s.segment)];
  const int first = std::clamp(static_cast<int>(std::lround(s.time_s / seg.frame_time_s)), 0, seg.frame_count() - 1);
  int best = -1, best_run = 0;
  for (int side = 0; side < 2; ++side) {
    if (!feet_.held(side)) continue;
    int run = 0;
    for (int k = first; k < seg.frame_count() && seg.frames[static_cast<std::size_t>(k)].planted[static_cast<std::size_t>(side)] >= 0.5; ++k) ++run;
    if (run > best_run) { best = side; best_run = run; }
  }
  if (best < 0) return;
  MkmFrame placed;
  sample(s, placed);
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  CanonicalPose c;
  decode_canonical(rig, placed, c);
  const CJ ankle = best == kLeft ? CJ::l_ankle : CJ::r_ankle;
  const Vector3d held = rig_positions_[static_cast<std::size_t>(rig.skeleton.index(ankle))];
  Vector2d shift(held.x() - at(c, ankle).x(), held.z() - at(c, ankle).z());
  // Along the line to the target: never back away for it (the held foot then steps up to where
  // the clip has it, rather than the whole strike landing short).
  if (strike_target_) {
    Vector2d dir(strike_target_->x() - s.placement.origin_xz.x(), strike_target_->z() - s.placement.origin_xz.y());
    if (dir.norm() > 1e-6) {
      dir.normalize();
      const double along = shift.dot(dir);
      shift -= std::min(along, 0.0) * dir;
    }
  }
  const double limit = tun_.max_support_shift_m;
  if (shift.norm() > limit) shift *= limit / shift.norm();
  s.placement.origin_xz += shift;
}

void Behaviour::place_strike_travel(Source& s, double contact_time_s) const {
  // A lunge travels a fixed distance in the clip; the target is nearer or farther. Scale the
  // clip's floor travel up to contact (a shorter or longer lunge: Source::Travel) so that at
  // contact the limb's root (shoulder / hip) is as far from the target as the clip has it from
  // its own hit point: the limb arrives as extended as captured and d(t) only turns it,
  // instead of folding a straight punch up onto a near head or stretching it to a far one.
  // Clips that hardly travel keep their travel; the pelvis always stays min_contact_distance_m
  // short of the target at contact.
  s.travel = Source::Travel{};
  if (!strike_target_) return;
  Vector2d dir(strike_target_->x() - s.placement.origin_xz.x(), strike_target_->z() - s.placement.origin_xz.y());
  if (dir.norm() < 1e-6) return;
  dir.normalize();
  s.travel.from_s = s.time_s;
  s.travel.contact_s = contact_time_s;
  s.travel.release_s = tun_.release_time_s;
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(s.segment)];
  const auto eff = seg.effector();
  if (!eff) return;
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  Source at_contact = s;
  at_contact.time_s = contact_time_s;
  MkmFrame start_pose, contact_pose;
  sample(s, start_pose);
  sample(at_contact, contact_pose);
  const Vector2d travel2 = contact_pose.root_xz_m - start_pose.root_xz_m;
  const Vector3d target = *strike_target_;
  double k = 0;  // scale - 1
  const double leg = rig.morphology.leg_length_m;
  CanonicalPose c;
  decode_canonical(rig, contact_pose, c);
  const CJ root = eff->leg ? (eff->side == kLeft ? CJ::l_hip : CJ::r_hip) : (eff->side == kLeft ? CJ::l_shoulder : CJ::r_shoulder);
  Vector3d limb_root = at(c, root);
  const double reach = (at(c, eff->joint()) - limb_root).norm();
  if (!eff->leg) {
    // A target above what the arm reaches at max_punch_elevation_deg: raise the pelvis toward
    // its standing height (a higher stance), at most max_strike_rise_m.
    const double standing_n = at(rig.rest_pose, CJ::pelvis).y() / leg;
    const double room = std::max(0.0, standing_n - contact_pose.root_height_n) * leg;
    const double above = target.y() - limb_root.y() - reach * std::sin(tun_.max_punch_elevation_deg * std::numbers::pi / 180);
    const double rise = std::clamp(above, 0.0, std::min(room, tun_.max_strike_rise_m));
    s.travel.rise_n = rise / leg;
    limb_root.y() += rise;
  }
  if (travel2.norm() >= tun_.min_scaled_travel_m) {
    const Vector3d T(travel2.x(), 0, travel2.y());
    const Vector3d u = target - limb_root;
    // |u - k T| = reach, the root approaching from behind (the smaller k); when no k reaches
    // (a target far above or below), the k that comes closest.
    const double tt = T.squaredNorm(), ut = u.dot(T);
    const double disc = ut * ut - tt * (u.squaredNorm() - reach * reach);
    k = disc >= 0 ? (ut - std::sqrt(disc)) / tt : ut / tt;
    k = std::clamp(k, tun_.min_travel_scale - 1, tun_.max_travel_scale - 1);
    const double td = T.x() * dir.x() + T.z() * dir.y();
    if (td > 1e-6) {
      const double ahead = (Vector2d(target.x(), target.z()) - contact_pose.root_xz_m).dot(dir);
      k = std::min(k, (ahead - tun_.min_contact_distance_m) / td);
    }
    k = std::max(k, tun_.min_travel_scale - 1);
  } else {
    // No travel to scale: keep the pelvis short of the target by moving the clip back, at most
    // max_support_shift_m (as far as any placement shift goes: a target behind the fighter is
    // not a reason to slide the whole strike away from it).
    const double ahead = (Vector2d(target.x(), target.z()) - contact_pose.root_xz_m).dot(dir);
    if (ahead < tun_.min_contact_distance_m)
      s.placement.origin_xz -= std::min(tun_.min_contact_distance_m - ahead, tun_.max_support_shift_m) * dir;
  }
  s.travel.scale = 1 + k;
}

void Behaviour::start_strike(const StrikePlan& plan, Timestamp now) {
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(plan.segment)];
  const GroundFrame g_char = ground_frame_of(pose_);
  const GroundFrame g_clip = ground_frame_of(seg.frames[static_cast<std::size_t>(plan.start_frame)]);
  previous_ = current_;
  blend_elapsed_s_ = 0;
  current_ = Source{};
  current_.segment = plan.segment;
  current_.time_s = plan.start_frame * seg.frame_time_s;
  current_.placement.origin_xz = g_char.origin_xz;
  current_.placement.yaw_rad = wrap(g_char.yaw_rad - g_clip.yaw_rad);
  current_.anchor_xz_m = g_clip.origin_xz;
  strike_target_ = pending_->target_room_m;
  align_to_support_foot(current_);
  place_strike_travel(current_, plan.contact_frame * seg.frame_time_s);
  const Order order = pending_->order;
  strike_ = StrikeInfo{};
  strike_.active = true;
  strike_.order = order;
  strike_.target_room_m = pending_->target_room_m;
  strike_.plan = plan;
  strike_.effector = *seg.effector();
  strike_.start_time_s = plan.start_frame * seg.frame_time_s;
  strike_.contact_time_s = plan.contact_frame * seg.frame_time_s;
  strike_.end_time_s = (seg.frame_count() - 1) * seg.frame_time_s;
  strike_.release_end_s = std::max(strike_.contact_time_s + tun_.release_time_s, strike_.end_time_s - tun_.blend_time_s);
  state_ = FighterState::striking;
  following_ = false;
  compute_reach_error(strike_.contact_time_s);
  (void)now;
}

void Behaviour::compute_reach_error(double at_time_s) {
  // The pose at segment time `at_time_s`, composed exactly as update() will compose it then
  // (same sources, same blend weight), decoded without the offset: d(t) must close exactly
  // that gap.
  const Source* strike_src = current_.segment == strike_.plan.segment && state_ == FighterState::striking ? &current_ : nullptr;
  if (!strike_src) return;
  const double ahead = at_time_s - current_.time_s;
  Source cur = current_, prev = previous_;
  cur.time_s += ahead;
  prev.time_s += ahead;
  MkmFrame a, b, pose;
  sample(cur, b);
  const double be = blend_elapsed_s_ + ahead;
  if (prev.segment >= 0 && be < tun_.blend_time_s) {
    sample(prev, a);
    blend_mkm(a, b, smoothstep(be / tun_.blend_time_s), pose);
  } else {
    pose = b;
  }
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  CanonicalPose c;
  decode_canonical(rig, pose, c);
  const Vector3d effector = at(c, strike_.effector.joint());
  strike_.error_m = strike_.target_room_m - effector;
  // The correction turns and stretches the limb about its root (shoulder or hip) so that it
  // points at the target: the whole limb aims, instead of the wrist alone being pushed.
  const CJ root = strike_.effector.leg ? (strike_.effector.side == kLeft ? CJ::l_hip : CJ::r_hip)
                                       : (strike_.effector.side == kLeft ? CJ::l_shoulder : CJ::r_shoulder);
  // The limb vector as AdaptJob turns it: the motion's own (root -> root + limb_n * length),
  // not the decoded end, which IK clamps where the motion over-extends the limb by a hair.
  const int side = strike_.effector.side;
  const Vector3d from = strike_.effector.leg ? Vector3d(pose.leg_n[static_cast<std::size_t>(side)] * rig.morphology.limb_leg_length(side))
                                             : Vector3d(pose.arm_n[static_cast<std::size_t>(side)] * rig.morphology.arm_length(side));
  const Vector3d to = strike_.target_room_m - at(c, root);
  if (from.norm() > 1e-6 && to.norm() > 1e-6) {
    strike_.turn = Eigen::Quaterniond::FromTwoVectors(from, to);
    strike_.stretch = to.norm() / from.norm();
  } else {
    strike_.turn = Eigen::Quaterniond::Identity();
    strike_.stretch = 1;
  }
}

void Behaviour::update_follow(double dt, const Vector3d& head) {
  const Vector2d head_xz(head.x(), head.z());
  Vector2d to_head = head_xz - spot_xz_m_;
  const double dist = to_head.norm();
  Vector2d goal = spot_xz_m_;
  if (dist > 1e-6) goal = head_xz - to_head / dist * config_.strike_distance_m;
  if (recentre_goal_) goal = *recentre_goal_;
  // A visitor near a wall: back off (further from the visitor than the strike distance), so
  // nobody is drawn toward the wall by the fighter.
  if (keep_away_ && dist > 1e-6) goal = head_xz - to_head / dist * (config_.strike_distance_m + tun_.keep_away_extra_m);
  goal.x() = std::clamp(goal.x(), config_.min_x_m, config_.max_x_m);
  goal.y() = std::clamp(goal.y(), config_.min_z_m, config_.max_z_m);
  if (paused_) goal = spot_xz_m_;
  const Vector2d off = goal - spot_xz_m_;
  if (!following_ && off.norm() > tun_.follow_tolerance_m) following_ = true;
  spot_velocity_.setZero();
  if (following_) {
    const double step = std::min(off.norm(), tun_.walk_speed_mps * dt);
    if (off.norm() > 1e-9) spot_xz_m_ += off / off.norm() * step;
    if (off.norm() > 1e-9 && dt > 0) spot_velocity_ = off / off.norm() * step / dt;
    if ((goal - spot_xz_m_).norm() < tun_.arrive_tolerance_m) {
      following_ = false;
      recentre_goal_.reset();
    }
  }
  // Face the visitor.
  if (dist > 0.05 && !paused_) {
    const double want = std::atan2(to_head.x(), to_head.y());
    const double turn = std::clamp(wrap(want - facing_rad_), -tun_.turn_speed_rad_s * dt, tun_.turn_speed_rad_s * dt);
    facing_rad_ = wrap(facing_rad_ + turn);
  }
  const MotionSegment& rest = db_->segments[static_cast<std::size_t>(current_.segment)];
  current_.placement.origin_xz = spot_xz_m_;
  current_.placement.yaw_rad = wrap(facing_rad_ - ground_frame_of(rest.frames[0]).yaw_rad);
  state_ = following_ ? FighterState::following : FighterState::resting;
}

double Behaviour::swing_left_s(int side) const {
  // Time until the motion now playing puts this foot down again.
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(current_.segment)];
  if (current_.loop) return 0;  // the rest motion: nothing to follow (the shortest swing applies)
  const int n = seg.frame_count();
  const int first = std::clamp(static_cast<int>(std::ceil(current_.time_s / seg.frame_time_s - 1e-9)), 0, n);
  for (int k = first; k < n; ++k)
    if (seg.frames[static_cast<std::size_t>(k)].planted[static_cast<std::size_t>(side)] >= 0.5) return k * seg.frame_time_s - current_.time_s;
  return (n - 1) * seg.frame_time_s - current_.time_s + tun_.blend_time_s;  // the rest motion after it
}

namespace {
/// Where a placed MKM frame puts an ankle (m, room) on a rig, without decoding the whole pose:
/// pelvis, the rest pose's hip offset turned with the pelvis frame, the leg vector.
Vector3d mkm_ankle(const Rig& rig, const MkmFrame& f, int side) {
  const Vector3d pelvis(f.root_xz_m.x(), f.root_height_n * rig.morphology.leg_length_m, f.root_xz_m.y());
  const CanonicalPose& rest = rig.rest_pose;
  const Vector3d hip_local = pelvis_frame(rest).conjugate() * (at(rest, side == kLeft ? CJ::l_hip : CJ::r_hip) - at(rest, CJ::pelvis));
  return pelvis + f.pelvis * hip_local + f.leg_n[static_cast<std::size_t>(side)] * rig.morphology.limb_leg_length(side);
}
}  // namespace

void Behaviour::update_feet(double dt, const ReachGoal* reach, const MkmFrame& cur) {
  if (!have_pose_) {
    locks_ = FootLocks{};
    return;
  }
  const std::array<double, 2>& planted = cur.planted;
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  // The motion being played, one update earlier: how far it moved each foot since.
  MkmFrame before;
  Source earlier = current_;
  earlier.time_s -= dt;
  sample(earlier, before);

  // The motion's own ankle heights (without a strike's pelvis rise): a heel it raises.
  MkmFrame unraised = cur;
  if (current_.travel.rise_n != 0) {
    Source plain = current_;
    plain.travel.rise_n = 0;
    sample(plain, unraised);
  }
  constexpr double kLiftDeadband_m = 0.01;
  std::array<FootSample, 2> in;
  for (int s = 0; s < 2; ++s) {
    const auto us = static_cast<std::size_t>(s);
    const auto ankle = static_cast<std::size_t>(rig.skeleton.index(s == kLeft ? CJ::l_ankle : CJ::r_ankle));
    const auto hip = static_cast<std::size_t>(rig.skeleton.index(s == kLeft ? CJ::l_hip : CJ::r_hip));
    FootSample& f = in[us];
    // Contacts of the motion being blended TO: a cross-fade moves feet the new motion has
    // down elsewhere, and following the fade would slide them there along the floor.
    f.planted = planted[us] >= 0.5;
    f.swing_left_s = swing_left_s(s);
    // Where the motion alone would put the ankle now (last hip + this frame's leg vector).
    f.free_ankle_m = rig_positions_[hip] + pose_.leg_n[us] * rig.morphology.limb_leg_length(s);
    f.source_step_m = mkm_ankle(rig, cur, s) - mkm_ankle(rig, before, s);
    if (!f.planted && !current_.loop && std::isfinite(f.swing_left_s) && f.swing_left_s > 0) {
      // Where the motion puts this foot down next, and the horizontal way its ankle still goes.
      const double land_t = current_.time_s + f.swing_left_s;
      const Vector3d now_m = mkm_ankle(rig, cur, s);
      SwingPath& sp = swing_paths_[us];
      const bool same = sp.segment == current_.segment && sp.character == character_ && std::abs(sp.land_t - land_t) < 1e-9 &&
                        sp.placement.origin_xz == current_.placement.origin_xz && sp.placement.yaw_rad == current_.placement.yaw_rad &&
                        sp.anchor_xz_m == current_.anchor_xz_m && sp.travel == current_.travel;
      if (same) {
        sp.way_left_m = std::max(0.0, sp.way_left_m - Eigen::Vector2d(now_m.x() - sp.last_m.x(), now_m.z() - sp.last_m.z()).norm());
      } else {
        // The source's own frames from now to the landing (swing_left_s ends on a frame).
        const MotionSegment& seg = db_->segments[static_cast<std::size_t>(current_.segment)];
        const int land = std::min(static_cast<int>(std::lround(land_t / seg.frame_time_s)), seg.frame_count() - 1);
        MkmFrame g;
        Vector3d last = now_m;
        double path = 0;
        for (int k = static_cast<int>(std::floor(current_.time_s / seg.frame_time_s)) + 1; k <= land; ++k) {
          sample_frame(current_, k, g);
          const Vector3d p = mkm_ankle(rig, g, s);
          path += Eigen::Vector2d(p.x() - last.x(), p.z() - last.z()).norm();
          last = p;
        }
        sp = SwingPath{current_.segment, character_, land_t, current_.placement, current_.anchor_xz_m, current_.travel, last, now_m, path};
      }
      sp.last_m = now_m;
      f.has_landing = true;
      f.landing_ankle_m = sp.landing_m;
      f.source_path_left_m = sp.way_left_m;
    }
    f.drawn_ankle_m = rig_positions_[ankle];
    f.hip_m = rig_positions_[hip];
    f.leg_length_m = rig.morphology.limb_leg_length(s);
    f.standing_ankle_y_m = at(rig.rest_pose, s == kLeft ? CJ::l_ankle : CJ::r_ankle).y() - rest_floor_y(rig);
    f.reached = report_.foot_reached[us];
    if (f.planted) f.source_lift_m = std::max(0.0, mkm_ankle(rig, unraised, s).y() - f.standing_ankle_y_m - kLiftDeadband_m);
    f.effector = reach && strike_.effector.leg && strike_.effector.side == s && state_ == FighterState::striking;
  }
  // Steps also while recovering: a strike that ends in a long stance steps back under the
  // body instead of squatting into the rest motion's narrower one.
  // Not while d(t) still acts: the strike holds its stance until it has been taken back.
  const bool may_step = state_ != FighterState::striking && ramp_ <= 0;
  feet_.update(dt, in, may_step, spot_velocity_, locks_);
}

namespace {
double distance_to_segment(const Vector3d& p, const Vector3d& a, const Vector3d& b) {
  const Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double u = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (p - (a + u * ab)).norm();
}
}  // namespace

void Behaviour::judge_contact(Timestamp now, const Vector3d& head) {
  // Judged against the visitor as tracked now, not the target frozen at the order: a visitor
  // who ducked or stepped away since is not hit.
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  const Vector3d hit_point = rig_positions_[static_cast<std::size_t>(rig.skeleton.index(strike_.effector.joint()))];
  strike_.contact_done = true;
  strike_.contact_update = updates_;
  strike_.contact_distance_m = (hit_point - strike_.target_room_m).norm();
  strike_.contact_reached = report_.reached;
  strike_.target_reached = strike_.contact_distance_m <= config_.hit_radius_m;
  const Vector3d top = head - Vector3d::UnitY() * config_.visitor_neck_m;
  const Vector3d bottom(head.x(), std::min(top.y(), config_.visitor_capsule_bottom_m), head.z());
  const double gap = std::min((hit_point - head).norm() - config_.visitor_head_radius_m,
                              distance_to_segment(hit_point, top, bottom) - config_.visitor_body_radius_m);
  strike_.body_distance_m = gap;
  strike_.hit = gap <= 0;
  const MotionSegment& seg = db_->segments[static_cast<std::size_t>(strike_.plan.segment)];
  const std::string what = fmt::format("{} (frames {}->{})", seg.name, strike_.plan.start_frame, strike_.plan.contact_frame);
  if (strike_.hit) {
    emit(FighterEvent::Kind::hit, now, strike_.order,
         fmt::format("{}: touched the visitor ({:.1f} cm from the target)", what, strike_.contact_distance_m * 100), 0);
  } else if (strike_.target_reached) {
    emit(FighterEvent::Kind::dodged, now, strike_.order,
         fmt::format("{}: the visitor had moved, {:.1f} cm clear of the hit point", what, gap * 100), gap);
  } else {
    emit(FighterEvent::Kind::miss, now, strike_.order,
         fmt::format("{}: {:.1f} cm short of the target{}, {:.1f} cm clear of the visitor", what,
                     strike_.contact_distance_m * 100, report_.reached ? "" : " (out of reach)", gap * 100),
         gap);
  }
}

void Behaviour::update(Timestamp now, double dt, const Vector3d& head) {
  time_ = now;
  ++updates_;
  dt = std::max(0.0, dt);
  const int old_character = character_;
  std::vector<Vector3d> old_display;  // only on a switch (rare)
  const std::size_t old_n = static_cast<std::size_t>(characters_[static_cast<std::size_t>(character_)].joint_count());

  // A switch needs the old drawn pose; copy it before handle_orders changes character.
  const bool switch_pending = std::any_of(orders_.begin(), orders_.end(), [](const auto& o) {
    return o.first.kind == OrderKind::select_character;
  });
  if (switch_pending && have_pose_) old_display.assign(positions_.begin(), positions_.begin() + static_cast<std::ptrdiff_t>(old_n));

  handle_orders(now, head);
  if (pending_) {
    if (auto p = poll_(); p && p->id == pending_->request) {
      if (p->segment < 0) {
        emit(FighterEvent::Kind::warning, now, pending_->order, "no strike in the database for this order");
      } else {
        start_strike(*p, now);
      }
      pending_.reset();
    }
  }

  // Advance the clocks by the whole frame: the contact frame is the first frame at or past the
  // planned contact time, a real frame of motion (no sub-frame hold, no copy of the last).
  current_.time_s += dt;
  previous_.time_s += dt;
  blend_elapsed_s_ += dt;
  if (switch_elapsed_s_ >= 0) switch_elapsed_s_ += dt;
  const bool contact_now =
      state_ == FighterState::striking && !strike_.contact_done && current_.time_s >= strike_.contact_time_s;
  if (state_ == FighterState::striking && strike_.contact_done &&
      current_.time_s >= strike_.end_time_s - tun_.blend_time_s) {
    start_rest(now);
    state_ = FighterState::recovering;
  }
  // Recovering lasts until the blend into rest is done and d(t) is back to zero.
  if (state_ == FighterState::recovering && blend_elapsed_s_ >= tun_.blend_time_s &&
      previous_.time_s >= strike_.release_end_s) {
    state_ = FighterState::resting;
    strike_.active = false;
  }
  if (state_ == FighterState::resting || state_ == FighterState::following) update_follow(dt, head);

  // Compose the pose: cross-fade previous -> current.
  pose_before_ = pose_;
  MkmFrame cur;
  sample(current_, cur);
  if (previous_.segment >= 0 && blend_elapsed_s_ < tun_.blend_time_s) {
    MkmFrame prev;
    sample(previous_, prev);
    blend_mkm(prev, cur, smoothstep(blend_elapsed_s_ / tun_.blend_time_s), pose_);
  } else {
    pose_ = cur;
  }
  if (!have_pose_) pose_before_ = pose_;

  // d(t): zero at the strike start, the full error at contact, then back to zero over at least
  // release_time_s, carrying on through the blend into rest (leaving the strike never jumps).
  ReachGoal goal;
  const ReachGoal* reach = nullptr;
  double ramp = 0;
  if (strike_.active) {
    const Source& s = state_ == FighterState::striking ? current_ : previous_;
    const double t = s.time_s;
    if (contact_now) {
      // The error of this very frame, so the contact frame lands on the target.
      compute_reach_error(current_.time_s);
      strike_.contact_time_s = current_.time_s;
      strike_.release_end_s = std::max(strike_.contact_time_s + tun_.release_time_s, strike_.end_time_s - tun_.blend_time_s);
      ramp = 1;
    } else if (!strike_.contact_done) {
      ramp = smoothstep((t - strike_.start_time_s) / std::max(1e-6, strike_.contact_time_s - strike_.start_time_s));
    } else {
      ramp = 1 - smoothstep((t - strike_.contact_time_s) / std::max(1e-6, strike_.release_end_s - strike_.contact_time_s));
    }
    goal.effector = strike_.effector;
    goal.turn = Eigen::Quaterniond::Identity().slerp(ramp, strike_.turn);
    goal.stretch = 1 + ramp * (strike_.stretch - 1);
    goal.pin = ramp;
    reach = &goal;
  }
  ramp_ = ramp;
  motion_planted_ = cur.planted;
  update_feet(dt, reach, cur);
  if (reach && strike_.effector.leg && !feet_.held(strike_.effector.side)) {
    // The kicking foot leaves its hold on the same ramp as d(t): fully free at contact, so the
    // goal there is exactly the motion's own foot turned by d(t) (what compute_reach_error
    // assumed), and back under the hold as d(t) is released. Once put down it is held.
    locks_.weight[static_cast<std::size_t>(strike_.effector.side)] *= std::clamp(1 - ramp, 0.0, 1.0);
  }

  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  const auto n = static_cast<std::size_t>(rig.joint_count());
  // The pelvis drop for held feet changes at a bounded rate: a foot lifted or put down never
  // moves the whole body in one frame.
  const double last_drop = have_pose_ ? report_.root_drop_m : 0.0;
  locks_.min_root_drop_m = std::max(0.0, last_drop - tun_.max_drop_rate_mps * dt);
  locks_.max_root_drop_m = std::min(tun_.max_root_drop_m, last_drop + tun_.max_drop_rate_mps * dt);
  AdaptJob job;
  job.rig = &rig;
  job.pose = &pose_;
  job.reach = reach;
  job.feet = have_pose_ ? &locks_ : nullptr;
  job.local_rotations = std::span(local_).first(n);
  job.global_rotations = std::span(global_).first(n);
  job.global_positions = std::span(rig_positions_).first(n);
  job.root_position = &root_joint_;
  job.report = &report_;
  job.Run();
  have_pose_ = true;
  last_dt_ = dt > 0 ? dt : last_dt_;

  if (contact_now) judge_contact(now, head);




  // Character switch easing: offsets from the old drawn pose, fading over blend_time.
  if (switch_elapsed_s_ < 0) {
    switch_elapsed_s_ = 0;
    const Rig& old_rig = characters_[static_cast<std::size_t>(old_character)];
    CanonicalPose old_c, new_c;
    if (!old_display.empty()) {
      canonical_positions(old_rig.skeleton, old_display, old_c);
    } else {
      canonical_positions(rig.skeleton, rig_positions_, old_c);
    }
    canonical_positions(rig.skeleton, rig_positions_, new_c);
    for (std::size_t i = 0; i < n; ++i) {
      // The nearest canonical joint at or above i carries its offset.
      int j = static_cast<int>(i);
      int cj = -1;
      while (j >= 0 && cj < 0) {
        for (std::size_t c = 0; c < kCanonicalJointCount; ++c)
          if (rig.skeleton.canonical[c] == j && old_c[c].allFinite()) { cj = static_cast<int>(c); break; }
        if (cj < 0) j = rig.skeleton.parents[static_cast<std::size_t>(j)];
      }
      switch_offset_[i] = cj >= 0 ? Vector3d(old_c[static_cast<std::size_t>(cj)] - new_c[static_cast<std::size_t>(cj)]) : Vector3d::Zero();
    }
  }
  const double fade = switch_elapsed_s_ < tun_.blend_time_s ? 1 - smoothstep(switch_elapsed_s_ / tun_.blend_time_s) : 0.0;
  for (std::size_t i = 0; i < n; ++i) positions_[i] = rig_positions_[i] + switch_offset_[i] * fade;
}

FighterFrame Behaviour::frame() const {
  const Rig& rig = characters_[static_cast<std::size_t>(character_)];
  const auto n = static_cast<std::size_t>(rig.joint_count());
  FighterFrame f;
  f.time = time_;
  f.state = state_;
  f.character = character_;
  f.joints = std::span<const Vector3d>(positions_).first(n);
  f.parents = rig.skeleton.parents;
  f.joint_radii_m = rig.joint_radii_m;
  if (strike_.active || pending_) f.target = pending_ ? pending_->target_room_m : strike_.target_room_m;
  f.root = Vector3d(pose_.root_xz_m.x(), 0, pose_.root_xz_m.y());
  f.heading_rad = facing_rad_;
  return f;
}

StrikeRecording record_strike(std::shared_ptr<const Database> db, const Rig& character, OrderKind order,
                              const Vector3d& target, const FighterConfig& config_in) {
  FighterConfig config = config_in;
  config.home = Vector3d::Zero();
  config.initial_character = 0;
  config.min_x_m = config.min_z_m = -1e3;
  config.max_x_m = config.max_z_m = 1e3;
  Behaviour b(db, {character}, config);
  // Plan outside update() so the per-frame timings hold adaptation only.
  const StrikePlanner planner(db, config.retrieval);
  std::optional<StrikeRequest> request;
  std::optional<StrikePlan> result;
  b.set_planner([&](const StrikeRequest& r) { request = r; },
                [&]() -> std::optional<StrikePlan> { auto r = result; result.reset(); return r; });
  StrikeRecording rec;
  const Rig& rig = character;
  const auto n = static_cast<std::size_t>(rig.joint_count());
  rec.motion.name = "strike";
  rec.motion.skeleton = rig.skeleton;
  rec.motion.unit_m = character.unit_m;
  // The visitor stands where the target is (a kick's target lies kick_target_drop_m below the
  // head), so the contact is judged against a visitor who did not move.
  Vector3d head = target;
  if (const auto e = effector_of(order); e && e->leg) head.y() += config.behaviour.kick_target_drop_m;
  double dt = 1.0 / 120, t = 0;
  const int ankles[2] = {rig.skeleton.index(CJ::l_ankle), rig.skeleton.index(CJ::r_ankle)};
  auto record = [&] {
    StrikeRecording::TraceRow row;
    row.state = b.state();
    row.ramp = b.reach_ramp();
    for (int s = 0; s < 2; ++s) {
      const auto us = static_cast<std::size_t>(s);
      row.phase[us] = b.foot_planter().phase(s);
      row.planted[us] = b.motion_planted()[us];
      row.lock_weight[us] = b.foot_locks().weight[us];
      row.lock_m[us] = b.foot_locks().ankle_m[us];
      row.ankle_m[us] = b.rig_positions()[static_cast<std::size_t>(ankles[s])];
    }
    row.root_drop_m = b.last_report().root_drop_m;
    rec.trace.push_back(row);
    rec.motion.root_positions.push_back(b.root_position());
    rec.motion.local_rotations.insert(rec.motion.local_rotations.end(), b.local_rotations().begin(),
                                      b.local_rotations().begin() + static_cast<std::ptrdiff_t>(n));
    ++rec.motion.frame_count;
  };
  auto timed_update = [&] {
    const auto locked_before = b.feet_locked();
    const Vector3d before[2] = {b.rig_positions()[static_cast<std::size_t>(ankles[0])],
                                b.rig_positions()[static_cast<std::size_t>(ankles[1])]};
    const auto t0 = std::chrono::steady_clock::now();
    b.update(t, dt, head);
    rec.update_us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
    const auto locked = b.feet_locked();
    for (int s = 0; s < 2; ++s)
      if (locked[static_cast<std::size_t>(s)] && locked_before[static_cast<std::size_t>(s)])
        rec.max_foot_slide_m = std::max(rec.max_foot_slide_m,
                                        (b.rig_positions()[static_cast<std::size_t>(ankles[s])] - before[s]).norm());
    for (auto& e : b.take_events()) rec.events.push_back(std::string(to_string(e.kind)) + ": " + e.text);
    record();
    t += dt;
  };
  b.update(t, 0, head);  // the rest pose at the origin
  b.take_events();
  record();
  b.order_strike(Order{t, order}, target);
  timed_update();  // sends the request
  if (request) {
    const StrikePlan p = planner.plan(*request);
    rec.retrieval_us = p.retrieval_us;
    result = p;
    if (p.segment >= 0) dt = db->segments[static_cast<std::size_t>(p.segment)].frame_time_s;
  }
  for (int i = 0; i < 100000; ++i) {
    timed_update();
    if (b.strike().contact_done && b.state() == FighterState::resting) break;
    if (!b.strike().active && !b.strike().contact_done && i > 2) break;  // nothing to strike with
  }
  rec.motion.frame_time_s = dt;
  rec.strike = b.strike();
  if (rec.strike.contact_done) {
    rec.contact_frame = rec.strike.contact_update - 1;  // update k (1-based) recorded frame k-1
    const MotionSegment& seg = db->segments[static_cast<std::size_t>(rec.strike.plan.segment)];
    rec.segment_name = seg.name;
    rec.source_clip = seg.source_clip;
    rec.source_start_frame = seg.source_first_frame + rec.strike.plan.start_frame;
    rec.mirrored = seg.mirrored;
  }
  rec.effector_joint = rig.skeleton.index(effector_of(order).value_or(Effector{}).joint());
  return rec;
}

Rig load_character_rig(const std::string& name_or_path) {
  std::filesystem::path path(name_or_path);
  if (!std::filesystem::exists(path)) {
    const auto candidate = default_content_dir() / "characters" / (name_or_path + ".bvh");
    if (!std::filesystem::exists(candidate))
      throw Error("fighter", "character", fmt::format("{}: no such character file (nor {})", name_or_path, candidate.string()));
    path = candidate;
  }
  const Clip c = read_bvh(path);
  if (c.frame_count < 1) throw Error("fighter", "character", fmt::format("{}: no rest frame", path.string()));
  Rig rig = make_rig(c.skeleton, c.rotations(0), path.stem().string());
  rig.unit_m = c.unit_m;
  return rig;
}

std::vector<Rig> load_character_rigs(const FighterConfig& config) {
  std::vector<Rig> rigs;
  for (std::size_t i = 0; i < config.characters.size(); ++i) {
    rigs.push_back(load_character_rig(config.characters[i].string()));
    if (i < config.character_names.size() && !config.character_names[i].empty()) rigs.back().name = config.character_names[i];
  }
  return rigs;
}

}  // namespace kumite::content
