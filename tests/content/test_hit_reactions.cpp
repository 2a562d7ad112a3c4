// Hit reactions (issue 53, item 4): a SYNTHETIC visitor's fist driven into the sparring
// fighter's drawn head or torso. Every figure is judged here from the drawn joints alone,
// beside a run that is the same in everything but the blow (the fist held still where the
// blow starts): nothing of the reaction's own code is asked what it did.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <vector>

#include "kumite/content/behaviour.hpp"
#include "kumite/content/tunables.hpp"
#include "kumite/content/fighter.hpp"

using namespace kumite::content;
using kumite::recognition::Role;
using Eigen::Vector3d;
using CJ = CanonicalJoint;

namespace {

const std::filesystem::path kDb = std::filesystem::path(KUMITE_BINARY_DIR) / "demo" / "fighter.kdb";
const std::filesystem::path kKenji = std::filesystem::path(KUMITE_SOURCE_DIR) / "content" / "characters" / "kenji.bvh";
const Vector3d kVisitorHead(0, 1.65, -1.6);
constexpr double kDt = 1.0 / 60;

/// The visitor's right fist: still at `start` until update k0, then along `dir` at `speed_mps`
/// for `travel_m`, then still again.
struct Fist {
  int k0 = 1 << 30;
  Vector3d start{-0.15, 1.45, -1.8};
  Vector3d dir{0, 0, -1};
  double speed_mps = 0;
  double travel_m = 0.45;
  Vector3d at(int k) const {
    if (k < k0) return start;
    return start + dir * std::min(travel_m, speed_mps * (k - k0) * kDt);
  }
};

struct HitRun {
  std::vector<std::vector<Vector3d>> joints;  // per update, the drawn joints
  std::vector<Vector3d> root;
  std::vector<FighterAction> actions;
  std::vector<std::pair<int, FighterEvent>> events;  // (update, event)
  int first(EventKind k) const {
    for (const auto& [u, e] : events)
      if (e.kind == k) return u;
    return -1;
  }
};

HitRun hit_run(const PlannerTunables& planner, const Fist& fist, int updates = 60 * 6, int punch_order_at = -1,
               const Fist* left = nullptr) {
  FighterConfig cfg;
  cfg.database = kDb;
  cfg.characters = {kKenji};
  cfg.character_names = {"kenji"};
  cfg.planner = planner;
  auto f = Fighter::create(cfg);
  FighterOutput out;
  HitRun r;
  for (int k = 0; k < updates; ++k) {
    FighterInput in;
    in.now = k * kDt;
    in.dt_s = k ? kDt : 0;
    in.head_m = kVisitorHead;
    std::vector<VisitorBody> bodies(left ? 3 : 2);
    if (left) {
      bodies[2].role = Role::left_hand;
      bodies[2].position_m = left->at(k);
      bodies[2].tracked = true;
      bodies[2].t = in.now;
    }
    bodies[0].role = Role::head;
    bodies[0].position_m = kVisitorHead;
    bodies[0].tracked = true;
    bodies[0].t = in.now;
    bodies[1].role = Role::right_hand;
    bodies[1].position_m = fist.at(k);
    bodies[1].tracked = true;
    bodies[1].t = in.now;
    in.bodies = bodies;
    std::vector<kumite::Order> orders;
    if (k == punch_order_at) orders.push_back(kumite::Order{in.now, kumite::OrderKind::punch_right, 0});
    in.orders = orders;
    f->step(in, out);
    r.joints.emplace_back(out.frame.joints.begin(), out.frame.joints.end());
    r.root.push_back(out.frame.root);
    r.actions.push_back(out.frame.action);
    for (const FighterEvent& e : out.events) r.events.emplace_back(k, e);
  }
  return r;
}

int joint_index(CJ j) {
  static const Rig rig = load_character_rig(kKenji.string());
  return rig.skeleton.index(j);
}

/// A blow from 0.30 m in front of the drawn joint `j` (+ `offset`) at update k0 - 1 of `still`,
/// straight at it along the line from the visitor, at `speed_mps`.
Fist blow_at(const HitRun& still, int k0, CJ j, double speed_mps, const Vector3d& offset = Vector3d::Zero()) {
  const Vector3d p = still.joints[static_cast<std::size_t>(k0 - 1)][static_cast<std::size_t>(joint_index(j))] + offset;
  Vector3d u = kVisitorHead - p;
  u.y() = 0;
  u.normalize();
  Fist f;
  f.k0 = k0;
  f.start = p + u * 0.30;
  f.dir = -u;
  f.speed_mps = speed_mps;
  return f;
}

/// The largest one-frame step of any drawn joint over [from, to), and whether a step is a snap
/// as motion_quality.hpp and judge-bvh.py define one (faster than 20 m/s, or > 5 cm and > 3x
/// both neighbouring steps).
struct Steps {
  double largest_m = 0;
  int snaps = 0;
  std::size_t joint = 0;  // the largest step's joint and update, and the steps beside it
  int update = 0;
  double before_m = 0, after_m = 0;
};
/// A joint of a leg (the hip's or below): stepping feet move fast on their own.
bool leg_joint(std::size_t j) {
  static const Rig rig = load_character_rig(kKenji.string());
  for (int i = static_cast<int>(j); i >= 0; i = rig.skeleton.parents[static_cast<std::size_t>(i)])
    if (i == rig.skeleton.index(CJ::l_hip) || i == rig.skeleton.index(CJ::r_hip)) return true;
  return false;
}
Steps steps(const HitRun& r, int from, int to, bool upper_body_only = false) {
  Steps s;
  const std::size_t n = r.joints.front().size();
  for (std::size_t j = 0; j < n; ++j)
    if (!upper_body_only || !leg_joint(j))
    for (int k = std::max(2, from); k + 1 < to; ++k) {
      const auto step = [&](int i) { return (r.joints[static_cast<std::size_t>(i)][j] - r.joints[static_cast<std::size_t>(i - 1)][j]).norm(); };
      const double d = step(k);
      if (d > s.largest_m) s = Steps{d, s.snaps, j, k, step(k - 1), step(k + 1)};
      if (d / kDt > 20 || (d > 0.05 && d > 3 * step(k - 1) && d > 3 * step(k + 1))) ++s.snaps;
    }
  return s;
}

PlannerTunables sparring() {
  PlannerTunables p;
  p.mode = PlannerMode::spar;
  p.attack_rate_per_s = 0;
  p.counter_probability = 0;
  return p;
}

}  // namespace

