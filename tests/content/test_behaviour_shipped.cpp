// The SHIPPED content (content/motions + content/characters, real CMU 135 strikes): every
// character lands its strikes on a grid of targets around head height within 1 mm when the
// target is reachable, and planted feet stay put (<= 2 mm per frame).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "fighter_fixtures.hpp"
#include "kumite/content/behaviour.hpp"
#include "kumite/content/mkm.hpp"

using namespace kumite;
using namespace kumite::content;
using CJ = CanonicalJoint;
using Eigen::Vector3d;

namespace {
// The fighter at home at the room's origin, with room to step in or back around it (the
// default area ends at the home spot's z).
FighterConfig open_room_at_origin() {
  FighterConfig cfg;
  cfg.home = Vector3d::Zero();
  cfg.min_x_m = cfg.min_z_m = -3;
  cfg.max_x_m = cfg.max_z_m = 3;
  return cfg;
}
}  // namespace

namespace {
struct Outcome {
  bool contact = false, reached = false, hit = false;
  double distance_m = 0, max_slide_m = 0;
  double foot_up_after_m = 0;     ///< m: the higher ankle above its standing height, 1 s after the strike
  bool feet_held_after = true;    ///< both feet held then
  int frames_both_feet_off = 0;   ///< frames of that second with neither foot held
};

Outcome strike_once(Behaviour& b, OrderKind kind, const Vector3d& local_target) {
  const double dt = 1.0 / 120;
  double t = 0;
  const Vector3d head(0, 1.7, 0.9);
  for (int i = 0; i < 30; ++i) b.update(t += dt, dt, head);
  const Vector3d target = b.ground().to_world(local_target);
  b.order_strike(Order{t, kind}, target);
  Outcome o;
  const Rig* rig = &b.character(b.current_character());
  const int ankles[2] = {rig->skeleton.index(CJ::l_ankle), rig->skeleton.index(CJ::r_ankle)};
  for (int i = 0; i < 600 && !(b.state() == FighterState::resting && b.strike().contact_done); ++i) {
    const auto locked_before = b.feet_locked();
    const Vector3d before[2] = {b.rig_positions()[static_cast<std::size_t>(ankles[0])], b.rig_positions()[static_cast<std::size_t>(ankles[1])]};
    b.update(t += dt, dt, head);
    const auto locked = b.feet_locked();
    for (int s = 0; s < 2; ++s) {
      if (!(locked[s] && locked_before[s])) continue;
      // Along the floor: a held foot's heel may rise and come down with the motion's (a lunge's
      // back foot on its toes), which is not a slide.
      const Vector3d step = b.rig_positions()[static_cast<std::size_t>(ankles[s])] - before[s];
      const double d = std::hypot(step.x(), step.z());
      o.max_slide_m = std::max(o.max_slide_m, d);
    }
  }
  // Then a second at rest: both feet back on the floor, held (a kicking foot never hangs in
  // the air after the strike, and never both feet off the floor at once).
  // (or longer, up to 3 s more, while the fighter follows the visitor after a lunge, with a
  // stance step or procedural steps: its feet are judged once it has rested 0.5 s)
  int resting = 0;  // updates in a row at rest
  for (int i = 0; i < 480 && (i < 120 || resting < 60); ++i) {
    b.update(t += dt, dt, head);
    resting = b.state() == FighterState::resting && b.stance_step_segment() < 0 ? resting + 1 : 0;
    const auto locked = b.feet_locked();
    if (!locked[0] && !locked[1]) ++o.frames_both_feet_off;
  }
  const auto& rest = rig->rest_pose;
  const double floor_y = std::min({rest[static_cast<std::size_t>(CJ::l_ankle)].y(), rest[static_cast<std::size_t>(CJ::r_ankle)].y()});
  for (int s = 0; s < 2; ++s) {
    const double standing = rest[static_cast<std::size_t>(s == 0 ? CJ::l_ankle : CJ::r_ankle)].y() - floor_y;
    const double lowest_toe = std::min(rest[static_cast<std::size_t>(CJ::l_toe)].y(), rest[static_cast<std::size_t>(CJ::r_toe)].y());
    const double up = b.rig_positions()[static_cast<std::size_t>(ankles[s])].y() - (standing + std::max(0.0, floor_y - lowest_toe));
    o.foot_up_after_m = std::max(o.foot_up_after_m, up);
    o.feet_held_after = o.feet_held_after && b.feet_locked()[static_cast<std::size_t>(s)];
  }
  o.contact = b.strike().contact_done;
  o.reached = b.strike().contact_reached;
  o.hit = b.strike().target_reached;  // the visitor stands elsewhere: reaching the target is what counts here
  o.distance_m = b.strike().contact_distance_m;
  return o;
}
/// The fighter's drawn canonical joints now (m, room), one row of a track.
std::vector<Vector3d> drawn_canonical(const Behaviour& b) {
  const Rig& rig = b.character(b.current_character());
  CanonicalPose now;
  canonical_positions(rig.skeleton, b.joint_positions().first(static_cast<std::size_t>(rig.joint_count())), now);
  return {now.begin(), now.end()};
}

/// Drawn snaps in a track of drawn_canonical rows, by motion_quality's rule (a step over 5 cm and
/// 3x both neighbouring steps); the first is described in `first_snap` (prefixed `what`) if empty.
int count_snaps(const std::vector<std::vector<Vector3d>>& track, const std::string& what, std::string& first_snap) {
  int snaps = 0;
  for (std::size_t j = 0; j < kCanonicalJointCount; ++j) {
    const auto step = [&](std::size_t k) { return (track[k][j] - track[k - 1][j]).norm(); };
    for (std::size_t k = 2; k + 1 < track.size(); ++k) {
      if (!track[k][j].allFinite() || !track[k - 1][j].allFinite() || !track[k - 2][j].allFinite() || !track[k + 1][j].allFinite()) continue;
      const double st = step(k);
      if (st > 0.05 && st > 3 * step(k - 1) && st > 3 * step(k + 1)) {
        ++snaps;
        if (first_snap.empty()) first_snap = what + fmt::format(": joint {} {:.0f} mm at frame {}", j, st * 1000, k - 1);
      }
    }
  }
  return snaps;
}

/// A fighter in the open room (open_room_at_origin) as `character` of `rigs`, having stood one
/// second at 60 Hz (its first update, then 60) facing the visitor's head at `head`: feet held.
/// `t` (s) is set to the time reached.
std::unique_ptr<Behaviour> standing_in_open_room(std::shared_ptr<const Database> db, const std::vector<Rig>& rigs,
                                                 std::size_t character, const Vector3d& head, double& t) {
  FighterConfig cfg = open_room_at_origin();
  cfg.initial_character = static_cast<int>(character);
  auto b = std::make_unique<Behaviour>(std::move(db), rigs, cfg);
  const double dt = 1.0 / 60;
  t = 0;
  b->update(t, 0, head);
  for (int i = 0; i < 60; ++i) b->update(t += dt, dt, head);
  return b;
}
}  // namespace

