// Behaviour driven by a scripted head, no window: strikes reach, orders are ignored
// mid-strike, hit/miss, feet stay planted, character switches do not jump.
// Data: SYNTHETIC clips and characters (fighter_fixtures.hpp).
#include <algorithm>
#include <limits>

#include <gtest/gtest.h>

#include "fighter_fixtures.hpp"
#include "kumite/content/behaviour.hpp"

using namespace kumite;
using namespace kumite::content;
using CJ = CanonicalJoint;
using Eigen::Vector3d;

namespace {

constexpr double kDt = 1.0 / 120;

FighterConfig test_config() {
  FighterConfig c;
  c.home = Vector3d(0, 0, 0);
  c.min_x_m = -3;
  c.max_x_m = 3;
  c.min_z_m = -3;
  c.max_z_m = 3;
  return c;
}

/// Along the floor (a held foot's heel may rise and come down with the motion's: not a slide).
double horizontal(const Vector3d& d) { return std::hypot(d.x(), d.z()); }

struct Script {
  double t = 0;
  Vector3d head{0, 1.7, 0.9};
  double max_jump_m = 0;       // largest joint displacement between two updates
  double max_slide_m = 0;      // largest displacement of a held ankle along the floor between two updates
  std::vector<FighterEvent> events;

  void step(Behaviour& b, int n = 1) {
    for (int i = 0; i < n; ++i) {
      const auto before = std::vector<Vector3d>(b.joint_positions().begin(), b.joint_positions().end());
      const auto locked_before = b.feet_locked();
      const int char_before = b.current_character();
      const Rig& rig0 = b.character(char_before);
      const auto raw = b.rig_positions();  // without the switch easing
      const Vector3d la = raw.empty() ? Vector3d::Zero() : raw[static_cast<std::size_t>(rig0.skeleton.index(CJ::l_ankle))];
      const Vector3d ra = raw.empty() ? Vector3d::Zero() : raw[static_cast<std::size_t>(rig0.skeleton.index(CJ::r_ankle))];
      t += kDt;
      b.update(t, kDt, head);
      for (auto& e : b.take_events()) events.push_back(e);
      if (b.update_count() > 1 && b.current_character() == char_before) {
        for (std::size_t j = 0; j < before.size(); ++j) {
          const double d = (b.joint_positions()[j] - before[j]).norm();
          max_jump_m = std::max(max_jump_m, d);
        }
        const auto locked = b.feet_locked();
        const Rig& rig = b.character(b.current_character());
        if (locked[0] && locked_before[0])
          max_slide_m = std::max(max_slide_m, horizontal(b.rig_positions()[static_cast<std::size_t>(rig.skeleton.index(CJ::l_ankle))] - la));
        if (locked[1] && locked_before[1])
          max_slide_m = std::max(max_slide_m, horizontal(b.rig_positions()[static_cast<std::size_t>(rig.skeleton.index(CJ::r_ankle))] - ra));
      }
    }
  }
  // Steps until the current strike has passed contact (or a time limit).
  void until_contact(Behaviour& b, double limit_s = 3) {
    for (double s = 0; s < limit_s && !(b.strike().active && b.strike().contact_done); s += kDt) step(b);
  }
  // Resting with no strike order under way (a fighter stepping in rests between its steps).
  void until_rest(Behaviour& b, double limit_s = 4) {
    for (double s = 0; s < limit_s && (b.state() != FighterState::resting || b.strike_pending()); s += kDt) step(b);
  }
  // Steps until a strike is under way (after stepping in, when the target was out of reach).
  void until_striking(Behaviour& b, double limit_s = 3) {
    for (double s = 0; s < limit_s && b.state() != FighterState::striking; s += kDt) step(b);
  }
  // The target the last accepted strike order froze.
  Vector3d accepted_target() const {
    for (auto e = events.rbegin(); e != events.rend(); ++e)
      if (e->kind == FighterEvent::Kind::order_accepted && e->reason == FighterEvent::Reason::strike) return e->target;
    return Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  int count(FighterEvent::Kind k) const {
    return static_cast<int>(std::count_if(events.begin(), events.end(), [&](const auto& e) { return e.kind == k; }));
  }
};

Behaviour make_behaviour(int character = 0) {
  FighterConfig c = test_config();
  c.initial_character = character;
  return Behaviour(kumite::content::testing::synthetic_database().db, kumite::content::testing::synthetic_characters(), c);
}

Order order_of(OrderKind k, int character = -1) { return Order{0, k, character}; }

}  // namespace

TEST(Behaviour, StrikesLandOnReachableTargetsForEveryCharacterWithinOneMillimetre) {
  for (int c = 0; c < 3; ++c) {
    int reached = 0, total = 0;
    for (double dx : {-0.15, 0.0, 0.15}) {
      for (double dy : {-0.1, 0.0, 0.1}) {
        Behaviour b = make_behaviour(c);
        Script run;
        run.step(b, 30);
        const Rig& rig = b.character(c);
        const double sh = rig.rest_pose[static_cast<std::size_t>(CJ::r_shoulder)].y() - rig.rest_pose[static_cast<std::size_t>(CJ::r_ankle)].y();
        const Vector3d local(dx, sh + dy, 0.75 * rig.morphology.arm_length(kRight) + 0.1);
        const Vector3d target = b.ground().to_world(local);
        b.order_strike(order_of(OrderKind::punch_right), target);
        run.until_contact(b);
        ASSERT_TRUE(b.strike().contact_done) << rig.name;
        ++total;
        if (b.strike().contact_reached) {
          ++reached;
          EXPECT_LT(b.strike().contact_distance_m, 1e-3) << rig.name << " " << dx << " " << dy;
          EXPECT_TRUE(b.strike().target_reached);
        }
        run.until_rest(b);
        EXPECT_EQ(b.state(), FighterState::resting);
        EXPECT_EQ(run.count(FighterEvent::Kind::hit) + run.count(FighterEvent::Kind::dodged) +
                      run.count(FighterEvent::Kind::miss), 1);
      }
    }
    EXPECT_GE(reached, total - 1) << "character " << c;
  }
}

TEST(Behaviour, OrdersDuringAStrikeAreIgnoredWithAReason) {
  Behaviour b = make_behaviour();
  Script run;
  run.step(b, 10);
  b.order(order_of(OrderKind::punch_right));
  run.until_striking(b);
  run.step(b, 3);
  EXPECT_EQ(b.state(), FighterState::striking);
  b.order(order_of(OrderKind::punch_left));
  b.order(order_of(OrderKind::kick_right));
  run.step(b);
  EXPECT_EQ(run.count(FighterEvent::Kind::order_ignored), 2);
  for (const auto& e : run.events) {
    if (e.kind == FighterEvent::Kind::order_ignored) {
      EXPECT_EQ(e.reason, FighterEvent::Reason::mid_strike);
      EXPECT_EQ(b.describe(e), "mid-strike");
    }
  }
  run.until_rest(b);
  b.order(order_of(OrderKind::punch_left));  // accepted again once resting
  run.until_striking(b);
  EXPECT_EQ(b.state(), FighterState::striking);
  EXPECT_EQ(b.strike().effector.side, kLeft);  // mirrored clips give left punches
}

TEST(Behaviour, FarTargetIsAMissReportedOutOfReach) {
  Behaviour b = make_behaviour();
  Script run;
  run.step(b, 10);
  const Vector3d target = b.ground().to_world(Vector3d(0, 1.4, 3.0));
  run.head = target;  // the visitor stands there, out of reach (a visitor in between would be hit)
  b.order_strike(order_of(OrderKind::punch_right), target);
  run.until_contact(b);
  ASSERT_TRUE(b.strike().contact_done);
  EXPECT_FALSE(b.strike().contact_reached);
  EXPECT_FALSE(b.strike().hit);
  EXPECT_GT(b.strike().contact_distance_m, 1.0);
  ASSERT_EQ(run.count(FighterEvent::Kind::miss), 1);
}

TEST(Behaviour, TargetFrozenAtOrderTimeAndKicksWithoutClipsWarn) {
  Behaviour b = make_behaviour();
  Script run;
  run.step(b, 10);
  b.order(order_of(OrderKind::punch_right));
  run.step(b);
  const Vector3d frozen = run.accepted_target();
  // The visitor's head as it was at the order (punched no higher than the arm reaches: the
  // synthetic body is short, so at the neck below it).
  EXPECT_LT(std::hypot(frozen.x() - run.head.x(), frozen.z() - run.head.z()), 1e-12);
  EXPECT_LE(frozen.y(), run.head.y());
  EXPECT_GT(frozen.y(), run.head.y() - 0.4);
  run.head += Vector3d(0.3, 0, 0);  // the visitor moves; the strike keeps its target
  run.until_contact(b);
  // Frozen: where the visitor was, at most aimed lower (a straight arm to it would lift the
  // elbow over the fighter's own head: the synthetic body is short).
  const Vector3d aimed = frozen - Vector3d::UnitY() * b.strike().aim_lowered_m;
  EXPECT_GE(b.strike().aim_lowered_m, 0.0);
  EXPECT_LT((b.strike().target_room_m - aimed).norm(), 1e-12);
  run.until_rest(b);
  b.order(order_of(OrderKind::kick_left));  // the synthetic set has no kicks
  run.step(b, 2);
  EXPECT_EQ(run.count(FighterEvent::Kind::warning), 1);
  EXPECT_NE(b.state(), FighterState::striking);
}

// A visitor whose head the character's arm cannot reach (0.6 m above the head of the synthetic
// body) is punched at the neck or chest, and that counts as a hit on the tracked body; a head
// within reach is punched where it is.
TEST(Behaviour, AHeadOutOfReachIsPunchedLowerAndStillHits) {
  for (const double lift : {0.0, 0.6}) {
    Behaviour b = make_behaviour();
    Script run;
    run.step(b, 10);
    const Vector3d own_head = b.frame().joints[static_cast<std::size_t>(b.character(0).skeleton.index(CJ::head))];
    run.head.y() = own_head.y() + lift;
    run.step(b, 30);
    b.order(order_of(OrderKind::punch_right));
    run.step(b);
    const Vector3d target = run.accepted_target();
    if (lift == 0.0) {
      EXPECT_NEAR(target.y(), run.head.y(), 1e-12) << "a head within reach is the target";
    } else {
      EXPECT_LT(target.y(), run.head.y() - 0.3) << "a head 0.6 m above the fighter's is punched lower";
    }
    run.until_contact(b);
    EXPECT_EQ(run.count(FighterEvent::Kind::hit), 1) << "lift " << lift;
  }
}

// Switching character mid-strike: drawn joints stay continuous. Bound: the largest per-update
// joint motion of the strike itself (measured without a switch) plus the size difference
// spread over the easing: offset <= ~0.3 m (1.5 m vs 2.0 m bodies) faded by a smoothstep over
// blend_time (max slope 1.5 / blend_time) -> 0.3 * 1.5 * dt / 0.2 s = 1.9 cm per 1/120 s update.
TEST(Behaviour, SwitchingCharacterMidStrikeDoesNotJump) {
  Behaviour ref = make_behaviour(0);
  Script rr;
  rr.step(ref, 10);
  ref.order(order_of(OrderKind::punch_right));
  rr.step(ref, 2);
  rr.until_rest(ref);
  const double motion_bound = rr.max_jump_m;

  Behaviour b = make_behaviour(0);
  Script run;
  run.step(b, 10);
  b.order(order_of(OrderKind::punch_right));
  run.until_striking(b);
  run.step(b, 18);
  ASSERT_EQ(b.state(), FighterState::striking);
  double worst = 0;
  for (int target_char : {1, 2, 0}) {
    const auto before = std::vector<Vector3d>(b.joint_positions().begin(), b.joint_positions().end());
    const Rig& old_rig = b.character(b.current_character());
    b.order(order_of(OrderKind::select_character, target_char));
    run.step(b);
    const Rig& rig = b.character(b.current_character());
    ASSERT_EQ(b.current_character(), target_char);
    for (std::size_t j = 0; j < kCanonicalJointCount; ++j) {
      const int io = old_rig.skeleton.canonical[j], in = rig.skeleton.canonical[j];
      if (io < 0 || in < 0) continue;
      worst = std::max(worst, (b.joint_positions()[static_cast<std::size_t>(in)] - before[static_cast<std::size_t>(io)]).norm());
    }
    run.step(b, 8);
  }
  run.until_rest(b);
  EXPECT_LT(worst, motion_bound + 0.005) << "jump at the switch itself";
  EXPECT_LT(run.max_jump_m, motion_bound + 0.019) << "jump while easing";
  EXPECT_EQ(run.count(FighterEvent::Kind::character_changed), 3);
  EXPECT_EQ(run.count(FighterEvent::Kind::hit) + run.count(FighterEvent::Kind::dodged) +
                run.count(FighterEvent::Kind::miss), 1);
}

TEST(Behaviour, FollowsTheVisitorWithPlantedFeetThatDoNotSlide) {
  Behaviour b = make_behaviour(1);
  Script run;
  run.step(b, 30);
  const Vector3d start = b.frame().root;
  run.head = Vector3d(1.0, 1.7, 1.2);  // visitor steps aside and back
  run.step(b, 30);
  EXPECT_EQ(b.state(), FighterState::following);
  run.step(b, 600);
  EXPECT_EQ(b.state(), FighterState::resting);
  const Vector3d root = b.frame().root;
  EXPECT_GT((root - start).norm(), 0.5);
  const double dist = Eigen::Vector2d(run.head.x() - root.x(), run.head.z() - root.z()).norm();
  EXPECT_NEAR(dist, test_config().strike_distance_m, 0.3);
  EXPECT_LT(run.max_slide_m, 0.002);  // 2 mm per update for held feet
}

// Updated 30 times a second (a 30 fps clip played at its rate, or a frame loop fallen to 30 Hz),
// the spot the rest motion is anchored on speeds up and slows down a little an update
// (12 m/s^2: 1.3 cm of step an update) instead of taking the whole walking speed (2.3 cm an
// update) from standing and stopping dead: at 30 Hz that moved the pelvis 5 cm in each of two
// frames of a step-in and jumped a knee 6 cm in one. It still gets there.
TEST(Behaviour, AtThirtyUpdatesASecondTheFollowedSpotStartsAndStopsWithoutAJump) {
  Behaviour b = make_behaviour(1);
  const double dt = 1.0 / 30;
  double t = 0;
  Vector3d head(0, 1.7, 0.9);
  for (int i = 0; i < 15; ++i) b.update(t += dt, dt, head);
  const Vector3d start = b.frame().root;
  head = Vector3d(1.0, 1.7, 0.9);  // the visitor steps 1 m aside
  std::vector<double> steps;
  Eigen::Vector2d last(start.x(), start.z());
  bool followed = false;
  for (int i = 0; i < 300; ++i) {
    b.update(t += dt, dt, head);
    followed = followed || b.state() == FighterState::following;
    const Eigen::Vector2d now(b.frame().root.x(), b.frame().root.z());
    steps.push_back((now - last).norm());
    last = now;
  }
  ASSERT_TRUE(followed);
  EXPECT_EQ(b.state(), FighterState::resting);
  EXPECT_GT((b.frame().root - start).norm(), 0.3);
  double most_change = 0;
  for (std::size_t i = 1; i < steps.size(); ++i) most_change = std::max(most_change, std::abs(steps[i] - steps[i - 1]));
  RecordProperty("most_step_change_m", std::to_string(most_change));
  EXPECT_LT(most_change, 12 * dt * dt + 0.002);
}

// A recentre ordered while the fighter already stands at home (within follow_tolerance_m) is
// done at once: afterwards the fighter follows the visitor again. (It used to keep the home
// spot as its goal for good: the order was only ever cleared on arriving from afar.)
TEST(Behaviour, ARecentreAtHomeIsDoneAndTheFighterFollowsTheVisitorAgain) {
  Behaviour b = make_behaviour(1);
  Script run;
  run.step(b, 30);
  b.order(Order{run.t, OrderKind::recentre});
  run.step(b, 30);
  EXPECT_EQ(b.state(), FighterState::resting);
  const Vector3d start = b.frame().root;
  run.head = Vector3d(1.0, 1.7, 1.2);  // the visitor steps aside
  run.step(b, 600);
  EXPECT_GT((b.frame().root - start).norm(), 0.5) << "followed the visitor after the recentre";
  const Vector3d root = b.frame().root;
  EXPECT_NEAR(Eigen::Vector2d(run.head.x() - root.x(), run.head.z() - root.z()).norm(), test_config().strike_distance_m, 0.3);
}

namespace {
// A visitor standing where a right punch of character 0 can reach: the head itself is the
// target (local: shoulder height, 0.75 arm length + 10 cm ahead).
Vector3d reachable_head(const Behaviour& b) {
  const Rig& rig = b.character(b.current_character());
  const double sh = rig.rest_pose[static_cast<std::size_t>(CJ::r_shoulder)].y() - rig.rest_pose[static_cast<std::size_t>(CJ::r_ankle)].y();
  return b.ground().to_world(Vector3d(0, sh, 0.75 * rig.morphology.arm_length(kRight) + 0.1));
}
}  // namespace

// Issue 12 item 6: the strike is judged against the visitor as tracked at contact. SYNTHETIC
// visitor: stands still (hit), ducks 0.5 m or steps 0.45 m aside right after the order
// (dodged: the fist still reaches the frozen target, but nobody is there).
TEST(Behaviour, AVisitorWhoDucksOrStepsAsideIsNotHit) {
  const Vector3d moves[3] = {Vector3d::Zero(), Vector3d(0, -0.5, 0), Vector3d(0.45, 0, 0)};
  for (int m = 0; m < 3; ++m) {
    Behaviour b = make_behaviour(0);
    Script run;
    run.head = Vector3d(0, 1.2, 0.8);
    run.step(b, 2);
    run.head = reachable_head(b);
    run.step(b, 30);
    run.head = reachable_head(b);
    b.order(order_of(OrderKind::punch_right));
    run.step(b);
    run.head += moves[m];  // the visitor reacts right after the order
    run.until_contact(b);
    ASSERT_TRUE(b.strike().contact_done) << m;
    EXPECT_TRUE(b.strike().target_reached) << m;
    run.until_rest(b);
    if (m == 0) {
      EXPECT_TRUE(b.strike().hit);
      EXPECT_EQ(run.count(FighterEvent::Kind::hit), 1);
    } else {
      EXPECT_FALSE(b.strike().hit) << m;
      ASSERT_EQ(run.count(FighterEvent::Kind::dodged), 1) << m;
      const auto e = std::find_if(run.events.begin(), run.events.end(),
                                  [](const FighterEvent& x) { return x.kind == FighterEvent::Kind::dodged; });
      EXPECT_GT(e->distance_m, 0.05) << m;  // clear of the visitor's body, and says by how much
      EXPECT_NE(b.describe(*e).find("clear of the hit point"), std::string::npos) << b.describe(*e);
    }
  }
}

// Issue 12 item 2: a strike segment that ends at its hit frame still hands its reach offset
// back smoothly (over release_time_s, through the blend into rest), and the contact frame is a
// real frame of motion. SYNTHETIC clips cut at the hit frame; targets 12 cm off the clip's path.
TEST(Behaviour, ReachOffsetLeavesSmoothlyWhenTheSegmentEndsAtContact) {
  static const auto db = [] {
    const auto& set = kumite::content::testing::synthetic_database();
    std::vector<SegmentSource> src;
    src.push_back({&set.clips[0], "rest", 0, set.clips[0].frame_count - 1, SegmentKind::rest, std::nullopt, -1});
    for (std::size_t i = 1; i < set.clips.size(); ++i) {
      const Clip& c = set.clips[i];
      const int hit = static_cast<int>((0.45 + 0.05 * ((i - 1) % 3)) * (c.frame_count - 1));
      src.push_back({&c, c.name, 0, hit, SegmentKind::strike, Effector{kRight, false}, hit});
    }
    return std::make_shared<const Database>(build_database(src, {}));
  }();
  FighterConfig c = test_config();
  Behaviour b(db, kumite::content::testing::synthetic_characters(), c);
  Script run;
  run.step(b, 30);
  const Rig& rig = b.character(0);
  const double sh = rig.rest_pose[static_cast<std::size_t>(CJ::r_shoulder)].y() - rig.rest_pose[static_cast<std::size_t>(CJ::r_ankle)].y();
  b.order_strike(order_of(OrderKind::punch_right), b.ground().to_world(Vector3d(0.12, sh + 0.05, 0.7 * rig.morphology.arm_length(kRight))));
  run.step(b);
  run.until_contact(b);
  ASSERT_TRUE(b.strike().contact_done);
  const double before_contact = run.max_jump_m;
  const double error = b.strike().error_m.norm();
  ASSERT_GT(error, 0.03) << "the target must be off the clip's own path";
  const auto wrist = static_cast<std::size_t>(rig.skeleton.index(CJ::r_wrist));
  Vector3d last = b.joint_positions()[wrist];
  double worst_wrist = 0;
  int updates = 0;
  for (; updates < 240 && b.state() != FighterState::resting; ++updates) {
    run.step(b);
    worst_wrist = std::max(worst_wrist, (b.joint_positions()[wrist] - last).norm());
    last = b.joint_positions()[wrist];
  }
  EXPECT_EQ(b.state(), FighterState::resting);
  // Over >= 0.25 s by smoothstep, the offset moves the wrist at most 1.5 * error / 0.25 s.
  EXPECT_LT(worst_wrist, before_contact + 1.5 * error / 0.25 * kDt + 1e-3) << "error " << error;
  EXPECT_GE(updates * kDt, 0.25 - 1e-9) << "d(t) released in fewer updates than release_time_s";
}

TEST(Behaviour, KeepsAwayFromAVisitorNearAWallAndIgnoresStrikesMeanwhile) {
  // Visitor safety: while the app says the visitor is near a wall, the fighter backs off to
  // keep_away_extra_m beyond its strike distance and refuses strike orders with a reason;
  // afterwards it comes back and strikes again.
  Behaviour b = make_behaviour(0);
  Script run;
  run.step(b, 240);  // settle at the strike distance
  const auto distance = [&] {
    const Vector3d r = b.frame().root;
    return Eigen::Vector2d(run.head.x() - r.x(), run.head.z() - r.z()).norm();
  };
  const double near = distance();
  EXPECT_NEAR(near, test_config().strike_distance_m, 0.3);
  b.keep_away(true);
  run.step(b, 5 * 120);
  const double away = distance();
  EXPECT_GT(away, near + 0.6) << "near " << near << " m, away " << away << " m";
  EXPECT_LT(run.max_slide_m, 0.002);
  b.order(order_of(OrderKind::punch_right));
  run.step(b, 2);
  ASSERT_EQ(run.count(FighterEvent::Kind::order_ignored), 1);
  const auto ignored = std::find_if(run.events.begin(), run.events.end(),
                                    [](const FighterEvent& e) { return e.kind == FighterEvent::Kind::order_ignored; });
  EXPECT_EQ(ignored->reason, FighterEvent::Reason::near_wall);
  EXPECT_NE(b.describe(*ignored).find("near a wall"), std::string::npos) << b.describe(*ignored);
  b.keep_away(false);
  run.step(b, 5 * 120);
  EXPECT_NEAR(distance(), test_config().strike_distance_m, 0.3);
  b.order(order_of(OrderKind::punch_right));
  run.until_contact(b);
  EXPECT_TRUE(b.strike().contact_done);
}
