// The retarget: a skeleton onto itself, and the shipped bodies following a fighter's strikes.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <random>

#include "kumite/body/retarget.hpp"
#include "kumite/content/character.hpp"
#include "kumite/content/fighter.hpp"

namespace fs = std::filesystem;
using namespace kumite;
using namespace kumite::body;

namespace {

content::Character character(const char* name) {
  const auto catalog = content::read_characters(fs::path(KUMITE_SOURCE_DIR) / "content" / "characters" / "characters.toml");
  return content::load_character(catalog, name);
}
fs::path asset(const char* name) { return fs::path(KUMITE_SOURCE_DIR) / "body" / "assets" / name; }

double angle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) { return a.angularDistance(b); }
double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180 / M_PI;
}

/// Buffers for one retarget of `s`.
struct Buffers {
  std::vector<Eigen::Vector3d> sp;
  std::vector<Eigen::Quaterniond> sr;
  std::vector<Eigen::Matrix4d> d;
  std::vector<Eigen::Quaterniond> r, l;
  std::vector<Eigen::Vector3d> p;
  std::vector<Eigen::Matrix4f> palette;
  explicit Buffers(const RetargetSetup& s)
      : sp(static_cast<std::size_t>(s.source.joint_count())), sr(sp.size()), d(s.target.names.size()), r(d.size()),
        l(d.size()), p(d.size()), palette(d.size()) {}
  RetargetJob job(const RetargetSetup& s, std::span<const Eigen::Quaterniond> locals, const Eigen::Vector3d& root) {
    RetargetJob j;
    j.setup = &s;
    j.local_rotations = locals;
    j.root_position = root;
    j.source_positions = sp;
    j.source_rotations = sr;
    j.deltas = d;
    j.rotations = r;
    j.positions = p;
    j.locals = l;
    j.palette = palette;
    return j;
  }
};

}  // namespace

TEST(Retarget, ASkeletonOntoItselfReproducesItsLocalRotations) {
  for (const char* name : {"kenji", "viktor", "mei"}) {
    SCOPED_TRACE(name);
    const content::Character c = character(name);
    const content::Skeleton& sk = c.rest.skeleton;
    const RetargetSetup s = RetargetSetup::build(sk, c.rest.root_positions[0], skeleton_rig(sk, sk));
    Buffers b(s);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1, 1);
    double worst = 0, worst_pos = 0;
    for (int trial = 0; trial < 50; ++trial) {
      std::vector<Eigen::Quaterniond> q(static_cast<std::size_t>(sk.joint_count()));
      for (auto& x : q) x = Eigen::Quaterniond(Eigen::AngleAxisd(2 * u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()));
      const Eigen::Vector3d root(u(rng), 1 + u(rng), u(rng));
      ASSERT_TRUE(b.job(s, q, root).Run());
      for (std::size_t j = 0; j < q.size(); ++j) {
        worst = std::max(worst, angle(q[j], b.l[j]));
        worst_pos = std::max(worst_pos, (b.p[j] - b.sp[j]).norm());
      }
    }
    EXPECT_LT(worst, 1e-5);
    EXPECT_LT(worst_pos, 1e-9);
    std::printf("%s onto itself: max local rotation error %.2g rad, joint position error %.2g m (50 random poses)\n", name, worst, worst_pos);
  }
}

TEST(Retarget, JobRefusesBuffersTooSmall) {
  const content::Character c = character("kenji");
  const RetargetSetup s = RetargetSetup::build(c.rest.skeleton, c.rest.root_positions[0], skeleton_rig(c.rest.skeleton, c.rest.skeleton));
  Buffers b(s);
  RetargetJob j = b.job(s, c.rest.rotations(0), c.rest.root_positions[0]);
  EXPECT_TRUE(j.Validate());
  j.deltas = j.deltas.first(3);
  EXPECT_FALSE(j.Validate());
  EXPECT_FALSE(j.Run());
}

