#include <gtest/gtest.h>

#include <map>

#include "kumite/common/error.hpp"
#include "kumite/content/bvh.hpp"
#include "kumite/content/canonical.hpp"
#include "kumite/content/mirror.hpp"
#include "kumite/content/proportions.hpp"
#include "mocap_data.hpp"

using namespace kumite::content;
using kumite::content::testing::mocap_clip;
using CJ = CanonicalJoint;

namespace {

std::string name_of(const Skeleton& s, CJ j) {
  const int i = s.index(j);
  return i < 0 ? "-" : s.names[static_cast<std::size_t>(i)];
}

/// A small synthetic humanoid (labelled synthetic: lengths chosen by hand) with the given
/// names for pelvis, spine, chest, neck, head, and the per-side limb names built by `side`.
Skeleton synthetic_humanoid(const std::map<std::string, std::string>& names) {
  Skeleton s;
  auto add = [&](const std::string& key, int parent, Eigen::Vector3d offset, bool end = false) {
    s.names.push_back(end ? key : names.at(key));
    s.parents.push_back(parent);
    s.offsets.push_back(offset);
    s.end_site.push_back(end);
    return s.joint_count() - 1;
  };
  const int pelvis = add("pelvis", -1, {0, 1.0, 0});
  const int spine = add("spine", pelvis, {0, 0.1, 0});
  const int chest = add("chest", spine, {0, 0.2, 0});
  const int neck = add("neck", chest, {0, 0.2, 0});
  const int head = add("head", neck, {0, 0.1, 0});
  add("head_end", head, {0, 0.2, 0}, true);
  for (const char* side : {"l", "r"}) {
    const double x = side[0] == 'l' ? 1 : -1;
    const std::string p(side);
    const int clav = add(p + "_clavicle", chest, {0.02 * x, 0.18, 0});
    const int sh = add(p + "_shoulder", clav, {0.15 * x, 0, 0});
    const int el = add(p + "_elbow", sh, {0.3 * x, 0, 0});
    const int wr = add(p + "_wrist", el, {0.25 * x, 0, 0});
    add(p + "_hand_end", wr, {0.08 * x, 0, 0}, true);
    const int hip = add(p + "_hip", pelvis, {0.1 * x, -0.05, 0});
    const int kn = add(p + "_knee", hip, {0, -0.45, 0});
    const int an = add(p + "_ankle", kn, {0, -0.42, 0});
    const int toe = add(p + "_toe", an, {0, -0.05, 0.12});
    add(p + "_toe_end", toe, {0, 0, 0.05}, true);
  }
  s.canonical.fill(-1);
  return s;
}

std::map<std::string, std::string> bandai_like() {
  return {{"pelvis", "Hips"}, {"spine", "Spine"}, {"chest", "Chest"}, {"neck", "Neck"}, {"head", "Head"},
          {"l_clavicle", "Shoulder_L"}, {"l_shoulder", "UpperArm_L"}, {"l_elbow", "LowerArm_L"},
          {"l_wrist", "Hand_L"}, {"l_hip", "UpperLeg_L"}, {"l_knee", "LowerLeg_L"}, {"l_ankle", "Foot_L"},
          {"l_toe", "Toes_L"}, {"r_clavicle", "Shoulder_R"}, {"r_shoulder", "UpperArm_R"},
          {"r_elbow", "LowerArm_R"}, {"r_wrist", "Hand_R"}, {"r_hip", "UpperLeg_R"}, {"r_knee", "LowerLeg_R"},
          {"r_ankle", "Foot_R"}, {"r_toe", "Toes_R"}};
}

}  // namespace

