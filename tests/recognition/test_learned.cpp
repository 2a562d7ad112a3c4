// The learned recogniser: the C++ inference matches torch (a fixture exported by
// train_touche.py --fixture: SYNTHETIC random weights), the model file is validated, the
// shipped model loads, and the event logic (begin / end / cancel) on a hand-built network.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "kumite/common/error.hpp"
#include "kumite/recognition/learned.hpp"

namespace fs = std::filesystem;
using namespace kumite::recognition;

namespace {
fs::path data_dir() { return fs::path(KUMITE_SOURCE_DIR) / "tests" / "recognition" / "data"; }
std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
std::string error_of(const std::string& text) {
  try {
    parse_learned_model(text, "m.klearn");
  } catch (const kumite::Error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(LearnedRecogniser, InferenceMatchesTorchOnTheFixture) {
  const LearnedModel m = read_learned_model(data_dir() / "learned_fixture.klearn");
  const auto j = nlohmann::json::parse(slurp(data_dir() / "learned_fixture.json"));
  ASSERT_EQ(j["cases"].size(), 8u);
  std::vector<float> scratch;
  LearnedOutput out;
  for (const auto& c : j["cases"]) {
    const LearnedNet* net = m.net(*limb_kind_from_string(c["kind"].get<std::string>()));
    ASSERT_NE(net, nullptr);
    std::array<LearnedInput, kLearnedWindow> w{};
    for (int t = 0; t < kLearnedWindow; ++t)
      for (int i = 0; i < kLearnedInputs; ++i)
        w[static_cast<std::size_t>(t)][static_cast<std::size_t>(i)] = c["window"][static_cast<std::size_t>(t)][static_cast<std::size_t>(i)];
    learned_infer(*net, w, out, scratch);
    ASSERT_EQ(out.probabilities.size(), c["probabilities"].size());
    for (std::size_t k = 0; k < out.probabilities.size(); ++k)
      EXPECT_NEAR(out.probabilities[k], c["probabilities"][k].get<double>(), 1e-5) << c["kind"] << " class " << k;
    EXPECT_NEAR(out.progress, c["progress"].get<double>(), 1e-5);
  }
}

TEST(LearnedRecogniser, ModelFileFromAnotherVersionOrDamagedIsRefusedInOneLine) {
  const std::string good = slurp(data_dir() / "learned_fixture.klearn");
  ASSERT_NO_THROW(parse_learned_model(good, "m.klearn"));
  std::string other = good;
  other.replace(0, good.find('\n'), "kumite-learned-model 2");
  EXPECT_NE(error_of(other).find("m.klearn:1: version:"), std::string::npos) << error_of(other);
  std::string damaged = good;
  const auto at = damaged.find("setting loop_hz 60");
  ASSERT_NE(at, std::string::npos);
  damaged[at + 16] = '7';  // 60 -> 70
  EXPECT_NE(error_of(damaged).find("m.klearn:2: checksum:"), std::string::npos) << error_of(damaged);
  EXPECT_NE(error_of("kumite-recognition-model 1\n").find("m.klearn:1: format:"), std::string::npos);
  for (const std::string& e : {error_of(other), error_of(damaged)}) EXPECT_EQ(e.find('\n'), std::string::npos);
}

TEST(LearnedRecogniser, TheShippedModelLoadsWithItsLicenceNote) {
  const LearnedModel m = read_learned_model(fs::path(KUMITE_SOURCE_DIR) / "recognition" / "models" / "strikes.klearn");
  ASSERT_NE(m.net(LimbKind::hand), nullptr);
  ASSERT_NE(m.net(LimbKind::foot), nullptr);
  EXPECT_EQ(m.net(LimbKind::hand)->hidden, 100);
  EXPECT_EQ(m.net(LimbKind::hand)->classes.front(), "none");
  EXPECT_NE(m.note.find("CC BY-SA 3.0"), std::string::npos);
  EXPECT_EQ(m.note.find("Sony"), std::string::npos);
}

namespace {
/// A hand-built network (hidden 1): "straight_punch" when the hand is more than 0.2 head
/// heights in front of the head (z < -0.2) in the newest loop, else "none"; progress 0.5.
LearnedModel reach_model() {
  LearnedNet n;
  n.kind = LimbKind::hand;
  n.classes = {"none", "straight_punch"};
  n.hidden = 1;
  n.mean.assign(6, 0);
  n.std.assign(6, 1);
  n.conv1_weight.assign(6 * 4, 0);
  n.conv1_weight[2 * 4 + 3] = -1;  // [o=0][i=z][k=3]: the newest of conv1's 4 loops
  n.conv1_bias = {0};
  n.conv2_weight = {0, 0, 0, 1};   // [0][0][k=3]: conv1's newest output
  n.conv2_bias = {0};
  n.out_weight = {0, 10, 0};       // none, punch, progress
  n.out_bias = {0, -2, 0};
  n.impact = {0, 0, 0, 0.1f, -0.1f, -0.45f};
  LearnedModel m;
  m.nets.push_back(n);
  return m;
}

std::vector<PoseSample> reach(double until_s, bool come_back) {
  std::vector<PoseSample> s;
  for (int k = 0; k * (1.0 / 120) <= until_s; ++k) {
    const double t = k / 120.0;
    double z = -0.15;  // hand 0.15 m in front of the head
    if (t > 0.5) z = -0.15 - std::min(1.0, (t - 0.5) / 0.15) * 0.5;
    if (come_back && t > 0.8) z = -0.65 + std::min(1.0, (t - 0.8) / 0.2) * 0.5;
    s.push_back({t, Role::head, {0, 1.6, 0}, {1, 0, 0, 0}, true});
    s.push_back({t, Role::right_hand, {0.15, 1.3, z}, {1, 0, 0, 0}, true});
  }
  return s;
}
}  // namespace

TEST(LearnedRecogniser, BeginsEndsAndCancelsOnAHandBuiltNetwork) {
  {
    LearnedRecogniser r(reach_model());
    std::vector<Event> ev;
    for (const auto& s : reach(1.5, true)) r.push(s, ev);
    r.finish(1.5, ev);
    ASSERT_EQ(ev.size(), 2u);
    EXPECT_EQ(ev[0].type, EventType::begin);
    EXPECT_EQ(ev[0].limb, Role::right_hand);
    EXPECT_EQ(ev[0].action, "straight_punch");
    // z < -0.2 head heights = -0.32 m: reached 0.5 + 0.15 * (0.17 / 0.5) s = 0.551 s
    EXPECT_GT(ev[0].t, 0.54);
    EXPECT_LT(ev[0].t, 0.6);
    EXPECT_NEAR(ev[0].progress, 0.5, 1e-6);
    EXPECT_EQ(ev[1].type, EventType::end);
    EXPECT_GT(ev[1].t, 0.9);
  }
  {
    // The stream stops mid-strike: cancel.
    LearnedRecogniser r(reach_model());
    std::vector<Event> ev;
    for (const auto& s : reach(0.7, false)) r.push(s, ev);
    r.finish(0.7, ev);
    ASSERT_EQ(ev.size(), 2u);
    EXPECT_EQ(ev[0].type, EventType::begin);
    EXPECT_EQ(ev[1].type, EventType::cancel);
    EXPECT_DOUBLE_EQ(ev[1].t, 0.7);
  }
  {
    // Two loops of confirmation delay the begin by two loops (1/30 s).
    LearnedModel m = reach_model();
    std::vector<Event> a, b;
    LearnedRecogniser r1(m);
    for (const auto& s : reach(0.7, false)) r1.push(s, a);
    m.settings.confirm_frames = 3;
    LearnedRecogniser r3(m);
    for (const auto& s : reach(0.7, false)) r3.push(s, b);
    ASSERT_EQ(a.size(), 1u);
    ASSERT_EQ(b.size(), 1u);
    EXPECT_NEAR(b[0].t - a[0].t, 2.0 / 60, 1e-3);
  }
}