TEST(Retarget, BoneMapsAreDetectedFromTheShippedBodies) {
  EXPECT_EQ(detect_bone_map(load_model(asset("male_casual.glb")).skeleton.names)->family, "quaternius");
  EXPECT_EQ(detect_bone_map(load_model(asset("female_casual.glb")).skeleton.names)->family, "quaternius");
  EXPECT_EQ(detect_bone_map(load_model(asset("male_base_mesh.glb")).skeleton.names)->family, "rigify");
  const std::vector<std::string> ue = {"root", "pelvis", "spine_01", "spine_02", "spine_03", "neck_01", "Head",
                                       "clavicle_l", "upperarm_l", "lowerarm_l", "hand_l", "clavicle_r", "upperarm_r",
                                       "lowerarm_r", "hand_r", "thigh_l", "calf_l", "foot_l", "ball_l", "thigh_r",
                                       "calf_r", "foot_r", "ball_r"};
  EXPECT_EQ(detect_bone_map(ue)->family, "ue_mannequin");
  std::vector<std::string> mixamo;
  for (const char* n : {"Hips", "Spine", "Spine1", "Spine2", "Neck", "Head", "LeftShoulder", "LeftArm", "LeftForeArm",
                        "LeftHand", "RightShoulder", "RightArm", "RightForeArm", "RightHand", "LeftUpLeg", "LeftLeg",
                        "LeftFoot", "LeftToeBase", "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase"})
    mixamo.push_back(std::string("mixamorig:") + n);
  EXPECT_EQ(detect_bone_map(mixamo)->family, "mixamo");
  EXPECT_EQ(detect_bone_map(std::vector<std::string>{"a", "b"}), nullptr);
}

TEST(Retarget, EveryMappedBoneOfTheBodiesPointsAlongTheDrawnSkeletonsBoneThroughStrikes) {
  const fs::path db = fs::path(KUMITE_BINARY_DIR) / "demo" / "fighter.kdb";
  if (!fs::exists(db)) GTEST_SKIP() << "no demo database (scripts/setup.sh makes it)";
  for (const char* who : {"kenji", "viktor", "mei", "bruno"}) {
    const content::Character c = character(who);
    content::FighterConfig cfg;
    cfg.database = db;
    cfg.characters.push_back(fs::path(KUMITE_SOURCE_DIR) / "content" / "characters" / (std::string(who) + ".bvh"));
    cfg.character_names.emplace_back(who);
    cfg.max_z_m = 0.6;
    auto fighter = content::Fighter::create(cfg);
    for (const char* body : {"male_casual.glb", "female_casual.glb", "male_base_mesh.glb"}) {
      SCOPED_TRACE(std::string(who) + " as " + body);
      const SkinnedModel model = load_model(asset(body));
      const BoneMap* map = detect_bone_map(model.skeleton.names);
      ASSERT_NE(map, nullptr);
      const RetargetSetup s = RetargetSetup::build(c.rest.skeleton, c.rest.root_positions[0], model_rig(model, c.rest.skeleton, *map));
      Buffers b(s);
      std::vector<Eigen::Vector3f> vp(model.vertex_count()), vn(model.vertex_count());
      (void)fighter;
      auto f = content::Fighter::create(cfg);
      content::FighterOutput out;
      double worst = 0, worst_hips = 0;
      int bones = 0, frames = 0;
      const Order orders[] = {{0, OrderKind::punch_right, -1}, {0, OrderKind::kick_left, -1}, {0, OrderKind::punch_left, -1},
                              {0, OrderKind::kick_right, -1}};
      for (int k = 0; k < 480; ++k) {
        content::FighterInput in;
        in.now = k / 60.0;
        in.dt_s = k == 0 ? 0.0 : 1 / 60.0;
        in.head_m = {0, 1.6, 0};
        Order o = orders[(k / 120) % 4];
        o.time = in.now;
        if (k % 120 == 10) in.orders = std::span<const Order>(&o, 1);
        f->step(in, out);
        const content::FighterFrame& fr = out.frame;
        ASSERT_EQ(fr.local_rotations.size(), static_cast<std::size_t>(c.rest.skeleton.joint_count()));
        ASSERT_TRUE(b.job(s, fr.local_rotations, fr.root_joint).Run());
        ++frames;
        for (int j = 0; j < s.target.joint_count(); ++j) {
          const int kk = s.direction_child[static_cast<std::size_t>(j)];
          if (kk < 0) continue;
          // The model's bone as the skin moves it: its rest end carried by the joint's matrix.
          const Eigen::Matrix4d& d = b.d[static_cast<std::size_t>(j)];
          const Eigen::Vector3d a = d.topLeftCorner<3, 3>() * s.rest_positions[static_cast<std::size_t>(j)] + d.topRightCorner<3, 1>();
          const Eigen::Vector3d e = d.topLeftCorner<3, 3>() * s.rest_positions[static_cast<std::size_t>(kk)] + d.topRightCorner<3, 1>();
          const int sj = s.target.source[static_cast<std::size_t>(j)], sk = s.target.source[static_cast<std::size_t>(kk)];
          const Eigen::Vector3d drawn = fr.joints[static_cast<std::size_t>(sk)] - fr.joints[static_cast<std::size_t>(sj)];
          if (drawn.norm() < 1e-6) continue;
          worst = std::max(worst, angle_deg(e - a, drawn));
          ++bones;
        }
        const int sp = s.target.source[static_cast<std::size_t>(s.pelvis)];
        worst_hips = std::max(worst_hips, (b.p[static_cast<std::size_t>(s.pelvis)] - fr.joints[static_cast<std::size_t>(sp)]).norm());
        if (k % 60 == 0) {
          skin_cpu(model, b.palette, vp, vn);
          for (const auto& v : vp) ASSERT_TRUE(v.allFinite());
        }
      }
      EXPECT_LT(worst, 3.0);
      EXPECT_LT(worst_hips, 1e-9);
      EXPECT_GT(bones, frames * 12);
      std::printf("%s as %s (%s map, scale %.3f): %d frames, %d bone checks, max bone direction error %.3g deg, hips %.2g m\n",
                  who, body, map->family.c_str(), s.scale, frames, bones, worst, worst_hips);
    }
  }
}