TEST(Canonical, StructuralMappingOfUnknownNames) {
  // Names no dialect lists: found from hand/foot/head names and the chains above them.
  Skeleton s = synthetic_humanoid({{"pelvis", "Becken"}, {"spine", "Ruecken"}, {"chest", "Brust"},
                                   {"neck", "Hals"}, {"head", "Head"},
                                   {"l_clavicle", "l_Schluessel"}, {"l_shoulder", "l_Oberarm"},
                                   {"l_elbow", "l_Unterarm"}, {"l_wrist", "l_hand"}, {"l_hip", "l_Oberschenkel"},
                                   {"l_knee", "l_Schienbein"}, {"l_ankle", "l_foot"}, {"l_toe", "l_Zeh"},
                                   {"r_clavicle", "r_Schluessel"}, {"r_shoulder", "r_Oberarm"},
                                   {"r_elbow", "r_Unterarm"}, {"r_wrist", "r_hand"}, {"r_hip", "r_Oberschenkel"},
                                   {"r_knee", "r_Schienbein"}, {"r_ankle", "r_foot"}, {"r_toe", "r_Zeh"}});
  EXPECT_EQ(map_canonical(s, std::span<const Dialect>(builtin_dialects()), "synthetic"), "structural");
  // Guessed joints are said, naming the file (a named dialect is not).
  EXPECT_EQ(structural_mapping_warning(s, "chars/odd.bvh").rfind("chars/odd.bvh: skeleton: no dialect map matched", 0), 0u)
      << structural_mapping_warning(s, "chars/odd.bvh");
  Skeleton named = s;
  named.dialect = "cmu";
  EXPECT_EQ(structural_mapping_warning(named, "x.bvh"), "");
  EXPECT_EQ(name_of(s, CJ::pelvis), "Becken");
  EXPECT_EQ(name_of(s, CJ::spine), "Ruecken");
  EXPECT_EQ(name_of(s, CJ::chest), "Brust");
  EXPECT_EQ(name_of(s, CJ::neck), "Hals");
  EXPECT_EQ(name_of(s, CJ::l_clavicle), "l_Schluessel");
  EXPECT_EQ(name_of(s, CJ::r_shoulder), "r_Oberarm");
  EXPECT_EQ(name_of(s, CJ::l_elbow), "l_Unterarm");
  EXPECT_EQ(name_of(s, CJ::r_hip), "r_Oberschenkel");
  EXPECT_EQ(name_of(s, CJ::l_knee), "l_Schienbein");
  EXPECT_EQ(name_of(s, CJ::r_toe), "r_Zeh");
}

TEST(Canonical, TomlDialectIsDetected) {
  const auto dialects = load_dialects(kumite::content::testing::source_dir() / "content" / "dialects");
  ASSERT_GE(dialects.size(), 4u);  // cmu, assimp_boxer + the shipped TOML maps
  Skeleton s = synthetic_humanoid(bandai_like());
  EXPECT_EQ(map_canonical(s, std::span<const Dialect>(dialects), "bandai"), "bandai_namco");
  EXPECT_EQ(name_of(s, CJ::l_clavicle), "Shoulder_L");
  EXPECT_EQ(name_of(s, CJ::l_shoulder), "UpperArm_L");
  // Without the map the structure alone gives the same answer.
  Skeleton t = synthetic_humanoid(bandai_like());
  EXPECT_EQ(map_canonical(t, nullptr, "bandai"), "structural");
  EXPECT_EQ(t.canonical, s.canonical);
}

TEST(Canonical, MissingCoreJointsNameTheJoints) {
  Skeleton s;
  s.names = {"a", "b"};
  s.parents = {-1, 0};
  s.offsets = {Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 1, 0)};
  s.end_site = {false, false};
  try {
    map_canonical(s, nullptr, "odd.bvh");
    FAIL();
  } catch (const kumite::Error& e) {
    EXPECT_NE(std::string(e.what()).find("odd.bvh: structural: cannot find canonical joint(s) pelvis, head"),
              std::string::npos)
        << e.what();
  }
}