TEST(HitReactions, AHeadBlowMovesTheDrawnHeadAlongTheBlowFromTheFrameAfterContactAndNotBefore) {
  if (!std::filesystem::exists(kDb)) GTEST_SKIP() << "no demo database (scripts/setup.sh makes it)";
  const PlannerTunables p = sparring();
  const HitRun still = hit_run(p, Fist{});
  const int k0 = 180;
  const Fist fist = blow_at(still, k0, CJ::head, 4.0);  // share (4 - 1.5) / (6 - 1.5): no step back
  const HitRun still_there = hit_run(p, [&] { Fist f = fist; f.k0 = 1 << 30; return f; }());
  const HitRun blow = hit_run(p, fist);
  const int kh = blow.first(EventKind::visitor_hit);
  ASSERT_GE(kh, k0) << "the SYNTHETIC blow was judged a hit";
  const auto head = static_cast<std::size_t>(joint_index(CJ::head));
  for (int k = 0; k < kh; ++k)
    ASSERT_EQ(blow.joints[static_cast<std::size_t>(k)], still_there.joints[static_cast<std::size_t>(k)])
        << "nothing moves before the contact is judged (update " << k << ")";
  // The update that judges the contact draws the frame after it: the head has moved along the blow.
  const Vector3d first = blow.joints[static_cast<std::size_t>(kh)][head] - still_there.joints[static_cast<std::size_t>(kh)][head];
  EXPECT_GT(first.dot(fist.dir), 0) << "the head moves along the fist's velocity";
  double most = 0;
  int most_at = kh;
  for (int k = kh; k < kh + 30; ++k) {
    const double along = (blow.joints[static_cast<std::size_t>(k)][head] - still_there.joints[static_cast<std::size_t>(k)][head]).dot(fist.dir);
    if (along > most) most = along, most_at = k;
  }
  EXPECT_GT(most, 0.02) << "the head reels visibly";
  EXPECT_LT(most, 0.15);
  std::printf("head blow 4 m/s: contact judged at update %d; the head along the blow %.1f mm on that frame, %.1f mm at most (%d frames later)\n",
              kh, first.dot(fist.dir) * 1000, most * 1000, most_at - kh);
  const Steps b = steps(blow, kh - 5, kh + 60), s = steps(still_there, kh - 5, kh + 60);
  EXPECT_EQ(b.snaps, 0);
  EXPECT_LT(b.largest_m, std::max(0.05, s.largest_m));
  std::printf("  largest one-frame joint step %.1f mm (without the blow %.1f mm)\n", b.largest_m * 1000, s.largest_m * 1000);
}