TEST(BehaviourShipped, EveryCharacterReachesTargetsAroundHeadHeight) {
  const auto& set = kumite::content::testing::shipped_database();
  const auto rigs = kumite::content::testing::shipped_characters();
  FighterConfig cfg;
  cfg.home = Vector3d::Zero();
  cfg.min_z_m = -3;  // home inside the area (the default depth limits lie behind it:
  cfg.max_z_m = 3;   // the fighter would walk away from the strike being judged)
  for (std::size_t c = 0; c < rigs.size(); ++c) {
    const double h = rigs[c].morphology.height_m;
    int reached = 0, total = 0;
    double worst = 0, worst_slide = 0;
    for (OrderKind kind : {OrderKind::punch_right, OrderKind::punch_left, OrderKind::kick_right, OrderKind::kick_left}) {
      const bool kick = kind == OrderKind::kick_right || kind == OrderKind::kick_left;
      for (double fy : {0.85, 0.95}) {
        for (double dx : {-0.15, 0.0, 0.15}) {
          cfg.initial_character = static_cast<int>(c);
          Behaviour b(set.db, {rigs[c]}, cfg);
          const Vector3d local(dx, kick ? fy * 0.65 * h : fy * h, kick ? 0.45 * h : 0.36 * h);
          const Outcome o = strike_once(b, kind, local);
          ASSERT_TRUE(o.contact) << rigs[c].name;
          // "Down" is within landing_height_m (4 cm) of the standing height: a foot is put
          // down where the motion has it, up to that little above the floor.
          EXPECT_LT(o.foot_up_after_m, 0.05) << rigs[c].name << " " << to_string(kind) << ": a foot still in the air 1 s after the strike";
          EXPECT_TRUE(o.feet_held_after) << rigs[c].name << " " << to_string(kind);
          EXPECT_EQ(o.frames_both_feet_off, 0) << rigs[c].name << " " << to_string(kind);
          ++total;
          worst_slide = std::max(worst_slide, o.max_slide_m);
          if (o.reached) {
            ++reached;
            worst = std::max(worst, o.distance_m);
            EXPECT_TRUE(o.hit);
          }
        }
      }
    }
    EXPECT_LT(worst, 1e-3) << rigs[c].name;
    // A held foot whose leg is nearly straight is drawn a few mm short of its hold (soft
    // two-bone IK: no knee pop), and that shortfall changes as the hip moves: <= 3 mm a frame.
    EXPECT_LT(worst_slide, 3e-3) << rigs[c].name;
    EXPECT_GE(reached, total * 3 / 4) << rigs[c].name << ": reached " << reached << " of " << total;
    std::printf("%s (%.2f m): reached %d/%d, worst reach error %.2e m, worst foot slide %.2e m\n",
                rigs[c].name.c_str(), h, reached, total, worst, worst_slide);
  }
}

// A kick ordered while its foot is in the middle of a procedural step (the fighter following
// a visitor who moved): the kick takes the foot from where the step has it and lands on the
// target. Seen in the demo: the step carried on through the strike and the kick "landed" with
// the foot on the floor, 127 cm short.
TEST(BehaviourShipped, AKickOrderedMidStepStillReachesItsTarget) {
  const auto& set = kumite::content::testing::shipped_database();
  const auto rigs = kumite::content::testing::shipped_characters();
  FighterConfig cfg = open_room_at_origin();
  const double dt = 1.0 / 120;
  int tried = 0;
  for (const OrderKind kind : {OrderKind::kick_left, OrderKind::kick_right}) {
    const int side = kind == OrderKind::kick_left ? kLeft : kRight;
    Behaviour b(set.db, {rigs[0]}, cfg);
    double t = 0;
    Vector3d head(0, 1.6, 0.9);
    for (int i = 0; i < 60; ++i) b.update(t += dt, dt, head);
    head = Vector3d(0.6, 1.6, 1.4);  // the visitor steps aside: the fighter follows with steps
    bool stepping = false;
    for (int i = 0; i < 600 && !stepping; ++i) {
      b.update(t += dt, dt, head);
      stepping = b.foot_planter().phase(side) == FootPlanter::Phase::stepping;
    }
    if (!stepping) continue;
    ++tried;
    const Vector3d target = b.ground().to_world(Vector3d(0, 0.55 * rigs[0].morphology.height_m, 0.45 * rigs[0].morphology.height_m));
    b.order_strike(Order{t, kind}, target);
    // From the strike's first update the kick owns the foot: never a procedural step while
    // d(t) acts on it (a step that outlasts the kick's approach puts the foot on the floor at
    // contact).
    int stepping_while_kicking = 0;
    for (int i = 0; i < 600 && !b.strike().contact_done; ++i) {
      b.update(t += dt, dt, head);
      if (b.state() == FighterState::striking && b.foot_planter().phase(side) == FootPlanter::Phase::stepping) ++stepping_while_kicking;
    }
    EXPECT_EQ(stepping_while_kicking, 0) << to_string(kind);
    ASSERT_TRUE(b.strike().contact_done) << to_string(kind);
    EXPECT_TRUE(b.strike().target_reached) << to_string(kind) << ": the kicking foot ended "
                                           << b.strike().contact_distance_m << " m from the target";
  }
  EXPECT_GE(tried, 1) << "no foot was ever caught mid-step: the test did not test anything";
}

