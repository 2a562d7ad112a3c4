// Cross-actor check on the real development mocap: templates from CMU 135 and four HDM05
// actors recognise the fifth actor's left front kicks (never trained on). Skips when the
// shared data is absent.
#include <gtest/gtest.h>

#include <filesystem>

#include "kumite/recognition/recognition.hpp"
#include "offline.hpp"

namespace fs = std::filesystem;
using namespace kumite::recognition;

TEST(RecognitionMocap, HeldOutActorsFrontKicksAreRecognised) {
  const fs::path motions = fs::path(KUMITE_SOURCE_DIR) / "content" / "motions" / "motions.toml";
  const fs::path shared = fs::path(KUMITE_SHARED_DATA_DIR) / "mocap" / "hdm05";
  if (!fs::exists(shared) || !fs::exists(motions)) GTEST_SKIP() << "no shared mocap data at " << shared;
  const auto recs = offline::load_motions(motions);
  const std::string held = "tr";
  std::vector<const offline::Recording*> train;
  for (const auto& r : recs)
    if (r.actor != held && !r.strikes.empty()) train.push_back(&r);
  const Model m = offline::train(train, {}, {}, "test fold without tr");
  int kicks = 0, right = 0;
  for (const auto& r : recs) {
    if (r.actor != held) continue;
    const auto ev = recognise(m, r.samples);
    for (const auto& s : r.strikes) {
      ++kicks;
      for (const auto& e : ev)
        if (e.type == EventType::begin && e.limb == s.limb && e.t >= s.first / r.fps && e.t <= s.hit / r.fps + 0.1) {
          right += e.action == "front_kick";
          break;
        }
    }
  }
  EXPECT_EQ(kicks, 5);
  EXPECT_GE(right, 4) << "held-out actor tr: " << right << " of " << kicks << " front kicks recognised";
}
