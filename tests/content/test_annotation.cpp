#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <map>

#include <fmt/format.h>

#include "kumite/common/error.hpp"
#include "kumite/content/annotation.hpp"
#include "kumite/content/bvh.hpp"
#include "kumite/content/database.hpp"
#include "kumite/content/mkm.hpp"
#include "mocap_data.hpp"

using namespace kumite::content;
using kumite::content::testing::mocap_clip;

namespace {

std::string annotation_error(const std::string& text) {
  try {
    parse_annotations(text, "m.toml");
  } catch (const kumite::Error& e) {
    EXPECT_EQ(e.component(), "annotation");
    return e.what();
  }
  return "(no error)";
}

const std::string kHeader = "version = 1\n[[clip]]\nfile = \"a.bvh\"\n[[clip.motion]]\nname = \"k\"\n";

struct Listed {
  HitSegment segment;
  int peak;  // PROVENANCE.md peak frame
};

std::vector<const MotionAnnotation*> strikes_of(const ClipAnnotation& c, Semantics s) {
  std::vector<const MotionAnnotation*> out;
  for (const auto& m : c.motions) {
    if (m.semantics == s) out.push_back(&m);
  }
  return out;
}

/// Every listed strike is found once (same limb, hit frame within `tolerance` frames), and
/// nothing else of that kind is reported.
void expect_strikes(const std::string& rel, Semantics kind, const std::vector<Listed>& listed, int tolerance = 4,
                    double min_speed = 3.0, int min_after = 10) {
  const Clip& clip = mocap_clip(rel);
  const ClipAnnotation a = propose_annotations(clip, rel + ".bvh");
  const auto found = strikes_of(a, kind);
  EXPECT_EQ(found.size(), listed.size()) << rel;
  for (const auto& l : listed) {
    const MotionAnnotation* match = nullptr;
    for (const auto* m : found) {
      if (m->hit_segment == l.segment && std::abs(*m->hit_frame - l.peak) <= tolerance) match = m;
    }
    ASSERT_NE(match, nullptr) << rel << ": " << to_string(kind) << " " << to_string(l.segment) << " at f" << l.peak
                              << " not found";
    EXPECT_LE(match->first_frame, l.peak - 10) << rel << " f" << l.peak;
    EXPECT_GE(match->last_frame, l.peak + min_after) << rel << " f" << l.peak;
    EXPECT_GT(match->peak_speed_mps, min_speed) << rel << " f" << l.peak;
    EXPECT_GT(match->extension, 0.85) << rel << " f" << l.peak;
  }
}

}  // namespace

// ---- Schema ---------------------------------------------------------------------------------

TEST(Annotation, RoundTrip) {
  AnnotationSet set;
  ClipAnnotation c;
  c.file = "clips/135_04.bvh";
  c.name = "135_04";
  c.mirror = false;
  MotionAnnotation k;
  k.name = "135_04_kick_right_1";
  k.semantics = Semantics::kick;
  k.first_frame = 330;
  k.last_frame = 410;
  k.hit_segment = HitSegment::right_foot;
  k.hit_frame = 374;
  k.height = StrikeHeight::mid;
  k.note = "front kick \"mae-geri\"";
  k.peak_speed_mps = 9.75;
  k.extension = 0.945;
  k.repair_frames = std::array<int, 2>{376, 377};
  MotionAnnotation r;
  r.name = "135_04_rest_1";
  r.semantics = Semantics::rest;
  r.first_frame = 0;
  r.last_frame = 100;
  c.motions = {k, r};
  set.clips = {c};
  const std::string text = format_annotations(set);
  const AnnotationSet back = parse_annotations(text, "/some/dir/motions.toml");
  ASSERT_EQ(back.clips.size(), 1u);
  EXPECT_EQ(back.resolve(back.clips[0]), std::filesystem::path("/some/dir/clips/135_04.bvh"));
  EXPECT_FALSE(back.clips[0].mirror);
  ASSERT_EQ(back.clips[0].motions.size(), 2u);
  const auto& bk = back.clips[0].motions[0];
  EXPECT_EQ(bk.name, k.name);
  EXPECT_EQ(bk.semantics, Semantics::kick);
  EXPECT_EQ(bk.first_frame, 330);
  EXPECT_EQ(bk.last_frame, 410);
  EXPECT_EQ(bk.hit_segment, HitSegment::right_foot);
  EXPECT_EQ(bk.hit_frame, 374);
  EXPECT_EQ(bk.height, StrikeHeight::mid);
  EXPECT_EQ(bk.note, k.note);
  EXPECT_DOUBLE_EQ(bk.peak_speed_mps, 9.75);
  EXPECT_DOUBLE_EQ(bk.extension, 0.945);
  EXPECT_EQ(bk.repair_frames, k.repair_frames);
  EXPECT_FALSE(back.clips[0].motions[1].repair_frames);
  EXPECT_GT(bk.line, 0);
  EXPECT_FALSE(back.clips[0].motions[1].hit_frame);
  EXPECT_FALSE(back.clips[0].motions[1].height);
  EXPECT_EQ(format_annotations(back), text);
  EXPECT_NE(text.find("height = \"mid\"\n"), std::string::npos);
  // Every height survives the round trip; a strike without one stays without.
  for (StrikeHeight h : {StrikeHeight::low, StrikeHeight::mid, StrikeHeight::high}) {
    set.clips[0].motions[0].height = h;
    EXPECT_EQ(parse_annotations(format_annotations(set), "m.toml").clips[0].motions[0].height, h);
    EXPECT_EQ(strike_height_from_string(to_string(h)), h);
  }
  set.clips[0].motions[0].height.reset();
  EXPECT_FALSE(parse_annotations(format_annotations(set), "m.toml").clips[0].motions[0].height);
  EXPECT_FALSE(strike_height_from_string("Mid"));
  EXPECT_FALSE(strike_height_from_string(""));
}

