// Findings of the content fuzzers (issue 15), each kept as a regression seed in
// tests/content/fuzz/corpus_<fuzzer>/ and checked here.
#include <gtest/gtest.h>

#include <string>

#include "kumite/common/error.hpp"
#include "kumite/content/annotation.hpp"
#include "kumite/content/character.hpp"

using namespace kumite::content;

// fuzz_characters (regression-newline-in-notes.toml): a note with a newline escape ("\n")
// was written back raw inside "...", which the reader refuses: format_characters now
// escapes like format_annotations (newlines, other control characters and DEL).
TEST(FuzzRegressions, CharacterTextWithControlCharactersIsWrittenBackReadable) {
  const std::string text =
      "version = 1\n[[character]]\nname = \"kenji\"\ndisplay_name = \"Ken\\u007fji\"\nfile = \"kenji.bvh\"\n"
      "notes = \"bal\\nced\\tkarate\\u0001ka \\\"q\\\" \\\\\"\n";
  const CharacterCatalog c = parse_characters(text, "characters.toml");
  ASSERT_EQ(c.characters.size(), 1U);
  EXPECT_EQ(c.characters[0].notes, "bal\nced\tkarate\x01ka \"q\" \\");
  const std::string out = format_characters(c);
  const CharacterCatalog back = parse_characters(out, "characters-out.toml");
  ASSERT_EQ(back.characters.size(), 1U);
  EXPECT_EQ(back.characters[0].notes, c.characters[0].notes);
  EXPECT_EQ(back.characters[0].display_name, "Ken\x7f" "ji");
  EXPECT_EQ(format_characters(back), out);
}

// The same escaping serves motions.toml's notes (DEL was written raw before).
TEST(FuzzRegressions, AnnotationNotesWithDelAreWrittenBackReadable) {
  const std::string text =
      "version = 1\n[[clip]]\nfile = \"a.bvh\"\n[[clip.motion]]\nname = \"a_rest\"\nsemantics = \"rest\"\n"
      "frames = [0, 10]\nnote = \"x\\u007fy\\nz\"\n";
  const AnnotationSet s = parse_annotations(text, "motions.toml");
  const std::string out = format_annotations(s);
  const AnnotationSet back = parse_annotations(out, "motions-out.toml");
  ASSERT_EQ(back.clips.size(), 1U);
  ASSERT_EQ(back.clips[0].motions.size(), 1U);
  EXPECT_EQ(back.clips[0].motions[0].note, "x\x7fy\nz");
  EXPECT_EQ(format_annotations(back), out);
}

// fuzz_motions (corpus_fuzz_motions/regression-peak-speed-rounds-to-zero): peak_speed_mps =
// 0.004 was written "0.00", which reads back as no value, so writing what was read back gave
// another text: a value that rounds to zero is now left out the first time.
TEST(FuzzRegressions, AnnotationValuesThatRoundToZeroAreWrittenAsAFixedPoint) {
  for (const char* line : {"peak_speed_mps = 0.004\n", "extension = 0.0004\n", "peak_speed_mps = 0.005\n"}) {
    const std::string text = std::string("version = 1\n[[clip]]\nfile = \"a.bvh\"\n[[clip.motion]]\nname = \"a_rest\"\n"
                                         "semantics = \"rest\"\nframes = [0, 10]\n") + line;
    const std::string out = format_annotations(parse_annotations(text, "motions.toml"));
    EXPECT_EQ(format_annotations(parse_annotations(out, "motions-out.toml")), out) << line;
  }
}

// fuzz_motions (corpus_fuzz_motions/regression-extension-1e281): extension = 0.1e282 was
// read (only >= 0 was checked) and written back as a 282-digit literal, which the reader then
// refused. Both informational numbers are read within a range now, naming file, line and key.
TEST(FuzzRegressions, AnnotationSpeedsAndExtensionsOutOfAnyBodysRangeAreRefused) {
  const std::string head = "version = 1\n[[clip]]\nfile = \"a.bvh\"\n[[clip.motion]]\nname = \"a_rest\"\n"
                           "semantics = \"rest\"\nframes = [0, 10]\n";
  for (const char* line : {"extension = 0.1e282\n", "extension = 2.5\n", "peak_speed_mps = 1e300\n", "peak_speed_mps = 120\n"}) {
    try {
      (void)parse_annotations(head + line, "motions.toml");
      ADD_FAILURE() << "accepted " << line;
    } catch (const kumite::Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("motions.toml:8"), std::string::npos) << what;
      EXPECT_NE(what.find(std::string(line).substr(0, std::string(line).find(' '))), std::string::npos) << what;
    }
  }
  // In range: read, and written back as a fixed point.
  const std::string out = format_annotations(parse_annotations(head + "extension = 1.02\npeak_speed_mps = 14.5\n", "motions.toml"));
  EXPECT_NE(out.find("extension = 1.020\n"), std::string::npos) << out;
  EXPECT_EQ(format_annotations(parse_annotations(out, "motions-out.toml")), out);
}

// fuzz_characters (regression-scale-precision.toml): shoulder_width = 1.0001 was written as
// "1.000" (3 decimals), which reads back as 1.0 and is then left out: numbers are written with
// the digits that read back to the same value.
TEST(FuzzRegressions, CharacterScalesAreWrittenBackToTheSameValue) {
  const std::string text =
      "version = 1\n[[character]]\nname = \"k\"\ndisplay_name = \"K\"\nfile = \"k.bvh\"\nnotes = \"\"\n"
      "[character.generate]\nstature_m = 1.84\ndialect = \"motionbuilder\"\nshoulder_width = 1.0001\nforearm = 2\n";
  const CharacterCatalog c = parse_characters(text, "characters.toml");
  const std::string out = format_characters(c);
  EXPECT_NE(out.find("shoulder_width = 1.0001\n"), std::string::npos) << out;
  EXPECT_NE(out.find("forearm = 2.0\n"), std::string::npos) << out;
  EXPECT_NE(out.find("stature_m = 1.84\n"), std::string::npos) << out;
  EXPECT_EQ(format_characters(parse_characters(out, "characters-out.toml")), out);
}