TEST(Canonical, DialectTomlErrorsNameFileLineKey) {
  auto err = [](const std::string& text) {
    try {
      parse_dialect_toml(text, "d.toml");
    } catch (const kumite::Error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_EQ(err("name = \"x\"\n[joints]\npelvis = \"Hips\"\nl_elbw = \"LeftForeArm\"\n"),
            "d.toml:4: joints.l_elbw: not a canonical joint (pelvis, spine, chest, neck, head, l_/r_ clavicle, "
            "shoulder, elbow, wrist, hip, knee, ankle, toe)");
  EXPECT_EQ(err("name = \"x\"\n[joints]\npelvis = 3\n"), "d.toml:3: joints.pelvis: must be a string");
  EXPECT_EQ(err("name = \"x\"\ncolour = \"red\"\n[joints]\n"), "d.toml:2: colour: unknown key (allowed here: name, description, joints)");
  EXPECT_EQ(err("[joints]\npelvis = \"Hips\"\n"), "d.toml:1: name: is required");
  EXPECT_EQ(err("name = \"x\"\n[joints]\npelvis = \"Hips\"\nspine = \"Hips\"\n"),
            "d.toml:4: joints.spine: joint 'Hips' is mapped twice");
  EXPECT_NE(err("name = \"x\n").find("d.toml:1: "), std::string::npos);
}

TEST(CanonicalMocap, CmuAndBoxerDialects) {
  KUMITE_REQUIRE_MOCAP();
  const Skeleton& cmu = mocap_clip("cmu/135_04").skeleton;
  EXPECT_EQ(cmu.dialect, "cmu");
  EXPECT_EQ(name_of(cmu, CJ::pelvis), "root");
  EXPECT_EQ(name_of(cmu, CJ::l_shoulder), "lhumerus");
  EXPECT_EQ(name_of(cmu, CJ::l_elbow), "lradius");
  EXPECT_EQ(name_of(cmu, CJ::r_wrist), "rwrist");
  EXPECT_EQ(name_of(cmu, CJ::l_hip), "lfemur");
  EXPECT_EQ(name_of(cmu, CJ::r_knee), "rtibia");
  EXPECT_EQ(name_of(cmu, CJ::l_ankle), "lfoot");
  EXPECT_EQ(name_of(cmu, CJ::r_toe), "rtoes");
  EXPECT_EQ(name_of(cmu, CJ::chest), "thorax");
  const Skeleton& boxer = mocap_clip("assimp/Boxing_Toes").skeleton;
  EXPECT_EQ(boxer.dialect, "assimp_boxer");
  EXPECT_EQ(name_of(boxer, CJ::l_clavicle), "LeftCollar");
  EXPECT_EQ(name_of(boxer, CJ::l_shoulder), "LeftShoulder");
  EXPECT_EQ(name_of(boxer, CJ::r_toe), "RightToes");
  // The structural mapper alone agrees with the built-in maps on the core joints.
  for (const Skeleton* s : {&cmu, &boxer}) {
    Skeleton copy = *s;
    map_canonical(copy, nullptr, "copy");
    for (CJ c : {CJ::pelvis, CJ::l_shoulder, CJ::l_elbow, CJ::l_wrist, CJ::r_shoulder, CJ::r_elbow, CJ::r_wrist,
                 CJ::l_hip, CJ::l_knee, CJ::l_ankle, CJ::l_toe, CJ::r_hip, CJ::r_knee, CJ::r_ankle, CJ::head,
                 CJ::chest, CJ::l_clavicle}) {
      EXPECT_EQ(name_of(copy, c), name_of(*s, c)) << s->dialect << " " << to_string(c);
    }
  }
}

TEST(CanonicalMocap, MeasuredStaturesMatchProvenance) {
  KUMITE_REQUIRE_MOCAP();
  // PROVENANCE.md: rest-pose height toes to head end site 158.9 / 151.2 / 157.1 cm; boxer ~173.
  EXPECT_NEAR(measure_proportions(mocap_clip("cmu/135_04").skeleton).stature_m, 1.589, 0.002);
  EXPECT_NEAR(measure_proportions(mocap_clip("cmu/07_05").skeleton).stature_m, 1.512, 0.002);
  EXPECT_NEAR(measure_proportions(mocap_clip("cmu/09_06").skeleton).stature_m, 1.571, 0.002);
  EXPECT_NEAR(measure_proportions(mocap_clip("assimp/Boxing_Toes").skeleton).stature_m, 1.73, 0.02);
  const Proportions p = measure_proportions(mocap_clip("cmu/135_04").skeleton);
  // CMU 135: ltibia offset |(13.76,-37.81,0)| = 40.23 cm is the thigh; lfoot offset the shin.
  EXPECT_NEAR(p.thigh_m, 0.5 * (std::hypot(13.760619, 37.807020) / 100 +
                                mocap_clip("cmu/135_04").skeleton.offsets[static_cast<std::size_t>(
                                    mocap_clip("cmu/135_04").skeleton.find("rtibia"))].norm()), 1e-9);
  EXPECT_GT(p.arm_m, 0.45);
  EXPECT_LT(p.arm_m, 0.65);
  EXPECT_GT(p.leg_m, 0.70);
  EXPECT_LT(p.leg_m, 0.90);
  EXPECT_GT(p.torso_m, 0.35);
  EXPECT_LT(p.torso_m, 0.60);
  EXPECT_NEAR(p.arm_m, p.upper_arm_m + p.forearm_m, 1e-12);
}

TEST(CanonicalMocap, MirrorReflectsAndSwapsSides) {
  KUMITE_REQUIRE_MOCAP();
  const Clip& c = mocap_clip("cmu/135_04");
  EXPECT_EQ(lateral_axis(c.skeleton), 0);  // actor's left = +X
  const Clip m = mirror_clip(c);
  EXPECT_EQ(m.name, "135_04_mirror");
  const auto partner = mirror_map(c.skeleton);
  EXPECT_EQ(c.skeleton.names[static_cast<std::size_t>(partner[static_cast<std::size_t>(c.skeleton.find("lhand"))])], "rhand");
  EXPECT_EQ(c.skeleton.names[static_cast<std::size_t>(partner[static_cast<std::size_t>(c.skeleton.find("lthumb_end"))])], "rthumb_end");
  EXPECT_EQ(partner[static_cast<std::size_t>(c.skeleton.find("head"))], c.skeleton.find("head"));
  const auto n = static_cast<std::size_t>(c.skeleton.joint_count());
  std::vector<Eigen::Vector3d> p(n), q(n);
  std::vector<Eigen::Quaterniond> r(n);
  double worst = 0;
  for (int f = 0; f < c.frame_count; f += 25) {
    forward_kinematics(c, f, p, r);
    forward_kinematics(m, f, q, r);
    for (std::size_t j = 0; j < n; ++j) {
      const Eigen::Vector3d& src = p[static_cast<std::size_t>(partner[j])];
      worst = std::max(worst, (q[j] - Eigen::Vector3d(-src.x(), src.y(), src.z())).norm());
    }
  }
  EXPECT_LT(worst, 1e-9);
  // PROVENANCE: right front kick peaks at f374; in the mirror the LEFT ankle is up there.
  forward_kinematics(m, 374, q, r);
  EXPECT_GT(q[static_cast<std::size_t>(m.skeleton.index(CJ::l_ankle))].y(), 1.0);
  EXPECT_LT(q[static_cast<std::size_t>(m.skeleton.index(CJ::r_ankle))].y(), 0.3);
  // Mirroring twice gives the original back.
  const Clip mm = mirror_clip(m);
  for (std::size_t i = 0; i < c.local_rotations.size(); i += 97) {
    EXPECT_TRUE(mm.local_rotations[i].isApprox(c.local_rotations[i], 1e-12));
  }
}