TEST(Annotation, StrikeHeightClasses) {
  // Fractions of stature: low below 0.55, high from 0.81.
  EXPECT_EQ(classify_strike_height(0.87, 1.60), StrikeHeight::low);   // 0.544
  EXPECT_EQ(classify_strike_height(0.89, 1.60), StrikeHeight::mid);   // 0.556
  EXPECT_EQ(classify_strike_height(1.28, 1.60), StrikeHeight::mid);   // 0.800: CMU 135's highest chudan punch
  EXPECT_EQ(classify_strike_height(1.31, 1.60), StrikeHeight::high);  // 0.819: the boxer's lowest head jab
  EXPECT_EQ(classify_strike_height(1.31, 2.00), StrikeHeight::mid);   // taller actor, same height
  EXPECT_EQ(classify_strike_height(1.0, 1.6, {.low_below = 0.7, .high_from = 0.9}), StrikeHeight::low);
  EXPECT_THROW(classify_strike_height(1.0, 0.0), kumite::Error);
}

TEST(Annotation, SchemaErrorsNameFileLineKey) {
  EXPECT_EQ(annotation_error(kHeader + "semantics = \"kick\"\nframes = [1, 9]\nhit_segment = \"right_knee\"\nhit_frame = 5\n"),
            "m.toml:8: clip[0].motion[0].hit_segment: unknown segment 'right_knee' (left_hand, right_hand, left_foot, "
            "right_foot)");
  EXPECT_EQ(annotation_error(kHeader + "semantics = \"kick\"\nframes = [1, 9]\nhit_segment = \"right_foot\"\nhit_frame = 12\n"),
            "m.toml:9: clip[0].motion[0].hit_frame: 12 is outside frames [1, 9]");
  EXPECT_EQ(annotation_error(kHeader + "semantics = \"kick\"\nframes = [1, 9]\n"),
            "m.toml:4: clip[0].motion[0].hit_segment: is required for a kick");
  EXPECT_EQ(annotation_error(kHeader + "semantics = \"punch\"\nframes = [1, 9]\nhit_segment = \"left_foot\"\nhit_frame = 5\n"),
            "m.toml:8: clip[0].motion[0].hit_segment: a punch hits with a hand");
  EXPECT_EQ(annotation_error(kHeader + "semantics = \"rest\"\nframes = [1, 9]\nhit_frame = 5\n"),
            "m.toml:8: clip[0].motion[0].hit_frame: only strikes (punch, kick) have one, not rest");
  EXPECT_EQ(annotation_error(kHeader + "semantics = \"dance\"\nframes = [1, 9]\n"),
            "m.toml:6: clip[0].motion[0].semantics: unknown semantics 'dance' (punch, kick, block, walk, rest, other)");
  EXPECT_EQ(annotation_error(kHeader + "semantics = \"rest\"\nframes = [9, 1]\n"),
            "m.toml:7: clip[0].motion[0].frames: [9, 1] must satisfy 0 <= first <= last");
  EXPECT_EQ(annotation_error(kHeader + "semantics = \"rest\"\nframes = [1, 9]\nspeed = 3\n"),
            "m.toml:8: clip[0].motion[0].speed: unknown key (allowed here: name, semantics, frames, "
            "hit_segment, hit_frame, height, note, peak_speed_mps, extension, repair_frames, forearm, intercept_frames)");
  EXPECT_EQ(annotation_error(kHeader + "semantics = \"rest\"\nframes = [1, 9]\nrepair_frames = [1, 2]\n"),
            "m.toml:8: clip[0].motion[0].repair_frames: [1, 2] must lie inside frames [1, 9], not on their first or last "
            "(the frames around it are interpolated)");
  EXPECT_EQ(annotation_error(kHeader + "semantics = \"rest\"\nframes = [1, 90]\nrepair_frames = [10, 19]\n"),
            "m.toml:8: clip[0].motion[0].repair_frames: [10, 19] rebuilds 10 frames: at most 8 (a glitch, not a motion)");
  EXPECT_EQ(annotation_error(kHeader + "semantics = \"rest\"\nframes = [1, 90]\nrepair_frames = [10]\n"),
            "m.toml:8: clip[0].motion[0].repair_frames: must be [first, last] (two integers)");
  EXPECT_EQ(annotation_error(kHeader + "semantics = \"rest\"\nframes = [1, 9]\n[[clip.motion]]\nname = \"k\"\n"
                                       "semantics = \"rest\"\nframes = [1, 9]\n"),
            "m.toml:9: clip[0].motion[1].name: motion name 'k' is used twice");
  EXPECT_EQ(annotation_error(kHeader + "semantics = \"kick\"\nframes = [1, 9]\nhit_segment = \"right_foot\"\nhit_frame = 5\n"
                                       "height = \"medium\"\n"),
            "m.toml:10: clip[0].motion[0].height: unknown height 'medium' (low, mid, high)");
  EXPECT_EQ(annotation_error(kHeader + "semantics = \"kick\"\nframes = [1, 9]\nhit_segment = \"right_foot\"\nhit_frame = 5\n"
                                       "height = 2\n"),
            "m.toml:10: clip[0].motion[0].height: must be a string");
  EXPECT_EQ(annotation_error(kHeader + "semantics = \"rest\"\nframes = [1, 9]\nheight = \"low\"\n"),
            "m.toml:8: clip[0].motion[0].height: only strikes (punch, kick) and blocks have one, not rest");
  EXPECT_EQ(annotation_error("version = 2\n"), "m.toml:1: version: version 2 is not supported (expected 1)");
  EXPECT_EQ(annotation_error("[[clip]]\n"), "m.toml:1: version: is required");
  EXPECT_NE(annotation_error("version = 1\n[[clip]\n").find("m.toml:2: "), std::string::npos);
}

