// DTrack ASCII parsing: verbatim packets as DTrack sent them, and malformed ones.
//
// The verbatim packets (ART's programmer's guide is a PDF the project could not read; these
// are DTrack's own output as printed in public sources):
//  - kCapturedA: "an actual frame sample" in the comment of a DTrack reader for InstantReality
//    (readARTHead.cpp, written from "DTrack2_User-Manual.v2.13.pdf", Appendix B);
//  - kCapturedB: a packet a DTrack user replays from a C string (6dcal, an untracked Flystick
//    with 8 buttons and 3 controllers, 6dmt2, 6dmtr, gl, glcal, a trailing NUL);
//  - kUnityIssue3: the 6df2 line with an untracked Flystick and an empty block that broke
//    ART's Unity plugin (ar-tracking/UnityDTrackPlugin#3; "] [" between the Flysticks).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "kumite/tracking/interop.hpp"

using namespace kumite::tracking;

namespace {

const std::string kCapturedA =
    "fr 24981717\n"
    "6d 1 [0 1.000][-475.292 -567.632 -53.704 135.5743 5.7618 -3.3069][0.993291 0.111352 0.031199 0.057393 -0.708916 "
    "0.702954 0.100393 -0.696447 -0.710551]\n"
    "6df2 1 1 [0 1.000 6 2][-48.603 -122.146 -389.220][0.175884 0.118374 -0.977268 0.887803 0.409816 0.209422 0.425290 "
    "-0.904455 -0.033013][0 0.00 0.00]\n";

const std::string kCapturedB = std::string(
    "fr 3823\nts 44597.741924\n6dcal 1\n6df2 1 1 [0 -1.000 8 3][0.000 0.000 0.000][0.000000 0.000000 0.000000 0.000000 "
    "0.000000 0.000000 0.000000 0.000000 0.000000][0 0.00 0.00 0.00]\n6d 1 [0 1.000][84.203 37.681 172.102 99.1970 "
    "6.7130 9.6575][0.979069 0.086946 0.184021 -0.166608 -0.176923 0.970021 0.116897 -0.980377 -0.158734]\n3d 0\n6dmt2 "
    "1 1 [0 -1.000 1 0.000][1.500 2.500 3.500][0.888888 1.888888 2.888888 3.888888 4.888888 5.888888 6.888888 7.888888 "
    "8.888888][0][0.000e+00 0.000e+00 0.000e+00 0.000e+00 0.000e+00 0.000e+00]\n6dmtr 0 0\ngl 0 \nglcal 0 ") + '\0';

const std::string kUnityIssue3 =
    "6df2 2 2 [0 1.000 4 2][1157.327 437.914 653.582][0.160277 0.837277 0.522760 -0.986406 0.155321 0.053661 -0.036267 "
    "-0.524254 0.850789][0 0.00 0.00] [1 -1.000 0 0][0.000 0.000 0.000][0.000000 0.000000 0.000000 0.000000 0.000000 "
    "0.000000 0.000000 0.000000 0.000000][]";

std::string all_problems(const DtrackFrame& f) {
  std::string s;
  for (const auto& p : f.problems) s += p + "\n";
  return s;
}

bool has_problem(const DtrackFrame& f, const std::string& part) {
  return all_problems(f).find(part) != std::string::npos;
}

}  // namespace