// The strike's playback rate (BehaviourTunables::min_strike_rate, on by default) is found off
// the frame: the update that starts the strike only sends a StrikeRateJob (a copy of its start
// state), and the rate enters exactly kStrikeRateDelayUpdates later, whoever solves it and
// whenever: the frames are the same bit for bit. Bruno's left punch at his own head height
// (the shipped mid punch must rise and lunge more than captured: played slower).
TEST(BehaviourShipped, AStrikesPlaybackRateIsFoundOffTheFrameAndEntersAtAFixedUpdate) {
  const auto& set = kumite::content::testing::shipped_database();
  const auto rigs = kumite::content::testing::shipped_characters();
  const Rig& bruno = rigs[1];
  FighterConfig cfg;
  cfg.home = Vector3d::Zero();
  cfg.min_z_m = -3;  // home inside the area (the default depth limits lie behind it:
  cfg.max_z_m = 3;   // the fighter would walk away from the strike being judged)
  ASSERT_LT(cfg.behaviour.min_strike_rate, 1) << "the playback rate is on by default";
  const Vector3d target(0.074, 1.786, 0.966);
  enum class Solve { in_frame, at_submit, thread_late, at_poll };
  struct Run {
    std::vector<std::vector<Vector3d>> joints;
    std::vector<int> submitted, polled;  // updates
    Behaviour::StrikeInfo strike;
    int job_segment = -1;
  };
  const auto play = [&](Solve how) {
    Run out;
    Behaviour b(set.db, {bruno}, cfg);
    StrikeRateSolver solver(set.db, cfg.behaviour);
    std::optional<StrikeRateJob> job;
    std::optional<StrikeRateResult> result;
    std::thread worker;
    if (how != Solve::in_frame) {
      b.set_rate_solver(
          [&](const StrikeRateJob& j) {
            out.submitted.push_back(b.update_count());
            out.job_segment = j.current.segment;
            job = j;
            if (how == Solve::at_submit) result = solver.solve(j);
            if (how == Solve::thread_late)
              worker = std::thread([&solver, &result, j] {
                std::this_thread::sleep_for(std::chrono::milliseconds(30));
                result = solver.solve(j);
              });
          },
          [&]() -> std::optional<StrikeRateResult> {
            out.polled.push_back(b.update_count());
            if (how == Solve::thread_late) worker.join();
            if (how == Solve::at_poll) result = solver.solve(*job);
            return std::exchange(result, std::nullopt);
          });
    }
    const double dt = 1.0 / 60;
    double t = 0;
    const Vector3d head = target;
    b.update(t, 0, head);
    b.order_strike(Order{t, OrderKind::punch_left}, target);
    for (int i = 0; i < 150; ++i) {
      b.update(t += dt, dt, head);
      out.joints.emplace_back(b.joint_positions().begin(), b.joint_positions().end());
    }
    out.strike = b.strike();
    return out;
  };
  const Run a = play(Solve::at_submit);
  ASSERT_TRUE(a.strike.contact_done);
  ASSERT_EQ(a.submitted.size(), 1u);
  EXPECT_EQ(a.submitted[0], a.strike.start_update);  // sent by the update that starts the strike
  EXPECT_EQ(a.job_segment, a.strike.plan.segment);
  ASSERT_EQ(a.polled.size(), 1u);
  EXPECT_EQ(a.polled[0], a.strike.start_update + kStrikeRateDelayUpdates);
  EXPECT_EQ(a.strike.rate_update, a.strike.start_update + kStrikeRateDelayUpdates);
  EXPECT_EQ(a.strike.rate_lead_updates, kStrikeRateDelayUpdates);
  EXPECT_LT(a.strike.rate, 0.9);
  EXPECT_GE(a.strike.rate, cfg.behaviour.min_strike_rate);
  for (Solve how : {Solve::in_frame, Solve::thread_late, Solve::at_poll}) {
    const Run b = play(how);
    EXPECT_EQ(b.strike.rate, a.strike.rate);
    ASSERT_EQ(b.joints.size(), a.joints.size());
    for (std::size_t i = 0; i < a.joints.size(); ++i)
      for (std::size_t j = 0; j < a.joints[i].size(); ++j)
        ASSERT_EQ(b.joints[i][j], a.joints[i][j]) << "solve " << static_cast<int>(how) << " update " << i + 2 << " joint " << j;
  }
}

// A punch whose target the lunge would only reach by dragging its back foot (kenji's left
// punch at his head height, 0.44 x stature ahead: the shipped lunge's back foot stands farther
// back in the rest stance than in the clip) steps in first: a stepping_in event, then the
// strike, which lands on the target with every held foot still (<= 3 mm a frame along the
// floor) and each held foot keeping its heading (the toes do not swivel about a held ankle),
// through the recovery into the rest motion too.
// With step-ins off (max_step_in_m 0) the same order strikes at once.
TEST(BehaviourShipped, AStrikeBeyondTheLungesReachStepsInFirstAndKeepsItsFeet) {
  const auto& set = kumite::content::testing::shipped_database();
  const auto rigs = kumite::content::testing::shipped_characters();
  const Rig& kenji = rigs[2];
  ASSERT_EQ(kenji.name, "kenji");
  const Vector3d target(0.0374, 1.5834, 0.7125);  // the quality grid's first left punch target
  for (const double max_step_in : {0.8, 0.0}) {
    FighterConfig cfg = open_room_at_origin();
    cfg.behaviour.max_step_in_m = max_step_in;
    Behaviour b(set.db, {kenji}, cfg);
    const double dt = 1.0 / 120;
    double t = 0;
    b.update(t, 0, target);
    for (int i = 0; i < 30; ++i) b.update(t += dt, dt, target);  // standing, feet held
    b.order_strike(Order{t, OrderKind::punch_left}, target);
    const int first_update = b.update_count();
    const int ankle[2] = {kenji.skeleton.index(CJ::l_ankle), kenji.skeleton.index(CJ::r_ankle)};
    const int toe[2] = {kenji.skeleton.index(CJ::l_toe), kenji.skeleton.index(CJ::r_toe)};
    std::vector<FighterEvent> events;
    int start_update = -1;
    double worst_slide = 0, worst_turn_deg = 0;
    // Through the strike and its recovery into the rest motion (where the feet turned).
    for (int i = 0; i < 900 && !(b.strike().contact_done && b.state() == FighterState::resting); ++i) {
      const auto held_before = b.feet_locked();
      std::array<Vector3d, 2> a0, t0;
      for (int s = 0; s < 2; ++s) {
        a0[static_cast<std::size_t>(s)] = b.rig_positions()[static_cast<std::size_t>(ankle[s])];
        t0[static_cast<std::size_t>(s)] = b.rig_positions()[static_cast<std::size_t>(toe[s])];
      }
      b.update(t += dt, dt, target);
      for (auto& e : b.take_events()) events.push_back(e);
      if (start_update < 0 && b.state() == FighterState::striking) start_update = b.update_count();
      const auto held = b.feet_locked();
      for (int s = 0; s < 2; ++s) {
        const auto us = static_cast<std::size_t>(s);
        if (!(held[us] && held_before[us])) continue;
        const Vector3d a1 = b.rig_positions()[static_cast<std::size_t>(ankle[s])];
        const Vector3d t1 = b.rig_positions()[static_cast<std::size_t>(toe[s])];
        worst_slide = std::max(worst_slide, std::hypot(a1.x() - a0[us].x(), a1.z() - a0[us].z()));
        const double h0 = std::atan2(t0[us].x() - a0[us].x(), t0[us].z() - a0[us].z());
        const double h1 = std::atan2(t1.x() - a1.x(), t1.z() - a1.z());
        // (a stance step's support foot turns on the spot with the mocap's: FootSample::pivot;
        // the fighter steps back out after the strike stepped in)
        if (b.stance_step_segment() < 0)
          worst_turn_deg = std::max(worst_turn_deg, std::abs(std::remainder(h1 - h0, 2 * M_PI)) * 180 / M_PI);
      }
    }
    ASSERT_TRUE(b.strike().contact_done) << "max_step_in_m " << max_step_in;
    const auto stepped = std::count_if(events.begin(), events.end(), [](const FighterEvent& e) { return e.kind == FighterEvent::Kind::stepping_in; });
    if (max_step_in > 0) {
      EXPECT_EQ(stepped, 1);
      EXPECT_GT(start_update - first_update, 30) << "the strike starts once the fighter has stepped in";
      EXPECT_LT(b.strike().contact_distance_m, 2e-3);
      EXPECT_TRUE(b.strike().target_reached);
      EXPECT_LT(worst_slide, 3e-3);
      EXPECT_LT(worst_turn_deg, 1.0) << "a held foot turned on its ankle";
    } else {
      EXPECT_EQ(stepped, 0);
      EXPECT_LE(start_update - first_update, 1) << "without step-ins the strike starts on its plan";
    }
  }
}