TEST(Annotation, AnnotationOutsideTheClipIsAnError) {
  KUMITE_REQUIRE_MOCAP();
  const auto dir = kumite::content::testing::mocap_dir() / "cmu";
  const std::string text = "version = 1\n[[clip]]\nfile = \"135_08.bvh\"\n[[clip.motion]]\nname = \"r\"\n"
                           "semantics = \"rest\"\nframes = [0, 400]\n";
  const AnnotationSet set = parse_annotations(text, (dir / "motions.toml").string());
  try {
    load_annotated_clips(set);
    FAIL();
  } catch (const kumite::Error& e) {
    EXPECT_EQ(std::string(e.what()), (dir / "motions.toml").string() +
                                         ":4: clip[0].motion[0].frames: [0, 400] is outside the clip '135_08' "
                                         "(frames 0..290)");
  }
  const AnnotationSet missing = parse_annotations("version = 1\n[[clip]]\nfile = \"nope.bvh\"\n", "/tmp/m.toml");
  EXPECT_THROW(load_annotated_clips(missing), kumite::Error);
}

TEST(Annotation, AnnotationOutsideTheShippedClipNamesFileLineKey) {
  // Runs without ../shared: the shipped 135_08 has 291 frames.
  const auto dir = kumite::content::testing::source_dir() / "content" / "motions";
  const std::string text = "version = 1\n[[clip]]\nfile = \"135_08.bvh\"\n\n[[clip.motion]]\nname = \"k\"\n"
                           "semantics = \"kick\"\nframes = [200, 280]\nhit_segment = \"left_foot\"\nhit_frame = 250\n"
                           "[[clip.motion]]\nname = \"r\"\nsemantics = \"rest\"\nframes = [250, 291]\n";
  const AnnotationSet set = parse_annotations(text, (dir / "motions.toml").string());
  try {
    load_annotated_clips(set);
    FAIL() << "frames past the clip's end were accepted";
  } catch (const kumite::Error& e) {
    EXPECT_EQ(std::string(e.what()), (dir / "motions.toml").string() +
                                         ":11: clip[0].motion[1].frames: [250, 291] is outside the clip '135_08' "
                                         "(frames 0..290)");
  }
}

// ---- Unit detection: the proposer warns, the database refuses ---------------------------------

namespace {
/// SYNTHETIC: the shipped 135_08 (a 1.63 m rest pose in cm) scaled by `scale` and written in
/// `unit_m`, read back with the unit guessed as for any file.
Clip rescaled(double scale, double unit_m, const std::string& source) {
  Clip c = read_bvh(kumite::content::testing::source_dir() / "content" / "motions" / "135_08.bvh");
  for (auto& o : c.skeleton.offsets) o *= scale;
  for (auto& p : c.root_positions) p *= scale;
  c.unit_m = unit_m;
  return parse_bvh(format_bvh(c), source);
}
}  // namespace

