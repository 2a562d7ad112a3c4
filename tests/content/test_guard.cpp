// The Guard alone (guard.hpp): parries laid on a still motion's arms, judged on the arm as the
// decode's two-bone IK draws it, worked out here from each laid arm direction and pole by the
// law of cosines (not by the code under test). SYNTHETIC fists: straight paths at the body.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <initializer_list>
#include <string>
#include <vector>

#include "kumite/content/behaviour.hpp"
#include "kumite/content/guard.hpp"

using namespace kumite::content;
using Eigen::Vector3d;
using CJ = CanonicalJoint;

namespace {

/// The elbow (m, from the shoulder) of an arm whose wrist is `arm_n` x its length from the
/// shoulder, bent toward `pole` (made across the shoulder -> wrist line here).
Vector3d elbow_from(const Vector3d& arm_n, const Vector3d& pole, double upper, double fore) {
  const Vector3d w = arm_n * (upper + fore);
  const double d = std::clamp(w.norm(), std::abs(upper - fore) + 1e-6, upper + fore);
  const Vector3d axis = w.normalized();
  const Vector3d across = (pole - pole.dot(axis) * axis).normalized();
  const double along = (upper * upper - fore * fore + d * d) / (2 * d);
  return axis * along + across * std::sqrt(std::max(0.0, upper * upper - along * along));
}

/// The character the scenes judge (its arms' lengths for the law of cosines).
Rig kenji() {
  return load_character_rig((std::filesystem::path(KUMITE_SOURCE_DIR) / "content" / "characters" / "kenji.bvh").string());
}

/// The still motion the guard is laid on: chest facing +z, both arms hanging.
MkmFrame arms_hanging() {
  MkmFrame pose;
  pose.chest = Eigen::Quaterniond::Identity();
  for (int s = 0; s < 2; ++s) {
    pose.arm_n[static_cast<std::size_t>(s)] = Vector3d(0, -0.97, 0.05);
    pose.arm_pole[static_cast<std::size_t>(s)] = Vector3d(0, 0, -1);
  }
  return pose;
}

/// A fist from `from` straight at `aim` at `speed` (m/s), thrown by the hand on the side of x.
BlockOrder fist_at(double x, const Vector3d& from, const Vector3d& aim, double speed) {
  BlockOrder b;
  b.limb = x > 0 ? kumite::recognition::Role::right_hand : kumite::recognition::Role::left_hand;
  b.fist_m = from;
  b.velocity_mps = (aim - from).normalized() * speed;
  b.arrival_s = (aim - from).norm() / speed;
  return b;
}

/// What a scene of parries drew: how many fists got a parry, and the fastest drawn elbow or
/// wrist step, judged on the arm from its shoulder (m/s at 60 Hz) and where.
struct ParryScene {
  int parries = 0, cases = 0;
  double fastest = 0;
  std::string where;
  /// Drawn elbow or wrist steps (from the shoulder) over 5 cm and over 3x both the step before
  /// and the step after: the motion-quality check's one-frame jump.
  int jumps = 0;
  std::string jump_where;
};

/// The fighter faces +z (chest frame: x left, y up, z forward), shoulders 1.45 m up, arms
/// hanging in the motion; the guard comes up over 1 s, then a fist comes from 0.9 m ahead at
/// (x, y, aim_z) for each x, y and speed. From when the fist is due at the forearm, the body
/// walks forward at walk_mps, and for dip_s the guard is not allowed (a strike of its own starting).
ParryScene run_parries(std::initializer_list<double> xs, std::initializer_list<double> ys, std::initializer_list<double> speeds,
                       double aim_z, double walk_mps, double dip_s = 0, double dt = 1.0 / 60) {
  const Rig rig = kenji();
  const Morphology& m = rig.morphology;
  const auto at = [&](CJ j) { return static_cast<std::size_t>(rig.skeleton.index(j)); };
  ParryScene out;
  for (const double x : xs)
    for (const double y : ys)
      for (const double speed : speeds) {
        ++out.cases;
        Guard g;
        g.want(true);
        std::vector<Vector3d> drawn(static_cast<std::size_t>(rig.joint_count()), Vector3d::Zero());
        std::array<Vector3d, 2> elbow_before{}, wrist_before{};
        std::array<std::vector<double>, 4> steps;  // [side * 2 + (0 elbow, 1 wrist)], from the parry on
        std::vector<FighterEvent> events;
        const Vector3d aim(x, y, aim_z), from(x * 0.3, 1.4, 0.9);
        const double due_s = 60 * dt + (aim - from).norm() / speed;
        for (int k = 0; k < 150; ++k) {
          const double now = k * dt;
          const double walked = walk_mps * std::max(0.0, now - due_s);
          const std::array<Vector3d, 2> shoulder{Vector3d(0.18, 1.45, walked), Vector3d(-0.18, 1.45, walked)};
          MkmFrame pose = arms_hanging();
          if (k == 60) out.parries += g.parry(fist_at(x, from, aim, speed), now, rig, drawn, pose.chest);
          for (int s = 0; s < 2; ++s) drawn[at(s == kLeft ? CJ::l_shoulder : CJ::r_shoulder)] = shoulder[static_cast<std::size_t>(s)];
          g.lay(k ? dt : 0.0, now, dip_s <= 0 || now < due_s || now >= due_s + dip_s, k > 0, rig, drawn, pose, events);
          for (int s = 0; s < 2; ++s) {
            const auto us = static_cast<std::size_t>(s);
            const double up = m.upper_arm_m[us], fore = m.forearm_m[us];
            const Vector3d e = elbow_from(pose.arm_n[us], pose.arm_pole[us], up, fore);  // from the shoulder
            const Vector3d w = pose.arm_n[us] * (up + fore);
            if (k >= 59) {  // from the update before the parry's
              steps[us * 2].push_back((e - elbow_before[us]).norm());
              steps[us * 2 + 1].push_back((w - wrist_before[us]).norm());
            }
            if (k > 60) {
              const double step = std::max((e - elbow_before[us]).norm(), (w - wrist_before[us]).norm()) / dt;
              if (step > out.fastest) {
                out.fastest = step;
                out.where = "aim (" + std::to_string(x) + ", " + std::to_string(y) + ") at " + std::to_string(speed) +
                            " m/s, side " + std::to_string(s) + ", update " + std::to_string(k);
              }
            }
            elbow_before[us] = e;
            wrist_before[us] = w;
            drawn[at(s == kLeft ? CJ::l_elbow : CJ::r_elbow)] = shoulder[us] + e;
            drawn[at(s == kLeft ? CJ::l_wrist : CJ::r_wrist)] = shoulder[us] + w;
          }
        }
        for (std::size_t j = 0; j < steps.size(); ++j)
          for (std::size_t i = 1; i + 1 < steps[j].size(); ++i)
            if (steps[j][i] > 0.05 && steps[j][i] > 3 * steps[j][i - 1] && steps[j][i] > 3 * steps[j][i + 1]) {
              ++out.jumps;
              out.jump_where = "aim (" + std::to_string(x) + ", " + std::to_string(y) + ") at " + std::to_string(speed) +
                               " m/s, side " + std::to_string(j / 2) + (j % 2 ? " wrist " : " elbow ") +
                               std::to_string(steps[j][i]) + " m at update " + std::to_string(59 + i);
            }
      }
  return out;
}


/// A fist from 0.9 m ahead at (x, y, aim_z) at `speed` for each x, y and speed, the guard up,
/// updates `dt` apart: how many got a parry, and how many met the forearm as drawn (the fist's
/// straight path, sampled finely between updates, within kFist_m of the segment between the drawn
/// elbow and wrist, worked out by the law of cosines) before it reached the body (aim_z).
struct MetScene {
  int parries = 0, met = 0, cases = 0;
  std::string missed;
};
MetScene fists_met(std::initializer_list<double> xs, std::initializer_list<double> ys, std::initializer_list<double> speeds,
                   double aim_z, double dt) {
  constexpr double kFist_m = 0.05;
  const Rig rig = kenji();
  const Morphology& m = rig.morphology;
  const auto at = [&](CJ j) { return static_cast<std::size_t>(rig.skeleton.index(j)); };
  const auto segment_distance = [](const Vector3d& p, const Vector3d& a, const Vector3d& b) {
    const Vector3d ab = b - a;
    const double t = std::clamp((p - a).dot(ab) / std::max(1e-12, ab.squaredNorm()), 0.0, 1.0);
    return (p - (a + t * ab)).norm();
  };
  MetScene out;
  for (const double x : xs)
    for (const double y : ys)
      for (const double speed : speeds) {
        ++out.cases;
        Guard g;
        g.want(true);
        std::vector<Vector3d> drawn(static_cast<std::size_t>(rig.joint_count()), Vector3d::Zero());
        std::vector<FighterEvent> events;
        const Vector3d aim(x, y, aim_z), from(x * 0.3, 1.4, 0.9);
        const Vector3d v = (aim - from).normalized() * speed;
        const double start = std::ceil(1.0 / dt) * dt;  // the guard up (0.4 s) well before
        const double arrive = start + (aim - from).norm() / speed;
        const std::array<Vector3d, 2> shoulder{Vector3d(0.18, 1.45, 0), Vector3d(-0.18, 1.45, 0)};
        bool parried = false, met = false;
        for (int k = 0; k * dt < arrive + 0.1 && !met; ++k) {
          const double now = k * dt;
          MkmFrame pose = arms_hanging();
          if (std::abs(now - start) < 0.5 * dt) parried = g.parry(fist_at(x, from, aim, speed), now, rig, drawn, pose.chest);
          for (int s = 0; s < 2; ++s) drawn[at(s == kLeft ? CJ::l_shoulder : CJ::r_shoulder)] = shoulder[static_cast<std::size_t>(s)];
          g.lay(k ? dt : 0.0, now, true, k > 0, rig, drawn, pose, events);
          for (int s = 0; s < 2; ++s) {
            const auto us = static_cast<std::size_t>(s);
            const double up = m.upper_arm_m[us], fore = m.forearm_m[us];
            const Vector3d e = shoulder[us] + elbow_from(pose.arm_n[us], pose.arm_pole[us], up, fore);
            const Vector3d w = shoulder[us] + pose.arm_n[us] * (up + fore);
            // The fist over the frame this pose is shown for (from now to the next update),
            // before it reaches the body.
            if (k > 0 && now > start)
              for (int i = 0; i < 8 && !met; ++i) {
                const double t = now + dt * i / 8.0;
                if (t > arrive) break;
                met = segment_distance(from + v * (t - start), e, w) <= kFist_m;
              }
            drawn[at(s == kLeft ? CJ::l_elbow : CJ::r_elbow)] = e;
            drawn[at(s == kLeft ? CJ::l_wrist : CJ::r_wrist)] = w;
          }
        }
        out.parries += parried;
        out.met += met;
        if (!met)
          out.missed += " (" + std::to_string(x).substr(0, 5) + ", " + std::to_string(y).substr(0, 4) + ") at " +
                        std::to_string(speed).substr(0, 3) + " m/s;";
      }
  return out;
}
}  // namespace

