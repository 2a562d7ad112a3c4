// The shipped content/motions/ (no ../shared needed): the reviewed motions.toml loads,
// validates against its clips, keeps the strikes of PROVENANCE.md, and holds the wider
// repertoire of issue 12 (techniques per limb, strike heights).
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "kumite/content/annotation.hpp"
#include "kumite/content/canonical.hpp"
#include "kumite/content/database.hpp"
#include "kumite/content/proportions.hpp"
#include "mocap_data.hpp"

using namespace kumite::content;

namespace {
const std::filesystem::path kMotions = kumite::content::testing::source_dir() / "content" / "motions";

struct Shipped {
  AnnotationSet set;
  std::vector<Clip> clips;
};
const Shipped& shipped() {
  static const Shipped s = [] {
    Shipped r;
    r.set = read_annotations(kMotions / "motions.toml");
    r.clips = load_annotated_clips(r.set);  // validates every range and every clip's unit
    return r;
  }();
  return s;
}
}  // namespace

TEST(ShippedMotions, ReviewedAnnotationsLoadAndKeepTheListedStrikes) {
  const auto& [set, clips] = shipped();
  ASSERT_EQ(clips.size(), set.clips.size());
  std::map<std::string, std::vector<std::pair<HitSegment, int>>> strikes;
  int rests = 0;
  for (const auto& c : set.clips) {
    for (const auto& m : c.motions) {
      if (is_strike(m.semantics)) strikes[c.name].emplace_back(*m.hit_segment, *m.hit_frame);
      if (m.semantics == Semantics::rest) ++rests;
    }
  }
  EXPECT_GE(rests, 5);
  using H = HitSegment;
  // The development set's PROVENANCE.md peaks (first review), within 2 frames.
  const std::map<std::string, std::vector<std::pair<HitSegment, int>>> provenance = {
      {"135_04", {{H::right_foot, 374}, {H::left_foot, 584}, {H::right_foot, 812}}},
      {"135_07", {{H::right_foot, 118}, {H::left_foot, 442}, {H::right_foot, 772}, {H::left_foot, 1126}}},
      {"135_09", {{H::right_hand, 304}, {H::left_hand, 530}, {H::right_hand, 760}, {H::left_hand, 1000}}},
      {"135_11", {{H::right_foot, 348}, {H::right_foot, 608}, {H::right_foot, 884}, {H::left_foot, 1310},
                  {H::left_foot, 1578}, {H::left_foot, 1850}, {H::left_foot, 2130}}}};
  for (const auto& [clip, listed] : provenance) {
    ASSERT_EQ(strikes[clip].size(), listed.size()) << clip;
    for (std::size_t i = 0; i < listed.size(); ++i) {
      EXPECT_EQ(strikes[clip][i].first, listed[i].first) << clip << " #" << i;
      EXPECT_NEAR(strikes[clip][i].second, listed[i].second, 2) << clip << " #" << i;
    }
  }
  EXPECT_TRUE(strikes["135_08"].empty());
  for (const Clip& c : clips) EXPECT_EQ(c.skeleton.dialect, "cmu") << c.name;  // CMU 135 and HDM05 (Acclaim names)
}