TEST(DtrackParse, CapturedPacketWithA6dBodyAndA6df2Flystick) {
  const DtrackFrame f = parse_dtrack(kCapturedA);
  EXPECT_TRUE(f.ok()) << all_problems(f);
  EXPECT_TRUE(f.has_frame);
  EXPECT_EQ(f.frame, 24981717u);
  EXPECT_EQ(f.timestamp_s, -1);
  ASSERT_EQ(f.bodies.size(), 1u);
  const DtrackBody& b = f.bodies[0];
  EXPECT_EQ(b.id, 0);
  EXPECT_DOUBLE_EQ(b.quality, 1.0);
  EXPECT_TRUE(b.tracked());
  EXPECT_NEAR(b.position_m[0], -0.475292, 1e-12);  // mm -> m
  EXPECT_NEAR(b.position_m[1], -0.567632, 1e-12);
  EXPECT_NEAR(b.position_m[2], -0.053704, 1e-12);
  // Column-wise on the wire: b0 b1 b2 is the first COLUMN.
  EXPECT_DOUBLE_EQ(b.rotation[0], 0.993291);  // R00
  EXPECT_DOUBLE_EQ(b.rotation[3], 0.111352);  // R10
  EXPECT_DOUBLE_EQ(b.rotation[6], 0.031199);  // R20
  EXPECT_DOUBLE_EQ(b.rotation[1], 0.057393);  // R01
  EXPECT_DOUBLE_EQ(b.rotation[2], 0.100393);  // R02
  EXPECT_DOUBLE_EQ(b.rotation[8], -0.710551);
  ASSERT_EQ(f.flysticks.size(), 1u);
  const DtrackFlystick& fs = f.flysticks[0];
  EXPECT_EQ(fs.pose.id, 0);
  EXPECT_TRUE(fs.pose.tracked());
  EXPECT_EQ(fs.button_count, 6);
  EXPECT_EQ(fs.buttons, 0u);
  EXPECT_EQ(fs.joystick_count, 2);
  EXPECT_NEAR(fs.pose.position_m[2], -0.389220, 1e-12);
}

TEST(DtrackParse, CapturedPacketWithTimestampCalibratedCountAndLinesItSkips) {
  const DtrackFrame f = parse_dtrack(kCapturedB);
  EXPECT_TRUE(f.ok()) << all_problems(f);  // 6dmt2, 6dmtr, gl, glcal skipped; trailing NUL allowed
  EXPECT_EQ(f.frame, 3823u);
  EXPECT_DOUBLE_EQ(f.timestamp_s, 44597.741924);
  EXPECT_EQ(f.calibrated_bodies, 1);
  ASSERT_EQ(f.flysticks.size(), 1u);
  EXPECT_FALSE(f.flysticks[0].pose.tracked());
  EXPECT_EQ(f.flysticks[0].button_count, 8);
  EXPECT_EQ(f.flysticks[0].joystick_count, 3);
  // An untracked body's all-zero matrix is no rotation: the identity instead.
  EXPECT_EQ(f.flysticks[0].pose.rotation, (std::array<double, 9>{1, 0, 0, 0, 1, 0, 0, 0, 1}));
  ASSERT_EQ(f.bodies.size(), 1u);
  EXPECT_NEAR(f.bodies[0].position_m[0], 0.084203, 1e-12);
  EXPECT_TRUE(f.markers.empty());
}

TEST(DtrackParse, FlystickLineThatBrokeArtsUnityPlugin) {
  const DtrackFrame f = parse_dtrack("fr 1\n" + kUnityIssue3 + "\n");
  EXPECT_TRUE(f.ok()) << all_problems(f);
  ASSERT_EQ(f.flysticks.size(), 2u);
  EXPECT_TRUE(f.flysticks[0].pose.tracked());
  EXPECT_EQ(f.flysticks[0].button_count, 4);
  EXPECT_NEAR(f.flysticks[0].pose.position_m[0], 1.157327, 1e-12);
  EXPECT_FALSE(f.flysticks[1].pose.tracked());
  EXPECT_EQ(f.flysticks[1].pose.id, 1);
  EXPECT_EQ(f.flysticks[1].button_count, 0);
  EXPECT_EQ(f.flysticks[1].joystick_count, 0);
}

TEST(DtrackParse, EulerAnglesInTheLocationBlockMatchTheMatrixAsRxRyRz) {
  // Both captured 6d lines carry η θ φ after the position; R = Rx(η)·Ry(θ)·Rz(φ).
  const DtrackFrame a = parse_dtrack(kCapturedA);
  const DtrackFrame b = parse_dtrack(kCapturedB);
  ASSERT_EQ(a.bodies.size(), 1u);
  ASSERT_EQ(b.bodies.size(), 1u);
  const auto ea = dtrack_euler_deg(a.bodies[0].rotation);
  const auto eb = dtrack_euler_deg(b.bodies[0].rotation);
  EXPECT_NEAR(ea[0], 135.5743, 2e-3);
  EXPECT_NEAR(ea[1], 5.7618, 2e-3);
  EXPECT_NEAR(ea[2], -3.3069, 2e-3);
  EXPECT_NEAR(eb[0], 99.1970, 2e-3);
  EXPECT_NEAR(eb[1], 6.7130, 2e-3);
  EXPECT_NEAR(eb[2], 9.6575, 2e-3);
}