TEST(HitReactions, ATouchBelowTheSpeedThresholdMovesNothing) {
  if (!std::filesystem::exists(kDb)) GTEST_SKIP() << "no demo database (scripts/setup.sh makes it)";
  const PlannerTunables p = sparring();
  const HitRun still = hit_run(p, Fist{});
  Fist touch = blow_at(still, 180, CJ::head, 1.0);  // 1 m/s: under hit_min_speed_mps (1.5)
  Fist there = touch;
  there.k0 = 1 << 30;
  const HitRun a = hit_run(p, touch), b = hit_run(p, there);
  EXPECT_EQ(a.first(EventKind::visitor_hit), -1);
  ASSERT_EQ(a.joints.size(), b.joints.size());
  for (std::size_t k = 0; k < a.joints.size(); ++k) ASSERT_EQ(a.joints[k], b.joints[k]) << "update " << k;
}

TEST(HitReactions, OrdersModeDoesNotReact) {
  if (!std::filesystem::exists(kDb)) GTEST_SKIP() << "no demo database (scripts/setup.sh makes it)";
  PlannerTunables p;  // orders
  const HitRun still = hit_run(p, Fist{});
  Fist fist = blow_at(still, 180, CJ::head, 8.0);
  Fist there = fist;
  there.k0 = 1 << 30;
  const HitRun a = hit_run(p, fist), b = hit_run(p, there);
  EXPECT_EQ(a.first(EventKind::visitor_hit), -1);
  for (std::size_t k = 0; k < a.joints.size(); ++k) ASSERT_EQ(a.joints[k], b.joints[k]) << "update " << k;
}

TEST(HitReactions, AHardBlowOffCentreReelsTheStruckShoulderAndStepsBackWithoutSlidingAFoot) {
  if (!std::filesystem::exists(kDb)) GTEST_SKIP() << "no demo database (scripts/setup.sh makes it)";
  const PlannerTunables p = sparring();
  const HitRun still = hit_run(p, Fist{});
  const int k0 = 180;
  // At the chest, 0.12 m toward the fighter's left shoulder, 9 m/s (a full blow: it steps back).
  const auto ls = static_cast<std::size_t>(joint_index(CJ::l_shoulder)), rs = static_cast<std::size_t>(joint_index(CJ::r_shoulder));
  const Vector3d left = (still.joints[k0 - 1][ls] - still.joints[k0 - 1][rs]).normalized();
  const Fist fist = blow_at(still, k0, CJ::chest, 9.0, left * 0.12);
  Fist there = fist;
  there.k0 = 1 << 30;
  const HitRun a = hit_run(p, fist), b = hit_run(p, there);
  const int kh = a.first(EventKind::visitor_hit);
  ASSERT_GE(kh, k0);
  // Each shoulder's move along the blow beside the pelvis joint's (the step back carries all).
  const auto pelvis = static_cast<std::size_t>(joint_index(CJ::pelvis));
  double l_most = 0, r_most = 0, back = 0;
  for (int k = kh; k < kh + 30; ++k) {
    const auto d = [&](std::size_t j) { return (a.joints[static_cast<std::size_t>(k)][j] - b.joints[static_cast<std::size_t>(k)][j]).dot(fist.dir); };
    l_most = std::max(l_most, d(ls) - d(pelvis));
    r_most = std::max(r_most, d(rs) - d(pelvis));
    back = std::max(back, (a.root[static_cast<std::size_t>(k)] - b.root[static_cast<std::size_t>(k)]).dot(fist.dir));
  }
  EXPECT_GT(l_most, r_most + 0.01) << "the struck (left) shoulder goes back further";
  EXPECT_GT(back, 0.15) << "a full blow steps the fighter back";
  std::printf("torso blow 9 m/s, 12 cm left of the midline: shoulders along the blow beside the pelvis at most L %.1f / R %.1f mm; "
              "stepped back %.0f mm within 0.5 s\n",
              l_most * 1000, r_most * 1000, back * 1000);
  // Feet: an ankle on the floor (within 1.5 cm of its lowest in the run, this frame and the
  // last) moves no faster than the run without the blow has one move.
  const auto slide = [&](const HitRun& r) {
    double most = 0;
    for (CJ ankle : {CJ::l_ankle, CJ::r_ankle}) {
      const auto j = static_cast<std::size_t>(joint_index(ankle));
      double low = 1e9;
      for (const auto& f : r.joints) low = std::min(low, f[j].y());
      for (std::size_t k = static_cast<std::size_t>(kh); k < static_cast<std::size_t>(kh + 90); ++k) {
        if (r.joints[k][j].y() > low + 0.015 || r.joints[k - 1][j].y() > low + 0.015) continue;
        Vector3d d = r.joints[k][j] - r.joints[k - 1][j];
        d.y() = 0;
        most = std::max(most, d.norm() / kDt);
      }
    }
    return most;
  };
  const double sa = slide(a), sb = slide(b);
  std::printf("  a foot down moves at most %.2f m/s (without the blow %.2f)\n", sa, sb);
  const Steps big = steps(a, kh - 5, kh + 90, true);
  EXPECT_LT(big.largest_m, 0.05);
  std::printf("  largest one-frame upper-body joint step %.1f mm (joint %zu, update %d; %.1f mm before, %.1f after)\n", big.largest_m * 1000, big.joint,
              big.update, big.before_m * 1000, big.after_m * 1000);
  EXPECT_LE(sa, std::max(1.0, sb));
  EXPECT_EQ(steps(a, kh - 5, kh + 90).snaps, 0);
}