TEST(Guard, AParryDownPastTheShoulderTurnsItsElbowTheShortWay) {
  // A fist at a point of the body low and out to a side, slow or fast (run_parries, the body
  // still). Where the parry's wrist goes
  // down past the shoulder -> wrist line, its elbow's pole taken from the straight line
  // between the two elbows swung round the long way (the spar demo, seed 1: a right parry of
  // a slow low punch, the drawn elbow 29 cm in one frame). No drawn elbow or wrist step over
  // 6.5 m/s at 60 Hz (13.5 before).
  const ParryScene r = run_parries({-0.3, -0.2, -0.1, 0.1, 0.2, 0.3}, {0.85, 1.0, 1.15}, {1.5, 3.0, 6.0}, 0.08, 0.0);
  std::printf("%d parries for %d fists; fastest drawn elbow or wrist %.2f m/s (%s)\n", r.parries, r.cases, r.fastest, r.where.c_str());
  EXPECT_GT(r.parries, r.cases / 2);
  EXPECT_LT(r.fastest, 6.5) << r.where;  // a parry is timed for 6 m/s at its peak, on 24 samples of its way
}

TEST(Guard, AParryTheBodyWalksOntoGoesWithTheBodyOnceTheFistIsDue) {
  // As above, but the body walks forward at 1 m/s from when the fist is due at the forearm (a
  // fighter following the visitor through its block's hold): its shoulders reach and pass
  // the place the forearm was put in the room. Held in the room past the fist's arrival, the
  // place came inside the fold around the shoulder and was pushed out of it the other way
  // from one frame to the next (spar demo seed 8: the wrist 16 cm in a frame, the elbow
  // 41 m/s). Judged on the arm from its shoulder: no drawn elbow or wrist step over 6.5 m/s
  // and the walk's 1 m/s.
  const double walk_mps = 1.0;
  const ParryScene r = run_parries({-0.2, -0.1, 0.1, 0.2}, {1.15, 1.3, 1.45}, {3.0, 6.0}, 0.12, walk_mps);
  std::printf("%d parries for %d fists, the body walking on at 1 m/s; fastest elbow or wrist from its shoulder %.2f m/s (%s)\n",
              r.parries, r.cases, r.fastest, r.where.c_str());
  EXPECT_GT(r.parries, r.cases / 2);
  EXPECT_LT(r.fastest, 6.5 + walk_mps) << r.where;  // (the walk adds to a move toward a place in the room)
}