TEST(DtrackParse, LineEndingsAndDtrack1TrailingSpaces) {
  const std::string body =
      "6d 1 [3 0.500][10 20 30 0 0 0][1 0 0 0 1 0 0 0 1] ";  // DTrack1 writes a space after ']'
  for (const std::string eol : {"\n", "\r\n", "\r"}) {
    const DtrackFrame f = parse_dtrack("fr 7" + eol + "ts 1.5" + eol + body + eol + "3d 1 [5 1.0][1 2 3]" + eol);
    EXPECT_TRUE(f.ok()) << all_problems(f);
    ASSERT_EQ(f.bodies.size(), 1u);
    EXPECT_EQ(f.bodies[0].id, 3);
    EXPECT_NEAR(f.bodies[0].position_m[2], 0.030, 1e-12);
    ASSERT_EQ(f.markers.size(), 1u);
    EXPECT_EQ(f.markers[0].id, 5);
    EXPECT_NEAR(f.markers[0].position_m[1], 0.002, 1e-12);
  }
}

TEST(DtrackParse, Ts2WithAndWithoutLatencyAnd6dfButtons) {
  const DtrackFrame f = parse_dtrack(
      "fr 2\nts2 1764921600 250000 1800\n6dcal 3\n"
      "6df 1 [0 1.000 5][1 2 3 0 0 0][1 0 0 0 1 0 0 0 1]\n");
  EXPECT_TRUE(f.ok()) << all_problems(f);
  EXPECT_EQ(f.ts2_s, 1764921600);
  EXPECT_EQ(f.ts2_us, 250000);
  EXPECT_EQ(f.latency_us, 1800);
  EXPECT_EQ(f.calibrated_bodies, 2);  // 6dcal counts the 6df Flystick too (as the SDK does)
  ASSERT_EQ(f.flysticks.size(), 1u);
  EXPECT_EQ(f.flysticks[0].buttons, 5u);
  const DtrackFrame g = parse_dtrack("fr 3\nts2 1764921600 250000\n");
  EXPECT_TRUE(g.ok()) << all_problems(g);
  EXPECT_EQ(g.latency_us, -1);
}

TEST(DtrackParse, UntrackedBodiesAreKeptAsNotTracked) {
  const DtrackFrame f =
      parse_dtrack("fr 1\n6d 2 [0 -1.000][0 0 0 0 0 0][0 0 0 0 0 0 0 0 0][1 0.9][1 2 3][1 0 0 0 1 0 0 0 1]\n");
  EXPECT_TRUE(f.ok()) << all_problems(f);
  ASSERT_EQ(f.bodies.size(), 2u);
  EXPECT_FALSE(f.bodies[0].tracked());
  EXPECT_TRUE(f.bodies[1].tracked());
  EXPECT_EQ(f.body(1), &f.bodies[1]);
  EXPECT_EQ(f.body(2), nullptr);
}

// --- malformed ------------------------------------------------------------------------------

TEST(DtrackParse, EveryCutOfACapturedPacketIsSaidOrParsedNeverACrash) {
  DtrackFrame f;
  for (std::size_t n = 0; n <= kCapturedA.size(); ++n) {
    parse_dtrack(std::string_view(kCapturedA).substr(0, n), f);
    const std::string_view cut = std::string_view(kCapturedA).substr(0, n);
    // A cut at a line's end leaves whole lines: a valid packet of fewer lines.
    const bool at_line_end = n == 0 || cut.back() == '\n' || n == kCapturedA.size() || kCapturedA[n] == '\n';
    if (n == 0) {
      EXPECT_TRUE(has_problem(f, "empty packet"));
    } else if (!at_line_end && n > 12) {
      EXPECT_FALSE(f.ok()) << "cut at " << n << ": " << cut;
    }
  }
  parse_dtrack(kCapturedA.substr(0, kCapturedA.find("][0.993291") + 5), f);  // inside the 6d's matrix
  EXPECT_TRUE(has_problem(f, "packet:2: 6d[0]: cut short: a block '[' without its ']'")) << all_problems(f);
  EXPECT_TRUE(f.bodies.empty());
  EXPECT_TRUE(f.has_frame);  // the frame counter before the cut is kept
}