TEST(HitReactions, AStrikeOfItsOwnUnderWayIsAbortedWithoutAJump) {
  if (!std::filesystem::exists(kDb)) GTEST_SKIP() << "no demo database (scripts/setup.sh makes it)";
  const PlannerTunables p = sparring();
  const int order_at = 150;
  const HitRun still = hit_run(p, Fist{}, 60 * 6, order_at);
  const int ks = static_cast<int>(std::find(still.actions.begin(), still.actions.end(), FighterAction::striking) - still.actions.begin());
  ASSERT_LT(ks, static_cast<int>(still.actions.size())) << "the ordered punch plays";
  int kc = -1;
  for (const auto& [u, e] : still.events)
    if (kc < 0 && (e.kind == EventKind::hit || e.kind == EventKind::dodged || e.kind == EventKind::miss)) kc = u;
  ASSERT_GT(kc, ks);
  const int k0 = ks + 2;
  const Fist fist = blow_at(still, k0, CJ::head, 6.0);
  Fist there = fist;
  there.k0 = 1 << 30;
  const HitRun a = hit_run(p, fist, 60 * 6, order_at), b = hit_run(p, there, 60 * 6, order_at);
  const int kh = a.first(EventKind::visitor_hit);
  ASSERT_GE(kh, k0);
  ASSERT_LT(kh, kc) << "the blow lands before the punch's contact";
  const int kr = static_cast<int>(std::find(a.actions.begin() + kh, a.actions.end(), FighterAction::recovering) - a.actions.begin());
  std::printf("punch started at update %d, contact (unhit) at %d; the blow judged at %d, the punch left for rest at %d\n", ks, kc, kh, kr);
  EXPECT_LT(kr, kc) << "the punch is aborted before its contact";
  EXPECT_LE(kr, ks + 16) << "as soon as its cross-fade in is done (0.25 s)";
  for (const auto& [u, e] : a.events)
    EXPECT_FALSE(e.kind == EventKind::hit || e.kind == EventKind::dodged || e.kind == EventKind::miss) << "the aborted punch has no contact";
  const Steps sa = steps(a, ks, kc + 60), sb = steps(b, ks, kc + 60);
  std::printf("  largest one-frame joint step %.1f mm (the punch unhit: %.1f mm); snaps %d\n", sa.largest_m * 1000, sb.largest_m * 1000, sa.snaps);
  EXPECT_EQ(sa.snaps, 0);
  // (the punch's fist moves 13 cm a frame on its own; the reel adds the trunk's turn to it)
  EXPECT_LT(sa.largest_m, std::max(0.05, 1.25 * sb.largest_m));
  // It rests again and takes the next order.
  EXPECT_EQ(a.actions.back(), FighterAction::idle);
}