TEST(Annotation, UnitGuessWarnsOnANonHumanRestHeight) {
  const Clip ok = rescaled(1.0, 0.01, "ok.bvh");
  EXPECT_DOUBLE_EQ(ok.unit_m, 0.01);
  EXPECT_TRUE(check_bvh_unit(ok, "ok.bvh").plausible);
  EXPECT_EQ(check_bvh_unit(ok, "ok.bvh").warning, "");
  // 3x too large in cm: 497 units. No known unit makes that a human (cm: 4.9 m, mm: 0.49 m).
  const Clip giant = rescaled(3.0, 0.01, "giant.bvh");
  const BvhUnitCheck g = check_bvh_unit(giant, "giant.bvh");
  EXPECT_FALSE(g.plausible);
  EXPECT_EQ(g.warning.rfind("giant.bvh: unit_m: rest height 497", 0), 0u) << g.warning;
  EXPECT_NE(g.warning.find("not a human's"), std::string::npos) << g.warning;
  EXPECT_EQ(g.warning.find('\n'), std::string::npos);
  // Written in inches: a human only in inches; plausible, but said.
  const Clip inches = rescaled(1.0, 0.0254, "inches.bvh");
  EXPECT_DOUBLE_EQ(inches.unit_m, 0.0254);
  const BvhUnitCheck i = check_bvh_unit(inches, "inches.bvh");
  EXPECT_TRUE(i.plausible);
  EXPECT_EQ(i.warning.rfind("inches.bvh: unit_m: rest height 65", 0), 0u) << i.warning;
  EXPECT_NE(i.warning.find("guessed inches"), std::string::npos) << i.warning;

  // The database build refuses the giant with one line naming motions.toml, the line and key.
  const auto dir = std::filesystem::path(KUMITE_BINARY_DIR) / "test_unit_warning";
  std::filesystem::create_directories(dir);
  write_bvh(dir / "giant.bvh", giant);
  const AnnotationSet set = parse_annotations("version = 1\n\n[[clip]]\nfile = \"giant.bvh\"\n", (dir / "motions.toml").string());
  try {
    load_annotated_clips(set);
    FAIL() << "a 4.9 m actor was loaded";
  } catch (const kumite::Error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind((dir / "motions.toml").string() + ":3: clip[0].file: refused: ", 0), 0u) << what;
    EXPECT_NE(what.find("rest height 497"), std::string::npos) << what;
  }
  // The proposer (kumite-motion annotate) warns with one line and still proposes.
  const auto tool = std::filesystem::path(KUMITE_BINARY_DIR) / "bin" / "kumite-motion";
  if (!std::filesystem::exists(tool)) GTEST_SKIP() << "kumite-motion not built";
  const auto err = dir / "stderr.txt";
  const std::string cmd = tool.string() + " annotate " + (dir / "giant.bvh").string() + " --out " +
                          (dir / "out.toml").string() + " > /dev/null 2> " + err.string();
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::ifstream in(err);
  std::string line, all;
  int lines = 0;
  while (std::getline(in, line)) {
    all += line;
    ++lines;
  }
  EXPECT_EQ(lines, 1) << all;
  EXPECT_EQ(all.rfind("kumite-motion: warning: " + (dir / "giant.bvh").string() + ": unit_m: rest height 497", 0), 0u)
      << all;
}

// ---- The proposer on CMU subject 135 (PROVENANCE.md lists the strikes) -------------------------

TEST(AnnotationMocap, FrontKicks13504) {
  KUMITE_REQUIRE_MOCAP();
  expect_strikes("cmu/135_04", Semantics::kick,
                 {{HitSegment::right_foot, 374}, {HitSegment::left_foot, 584}, {HitSegment::right_foot, 812}});
  EXPECT_TRUE(strikes_of(propose_annotations(mocap_clip("cmu/135_04"), "x"), Semantics::punch).empty());
}

TEST(AnnotationMocap, Roundhouse13507) {
  KUMITE_REQUIRE_MOCAP();
  expect_strikes("cmu/135_07", Semantics::kick,
                 {{HitSegment::right_foot, 118}, {HitSegment::left_foot, 442}, {HitSegment::right_foot, 772},
                  {HitSegment::left_foot, 1126}});
  EXPECT_TRUE(strikes_of(propose_annotations(mocap_clip("cmu/135_07"), "x"), Semantics::punch).empty());
}

TEST(AnnotationMocap, SideKicks13511) {
  KUMITE_REQUIRE_MOCAP();
  // "The arms extend during the kicks; ignore hand peaks there": no punches may be reported.
  expect_strikes("cmu/135_11", Semantics::kick,
                 {{HitSegment::right_foot, 348}, {HitSegment::right_foot, 608}, {HitSegment::right_foot, 884},
                  {HitSegment::left_foot, 1310}, {HitSegment::left_foot, 1578}, {HitSegment::left_foot, 1850},
                  {HitSegment::left_foot, 2130}});
  EXPECT_TRUE(strikes_of(propose_annotations(mocap_clip("cmu/135_11"), "x"), Semantics::punch).empty());
}

TEST(AnnotationMocap, LungePunches13509) {
  KUMITE_REQUIRE_MOCAP();
  // The four stepping lunge punches, then (after about f1200) four punches while stepping
  // back: the body retreats, so the wrist stays under punch_min_speed (2.6..2.9 m/s) although
  // the arm straightens as fast and fully (extension 0.98..0.99): found as jabs.
  expect_strikes("cmu/135_09", Semantics::punch,
                 {{HitSegment::right_hand, 304}, {HitSegment::left_hand, 530}, {HitSegment::right_hand, 760},
                  {HitSegment::left_hand, 1000}, {HitSegment::right_hand, 1312}, {HitSegment::left_hand, 1525},
                  {HitSegment::right_hand, 1711}, {HitSegment::left_hand, 1899}},
                 4, 2.5, 4);  // the arm held out after a jab: its window may end a few frames after the hit
  EXPECT_TRUE(strikes_of(propose_annotations(mocap_clip("cmu/135_09"), "x"), Semantics::kick).empty());
}