TEST(Guard, AWayBackToAGuardComingBackUpTurnsItsElbowOneWay) {
  // As above, the fist at the head's height beside a shoulder, but a strike starts as the fist
  // is due (the guard not allowed for 0.2 s: it goes down and comes back up). The way back from
  // the parry's place to the guard, the guard moving, ends on an elbow whose pole swings through
  // the opposite of the place's: turned the short way afresh each frame, the turn changed side
  // from one frame to the next (spar demo seed 6, stance steps on: the hand 14 cm in a frame).
  // Judged on the arm from its shoulder: no drawn elbow or wrist step over 12 m/s (8.95 with
  // the turn kept nearest the last frame's, 24.55 with it taken afresh; the guard's own way
  // down and up is driven by the scene, not timed along its way).
  const ParryScene r = run_parries({-0.45, -0.35, 0.35, 0.45}, {1.5, 1.65}, {4.0, 6.0}, -0.2, 0.0, 0.2);
  std::printf("%d parries for %d fists, a strike starting as each is due; fastest elbow or wrist from its shoulder %.2f m/s (%s)\n",
              r.parries, r.cases, r.fastest, r.where.c_str());
  EXPECT_GT(r.parries, r.cases / 2);
  EXPECT_LT(r.fastest, 12.0) << r.where;
}