TEST(DtrackParse, NanAndInfAreRefusedNamingTheField) {
  const DtrackFrame f = parse_dtrack(
      "fr 1\n6d 2 [0 nan][1 2 3][1 0 0 0 1 0 0 0 1][1 1.0][1 inf 3][1 0 0 0 1 0 0 0 1]\n");
  EXPECT_TRUE(has_problem(f, "packet:2: 6d[0]: must be a finite number, found 'nan'")) << all_problems(f);
  EXPECT_TRUE(has_problem(f, "packet:2: 6d[1]: must be a finite number, found 'inf'")) << all_problems(f);
  EXPECT_TRUE(f.bodies.empty());
  EXPECT_EQ(f.problem_count, 2);
  const DtrackFrame g = parse_dtrack("fr 1\nts NaN\n");
  EXPECT_TRUE(has_problem(g, "packet:2: ts: ")) << all_problems(g);
  const DtrackFrame h = parse_dtrack("fr 1\n6d 1 [0 1.0][1e999 2 3][1 0 0 0 1 0 0 0 1]\n");
  EXPECT_TRUE(has_problem(h, "must be a finite number, found '1e999'")) << all_problems(h);
}

TEST(DtrackParse, MissingFieldsAndNotNumbers) {
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6d 1 [0 1.0][1 2][1 0 0 0 1 0 0 0 1]\n"),
                          "packet:2: 6d[0]: missing fields: 2 numbers, needs 3"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6d 1 [0 1.0][1 2 3][1 0 0 0 1 0 0 0]\n"),
                          "6d[0]: missing fields: 8 numbers, needs 9"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6d 1 [0][1 2 3][1 0 0 0 1 0 0 0 1]\n"), "6d[0]: missing fields: 1 number, needs 2"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr\n"), "packet:1: fr: missing the frame number"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 12x\n"), "packet:1: fr: must be an unsigned integer, found '12x'"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6d\n"), "packet:2: 6d: missing the count"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6d 1 [0 1.0][1,5 2 3][1 0 0 0 1 0 0 0 1]\n"), "not a number: '1,5'"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6d 1 (0 1.0)\n"), "6d[0]: expected '[', found '(0 1.0)'"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\nts2 5\n"), "ts2: missing fields"));
}

TEST(DtrackParse, CountsThatDoNotMatchTheBlocks) {
  const std::string one = "[0 1.0][1 2 3][1 0 0 0 1 0 0 0 1]";
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6d 2 " + one + "\n"), "packet:2: 6d: cut short: 2 announced, 1 found"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6d 1 " + one + "[1 1.0]\n"), "6d: more data than its count of 1 announces"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6d -1\n"), "6d: must be in [0, 256], found -1"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6d 100000\n"), "6d: must be in [0, 256], found 100000"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n3d 2000\n"), "3d: must be in [0, 1024], found 2000"));
  // 6df2: more Flysticks than defined; a controller count past 8; its extra block too short.
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6df2 1 2\n"), "6df2: must be in [0, 1], found 2"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6df2 1 1 [0 1.0 2 9][1 2 3][1 0 0 0 1 0 0 0 1][0]\n"),
                          "6df2[0].joysticks: must be an integer in [0, 8], found 9"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6df2 1 1 [0 1.0 4 2][1 2 3][1 0 0 0 1 0 0 0 1][0 0.5]\n"),
                          "6df2[0]: missing fields: 2 numbers, needs 3"));
}