TEST(ShippedMotions, WiderRepertoireWithHeights) {
  const auto& [set, clips] = shipped();
  int strikes = 0, walks = 0;
  std::map<HitSegment, std::set<StrikeHeight>> heights;
  std::map<HitSegment, std::set<std::string>> actors;  // clip families per limb
  for (std::size_t c = 0; c < set.clips.size(); ++c) {
    const Clip& clip = clips[c];
    const Proportions body = measure_proportions(clip.skeleton);
    const auto all = all_joint_positions(clip);
    const auto n = static_cast<std::size_t>(clip.skeleton.joint_count());
    double floor_y = 1e300;
    for (int f = 0; f < clip.frame_count; ++f) {
      for (CanonicalJoint j : {CanonicalJoint::l_toe, CanonicalJoint::r_toe, CanonicalJoint::l_ankle, CanonicalJoint::r_ankle}) {
        floor_y = std::min(floor_y, all[static_cast<std::size_t>(f) * n + static_cast<std::size_t>(clip.skeleton.index(j))].y());
      }
    }
    for (const auto& m : set.clips[c].motions) {
      if (m.semantics == Semantics::walk) ++walks;
      if (!is_strike(m.semantics)) continue;
      ++strikes;
      ASSERT_TRUE(m.height) << m.name << ": every shipped strike says where it lands";
      heights[*m.hit_segment].insert(*m.height);
      actors[*m.hit_segment].insert(set.clips[c].name.substr(0, 6));
      // The height agrees with the hit point at the hit frame (the proposer smooths positions
      // over 5 frames: within 0.01 of a bound either class is accepted).
      const auto j = static_cast<std::size_t>(clip.skeleton.index(hit_joint(*m.hit_segment)));
      const double r = (all[static_cast<std::size_t>(*m.hit_frame) * n + j].y() - floor_y) / body.stature_m;
      const StrikeHeightThresholds t;
      const bool near_bound = std::abs(r - t.low_below) < 0.01 || std::abs(r - t.high_from) < 0.01;
      if (!near_bound) {
        EXPECT_EQ(*m.height, classify_strike_height(r, 1.0)) << m.name << ": " << r << " of stature";
      }
    }
  }
  // Issue 12 aimed at 60 strikes before mirroring; every clean strike of the shippable data
  // is in (54: the development set has no more; see content/README.md).
  EXPECT_GE(strikes, 54);
  EXPECT_GE(walks, 20);  // stance steps of 135_03 / 135_05 / 135_10
  // Feet: low, mid and high kicks (left) and mid and high (right; mirroring adds the rest).
  EXPECT_EQ(heights[HitSegment::left_foot].size(), 3u);
  EXPECT_GE(heights[HitSegment::right_foot].size(), 2u);
  // Hands: every shippable punch is a middle-level (chudan) one.
  EXPECT_EQ(heights[HitSegment::left_hand], std::set{StrikeHeight::mid});
  EXPECT_EQ(heights[HitSegment::right_hand], std::set{StrikeHeight::mid});
  EXPECT_GE(actors[HitSegment::left_foot].size(), 2u);  // CMU 135 and the HDM05 actors

  // segment_sources carries the height of every strike (and every block) into the database build.
  const auto sources = segment_sources(set, clips);
  int with_height = 0;
  for (const auto& s : sources) {
    if (s.kind == SegmentKind::strike) {
      EXPECT_TRUE(s.height) << s.name;
      with_height += s.height.has_value();
    } else if (s.kind == SegmentKind::block) {
      EXPECT_TRUE(s.height) << s.name;
    } else {
      EXPECT_FALSE(s.height) << s.name;
    }
  }
  EXPECT_EQ(with_height, strikes);
}

TEST(ShippedMotions, OnlyWhatIsUsedWithProvenance) {
  // Every BVH in content/motions is referenced by motions.toml and named in PROVENANCE.md,
  // smaller than 5 MiB; the non-shippable clips (assimp boxer, Sony crosses) are absent.
  const AnnotationSet set = read_annotations(kMotions / "motions.toml");
  std::ifstream in(kMotions / "PROVENANCE.md");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string provenance = ss.str();
  int bvh = 0;
  for (const auto& e : std::filesystem::directory_iterator(kMotions)) {
    if (e.path().extension() != ".bvh") continue;
    ++bvh;
    bool used = false;
    for (const auto& c : set.clips) used = used || set.resolve(c) == e.path();
    EXPECT_TRUE(used) << e.path() << " is not in motions.toml";
    EXPECT_LT(std::filesystem::file_size(e.path()), 5u << 20) << e.path();
    EXPECT_NE(provenance.find(e.path().filename().string()), std::string::npos)
        << e.path().filename() << " is not in PROVENANCE.md";
    const std::string name = e.path().filename().string();
    EXPECT_TRUE(name.rfind("135_", 0) == 0 || name.rfind("HDM_", 0) == 0) << name << ": CMU 135 and HDM05 only";
  }
  EXPECT_EQ(static_cast<std::size_t>(bvh), set.clips.size());
  EXPECT_FALSE(std::filesystem::exists(kMotions / "Boxing_Toes.bvh"));
  EXPECT_TRUE(std::filesystem::exists(kMotions / "LICENSE-CMU.txt"));
  EXPECT_TRUE(std::filesystem::exists(kMotions / "LICENSE-HDM05.txt"));
  EXPECT_NE(provenance.find("CC BY-SA 3.0"), std::string::npos);
}