// While it steps in before a strike, the fighter faces the strike's target (frozen at the
// order), not the visitor as tracked: a visitor who moves 0.6 m sideways right after the order
// neither turns the fighter away from the strike it is about to throw nor turns its feet into
// more steps the strike must wait for. At the strike's start the fighter faces the target
// within 5 degrees, and the strike lands on it.
TEST(BehaviourShipped, AFighterSteppingInFacesTheStrikesTargetNotTheMovingVisitor) {
  const auto& set = kumite::content::testing::shipped_database();
  const auto rigs = kumite::content::testing::shipped_characters();
  const Rig& kenji = rigs[2];
  ASSERT_EQ(kenji.name, "kenji");
  const Vector3d target(0.0374, 1.5834, 0.7125);  // beyond the lunge's reach: steps in (the test above)
  Behaviour b(set.db, {kenji}, open_room_at_origin());
  const double dt = 1.0 / 120;
  double t = 0;
  b.update(t, 0, target);
  for (int i = 0; i < 30; ++i) b.update(t += dt, dt, target);
  b.order_strike(Order{t, OrderKind::punch_left}, target);
  const double t_order = t;
  std::vector<FighterEvent> events;
  double off_deg = -1;
  for (int i = 0; i < 600 && !b.strike().contact_done; ++i) {
    t += dt;
    // The visitor steps 0.6 m to the fighter's left over 0.3 s after the order, and stays.
    const double u = std::clamp((t - t_order) / 0.3, 0.0, 1.0);
    const Vector3d head = target + Vector3d(0.6 * u * u * (3 - 2 * u), 0, 0);
    b.update(t, dt, head);
    for (auto& e : b.take_events()) events.push_back(e);
    if (off_deg < 0 && b.state() == FighterState::striking) {
      const FighterFrame f = b.frame();
      const double bearing = std::atan2(target.x() - f.root.x(), target.z() - f.root.z());
      off_deg = std::abs(std::remainder(f.heading_rad - bearing, 2 * M_PI)) * 180 / M_PI;
    }
  }
  ASSERT_TRUE(b.strike().contact_done);
  EXPECT_EQ(std::count_if(events.begin(), events.end(), [](const FighterEvent& e) { return e.kind == FighterEvent::Kind::stepping_in; }), 1);
  ASSERT_GE(off_deg, 0);
  EXPECT_LT(off_deg, 5.0) << "the fighter turned toward the visitor while stepping in";
  EXPECT_LT(b.strike().contact_distance_m, 2e-3);
}

// A punch at a target too near for it (issue 12, item 4: "keep the limb's extension
// plausible"): kenji's right punch at a crouching visitor's head 0.3 m in front of him. The
// lunge the database holds for it, shortened all it may be, would land with the arm folded
// (shoulder to wrist under half the arm's length, as in the scripted bout's 8.8 s order). The
// fighter steps back first (a stepping_back event), then strikes: measured on the drawn joints
// at contact, the arm reaches at least 0.6 of its length (shoulder-elbow plus elbow-wrist) and
// the wrist is ahead of its elbow toward the target; the strike lands within 2 mm of it.
// With step-backs off (max_step_back_m 0) the same order strikes at once, folded: the figure
// this test measures does see the fold.
TEST(BehaviourShipped, AStrikeAtATargetTooNearStepsBackFirstAndLandsWithItsArmExtended) {
  const auto& set = kumite::content::testing::shipped_database();
  const auto rigs = kumite::content::testing::shipped_characters();
  const Rig& kenji = rigs[2];
  ASSERT_EQ(kenji.name, "kenji");
  const Vector3d target(0.0, 1.30, 0.30);
  const int shoulder = kenji.skeleton.index(CJ::r_shoulder), elbow = kenji.skeleton.index(CJ::r_elbow),
            wrist = kenji.skeleton.index(CJ::r_wrist);
  for (const double max_step_back : {0.8, 0.0}) {
    FighterConfig cfg = open_room_at_origin();
    cfg.behaviour.max_step_back_m = max_step_back;
    Behaviour b(set.db, {kenji}, cfg);
    const double dt = 1.0 / 120;
    double t = 0;
    b.update(t, 0, target);  // the rest pose at the origin, the order at once (as kumite-motion strike)
    b.order_strike(Order{t, OrderKind::punch_right}, target);
    const int first_update = b.update_count();
    std::vector<FighterEvent> events;
    int start_update = -1;
    double extension = -1, ahead_m = 0;
    for (int i = 0; i < 600 && extension < 0; ++i) {
      b.update(t += dt, dt, target);
      for (auto& e : b.take_events()) events.push_back(e);
      if (start_update < 0 && b.state() == FighterState::striking) start_update = b.update_count();
      if (start_update >= 0 && b.strike().contact_done) {  // the contact frame, as drawn
        const auto at = [&](int j) { return b.rig_positions()[static_cast<std::size_t>(j)]; };
        const double arm = (at(elbow) - at(shoulder)).norm() + (at(wrist) - at(elbow)).norm();
        extension = (at(wrist) - at(shoulder)).norm() / arm;
        ahead_m = (at(wrist) - at(elbow)).dot((target - at(shoulder)).normalized());
      }
    }
    ASSERT_GE(extension, 0) << "max_step_back_m " << max_step_back << ": no contact";
    const auto back = std::count_if(events.begin(), events.end(), [](const FighterEvent& e) { return e.kind == FighterEvent::Kind::stepping_back; });
    if (max_step_back > 0) {
      EXPECT_EQ(back, 1);
      EXPECT_GT(start_update - first_update, 20) << "the strike starts once the fighter has stepped back";
      EXPECT_GE(extension, 0.6);
      EXPECT_GT(ahead_m, 0.02) << "the wrist ahead of its elbow toward the target";
      EXPECT_LT(b.strike().contact_distance_m, 2e-3);
    } else {
      EXPECT_EQ(back, 0);
      EXPECT_LE(start_update - first_update, 1) << "without step-backs the strike starts on its plan";
      EXPECT_LT(extension, 0.5) << "the case this test is about: the arm folds where the fighter does not step back";
    }
  }
}