TEST(AnnotationMocap, SlowStraightArmsAreJabs) {
  KUMITE_REQUIRE_MOCAP();
  const Clip& clip = mocap_clip("cmu/135_09");
  const auto jabs_in = [](const ClipAnnotation& a) {
    int n = 0;
    for (const auto* m : strikes_of(a, Semantics::punch)) {
      if (*m->hit_frame > 1200) {
        ++n;
        EXPECT_LT(m->peak_speed_mps, ProposerSettings{}.punch_min_speed) << *m->hit_frame;
        EXPECT_GE(m->extension, ProposerSettings{}.jab_min_extension) << *m->hit_frame;
        EXPECT_NE(m->note.find("jab"), std::string::npos) << m->note;
        EXPECT_EQ(m->height, StrikeHeight::mid) << *m->hit_frame;  // wrist at 0.72..0.74 of stature
      }
    }
    return n;
  };
  EXPECT_EQ(jabs_in(propose_annotations(clip, "x")), 4);
  // Without the extension-driven rule (only the speed rule) all four are missed.
  ProposerSettings no_jabs;
  no_jabs.jab_min_extension = 2.0;
  EXPECT_EQ(jabs_in(propose_annotations(clip, "x", no_jabs)), 0);
  // The boxer's punches are all fast; the rule adds nothing there (no arm swing or guard
  // straightens at jab speed), and its head punches are high.
  const ClipAnnotation boxer = propose_annotations(mocap_clip("assimp/Boxing_Toes"), "x");
  for (const auto* m : strikes_of(boxer, Semantics::punch)) {
    EXPECT_GE(m->peak_speed_mps, ProposerSettings{}.punch_min_speed) << *m->hit_frame;
    EXPECT_EQ(m->height, StrikeHeight::high) << *m->hit_frame;
  }
}

TEST(AnnotationMocap, ChamberedKicksAndHeights) {
  KUMITE_REQUIRE_MOCAP();
  // HDM05 bk 007/008: the knee rises first (the ankle's apex has a bent leg, extension 0.40),
  // the leg straightens lower: the hit is where it arrives straight, a low kick.
  for (const auto& [rel, hit] : {std::pair{"hdm05/HDM_bk_kickLFront1Reps_007_120", 199},
                                 std::pair{"hdm05/HDM_bk_kickLFront1Reps_008_120", 76}}) {
    const ClipAnnotation a = propose_annotations(mocap_clip(rel), "x");
    const auto kicks = strikes_of(a, Semantics::kick);
    ASSERT_EQ(kicks.size(), 1u) << rel;
    EXPECT_EQ(kicks[0]->hit_segment, HitSegment::left_foot);
    EXPECT_NEAR(*kicks[0]->hit_frame, hit, 3) << rel;
    EXPECT_GT(kicks[0]->extension, 0.95) << rel;
    EXPECT_EQ(kicks[0]->height, StrikeHeight::low) << rel;
  }
  // Roundhouse kicks at head height are high, front kicks to the chest mid.
  // (The annotations must outlive the pointers strikes_of returns into them.)
  const ClipAnnotation roundhouse = propose_annotations(mocap_clip("cmu/135_07"), "x");
  for (const auto* k : strikes_of(roundhouse, Semantics::kick)) EXPECT_EQ(k->height, StrikeHeight::high) << *k->hit_frame;
  const ClipAnnotation front = propose_annotations(mocap_clip("cmu/135_04"), "x");
  for (const auto* k : strikes_of(front, Semantics::kick)) EXPECT_EQ(k->height, StrikeHeight::mid) << *k->hit_frame;
}

TEST(AnnotationMocap, BlocksAreNotPunches) {
  KUMITE_REQUIRE_MOCAP();
  for (const char* rel : {"cmu/135_05", "cmu/135_10"}) {
    const ClipAnnotation a = propose_annotations(mocap_clip(rel), "x");
    EXPECT_TRUE(strikes_of(a, Semantics::punch).empty()) << rel;
    EXPECT_TRUE(strikes_of(a, Semantics::kick).empty()) << rel;
  }
  // The fast low blocks of 135_05 (L f364, R f570, L f830) are offered as blocks to review.
  const ClipAnnotation a = propose_annotations(mocap_clip("cmu/135_05"), "x");
  for (int peak : {364, 570, 830}) {
    bool found = false;
    for (const auto* b : strikes_of(a, Semantics::block)) found = found || (b->first_frame <= peak + 5 && b->last_frame >= peak - 60);
    EXPECT_TRUE(found) << "block near f" << peak;
  }
}

TEST(AnnotationMocap, BoxerPunchesOtherDialect) {
  KUMITE_REQUIRE_MOCAP();
  expect_strikes("assimp/Boxing_Toes", Semantics::punch,
                 {{HitSegment::left_hand, 578}, {HitSegment::left_hand, 926}, {HitSegment::right_hand, 349},
                  {HitSegment::right_hand, 547}, {HitSegment::right_hand, 651}, {HitSegment::right_hand, 997},
                  {HitSegment::right_hand, 1251}, {HitSegment::right_hand, 1421}});
}

TEST(AnnotationMocap, RestAndWalk) {
  KUMITE_REQUIRE_MOCAP();
  const ClipAnnotation still = propose_annotations(mocap_clip("cmu/135_08"), "x");
  ASSERT_EQ(still.motions.size(), 1u);
  EXPECT_EQ(still.motions[0].semantics, Semantics::rest);
  EXPECT_GE(still.motions[0].last_frame - still.motions[0].first_frame, 250);
  const ClipAnnotation walk = propose_annotations(mocap_clip("cmu/07_05"), "x");
  ASSERT_FALSE(walk.motions.empty());
  EXPECT_EQ(walk.motions[0].semantics, Semantics::walk);
  EXPECT_GE(walk.motions[0].last_frame - walk.motions[0].first_frame, 400);
  EXPECT_TRUE(strikes_of(walk, Semantics::kick).empty());
  EXPECT_TRUE(strikes_of(walk, Semantics::punch).empty());
  // Running strides lift the ankle fast but with a bent knee: not kicks.
  const ClipAnnotation run = propose_annotations(mocap_clip("cmu/09_06"), "x");
  EXPECT_TRUE(strikes_of(run, Semantics::kick).empty());
  EXPECT_TRUE(strikes_of(run, Semantics::punch).empty());
}

