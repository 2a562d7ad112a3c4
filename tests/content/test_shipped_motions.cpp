// The shipped content/motions/ (no ../shared needed): the reviewed motions.toml loads,
// validates against its clips, and lists exactly the strikes of PROVENANCE.md.
#include <gtest/gtest.h>

#include <map>

#include "kumite/content/annotation.hpp"
#include "kumite/content/canonical.hpp"
#include "mocap_data.hpp"

using namespace kumite::content;

namespace {
const std::filesystem::path kMotions = kumite::content::testing::source_dir() / "content" / "motions";
}

TEST(ShippedMotions, ReviewedAnnotationsLoadAndListTheStrikes) {
  const AnnotationSet set = read_annotations(kMotions / "motions.toml");
  const std::vector<Clip> clips = load_annotated_clips(set);  // validates every range
  ASSERT_EQ(clips.size(), 5u);
  std::map<std::string, std::vector<std::pair<HitSegment, int>>> strikes;
  int rests = 0;
  for (const auto& c : set.clips) {
    for (const auto& m : c.motions) {
      if (is_strike(m.semantics)) strikes[c.name].emplace_back(*m.hit_segment, *m.hit_frame);
      if (m.semantics == Semantics::rest) ++rests;
      EXPECT_NE(m.semantics, Semantics::block) << m.name;  // reviewed out
    }
  }
  EXPECT_GE(rests, 5);
  using H = HitSegment;
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
  for (const Clip& c : clips) EXPECT_EQ(c.skeleton.dialect, "cmu");
}

TEST(ShippedMotions, OnlyWhatIsUsed) {
  // Every BVH in content/motions is referenced by motions.toml, and the boxer is not shipped.
  const AnnotationSet set = read_annotations(kMotions / "motions.toml");
  for (const auto& e : std::filesystem::directory_iterator(kMotions)) {
    if (e.path().extension() != ".bvh") continue;
    bool used = false;
    for (const auto& c : set.clips) used = used || set.resolve(c) == e.path();
    EXPECT_TRUE(used) << e.path() << " is not in motions.toml";
  }
  EXPECT_FALSE(std::filesystem::exists(kMotions / "Boxing_Toes.bvh"));
  EXPECT_TRUE(std::filesystem::exists(kMotions / "LICENSE-CMU.txt"));
  EXPECT_TRUE(std::filesystem::exists(kMotions / "PROVENANCE.md"));
}