// Following with stance steps cut from the mocap (issue 12, item 3; [fighter.behaviour]
// stance_step_min_m > 0): a visitor who walks 0.8 m away and stops is followed with one
// karate step from a `walk` segment of motions.toml (not with procedural steps), its stepping
// foot in the air as the clip has it, the foot it stands on held without sliding, never both
// feet off the floor, and the fighter ends resting within follow_tolerance_m of its spot at
// the strike distance; the step travels toward the visitor, not off to a side (the mocap's
// steps, placed by the pelvis's heading, ended 0.2-0.3 m to the side). A visitor who walks
// 0.4 m closer is followed back with procedural steps (as a lunge that returns is); one who
// comes 0.8 m closer at once and stays makes it step back with a stance step. Off (the
// default, 0): the same walks are followed with procedural steps only.
TEST(BehaviourShipped, FollowsAVisitorWalkingAwayWithAStanceStepFromTheMocap) {
  const auto& set = kumite::content::testing::shipped_database();
  const auto rigs = kumite::content::testing::shipped_characters();
  for (const double min_m : {0.5, 0.0}) {
    FighterConfig cfg = open_room_at_origin();
    cfg.behaviour.stance_step_min_m = min_m;
    Behaviour b(set.db, {rigs[0]}, cfg);
    const Rig& rig = b.character(0);
    const int ankle[2] = {rig.skeleton.index(CJ::l_ankle), rig.skeleton.index(CJ::r_ankle)};
    const double dt = 1.0 / 60;
    double t = 0;
    Vector3d head(0, 1.6, cfg.strike_distance_m);
    for (int i = 0; i < 60; ++i) b.update(t += dt, dt, head);  // standing, feet held
    const Vector3d start = b.frame().root;
    std::vector<int> walk_segments;
    int both_off = 0, procedural_starts = 0;
    double worst_slide = 0;
    const auto run = [&](double seconds, double walk_to_z, double walk_s) {
      const double z0 = head.z();
      for (int i = 0; i < static_cast<int>(seconds / dt); ++i) {
        head.z() = z0 + (walk_to_z - z0) * std::min(1.0, i * dt / walk_s);  // a walk, then standing
        const auto held_before = b.feet_locked();
        const auto phase_before = std::array{b.foot_planter().phase(0), b.foot_planter().phase(1)};
        std::array<Vector3d, 2> before;
        for (int s = 0; s < 2; ++s) before[static_cast<std::size_t>(s)] = b.rig_positions()[static_cast<std::size_t>(ankle[s])];
        b.update(t += dt, dt, head);
        const int seg = b.stance_step_segment();
        if (seg >= 0 && (walk_segments.empty() || walk_segments.back() != seg)) walk_segments.push_back(seg);
        const auto held = b.feet_locked();
        if (!held[0] && !held[1]) ++both_off;
        for (int s = 0; s < 2; ++s) {
          const auto us = static_cast<std::size_t>(s);
          if (b.foot_planter().phase(s) == FootPlanter::Phase::stepping && phase_before[us] != FootPlanter::Phase::stepping) ++procedural_starts;
          if (!(held[us] && held_before[us])) continue;
          const Vector3d d = b.rig_positions()[static_cast<std::size_t>(ankle[s])] - before[us];
          worst_slide = std::max(worst_slide, std::hypot(d.x(), d.z()));
        }
      }
    };
    run(4.0, head.z() + 0.8, 1.0);  // walks 0.8 m away (+Z) in 1 s, then stands
    const Vector3d after_forward = b.frame().root;
    const std::size_t forward_steps = walk_segments.size();
    const int procedural_forward = procedural_starts;
    run(4.0, head.z() - 0.4, 1.0);  // walks 0.4 m closer
    const Vector3d after_back = b.frame().root;
    const std::size_t steps_after_walk_in = walk_segments.size();
    const int procedural_walk_in = procedural_starts - procedural_forward;
    run(4.0, head.z() - 0.8, 0.3);  // comes 0.8 m closer in 0.3 s and stays
    const Vector3d after_rush = b.frame().root;
    EXPECT_EQ(b.state(), FighterState::resting) << "stance_step_min_m " << min_m;
    EXPECT_GT(after_forward.z() - start.z(), 0.55) << "stance_step_min_m " << min_m;
    EXPECT_LT(std::abs(after_forward.x() - start.x()), 0.1) << "toward the visitor, not to a side: stance_step_min_m " << min_m;
    EXPECT_LT(after_back.z() - after_forward.z(), -0.2) << "stance_step_min_m " << min_m;
    EXPECT_LT(after_rush.z() - after_back.z(), -0.4) << "stance_step_min_m " << min_m;
    EXPECT_LT(worst_slide, 0.002) << "held feet do not slide (m per update), stance_step_min_m " << min_m;
    const Vector3d root = b.frame().root;
    EXPECT_NEAR(std::hypot(head.x() - root.x(), head.z() - root.z()), cfg.strike_distance_m, 0.5) << min_m;
    if (min_m > 0) {
      ASSERT_EQ(forward_steps, 1u) << "one stance step for the walk away";
      EXPECT_EQ(steps_after_walk_in, 1u) << "none for a visitor walking 0.4 m closer";
      ASSERT_EQ(walk_segments.size(), 2u) << "and one back from the rush";
      for (const int s : walk_segments) EXPECT_EQ(set.db->segments[static_cast<std::size_t>(s)].kind, SegmentKind::walk);
      EXPECT_EQ(b.stance_steps_begun(), 2);
      EXPECT_EQ(both_off, 0) << "never both feet off the floor";
      EXPECT_LE(procedural_forward, 4) << "a few procedural steps at most (settling into the rest stance)";
      EXPECT_GT(procedural_walk_in, 0) << "the visitor walking closer is followed with procedural steps";
    } else {
      EXPECT_TRUE(walk_segments.empty());
      EXPECT_EQ(b.stance_steps_begun(), 0);
      EXPECT_GT(procedural_starts, 2) << "off: the walk is followed with procedural steps";
    }
  }
}