TEST(AnnotationMocap, AnnotateToolWritesAValidFile) {
  KUMITE_REQUIRE_MOCAP();
  const auto tool = std::filesystem::path(KUMITE_BINARY_DIR) / "bin" / "kumite-motion";
  if (!std::filesystem::exists(tool)) GTEST_SKIP() << "kumite-motion not built";
  const auto out = std::filesystem::path(KUMITE_BINARY_DIR) / "test_annotate" / "motions.toml";
  std::filesystem::create_directories(out.parent_path());
  std::filesystem::remove(out);
  const std::string cmd = tool.string() + " annotate " + (kumite::content::testing::mocap_dir() / "cmu" / "135_08.bvh").string() +
                          " --out " + out.string() + " > /dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const AnnotationSet set = read_annotations(out);
  ASSERT_EQ(set.clips.size(), 1u);
  EXPECT_EQ(set.clips[0].name, "135_08");
  EXPECT_EQ(load_annotated_clips(set).size(), 1u);  // the relative path resolves
  // A bad command line exits non-zero with one line.
  EXPECT_NE(std::system((tool.string() + " annotate /nonexistent.bvh --out /tmp/x.toml 2> /dev/null").c_str()), 0);
}

// ---- Other frame rates, units and dialects (synthetic variants of the real clips) --------------

namespace {

/// SYNTHETIC: every k-th frame of `c` (120 fps -> 120/k fps), written in metres with joints
/// renamed by `rename` (others kept), then read back through the BVH reader so unit
/// detection and dialect detection run as on a real file.
Clip variant(const Clip& c, int k, const std::map<std::string, std::string>& rename) {
  Clip d = c;
  d.frame_count = (c.frame_count + k - 1) / k;
  d.frame_time_s = c.frame_time_s * k;
  d.unit_m = 1.0;
  const auto n = static_cast<std::size_t>(c.skeleton.joint_count());
  d.root_positions.clear();
  d.local_rotations.clear();
  for (int f = 0; f < c.frame_count; f += k) {
    d.root_positions.push_back(c.root_positions[static_cast<std::size_t>(f)]);
    for (std::size_t j = 0; j < n; ++j) d.local_rotations.push_back(c.local_rotations[static_cast<std::size_t>(f) * n + j]);
  }
  for (auto& name : d.skeleton.names) {
    if (auto it = rename.find(name); it != rename.end()) name = it->second;
  }
  return parse_bvh(format_bvh(d), c.name + ".bvh");
}

const std::map<std::string, std::string> kBandaiNames = {
    {"root", "Hips"}, {"upperback", "Spine"}, {"thorax", "Chest"}, {"lowerneck", "Neck"}, {"head", "Head"},
    {"lclavicle", "Shoulder_L"}, {"lhumerus", "UpperArm_L"}, {"lradius", "LowerArm_L"}, {"lwrist", "Hand_L"},
    {"rclavicle", "Shoulder_R"}, {"rhumerus", "UpperArm_R"}, {"rradius", "LowerArm_R"}, {"rwrist", "Hand_R"},
    {"lfemur", "UpperLeg_L"}, {"ltibia", "LowerLeg_L"}, {"lfoot", "Foot_L"}, {"ltoes", "Toes_L"},
    {"rfemur", "UpperLeg_R"}, {"rtibia", "LowerLeg_R"}, {"rfoot", "Foot_R"}, {"rtoes", "Toes_R"},
    {"lhand", "Palm_L"}, {"rhand", "Palm_R"}, {"lfingers", "Fingers_L"}, {"rfingers", "Fingers_R"},
    {"lthumb", "Thumb_L"}, {"rthumb", "Thumb_R"}, {"lhipjoint", "Pelvis_L"}, {"rhipjoint", "Pelvis_R"},
    {"lowerback", "Waist"}, {"upperneck", "Neck1"}};

}  // namespace

TEST(AnnotationMocap, ThirtyFpsMetresOtherNames) {
  KUMITE_REQUIRE_MOCAP();
  const Clip kicks = variant(mocap_clip("cmu/135_04"), 4, kBandaiNames);
  EXPECT_DOUBLE_EQ(kicks.unit_m, 1.0);
  EXPECT_NEAR(kicks.frame_rate_hz(), 30.0, 1e-3);
  EXPECT_EQ(kicks.skeleton.dialect, "bandai_namco");
  const ClipAnnotation a = propose_annotations(kicks, "x");
  const auto found = strikes_of(a, Semantics::kick);
  ASSERT_EQ(found.size(), 3u);
  const std::pair<HitSegment, int> listed[] = {{HitSegment::right_foot, 374}, {HitSegment::left_foot, 584},
                                               {HitSegment::right_foot, 812}};
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(found[i]->hit_segment, listed[i].first);
    EXPECT_NEAR(*found[i]->hit_frame * 4, listed[i].second, 8);  // within 2 frames at 30 fps
  }
  const Clip punches = variant(mocap_clip("cmu/135_09"), 4, {});
  const ClipAnnotation pa = propose_annotations(punches, "x");
  const auto p = strikes_of(pa, Semantics::punch);
  ASSERT_EQ(p.size(), 8u);
  const int peaks[] = {304, 530, 760, 1000, 1312, 1525, 1711, 1899};
  for (std::size_t i = 0; i < 8; ++i) EXPECT_NEAR(*p[i]->hit_frame * 4, peaks[i], 12) << i;
}