TEST(Guard, AtThirtyUpdatesASecondAParryTakesFourUpdatesAndJumpsNowhere) {
  // A frame loop fallen to 30 Hz (or a 30 fps database played at its rate): a parry against a
  // fast fist close by is timed at its shortest (0.05 s), and in 30 Hz updates the minimum-jerk
  // move put 79 % of its way into its first frame and the rest into the next (the spar demo on a
  // 30 Hz loop: the elbow 7.8 cm between steps of 1.9 and 3.9, every seed at 5.47 s). Under 55
  // updates a second it takes at least four of them (the 50 Hz case, a hand 7.4 cm between 0.7
  // and 2.2 in the spar demo, is not reproduced by this scene: it passes there without the floor).
  // Judged on the arm from its shoulder: no drawn elbow or wrist step over 5 cm and 3x both
  // neighbours.
  const ParryScene r = run_parries({-0.12, -0.06, 0.06, 0.12}, {1.3, 1.4, 1.5}, {4.0, 6.0}, 0.2, 0.0, 0.0, 1.0 / 30);
  std::printf("%d parries for %d fists at 30 Hz; %d one-frame jumps (%s); fastest elbow or wrist %.2f m/s\n", r.parries, r.cases,
              r.jumps, r.jump_where.c_str(), r.fastest);
  EXPECT_GT(r.parries, r.cases / 2);
  EXPECT_EQ(r.jumps, 0) << r.jump_where;
}

TEST(Guard, AtThirtyUpdatesASecondAParryStillMeetsTheFistBeforeTheBody) {
  // Under 55 updates a second a parry's move takes at least four updates (above), while
  // pick_parry plans it with its shortest move (0.05 s): the forearm is then in place after the
  // fist has passed the point it was sent to. Judged on the drawn forearm (law of cosines) and
  // the fist's straight path, sampled between updates: the forearm, still moving across the
  // path, meets every fist before the body, at 30 Hz as at 60. (Planning with the floor instead
  // chose crossings nearer the body and two of these fists went by: not kept.)
  const MetScene r = fists_met({-0.12, -0.06, 0.06, 0.12}, {1.3, 1.4, 1.5}, {4.0, 6.0}, 0.2, 1.0 / 30);
  std::printf("30 Hz: %d parries for %d fists, %d met the drawn forearm before the body; missed:%s\n", r.parries, r.cases, r.met,
              r.missed.c_str());
  EXPECT_EQ(r.parries, r.cases);
  EXPECT_EQ(r.met, r.cases) << r.missed;
  const MetScene r60 = fists_met({-0.12, -0.06, 0.06, 0.12}, {1.3, 1.4, 1.5}, {4.0, 6.0}, 0.2, 1.0 / 60);
  std::printf("60 Hz: %d parries for %d fists, %d met; missed:%s\n", r60.parries, r60.cases, r60.met, r60.missed.c_str());
  EXPECT_EQ(r60.parries, r60.cases);
  EXPECT_EQ(r60.met, r60.cases) << r60.missed;
}