// A character switch at rest between every two shipped characters keeps the feet held where
// they stand (FootPlanter::keep_held_only): whatever the sizes, never both feet off the floor
// (a foot the new legs cannot reach steps alone) and no drawn joint snaps (a step over 5 cm and
// 3x both neighbouring steps: motion_quality's rule). Mid-strike switches: the scripted bout
// (test content.kumite_motion_bout).
TEST(BehaviourShipped, ASwitchBetweenAnyTwoCharactersAtRestKeepsAFootOnTheFloor) {
  const auto& set = kumite::content::testing::shipped_database();
  const auto rigs = kumite::content::testing::shipped_characters();
  const double dt = 1.0 / 60;
  int snaps = 0, worst_both_off = 0;
  std::string first_snap;
  {
    for (std::size_t a = 0; a < rigs.size(); ++a) {
      for (std::size_t c = 0; c < rigs.size(); ++c) {
        if (a == c) continue;
        const std::string pair = rigs[a].name + " -> " + rigs[c].name;
        double t = 0;
        const Vector3d head(0, 1.6, 1.2);
        const auto fighter = standing_in_open_room(set.db, rigs, a, head, t);
        Behaviour& b = *fighter;
        // The drawn canonical joints from the frame before the switch on.
        std::vector<std::vector<Vector3d>> track{drawn_canonical(b)};
        b.order(Order{t, OrderKind::select_character, static_cast<std::int32_t>(c)});
        int both_off = 0;
        for (int i = 0; i < 120; ++i) {
          b.update(t += dt, dt, head);
          ASSERT_EQ(b.current_character(), static_cast<int>(c)) << pair;
          const auto held = b.feet_locked();
          if (!held[0] && !held[1]) ++both_off;
          track.push_back(drawn_canonical(b));
        }
        snaps += count_snaps(track, pair, first_snap);
        EXPECT_EQ(both_off, 0) << pair;
        worst_both_off = std::max(worst_both_off, both_off);
      }
    }
  }
  std::printf("switches between every two characters: %d snaps (%s), both feet off at most %d frames\n", snaps,
              first_snap.c_str(), worst_both_off);
  EXPECT_EQ(snaps, 0) << first_snap;
}

// A kick ordered on the update that switches to a taller character: the planter's samples on
// that update hung the new body's leg from the old body's drawn hip (viktor's free ankle 10 cm
// under the floor after mei), the kick's swing carried that gap, and the kicking foot went
// 14.5 cm up in one frame (the scripted bout with stance steps on, 15.25 s). Every shipped pair
// whose new leg is 5 cm longer or more, both kicks, judged on the drawn joints: no snap
// (motion_quality's rule) and no jolt in the kicking foot's rise.
TEST(BehaviourShipped, AKickOrderedAsATallerCharacterIsSwitchedInStartsWithoutAJolt) {
  const auto& set = kumite::content::testing::shipped_database();
  const auto rigs = kumite::content::testing::shipped_characters();
  const double dt = 1.0 / 60;
  int snaps = 0, cases = 0;
  double worst_rise = 0;
  std::string first_snap;
  for (std::size_t a = 0; a < rigs.size(); ++a) {
    for (std::size_t c = 0; c < rigs.size(); ++c) {
      if (rigs[c].morphology.leg_length_m < rigs[a].morphology.leg_length_m + 0.05) continue;
      for (const OrderKind kind : {OrderKind::kick_left, OrderKind::kick_right}) {
        ++cases;
        const std::string what = fmt::format("{} -> {}, {}", rigs[a].name, rigs[c].name, kind == OrderKind::kick_left ? "left kick" : "right kick");
        double t = 0;
        const Vector3d head(0, 1.6, 1.0);
        const auto fighter = standing_in_open_room(set.db, rigs, a, head, t);
        Behaviour& b = *fighter;
        std::vector<std::vector<Vector3d>> track{drawn_canonical(b)};
        b.order(Order{t, OrderKind::select_character, static_cast<std::int32_t>(c)});
        b.order_strike(Order{t, kind}, Vector3d(0, 1.1, 0.8));
        for (int i = 0; i < 90; ++i) {
          b.update(t += dt, dt, head);
          track.push_back(drawn_canonical(b));
        }
        snaps += count_snaps(track, what, first_snap);
        const std::size_t ankle = static_cast<std::size_t>(kind == OrderKind::kick_left ? CJ::l_ankle : CJ::r_ankle);
        for (std::size_t k = 2; k < 12 && k < track.size(); ++k)
          worst_rise = std::max(worst_rise, (track[k][ankle].y() - track[k - 1][ankle].y()) - (track[k - 1][ankle].y() - track[k - 2][ankle].y()));
      }
    }
  }
  std::printf("largest change of the kicking ankle's rise per frame in the first 10 frames: %.4f m\n", worst_rise);
  std::printf("kicks ordered as a taller character is switched in: %d cases, %d snaps (%s)\n", cases, snaps, first_snap.c_str());
  EXPECT_GT(cases, 0);
  EXPECT_EQ(snaps, 0) << first_snap;
  // The jolt itself (the change of the kicking ankle's rise from one frame to the next, 18 cases):
  // 0.064 m with the old body's hip on the switch's update, 0.022 m with the new body's.
  EXPECT_LE(worst_rise, 0.03);
}

// A kick switched to a shorter body on its way: planned on the taller one, d(t) was recomputed
// for the new leg to lock out at contact, but the source's leg is straighter on the way than
// at contact, so the stretched leg reached full length before contact and its knee straightened
// in one frame (the 120-order sweep: 135_07_kick_right_1 from kenji to mei 0.25 s after the
// order, the knee 11.6 cm in a frame). Every shipped pair whose new leg is 5 cm shorter or
// more, both kicks, switched at several points of the way; judged on the drawn joints (3 of
// these 72 snapped before: kenji to aiko, the right kick, the knee 12 cm).
TEST(BehaviourShipped, AKickSwitchedToAShorterBodyOnItsWayDrawsNoSnap) {
  const auto& set = kumite::content::testing::shipped_database();
  const auto rigs = kumite::content::testing::shipped_characters();
  const double dt = 1.0 / 60;
  int snaps = 0, cases = 0, switched_before_contact = 0;
  std::string first_snap;
  for (std::size_t a = 0; a < rigs.size(); ++a) {
    for (std::size_t c = 0; c < rigs.size(); ++c) {
      if (rigs[c].morphology.leg_length_m > rigs[a].morphology.leg_length_m - 0.05) continue;
      for (const OrderKind kind : {OrderKind::kick_left, OrderKind::kick_right}) {
        for (const int after : {8, 14, 20, 26}) {
          const std::string what = fmt::format("{} -> {} {} updates in, {}", rigs[a].name, rigs[c].name, after,
                                               kind == OrderKind::kick_left ? "left kick" : "right kick");
          ++cases;
          double t = 0;
          const Vector3d head(0, 1.6, 1.0);
          const auto fighter = standing_in_open_room(set.db, rigs, a, head, t);
          Behaviour& b = *fighter;
          // At the taller body's reach: beyond the shorter one's.
          const double reach = 0.97 * rigs[a].morphology.leg_length_m;
          b.order_strike(Order{t, kind}, b.ground().to_world(Vector3d(0, 1.0, reach)));
          std::vector<std::vector<Vector3d>> track{drawn_canonical(b)};
          for (int i = 0; i < 120; ++i) {
            if (i == after) {
              if (!b.strike().contact_done) ++switched_before_contact;
              b.order(Order{t, OrderKind::select_character, static_cast<std::int32_t>(c)});
            }
            b.update(t += dt, dt, head);
            track.push_back(drawn_canonical(b));
          }
          snaps += count_snaps(track, what, first_snap);
        }
      }
    }
  }
  std::printf("kicks switched to a shorter body on their way: %d cases (%d before contact), %d snaps (%s)\n", cases,
              switched_before_contact, snaps, first_snap.c_str());
  EXPECT_GT(switched_before_contact, cases / 2);
  EXPECT_EQ(snaps, 0) << first_snap;
}