// ---- A stated unit (unit_m) ------------------------------------------------------------------

namespace {
/// SYNTHETIC: the shipped 135_03 (stance steps, cm), its actor made 12 % taller (1.78 m: every
/// offset and root position scaled).
Clip scaled_original() {
  Clip c = read_bvh(kumite::content::testing::source_dir() / "content" / "motions" / "135_03.bvh");
  for (auto& o : c.skeleton.offsets) o *= 1.12;
  for (auto& p : c.root_positions) p *= 1.12;
  return c;
}
/// SYNTHETIC: scaled_original() re-exported as some studios export: every
/// joint's frame turned so that its bone to its first child lies along its local +X (the
/// right side's along -X, as a mirrored rig has it), offsets and rotations re-expressed so
/// that every frame's joint positions are the clip's own. Its rest pose (all rotations zero)
/// is no standing body: each chain lies along a line, left arm and leg out along +X, right
/// along -X: 2.57 m from the right toes to the left fingers, no human's size in any unit.
Clip along_local_x() {
  const Clip c = scaled_original();
  const Skeleton& s = c.skeleton;
  const auto n = static_cast<std::size_t>(s.joint_count());
  std::vector<Eigen::Quaterniond> a(n, Eigen::Quaterniond::Identity());  // new frame = old frame * a[j]
  for (std::size_t j = 0; j < n; ++j) {
    for (std::size_t k = j + 1; k < n; ++k) {
      if (s.parents[k] != static_cast<int>(j) || s.offsets[k].norm() < 1e-9) continue;
      const bool right = s.names[j] != "root" && s.names[j].front() == 'r';  // CMU: rfemur, rhumerus, ...
      const double side = right ? -1.0 : 1.0;
      a[j] = Eigen::Quaterniond::FromTwoVectors(side * Eigen::Vector3d::UnitX(), s.offsets[k].normalized());
      break;
    }
  }
  Clip x = c;
  for (std::size_t j = 1; j < n; ++j)
    x.skeleton.offsets[j] = a[static_cast<std::size_t>(s.parents[j])].conjugate() * s.offsets[j];
  for (int f = 0; f < c.frame_count; ++f) {
    for (std::size_t j = 0; j < n; ++j) {
      const std::size_t i = static_cast<std::size_t>(f) * n + j;
      const Eigen::Quaterniond parent = s.parents[j] < 0 ? Eigen::Quaterniond::Identity() : a[static_cast<std::size_t>(s.parents[j])];
      x.local_rotations[i] = (parent.conjugate() * c.local_rotations[i] * a[j]).normalized();
    }
  }
  return x;
}
}  // namespace