TEST(HitReactions, KeysAreReadCheckedAndNamed) {
  PlannerTunables p;
  std::uint64_t seed = 1;
  parse_planner_tunables("[fighter.planner]\nhit_head_max_deg = 20\nhit_step_back_m = 0\n", "room.toml", p, seed);
  EXPECT_EQ(p.hit_head_max_deg, 20);
  EXPECT_EQ(p.hit_step_back_m, 0);
  const auto error = [](const std::string& text) -> std::string {
    PlannerTunables q;
    std::uint64_t s = 1;
    try {
      parse_planner_tunables(text, "room.toml", q, s);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  const std::string damping = error("[fighter.planner]\n\nhit_damping_ratio = 2\n");
  EXPECT_NE(damping.find("room.toml:3"), std::string::npos) << damping;
  EXPECT_NE(damping.find("hit_damping_ratio"), std::string::npos) << damping;
  EXPECT_NE(error("[fighter.planner]\nhit_stiffness_rad_s = nan\n").find("hit_stiffness_rad_s"), std::string::npos);
  const std::string order = error("[fighter.planner]\nhit_min_speed_mps = 3\nhit_full_speed_mps = 2\n");
  EXPECT_NE(order.find("room.toml:3"), std::string::npos) << order;
  EXPECT_NE(order.find("hit_full_speed_mps"), std::string::npos) << order;
  PlannerTunables t;
  EXPECT_EQ(validate(t), "");
  t.hit_trunk_max_deg = 90;
  EXPECT_NE(validate(t).find("hit_trunk_max_deg"), std::string::npos);
  t = {};
  t.hit_full_speed_mps = 1;
  EXPECT_NE(validate(t).find("hit_full_speed_mps"), std::string::npos);
}

TEST(HitReactions, BothFistsAtOnceReelWithinTheLargestReelAndNeverSnap) {
  if (!std::filesystem::exists(kDb)) GTEST_SKIP() << "no demo database (scripts/setup.sh makes it)";
  const PlannerTunables p = sparring();
  const HitRun still = hit_run(p, Fist{});
  const int k0 = 180;
  const Fist right = blow_at(still, k0, CJ::head, 9.0);
  Fist left = blow_at(still, k0, CJ::chest, 9.0);
  left.start.x() += 0.3;  // from the visitor's left guard (x 0.15 of the line), still straight at the chest
  left.dir = (still.joints[k0 - 1][static_cast<std::size_t>(joint_index(CJ::chest))] - left.start).normalized();
  const HitRun a = hit_run(p, right, 60 * 6, -1, &left);
  int hits = 0;
  for (const auto& [u, e] : a.events) hits += e.kind == EventKind::visitor_hit;
  EXPECT_EQ(hits, 2) << "both fists judged";
  const Steps st = steps(a, k0, k0 + 90, true);
  EXPECT_EQ(steps(a, k0, k0 + 90).snaps, 0);
  std::printf("two full blows at once (judged at %d): largest one-frame upper-body joint step %.1f mm (joint %zu, update %d; %.1f mm before, %.1f after), snaps %d\n",
              a.first(EventKind::visitor_hit), st.largest_m * 1000, st.joint, st.update, st.before_m * 1000, st.after_m * 1000, st.snaps);
  EXPECT_EQ(st.snaps, 0);
  // Two full blows at once move the struck side's elbow ~55 mm a frame over three frames (the
  // trunk, the shoulder and the step back together): fast, as a blow is, but no snap (its
  // neighbours as large); a punch's fist moves 130 mm a frame.
  EXPECT_LT(st.largest_m, 0.08);
  for (const auto& f : a.joints)
    for (const Vector3d& j : f) ASSERT_TRUE(j.allFinite());
  EXPECT_EQ(a.actions.back(), FighterAction::idle);
}
