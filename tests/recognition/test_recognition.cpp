// Recognition on SYNTHETIC visitors with known ground truth (minimum-jerk punches and kicks,
// a synthetic walk), the model file, poses.csv, and one cross-actor check on the real
// development mocap (skipped when ../shared is absent).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <set>

#include "kumite/common/error.hpp"
#include "kumite/recognition/recognition.hpp"
#include "offline.hpp"

namespace fs = std::filesystem;
using namespace kumite;
using namespace kumite::recognition;
using offline::SynthMove;

namespace {
const Model& synth_model() {
  static const Model m = offline::synthetic_model();
  return m;
}
std::vector<Event> of_type(const std::vector<Event>& ev, EventType t) {
  std::vector<Event> out;
  std::copy_if(ev.begin(), ev.end(), std::back_inserter(out), [&](const Event& e) { return e.type == t; });
  return out;
}
std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(RecognitionSynthetic, ModelHasPunchAndKickTemplates) {
  const Model& m = synth_model();
  ASSERT_EQ(m.templates.size(), 2u);
  for (const auto& t : m.templates) {
    EXPECT_EQ(t.trials, 9);
    EXPECT_GT(t.threshold, 0);
    EXPECT_GT(t.hit, 0);
    EXPECT_LT(t.hit, static_cast<int>(t.frames.size()));
  }
}

TEST(RecognitionSynthetic, StraightPunchIsThatLimbAndAction) {
  // Speed and stature not among the training ones; both hands (the left mirrored).
  for (Role hand : {Role::right_hand, Role::left_hand}) {
    const auto syn = offline::synthesise({{SynthMove::idle, hand, 0.6, 1}, {SynthMove::straight_punch, hand, 1.4, 0.9},
                                          {SynthMove::idle, hand, 0.5, 1}},
                                         120, 0.96);
    const auto ev = recognise(synth_model(), syn.samples);
    const auto begins = of_type(ev, EventType::begin);
    ASSERT_EQ(begins.size(), 1u) << to_string(hand);
    EXPECT_EQ(begins[0].limb, hand);
    EXPECT_EQ(begins[0].action, "straight_punch");
    const auto& s = syn.strikes.at(0);
    const double t_hit = s.hit / 120.0, t_first = s.first / 120.0;
    EXPECT_GT(begins[0].t, t_first);
    EXPECT_LT(begins[0].t, t_hit + 0.02) << "the first guess comes before full extension";
    EXPECT_GT(begins[0].confidence, 0);
    // Predicted impact: the synthetic target (x = +-0.05, y = 1.45, z = -0.72, x 0.96).
    const double sx = hand == Role::left_hand ? -1 : 1;
    EXPECT_NEAR(begins[0].impact[0], sx * 0.05 * 0.96, 0.12);
    EXPECT_NEAR(begins[0].impact[1], 1.45 * 0.96, 0.12);
    EXPECT_NEAR(begins[0].impact[2], -0.72 * 0.96, 0.12);
    // The null signal ends it, once: the fist stops at full extension (or back at the guard).
    const auto ends = of_type(ev, EventType::end);
    ASSERT_EQ(ends.size(), 1u);
    EXPECT_EQ(ends[0].limb, hand);
    EXPECT_GT(ends[0].t, t_hit);
    EXPECT_LT(ends[0].t, s.last / 120.0 + 0.3);
    EXPECT_TRUE(of_type(ev, EventType::cancel).empty());
  }
}

TEST(RecognitionSynthetic, FrontKickIsAFootNotAHand) {
  const auto syn = offline::synthesise({{SynthMove::idle, Role::left_foot, 0.6, 1}, {SynthMove::front_kick, Role::left_foot, 1.5, 1.1},
                                        {SynthMove::idle, Role::left_foot, 0.5, 1}},
                                       120, 1.04);
  const auto ev = recognise(synth_model(), syn.samples);
  const auto begins = of_type(ev, EventType::begin);
  ASSERT_EQ(begins.size(), 1u);
  EXPECT_EQ(begins[0].limb, Role::left_foot);
  EXPECT_EQ(begins[0].action, "front_kick");
}

TEST(RecognitionSynthetic, WalkAndIdleAreNotStrikes) {
  const auto syn = offline::synthesise({{SynthMove::idle, Role::head, 1.0, 1}, {SynthMove::walk, Role::head, 4.0, 1},
                                        {SynthMove::idle, Role::head, 1.0, 1}});
  const auto ev = recognise(synth_model(), syn.samples);
  EXPECT_TRUE(of_type(ev, EventType::begin).empty()) << (ev.empty() ? "" : to_json(ev[0]));
  // The walk does move the feet fast relative to the head: the test is not vacuous.
  Frontend fe;
  std::vector<Frame> frames;
  for (const auto& s : syn.samples) fe.push(s, frames);
  double fastest = 0;
  for (const auto& f : frames) fastest = std::max(fastest, f.limbs[3].speed);
  EXPECT_GT(fastest, RecogniserSettings{}.onset_speed);
}

TEST(RecognitionSynthetic, StreamCutMidStrikeGivesCancel) {
  auto syn = offline::synthesise({{SynthMove::idle, Role::right_hand, 0.6, 1}, {SynthMove::straight_punch, Role::right_hand, 1.0, 1}});
  const auto& s = syn.strikes.at(0);
  const double cut = (s.hit - 1) / 120.0;  // just before full extension
  std::erase_if(syn.samples, [&](const PoseSample& p) { return p.t > cut; });
  const auto ev = recognise(synth_model(), syn.samples);
  ASSERT_FALSE(ev.empty());
  EXPECT_EQ(ev.front().type, EventType::begin);
  EXPECT_EQ(ev.back().type, EventType::cancel);
  EXPECT_EQ(ev.back().limb, Role::right_hand);
}

TEST(RecognitionSynthetic, LostGloveMidStrikeGivesCancel) {
  auto syn = offline::synthesise({{SynthMove::idle, Role::right_hand, 0.6, 1}, {SynthMove::straight_punch, Role::right_hand, 1.0, 1}});
  const auto& s = syn.strikes.at(0);
  const double lost_from = (s.hit - 1) / 120.0;
  for (auto& p : syn.samples)
    if (p.role == Role::right_hand && p.t > lost_from) p.tracked = false;
  const auto ev = recognise(synth_model(), syn.samples);
  ASSERT_GE(ev.size(), 2u);
  EXPECT_EQ(ev[0].type, EventType::begin);
  EXPECT_EQ(ev[1].type, EventType::cancel);
  EXPECT_NEAR(ev[1].t, lost_from, 0.05);
}

TEST(RecognitionDtw, OpenEndFindsThePrefix) {
  std::vector<Feature> templ;
  for (int i = 0; i < 40; ++i) templ.push_back({static_cast<float>(i) / 10, 0, 0, 0, 0, 0});
  std::vector<Feature> q(templ.begin(), templ.begin() + 20);
  std::vector<double> scratch;
  const auto m = dtw_open_end(q, templ, scratch);
  EXPECT_EQ(m.template_end, 19);
  EXPECT_NEAR(m.distance, 0, 1e-9);
  // A query at half speed still ends at the same template frame.
  std::vector<Feature> slow;
  for (int i = 0; i < 40; ++i) slow.push_back({static_cast<float>(i) / 20, 0, 0, 0, 0, 0});
  EXPECT_NEAR(dtw_open_end(slow, templ, scratch).template_end, 19, 1);
  // Something else entirely is far.
  std::vector<Feature> other(20, Feature{0, 5, 0, 0, 0, 0});
  EXPECT_GT(dtw_open_end(other, templ, scratch).distance, 4);
}

TEST(RecognitionModel, RoundTrip) {
  const Model& m = synth_model();
  const std::string text = format_model(m);
  const Model back = parse_model(text, "mem.krec");
  EXPECT_EQ(format_model(back), text);
  ASSERT_EQ(back.templates.size(), m.templates.size());
  EXPECT_EQ(back.templates[0].frames.size(), m.templates[0].frames.size());
  EXPECT_DOUBLE_EQ(back.templates[1].threshold, m.templates[1].threshold);
  EXPECT_EQ(back.settings.main_frames, 6);
  const fs::path p = fs::path(KUMITE_BINARY_DIR) / "test_recognition_model.krec";
  write_model(p, m);
  EXPECT_EQ(format_model(read_model(p)), text);
  fs::remove(p);
}

TEST(RecognitionModel, RefusesOtherVersionsAndDamage) {
  const std::string text = format_model(synth_model());
  std::string v2 = text;
  v2.replace(v2.find(" 1\n"), 3, " 2\n");
  EXPECT_EQ(error_of([&] { parse_model(v2, "old.krec"); }),
            "old.krec:1: version: model version 2 is not the version this build reads (1)");
  EXPECT_EQ(error_of([&] { parse_model("hello\n", "x.krec"); }).rfind("x.krec:1: format:", 0), 0u);
  std::string damaged = text;
  damaged[damaged.size() / 2] = damaged[damaged.size() / 2] == '1' ? '2' : '1';
  EXPECT_EQ(error_of([&] { parse_model(damaged, "d.krec"); }),
            "d.krec:2: checksum: does not match the contents (file damaged or edited)");
  EXPECT_EQ(error_of([&] { parse_model(text.substr(0, text.size() / 2), "cut.krec"); }).rfind("cut.krec:2: checksum", 0), 0u);
  EXPECT_EQ(error_of([&] { read_model("/nonexistent/m.krec"); }).rfind("/nonexistent/m.krec:", 0), 0u);
}

TEST(RecognitionModel, RefusesBadNumbersEvenWithAValidChecksum) {
  // Re-sign an edited body so only the value checks can refuse it.
  Model m = synth_model();
  m.templates[0].frames[3][1] = std::numeric_limits<float>::infinity();
  const std::string text = format_model(m);
  const std::string e = error_of([&] { parse_model(text, "inf.krec"); });
  EXPECT_NE(e.find("inf.krec:"), std::string::npos);
  EXPECT_NE(e.find(": frames: inf is outside"), std::string::npos) << e;
  Model z = synth_model();
  z.settings.main_frames = 0;
  EXPECT_NE(error_of([&] { parse_model(format_model(z), "z.krec"); }).find("main_frames: 0 is outside"), std::string::npos);
}

TEST(RecognitionPoses, ParsesAndIgnoresUnknownBodies) {
  const std::string csv = std::string(recognition::kPosesHeader) +
                          "\n0,1.000,head,tracked,0,1.6,0,1,0,0,0,4,3,5.1\n"
                          "0,1.000,prop,tracked,1,1,1,1,0,0,0,4,3,5.1\n"
                          "1,1.008,right_hand,lost,0,0,0,1,0,0,0,0,0,-1\n";
  const auto pf = recognition::parse_poses_csv(csv, "p.csv");
  ASSERT_EQ(pf.samples.size(), 2u);
  EXPECT_EQ(pf.ignored_rows, 1);
  EXPECT_EQ(pf.samples[1].role, Role::right_hand);
  EXPECT_FALSE(pf.samples[1].tracked);
  // Saved by a spreadsheet as "CSV UTF-8": the byte-order mark before the header is dropped.
  EXPECT_EQ(recognition::parse_poses_csv("\xEF\xBB\xBF" + csv, "p.csv").samples.size(), 2u);
  // Round trip through the writer.
  const auto back = recognition::parse_poses_csv(recognition::format_poses_csv(pf.samples), "w.csv");
  ASSERT_EQ(back.samples.size(), 2u);
  EXPECT_DOUBLE_EQ(back.samples[0].position[1], 1.6);
}

TEST(RecognitionPoses, MalformedLinesNameFileAndLine) {
  const std::string h = std::string(recognition::kPosesHeader) + "\n";
  EXPECT_EQ(error_of([&] { recognition::parse_poses_csv(h + "0,1,head,tracked,0,nan,0,1,0,0,0,4,3,5\n", "p.csv"); }),
            "p.csv:2: y: nan is outside [-100, 100]");
  EXPECT_EQ(error_of([&] { recognition::parse_poses_csv(h + "0,1,head,tracked,0,1\n", "p.csv"); }).rfind("p.csv:2: row: 6 columns", 0), 0u);
  EXPECT_EQ(error_of([&] { recognition::parse_poses_csv(h + "0,1,head,flying,0,1,0,1,0,0,0,4,3,5\n", "p.csv"); }),
            "p.csv:2: status: 'flying' is not tracked, coasting or lost");
  EXPECT_EQ(error_of([&] {
              recognition::parse_poses_csv(h + "0,2,head,tracked,0,1,0,1,0,0,0,4,3,5\n1,1,head,tracked,0,1,0,1,0,0,0,4,3,5\n", "p.csv");
            }),
            "p.csv:3: timestamp_s: 1 goes back in time (previous row 2)");
  EXPECT_EQ(error_of([&] { recognition::parse_poses_csv("frame,t\n", "p.csv"); }).rfind("p.csv:1: header:", 0), 0u);
  const std::string empty = error_of([&] { recognition::parse_poses_csv("", "p.csv"); });
  EXPECT_EQ(empty.rfind("p.csv:", 0), 0u) << empty;
  EXPECT_NE(empty.find("header: no header line"), std::string::npos) << empty;
}

TEST(RecognitionModel, ShippedModelLoadsWithTheDefaultSettings) {
  const Model m = read_model(fs::path(KUMITE_SOURCE_DIR) / "recognition" / "models" / "strikes.krec");
  std::set<std::string> actions;
  int nones = 0;
  for (const auto& t : m.templates) {
    if (t.action == kNoneAction) ++nones;
    else actions.insert(t.action);
  }
  EXPECT_EQ(actions, (std::set<std::string>{"straight_punch", "front_kick", "side_kick", "roundhouse_kick"}));
  EXPECT_GT(nones, 0);
  // Retrain it (kumite-recognise train --out recognition/models/strikes.krec) when a default changes.
  const RecogniserSettings d;
  EXPECT_EQ(m.settings.onset_speed, d.onset_speed);
  EXPECT_EQ(m.settings.absolute_weight, d.absolute_weight);
  EXPECT_EQ(m.settings.none_margin, d.none_margin);
  EXPECT_EQ(m.settings.main_frames, d.main_frames);
  EXPECT_EQ(m.settings.max_frames, d.max_frames);
  EXPECT_EQ(m.settings.frontend.velocity_weight, d.frontend.velocity_weight);
  EXPECT_EQ(m.settings.frontend.smoothing_tau_s, d.frontend.smoothing_tau_s);
}

TEST(RecognitionFrontend, TimeJumpsAndHugeTimesDoNotStall) {
  Frontend fe;
  std::vector<Frame> frames;
  PoseSample s;
  s.position = {0, 1.6, 0};
  for (double t : {0.0, 0.01, 5.0, 5.02, 1e15, 1e15 + 1, 2e15}) {
    s.t = t;
    fe.push(s, frames);
  }
  EXPECT_LT(frames.size(), 400u);
  EXPECT_GT(frames.size(), 2u);
}

TEST(RecognitionSynthetic, TemplatesPerStyleSplitHandStrikesAndNeverSwitchWithinAnAction) {
  // SYNTHETIC: two "actors" punching at different speeds (their styles), one kicking.
  std::vector<offline::Recording> recs;
  for (double speed : {0.7, 0.8, 0.9, 1.2, 1.3, 1.4})
    for (double scale : {0.92, 1.08})
      for (SynthMove mv : {SynthMove::straight_punch, SynthMove::front_kick}) {
        const Role limb = mv == SynthMove::front_kick ? Role::right_foot : Role::right_hand;
        const auto syn = offline::synthesise(
            {{SynthMove::idle, limb, 0.5, 1}, {mv, limb, 1.2, speed}, {SynthMove::idle, limb, 0.5, 1}}, 120, scale);
        offline::Recording r;
        r.name = "synthetic";
        r.actor = speed < 1 ? "slow" : "quick";
        r.fps = 120;
        r.frames = static_cast<int>(syn.samples.size() / kRoleCount);
        r.samples = syn.samples;
        r.strikes = syn.strikes;
        recs.push_back(std::move(r));
      }
  std::vector<const offline::Recording*> p;
  for (const auto& r : recs) p.push_back(&r);
  RecogniserSettings rs;
  TrainSettings ts;
  ts.template_per_style = true;
  Model m;
  m.settings = rs;
  m.templates = build_templates(offline::trials_of(p, rs, ts), rs, ts);
  int punch = 0, kick = 0;
  for (const auto& t : m.templates) {
    punch += t.action == "straight_punch";
    kick += t.action == "front_kick";
  }
  EXPECT_EQ(punch, 2) << "one per style";
  EXPECT_EQ(kick, 1) << "kicks keep one mean template";
  // A punch between the two styles' speeds: one begin, one end, and no switch between the two
  // punch templates (the same strike, whichever style fits best as it goes on).
  for (double speed : {0.8, 1.05, 1.3}) {
    const auto syn = offline::synthesise({{SynthMove::idle, Role::right_hand, 0.6, 1},
                                          {SynthMove::straight_punch, Role::right_hand, 1.4, speed},
                                          {SynthMove::idle, Role::right_hand, 0.5, 1}},
                                         120, 1.0);
    const auto ev = recognise(m, syn.samples);
    ASSERT_EQ(of_type(ev, EventType::begin).size(), 1u) << speed;
    EXPECT_EQ(of_type(ev, EventType::begin)[0].action, "straight_punch");
    EXPECT_TRUE(of_type(ev, EventType::switch_).empty()) << speed;
    EXPECT_EQ(of_type(ev, EventType::end).size(), 1u) << speed;
  }
}

TEST(RecognitionSynthetic, AnotherTemplateOfTheSameActionTakesOverWithoutASwitchEvent) {
  // Two punch templates (SYNTHETIC, the same shape): A matches loosely over the first loops and
  // not at all later, B as trained. The punch begins on A; when A stops matching, B carries
  // on: the same strike, so no switch event (a switch tells the opponent the strike changed).
  Model m = synth_model();
  const auto punch = std::find_if(m.templates.begin(), m.templates.end(), [](const Template& t) { return t.action == "straight_punch"; });
  ASSERT_NE(punch, m.templates.end());
  Template a = *punch;
  a.thresholds.assign(static_cast<std::size_t>(m.settings.max_frames), 0);
  for (int n = 1; n <= m.settings.max_frames; ++n)
    a.thresholds[static_cast<std::size_t>(n - 1)] = punch->threshold_at(n) * (n <= m.settings.main_frames + 2 ? 4.0 : 0.01);
  m.templates.insert(m.templates.begin(), a);
  const auto syn = offline::synthesise({{SynthMove::idle, Role::right_hand, 0.6, 1},
                                        {SynthMove::straight_punch, Role::right_hand, 1.4, 1.0},
                                        {SynthMove::idle, Role::right_hand, 0.5, 1}},
                                       120, 1.0);
  const auto ev = recognise(m, syn.samples);
  ASSERT_EQ(of_type(ev, EventType::begin).size(), 1u);
  EXPECT_EQ(of_type(ev, EventType::begin)[0].action, "straight_punch");
  EXPECT_TRUE(of_type(ev, EventType::switch_).empty());
  EXPECT_TRUE(of_type(ev, EventType::cancel).empty()) << "B carried the strike on";
  EXPECT_EQ(of_type(ev, EventType::end).size(), 1u);
}