TEST(Annotation, StatedUnitImportsAClipWhoseRestPoseIsNoBody) {
  const Clip original = scaled_original();
  const Clip x = along_local_x();
  const auto dir = std::filesystem::path(KUMITE_BINARY_DIR) / "test_unit_m";
  std::filesystem::create_directories(dir);
  write_bvh(dir / "walk_x.bvh", x);  // centimetres, as 135_03
  const std::string clip = "version = 1\n\n[[clip]]\nfile = \"walk_x.bvh\"\n";
  const std::string walk = "\n[[clip.motion]]\nname = \"step\"\nsemantics = \"walk\"\nframes = [113, 238]\n";
  // Without a stated unit: refused, in one line naming the file, line and key, and what to do.
  try {
    load_annotated_clips(parse_annotations(clip + walk, (dir / "motions.toml").string()));
    FAIL() << "a clip whose rest pose is no body's was loaded with a guessed unit";
  } catch (const kumite::Error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind((dir / "motions.toml").string() + ":3: clip[0].file: refused: ", 0), 0u) << what;
    EXPECT_NE(what.find("not a human's"), std::string::npos) << what;
    EXPECT_NE(what.find("unit_m"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
  // With unit_m = 0.01 (centimetres): loaded, every joint where the original has it.
  const AnnotationSet set = parse_annotations(clip + "unit_m = 0.01\n" + walk, (dir / "motions.toml").string());
  ASSERT_TRUE(set.clips[0].unit_m.has_value());
  const std::vector<Clip> clips = load_annotated_clips(set);
  ASSERT_EQ(clips.size(), 1u);
  EXPECT_DOUBLE_EQ(clips[0].unit_m, 0.01);
  EXPECT_FALSE(clips[0].skeleton.dialect.empty());
  ASSERT_EQ(clips[0].frame_count, original.frame_count);
  const auto p = all_joint_positions(clips[0]), q = all_joint_positions(original);
  ASSERT_EQ(p.size(), q.size());
  double worst = 0;
  for (std::size_t i = 0; i < p.size(); ++i) worst = std::max(worst, (p[i] - q[i]).norm());
  EXPECT_LT(worst, 1e-5) << "m: the re-exported clip's joints against the original's";
  // Into a database beside the clip it came from (first: the actor, whose rest pose stands): the
  // same walk, frame for frame, though its rest pose is no body (measured on its first frame).
  write_bvh(dir / "walk.bvh", original);
  const AnnotationSet both = parse_annotations(
      "version = 1\n\n[[clip]]\nfile = \"walk.bvh\"\n\n[[clip.motion]]\nname = \"o\"\nsemantics = \"walk\"\n"
      "frames = [113, 238]\n\n[[clip]]\nfile = \"walk_x.bvh\"\nunit_m = 0.01\n\n[[clip.motion]]\nname = \"x\"\n"
      "semantics = \"walk\"\nframes = [113, 238]\n",
      (dir / "both.toml").string());
  const std::vector<Clip> both_clips = load_annotated_clips(both);
  const Database db = build_database(segment_sources(both, both_clips), BuildOptions{});
  const auto seg = [&](const std::string& name) -> const MotionSegment& {
    for (const auto& sg : db.segments)
      if (sg.name == name) return sg;
    throw std::runtime_error("no segment " + name);
  };
  const MotionSegment& o = seg("o");
  const MotionSegment& xs = seg("x");
  ASSERT_EQ(o.frames.size(), xs.frames.size());
  double worst_mkm = 0;
  for (std::size_t f = 0; f < o.frames.size(); ++f) {
    const MkmFrame &a = o.frames[f], &b = xs.frames[f];
    worst_mkm = std::max({worst_mkm, std::abs(a.root_height_n - b.root_height_n), (a.root_xz_m - b.root_xz_m).norm()});
    for (int sd = 0; sd < 2; ++sd) {
      worst_mkm = std::max({worst_mkm, (a.leg_n[sd] - b.leg_n[sd]).norm(), (a.arm_n[sd] - b.arm_n[sd]).norm(),
                            (a.foot_dir[sd] - b.foot_dir[sd]).norm()});
      EXPECT_EQ(a.planted[sd], b.planted[sd]) << "frame " << f;
    }
  }
  EXPECT_LT(worst_mkm, 1e-4) << "the walk re-exported along local X against the original, in the database";
  // ...but not as the database's actor: measured on its rest pose, a line, it is refused.
  const AnnotationSet x_first = parse_annotations(clip + "unit_m = 0.01\n" + walk, (dir / "motions.toml").string());
  try {
    build_database(segment_sources(x_first, load_annotated_clips(x_first)), BuildOptions{});
    FAIL() << "an actor whose rest pose is no body was accepted";
  } catch (const kumite::Error& e) {
    EXPECT_NE(std::string(e.what()).find("rest pose is no standing body"), std::string::npos) << e.what();
  }
  // A stated unit that is wrong is taken as stated (it is the annotator's word): metres here.
  const std::vector<Clip> in_m = load_annotated_clips(parse_annotations(clip + "unit_m = 1.0\n" + walk, (dir / "motions.toml").string()));
  EXPECT_DOUBLE_EQ(in_m[0].unit_m, 1.0);
}

TEST(Annotation, StatedUnitIsCheckedAndWrittenBack) {
  const std::string head = "version = 1\n[[clip]]\nfile = \"a.bvh\"\n";
  const auto error_of = [&](const std::string& value) -> std::string {
    try {
      parse_annotations(head + "unit_m = " + value + "\n", "motions.toml");
    } catch (const kumite::Error& e) {
      return e.what();
    }
    return "";
  };
  for (const std::string bad : {"0", "-0.01", "0.00001", "11", "1e300"}) {
    const std::string e = error_of(bad);
    EXPECT_EQ(e.rfind("motions.toml:4: clip[0].unit_m: must be in [0.0001, 10] m per file unit, found ", 0), 0u) << bad << ": " << e;
  }
  for (const std::string bad : {"nan", "inf", "-inf"}) EXPECT_EQ(error_of(bad), "motions.toml:4: clip[0].unit_m: must be a finite number") << bad;
  EXPECT_EQ(error_of("\"cm\""), "motions.toml:4: clip[0].unit_m: must be a number");
  // In range: read, written back, read again the same.
  for (const double ok : {0.0001, 0.001, 0.01, 0.0254, 0.0254 / 0.45, 1.0, 10.0}) {
    const AnnotationSet set = parse_annotations(head + fmt::format("unit_m = {}\n", ok), "motions.toml");
    ASSERT_TRUE(set.clips[0].unit_m.has_value());
    EXPECT_EQ(*set.clips[0].unit_m, ok);
    const AnnotationSet again = parse_annotations(format_annotations(set), "again.toml");
    ASSERT_TRUE(again.clips[0].unit_m.has_value());
    EXPECT_EQ(*again.clips[0].unit_m, ok);
    EXPECT_EQ(format_annotations(again), format_annotations(set));
  }
  EXPECT_FALSE(parse_annotations(head, "motions.toml").clips[0].unit_m.has_value());
  EXPECT_EQ(format_annotations(parse_annotations(head, "motions.toml")).find("\nunit_m"), std::string::npos);
}