// A head-height punch switched to a shorter body on its way keeps the new body's elbow under
// its head at contact (the 120-order sweep with stance steps on: aiko's punch switched to mei
// 0.23 s before contact reached full stretch with mei's elbow over her head, in six bouts). The
// aim comes down for the new body as it would have been planned for it (keep_elbow_below_head).
TEST(BehaviourShipped, APunchSwitchedToAShorterBodyOnItsWayKeepsTheElbowUnderTheHead) {
  const auto& set = kumite::content::testing::shipped_database();
  const auto rigs = kumite::content::testing::shipped_characters();
  const double dt = 1.0 / 60;
  int snaps = 0, cases = 0, switched_before_contact = 0, over = 0;
  double worst = std::numeric_limits<double>::infinity();
  std::string first_snap, first_over;
  for (std::size_t a = 0; a < rigs.size(); ++a) {
    for (std::size_t c = 0; c < rigs.size(); ++c) {
      if (rigs[c].morphology.height_m > rigs[a].morphology.height_m - 0.05) continue;
      for (const OrderKind kind : {OrderKind::punch_left, OrderKind::punch_right}) {
        for (const int after : {6, 12, 18}) {
          const bool left = kind == OrderKind::punch_left;
          const std::string what = fmt::format("{} -> {} {} updates in, {}", rigs[a].name, rigs[c].name, after,
                                               left ? "left punch" : "right punch");
          ++cases;
          double t = 0;
          const Vector3d head(0, 1.6, 1.0);
          const auto fighter = standing_in_open_room(set.db, rigs, a, head, t);
          Behaviour& b = *fighter;
          // At the taller body's head height, 0.9 of its arm in front of its shoulder line.
          const double h = rigs[a].morphology.height_m;
          b.order_strike(Order{t, kind}, b.ground().to_world(Vector3d(0, 0.93 * h, 0.9 * rigs[a].morphology.arm_length(kRight) + 0.15)));
          std::vector<std::vector<Vector3d>> track{drawn_canonical(b)};
          bool judged = false;
          for (int i = 0; i < 90; ++i) {
            if (i == after) {
              if (!b.strike().contact_done) ++switched_before_contact;
              b.order(Order{t, OrderKind::select_character, static_cast<std::int32_t>(c)});
            }
            const bool before = b.strike().contact_done;
            b.update(t += dt, dt, head);
            track.push_back(drawn_canonical(b));
            if (!before && b.strike().contact_done && !judged && i >= after) {
              judged = true;
              const auto& j = track.back();
              const double elbow = j[static_cast<std::size_t>(left ? CJ::l_elbow : CJ::r_elbow)].y();
              const double under = j[static_cast<std::size_t>(CJ::head)].y() - elbow;
              worst = std::min(worst, under);
              if (under < 0 && ++over == 1) first_over = fmt::format("{}: elbow {:.3f} m over the head", what, -under);
            }
          }
          snaps += count_snaps(track, what, first_snap);
        }
      }
    }
  }
  std::printf("head-height punches switched to a shorter body on their way: %d cases (%d before contact), elbow over the "
              "head at contact %d (least room under it %.3f m), %d snaps (%s)\n",
              cases, switched_before_contact, over, worst, snaps, first_snap.c_str());
  EXPECT_GT(switched_before_contact, cases / 2);
  EXPECT_EQ(over, 0) << first_over;
  EXPECT_EQ(snaps, 0) << first_snap;
}

// A fighter left outside its area by less than follow_tolerance_m (as a lunge or a kick
// carries the body on past where it stood) walks back in, though the visitor stands where it
// would keep it: the area keeps it off the front wall. Before, it stayed there (0.2 m out, the
// visitor's spot within follow_tolerance_m of it) until the visitor moved.
TEST(BehaviourShipped, AFighterOutsideItsAreaWalksBackIn) {
  const auto& set = kumite::content::testing::shipped_database();
  const auto rigs = kumite::content::testing::shipped_characters();
  FighterConfig cfg = open_room_at_origin();
  cfg.max_z_m = -0.22;  // home (the origin) lies 0.22 m past the area's front edge
  ASSERT_LT(0.22, cfg.behaviour.follow_tolerance_m);
  Behaviour b(set.db, {rigs[2]}, cfg);
  const double dt = 1.0 / 60;
  double t = 0;
  const Vector3d head(0, 1.7, cfg.strike_distance_m);  // where the fighter at home would keep it
  b.update(t, 0, head);
  for (int i = 0; i < 180; ++i) b.update(t += dt, dt, head);
  EXPECT_LT(b.frame().root.z(), -0.1) << "walked back in (the pelvis sways about the spot by a few cm)";
  EXPECT_EQ(b.state(), FighterState::resting);
  // Paused, it stays where it is.
  FighterConfig paused_cfg = cfg;
  Behaviour p(set.db, {rigs[2]}, paused_cfg);
  t = 0;
  p.update(t, 0, head);
  p.order(Order{t, OrderKind::pause});
  for (int i = 0; i < 180; ++i) p.update(t += dt, dt, head);
  EXPECT_GT(p.frame().root.z(), -0.1) << "paused: no walk";
}