TEST(DtrackParse, IdsQualitiesPositionsAndRotationsOutOfRange) {
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6d 1 [300 1.0][1 2 3][1 0 0 0 1 0 0 0 1]\n"),
                          "6d[0].id: must be an integer in [0, 255], found 300"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6d 1 [1.5 1.0][1 2 3][1 0 0 0 1 0 0 0 1]\n"),
                          "6d[0].id: must be an integer in [0, 255], found 1.5"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6d 1 [0 7][1 2 3][1 0 0 0 1 0 0 0 1]\n"),
                          "6d[0].quality: must be in [-1, 1], found 7"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6d 1 [0 1][1 2e7 3][1 0 0 0 1 0 0 0 1]\n"),
                          "6d[0].position: must be within ±1000000 mm, found 20000000"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6d 1 [0 1][1 2 3][2 0 0 0 1 0 0 0 1]\n"),
                          "6d[0].rotation: not a rotation matrix"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\n6d 1 [0 1][1 2 3][-1 0 0 0 1 0 0 0 1]\n"),
                          "6d[0].rotation: not a rotation matrix"));  // a reflection (det -1)
  const DtrackFrame twice = parse_dtrack(
      "fr 1\n6d 2 [4 1][1 2 3][1 0 0 0 1 0 0 0 1][4 1][1 2 3][1 0 0 0 1 0 0 0 1]\n");
  EXPECT_TRUE(has_problem(twice, "6d[1].id: body 4 twice in the line"));
  EXPECT_EQ(twice.bodies.size(), 1u);
  // A body with a problem is left out; the others of the line are kept.
  const DtrackFrame mixed = parse_dtrack(
      "fr 1\n6d 2 [0 1][1 2 3][2 0 0 0 1 0 0 0 1][1 1][4 5 6][1 0 0 0 1 0 0 0 1]\n");
  ASSERT_EQ(mixed.bodies.size(), 1u);
  EXPECT_EQ(mixed.bodies[0].id, 1);
}

TEST(DtrackParse, OversizedEmptyAndOtherProtocols) {
  EXPECT_TRUE(has_problem(parse_dtrack(std::string(70000, ' ')), "packet: 70000 bytes, more than a UDP datagram"));
  EXPECT_TRUE(has_problem(parse_dtrack(""), "packet: empty packet"));
  EXPECT_TRUE(has_problem(parse_dtrack(std::string("\0\0", 2)), "packet: empty packet"));
  // An OSC bundle (binary) and an OSC message.
  const std::string bundle("#bundle\0\0\0\0\0\0\0\0\1", 16);
  EXPECT_TRUE(has_problem(parse_dtrack(bundle), "packet: not DTrack ASCII: byte 0x00 at offset 7 (an OSC packet?)"));
  const std::string message("/rigidbody/1/transformation\0,fffffff\0", 37);
  EXPECT_TRUE(has_problem(parse_dtrack(message), "(an OSC packet?)"));
  EXPECT_TRUE(has_problem(parse_dtrack("{\"frame\": 1}"), "packet:1: not a DTrack line: '{\"frame\": 1}'"));
  EXPECT_TRUE(has_problem(parse_dtrack("\xc3\xa9t\xc3\xa9"), "not DTrack ASCII: byte 0xc3 at offset 0"));
  EXPECT_TRUE(has_problem(parse_dtrack("6d 0\n"), "packet: fr: no frame counter line (fr) in the packet"));
  EXPECT_TRUE(has_problem(parse_dtrack("fr 1\nfr 2\n"), "packet:2: fr: a second such line in the packet (ignored)"));
}

TEST(DtrackParse, ParsingAgainKeepsTheCapacity) {
  DtrackFrame f;
  parse_dtrack(kCapturedA, f);
  const auto* data = f.bodies.data();
  const auto cap = f.bodies.capacity();
  for (int i = 0; i < 100; ++i) parse_dtrack(kCapturedA, f);
  EXPECT_EQ(f.bodies.data(), data);
  EXPECT_EQ(f.bodies.capacity(), cap);
  EXPECT_EQ(f.bodies.size(), 1u);
}

TEST(DtrackParse, ProblemsKeptAreCappedButCounted) {
  std::string p = "fr 1\n6d 40";
  for (int i = 0; i < 40; ++i) p += " [" + std::to_string(i) + " nan][1 2 3][1 0 0 0 1 0 0 0 1]";
  const DtrackFrame f = parse_dtrack(p);
  EXPECT_EQ(f.problem_count, 40);
  EXPECT_EQ(f.problems.size(), 16u);
}
