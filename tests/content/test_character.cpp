// The shipped characters (content/characters/, no ../shared needed) and their generator.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "kumite/common/error.hpp"
#include "kumite/content/bvh.hpp"
#include "kumite/content/character.hpp"
#include "mocap_data.hpp"

using namespace kumite::content;
using CJ = CanonicalJoint;

namespace {

const std::filesystem::path kContent = kumite::content::testing::source_dir() / "content";

const CharacterCatalog& catalog() {
  static const CharacterCatalog c = read_characters(kContent / "characters" / "characters.toml");
  return c;
}

const Clip& base() {
  static const Clip c = read_bvh(kContent / "motions" / "135_08.bvh");
  return c;
}

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string catalog_error(const std::string& text) {
  try {
    parse_characters(text, "c.toml");
  } catch (const kumite::Error& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(Characters, FiveClearlyDifferentBodies) {
  ASSERT_GE(catalog().characters.size(), 5u);
  std::vector<Character> chars;
  for (const auto& e : catalog().characters) chars.push_back(load_character(catalog(), e));
  double lo = 9, hi = 0;
  bool other_dialect = false;
  for (std::size_t i = 0; i < chars.size(); ++i) {
    const auto& c = chars[i];
    const Proportions& p = c.proportions;
    SCOPED_TRACE(c.name);
    EXPECT_EQ(c.rest.frame_count, 1);
    EXPECT_GE(p.stature_m, 1.50);
    EXPECT_LE(p.stature_m, 2.00);
    EXPECT_GE(p.standing_height_m, 1.50);
    EXPECT_LE(p.standing_height_m, 2.00);
    ASSERT_TRUE(catalog().characters[i].generate);
    EXPECT_NEAR(p.stature_m, catalog().characters[i].generate->stature_m, 0.001);
    lo = std::min(lo, p.stature_m);
    hi = std::max(hi, p.stature_m);
    // Feet on the floor in the rest frame.
    std::vector<Eigen::Vector3d> pos(static_cast<std::size_t>(c.rest.skeleton.joint_count()));
    std::vector<Eigen::Quaterniond> rot(pos.size());
    forward_kinematics(c.rest, 0, pos, rot);
    double floor = 9;
    for (const auto& q : pos) floor = std::min(floor, q.y());
    EXPECT_NEAR(floor, 0.0, 1e-5);
    if (c.rest.skeleton.dialect != "cmu") {
      other_dialect = true;
      EXPECT_EQ(c.rest.skeleton.dialect, "motionbuilder");
      EXPECT_EQ(c.rest.skeleton.channels[1], "zxy");
      EXPECT_EQ(c.rest.skeleton.names[static_cast<std::size_t>(c.rest.skeleton.index(CJ::l_elbow))], "LeftForeArm");
    }
    // Proportions differ clearly from every other character (>= 2 % of stature somewhere).
    for (std::size_t j = 0; j < i; ++j) {
      const Proportions& q = chars[j].proportions;
      const double d = std::max({std::abs(p.arm_ratio() - q.arm_ratio()), std::abs(p.leg_ratio() - q.leg_ratio()),
                                 std::abs(p.torso_ratio() - q.torso_ratio())});
      EXPECT_GE(d, 0.02) << c.name << " vs " << chars[j].name;
    }
  }
  EXPECT_GE(hi - lo, 0.35);
  EXPECT_TRUE(other_dialect);
}

TEST(Characters, ShippedFilesAreWhatTheGeneratorMakes) {
  for (const auto& e : catalog().characters) {
    ASSERT_TRUE(e.generate) << e.name;
    const Clip c = make_character(base().skeleton, *e.generate, e.name);
    EXPECT_EQ(format_bvh(c), slurp(catalog().resolve(e))) << e.name << ": run kumite-motion make-characters";
  }
}

TEST(Characters, SegmentScalesActOnTheirSegmentOnly) {
  // Independent of the uniform scaling to the stature: doubling the upper arm doubles the
  // upper-arm / forearm ratio and leaves thigh / shin alone.
  CharacterSpec plain, doubled;
  doubled.scales.upper_arm = 2.0;
  const Proportions a = measure_proportions(make_character(base().skeleton, plain, "a").skeleton);
  const Proportions b = measure_proportions(make_character(base().skeleton, doubled, "b").skeleton);
  EXPECT_NEAR(b.upper_arm_m / b.forearm_m, 2.0 * a.upper_arm_m / a.forearm_m, 1e-9);
  EXPECT_NEAR(b.thigh_m / b.shin_m, a.thigh_m / a.shin_m, 1e-9);
  EXPECT_NEAR(a.stature_m, 1.7, 1e-9);
  EXPECT_NEAR(b.stature_m, 1.7, 1e-9);  // arms are horizontal at rest: stature unchanged by them
  EXPECT_EQ(bone_segment(base().skeleton, base().skeleton.find("lhipjoint")), Segment::pelvis_width);
  EXPECT_EQ(bone_segment(base().skeleton, base().skeleton.find("lhand")), Segment::hand);
  EXPECT_EQ(bone_segment(base().skeleton, base().skeleton.find("upperneck")), Segment::neck_head);
  EXPECT_EQ(bone_segment(base().skeleton, base().skeleton.find("lradius")), Segment::upper_arm);
  EXPECT_EQ(bone_segment(base().skeleton, base().skeleton.find("ltoes_end")), Segment::foot);
}

TEST(Characters, LoadByNameOrFile) {
  const Character bruno = load_character(catalog(), "bruno");
  EXPECT_EQ(bruno.display_name, "Bruno");
  const Character file = load_character(catalog(), (kContent / "characters" / "mei.bvh").string());
  EXPECT_EQ(file.name, "mei");
  try {
    load_character(catalog(), "zorro");
    FAIL();
  } catch (const kumite::Error& e) {
    EXPECT_NE(std::string(e.what()).find("unknown character 'zorro' (known: kenji, mei, bruno, aiko, viktor)"),
              std::string::npos)
        << e.what();
  }
}

TEST(Characters, CatalogErrorsNameFileLineKey) {
  const std::string head = "version = 1\n[[character]]\nname = \"a\"\nfile = \"a.bvh\"\n";
  EXPECT_EQ(catalog_error(head + "colour = \"red\"\n"), "c.toml:5: character[0].colour: unknown key (allowed here: name, display_name, file, notes, generate)");
  EXPECT_EQ(catalog_error(head + "[character.generate]\nstature_m = 5.0\n"),
            "c.toml:6: character[0].generate.stature_m: must be 0.3..3 m");
  EXPECT_EQ(catalog_error(head + "[character.generate]\nstature_m = 1.8\ndialect = \"bandai\"\n"),
            "c.toml:7: character[0].generate.dialect: unknown dialect 'bandai' (cmu, motionbuilder)");
  EXPECT_EQ(catalog_error(head + "[[character]]\nname = \"a\"\nfile = \"b.bvh\"\n"),
            "c.toml:6: character[1].name: character 'a' is listed twice");
  EXPECT_EQ(catalog_error("version = 1\n"), "c.toml:1: character: at least one [[character]] is required");
  EXPECT_EQ(catalog_error("version = 1\n[[character]]\nname = \"a\"\n"), "c.toml:2: character[0].file: is required");
}