// After a stance step from the mocap (a kata step into a long stance, 0.7 m from foot to foot,
// and that take's own rest) to the front edge of its area, a punch whose lunge that stance
// holds short (placed on its back foot) first takes a rest stance the strikes are made for,
// its feet stepping into it (Behaviour::restance_for), and lands on its target. Before, it
// stepped in as far as the area let it, keeping the long stance, and fell short (aiko in the
// scripted bout with stance steps on: 24-30 cm).
TEST(BehaviourShipped, APunchAfterAStanceStepTakesTheRestStanceOnTheWayAndLands) {
  const auto& set = kumite::content::testing::shipped_database();
  const auto rigs = kumite::content::testing::shipped_characters();
  int landed = 0, restanced = 0, tried = 0;
  std::string misses;
  for (const Rig& rig : rigs) {
  for (const OrderKind kind : {OrderKind::punch_right, OrderKind::punch_left}) {
    for (const double walk : {0.8, 1.0}) {
      FighterConfig cfg = open_room_at_origin();
      cfg.behaviour.stance_step_min_m = 0.5;
      cfg.max_z_m = 0.55;  // the area's front edge: the stance step ends at it
      Behaviour b(set.db, {rig}, cfg);
      const double dt = 1.0 / 60;
      double t = 0;
      Vector3d head(0, 1.6, cfg.strike_distance_m);
      b.update(t, 0, head);
      for (int i = 0; i < 60; ++i) b.update(t += dt, dt, head);
      // The visitor walks away in 1 s and stands: the fighter follows with a stance step.
      const double z0 = head.z();
      for (int i = 0; i < 240; ++i) {
        head.z() = z0 + walk * std::min(1.0, i * dt / 1.0);
        b.update(t += dt, dt, head);
      }
      for (int i = 0; i < 180 && !(b.state() == FighterState::resting && b.stance_step_segment() < 0); ++i) b.update(t += dt, dt, head);
      ASSERT_GE(b.stance_steps_begun(), 1) << rig.name << " walk " << walk;
      ASSERT_EQ(b.state(), FighterState::resting) << rig.name << " walk " << walk;
      // The visitor stands 0.95 m ahead of the fighter's pelvis (the scripted bout's visitor
      // beyond the area's front edge): a lunge from the fighting stance reaches that far, one
      // placed on the long stance's back foot does not, and the area leaves no step in.
      head.z() = b.frame().root.z() + 0.95;
      ++tried;
      b.order_strike(Order{t, kind}, head);
      std::vector<FighterEvent> events;
      for (int i = 0; i < 300 && !b.strike().contact_done; ++i) {
        b.update(t += dt, dt, head);
        for (auto& e : b.take_events()) events.push_back(e);
      }
      ASSERT_TRUE(b.strike().contact_done) << "walk " << walk;
      const bool stepped = std::any_of(events.begin(), events.end(), [](const FighterEvent& e) {
        return (e.kind == FighterEvent::Kind::stepping_in || e.kind == FighterEvent::Kind::stepping_back) &&
               e.reason == FighterEvent::Reason::restance;
      });
      restanced += stepped;
      if (b.strike().target_reached && b.strike().contact_distance_m < 2e-3) ++landed;
      else misses += fmt::format(" [{} {} walk {}: {:.0f} mm short]", rig.name, kind == OrderKind::punch_right ? "right" : "left", walk,
                                 b.strike().contact_distance_m * 1000);
    }
  }
  }
  std::printf("punches after a stance step: %d of %d land, %d took the fighting stance first%s\n", landed, tried, restanced,
              misses.c_str());
  EXPECT_EQ(landed, tried) << misses;
  EXPECT_GT(restanced, tried / 4) << "the fighting stance taken on the way";
}

// A visitor walking forward past the fighter (1.6 m in 1 s, faster than it walks back; 25 cm
// to the side of its spot: a lunge of the fighter's own into a visitor walking in does the
// same, the spar demo at 10.3 s) and standing there: the fighter keeps its distance on its home's
// side of the visitor (follow_arc_deg, 45), where the walls show it, walking round beside the
// visitor, not through the head. Along the line to where it stood instead, it ended beside
// and behind the visitor (98 degrees from the way home). Judged from the drawn pelvis and the
// head: its bearing from straight toward home, and the nearest it came to the head.
TEST(BehaviourShipped, AVisitorWalkingPastTheFighterFindsItBeforeThemAgain) {
  const auto& set = kumite::content::testing::shipped_database();
  const auto rigs = kumite::content::testing::shipped_characters();
  // The arc from the tunable (orders mode's), from follow_at over a tunable of 180 (as the
  // sparring planner passes its own), and none (180).
  for (const double arc : {45.0, -45.0, 180.0}) {
    FighterConfig cfg = open_room_at_origin();
    cfg.behaviour.follow_arc_deg = arc > 0 ? arc : 180.0;
    Behaviour b(set.db, {rigs[1]}, cfg);
    if (arc < 0) b.follow_at(cfg.strike_distance_m, false, -1, -arc);
    const double dt = 1.0 / 60;
    double t = 0;
    Vector3d head(0.25, 1.7, 2.0);  // 2 m before home (the origin): the fighter follows to ~1.1
    b.update(t, 0, head);
    for (int i = 0; i < 240; ++i) b.update(t += dt, dt, head);
    const double spot_z = b.frame().root.z();
    ASSERT_GT(spot_z, 0.8) << "followed the visitor in first";
    double nearest = 1e9;
    for (int i = 0; i < 600; ++i) {  // 1.6 m in 1 s, then 9 s standing (0.5 m on home's side of the spot it had)
      head.z() = 2.0 - 1.6 * std::min(1.0, i * dt / 1.0);
      b.update(t += dt, dt, head);
      const Vector3d r = b.frame().root;
      if (i * dt > 1.0) nearest = std::min(nearest, std::hypot(r.x() - head.x(), r.z() - head.z()));
    }
    const Vector3d r = b.frame().root;
    // (home is the origin: the way home from the head is -head)
    const double bearing_deg =
        std::abs(std::remainder(std::atan2(r.x() - head.x(), r.z() - head.z()) - std::atan2(-head.x(), -head.z()), 2 * std::numbers::pi)) *
        180 / std::numbers::pi;
    std::printf("follow_arc_deg %.0f%s: the visitor at z %.2f, the fighter's pelvis at (%.2f, %.2f): %.0f deg from the way home, "
                "%.2f m from the head; nearest after the walk %.2f m\n",
                std::abs(arc), arc < 0 ? " (follow_at)" : "", head.z(), r.x(), r.z(), bearing_deg, std::hypot(r.x() - head.x(), r.z() - head.z()), nearest);
    if (std::abs(arc) < 90) {
      EXPECT_LT(bearing_deg, std::abs(arc) + 20) << "on its home's side of the visitor";
      EXPECT_LT(r.z(), head.z()) << "before the visitor";
      EXPECT_GT(nearest, 0.3) << "walked round the visitor, not through the head";
    } else {
      EXPECT_GT(bearing_deg, 90.0) << "along the line alone: beside and behind the visitor";
    }
  }
}