// The fist as the skin draws it: the thumb's last joint's skin (the vertices it moves most) lies
// near the curled fingers' skin, not out to the side. Measured on the skinned vertices, not on
// the curl's rotations: the thumb's tip from the centre of the four fingers' vertices.
TEST(Retarget, TheThumbLiesAcrossTheFist) {
  const content::Character c = character("kenji");
  for (const char* body : {"male_casual.glb", "female_casual.glb", "male_base_mesh.glb"}) {
    const SkinnedModel model = load_model(asset(body));
    const RetargetSetup s =
        RetargetSetup::build(c.rest.skeleton, c.rest.root_positions[0], model_rig(model, c.rest.skeleton, *detect_bone_map(model.skeleton.names)));
    Buffers b(s);
    const std::vector<Eigen::Quaterniond> rest(static_cast<std::size_t>(c.rest.skeleton.joint_count()), Eigen::Quaterniond::Identity());
    ASSERT_TRUE(b.job(s, rest, c.rest.root_positions[0]).Run());
    std::vector<Eigen::Vector3f> vp(model.vertex_count()), vn(model.vertex_count());
    skin_cpu(model, b.palette, vp, vn);
    const auto thumb = [&](int j) { return s.target.names[static_cast<std::size_t>(j)].find("humb") != std::string::npos; };
    for (const content::CanonicalJoint wrist_joint : {content::CanonicalJoint::l_wrist, content::CanonicalJoint::r_wrist}) {
      const int wrist = s.target.canonical[static_cast<std::size_t>(wrist_joint)];
      ASSERT_GE(wrist, 0);
      const auto in_hand = [&](int j) {
        for (; j >= 0; j = s.target.parents[static_cast<std::size_t>(j)])
          if (j == wrist) return true;
        return false;
      };
      int tip = -1;  // the thumb's last joint (parents first: the last found)
      for (int j = 0; j < s.target.joint_count(); ++j)
        if (in_hand(j) && s.target.finger[static_cast<std::size_t>(j)] && thumb(j)) tip = j;
      ASSERT_GE(tip, 0) << body;
      Eigen::Vector3d fingers = Eigen::Vector3d::Zero(), thumb_tip = Eigen::Vector3d::Zero();
      int nf = 0, nt = 0;
      for (std::size_t v = 0; v < model.vertex_count(); ++v) {
        const int j = model.joints[v][0];  // the largest influence (weights sorted largest first)
        if (!in_hand(j)) continue;
        if (s.target.finger[static_cast<std::size_t>(j)] && !thumb(j)) {
          fingers += vp[v].cast<double>();
          ++nf;
        }
        if (j == tip) {
          thumb_tip += vp[v].cast<double>();
          ++nt;
        }
      }
      ASSERT_GT(nf, 0);
      ASSERT_GT(nt, 0);
      const double apart = (thumb_tip / nt - fingers / nf).norm();
      std::printf("%s, %s hand: the thumb's tip %.1f cm from the curled fingers' centre\n", body,
                  wrist_joint == content::CanonicalJoint::l_wrist ? "left" : "right", apart * 100);
      EXPECT_LT(apart, 0.065) << body;
    }
  }
}
