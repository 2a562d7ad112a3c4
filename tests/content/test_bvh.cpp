#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "kumite/common/error.hpp"
#include "kumite/content/bvh.hpp"
#include "mocap_data.hpp"

using namespace kumite::content;
using kumite::content::testing::mocap_clip;

namespace {

/// Largest distance (m) between the joint positions of two clips over every `step`-th frame.
double max_position_difference(const Clip& a, const Clip& b, int step = 1) {
  EXPECT_EQ(a.frame_count, b.frame_count);
  EXPECT_EQ(a.skeleton.joint_count(), b.skeleton.joint_count());
  const auto n = static_cast<std::size_t>(a.skeleton.joint_count());
  std::vector<Eigen::Vector3d> pa(n), pb(n);
  std::vector<Eigen::Quaterniond> ra(n), rb(n);
  double worst = 0;
  for (int f = 0; f < a.frame_count; f += step) {
    forward_kinematics(a, f, pa, ra);
    forward_kinematics(b, f, pb, rb);
    for (std::size_t j = 0; j < n; ++j) worst = std::max(worst, (pa[j] - pb[j]).norm());
  }
  return worst;
}

std::vector<Eigen::Vector3d> frame_positions(const Clip& c, int f) {
  std::vector<Eigen::Vector3d> p(static_cast<std::size_t>(c.skeleton.joint_count()));
  std::vector<Eigen::Quaterniond> r(p.size());
  forward_kinematics(c, f, p, r);
  return p;
}

std::string error_of(std::string_view text) {
  try {
    parse_bvh(text, "bad.bvh");
  } catch (const kumite::Error& e) {
    EXPECT_EQ(e.component(), "bvh");
    return e.what();
  }
  return "(no error)";
}

// A two-bone arm: root (6 ch) -> upper (3 ch, order given) -> lower -> End Site.
std::string arm_bvh(std::string_view order, std::string_view frame, std::string_view eol = "\n") {
  std::string o(order);
  std::string ch;
  for (char c : o) ch += std::string(" ") + static_cast<char>(std::toupper(c)) + "rotation";
  std::string s = "HIERARCHY\nROOT root\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition" + ch +
                  "\n  JOINT upper\n  {\n    OFFSET 0 10 0\n    CHANNELS 3" + ch +
                  "\n    JOINT lower\n    {\n      OFFSET 20 0 0\n      CHANNELS 3" + ch +
                  "\n      End Site\n      {\n        OFFSET 0 -30 0\n      }\n    }\n  }\n}\n"
                  "MOTION\nFrames: 1\nFrame Time: 0.0333333\n" + std::string(frame) + "\n";
  if (eol != "\n") {
    std::string crlf;
    for (char c : s) {
      if (c == '\n') crlf += eol;
      else crlf += c;
    }
    return crlf;
  }
  return s;
}

}  // namespace

TEST(Bvh, EulerOrderFollowsChannelOrder) {
  // Rotations listed "Z X Y" compose as Rz * Rx * Ry (the first channel is outermost).
  // Upper joint: Z 90 then X 90. Bone (20,0,0) -> Rx keeps it -> Rz turns it to (0,20,0).
  // If the order were X then Z it would become Rx(Rz(20,0,0)) = Rx(0,20,0) = (0,0,20).
  const Clip zx = parse_bvh(arm_bvh("zxy", "0 0 0 0 0 0  90 90 0  0 0 0"), "zx.bvh");
  EXPECT_NEAR(zx.frame_time_s, 1 / 30.0, 1e-6);
  ASSERT_EQ(zx.skeleton.joint_count(), 4);  // root, upper, lower, lower_end
  EXPECT_TRUE(zx.skeleton.end_site[3]);
  EXPECT_EQ(zx.skeleton.names[3], "lower_end");
  EXPECT_EQ(zx.skeleton.channels[1], "zxy");
  EXPECT_DOUBLE_EQ(zx.unit_m, 0.01);  // extent 50 units -> centimetres
  auto p = frame_positions(zx, 0);
  EXPECT_TRUE(p[2].isApprox(Eigen::Vector3d(0, 0.10 + 0.20, 0), 1e-9)) << p[2].transpose();
  const Clip xz = parse_bvh(arm_bvh("xzy", "0 0 0 0 0 0  90 90 0  0 0 0"), "xz.bvh");
  p = frame_positions(xz, 0);
  EXPECT_TRUE(p[2].isApprox(Eigen::Vector3d(0, 0.10, 0.20), 1e-9)) << p[2].transpose();
}

TEST(Bvh, CrlfTabsAndPositionOfRoot) {
  std::string text = arm_bvh("zyx", "1\t2\t3\t0 0 0 0 0 0 0 0 0", "\r\n");
  const Clip c = parse_bvh(text, "crlf.bvh");
  EXPECT_TRUE(c.root_positions[0].isApprox(Eigen::Vector3d(0.01, 0.02, 0.03)));
  const auto p = frame_positions(c, 0);
  EXPECT_TRUE(p[3].isApprox(Eigen::Vector3d(0.21, 0.02 + 0.10 - 0.30, 0.03), 1e-9)) << p[3].transpose();
}

TEST(Bvh, MetresDetectedAndExplicitUnit) {
  const std::string text =
      "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Yrotation Xrotation Zrotation\n"
      "JOINT Spine\n{\nOFFSET 0 0.5 0\nCHANNELS 3 Yrotation Xrotation Zrotation\nEnd Site\n{\nOFFSET 0 0.7 0\n}\n}\n}\n"
      "MOTION\nFrames: 2\nFrame Time: 0.01\n0 0.9 0 0 0 0 0 0 0\n0 1.0 0 0 0 0 0 0 0\n";
  const Clip m = parse_bvh(text, "m.bvh");
  EXPECT_DOUBLE_EQ(m.unit_m, 1.0);
  EXPECT_NEAR(frame_positions(m, 1)[2].y(), 1.0 + 0.5 + 0.7, 1e-12);
  const Clip forced = parse_bvh(text, "m.bvh", {.unit_m = 0.01});
  EXPECT_NEAR(frame_positions(forced, 1)[2].y(), 0.022, 1e-12);
  // Humanoids: the unit giving a plausible body (CMU ASF units as in the cgspeed release).
  EXPECT_EQ(guess_bvh_unit_m(160, true), 0.01);
  EXPECT_EQ(guess_bvh_unit_m(95, true), 0.01);
  EXPECT_EQ(guess_bvh_unit_m(1.62, true), 1.0);
  EXPECT_EQ(guess_bvh_unit_m(1750, true), 0.001);
  EXPECT_EQ(guess_bvh_unit_m(66, true), 0.0254);
  EXPECT_DOUBLE_EQ(guess_bvh_unit_m(28, true), 0.0254 / 0.45);
  EXPECT_EQ(guess_bvh_unit_m(1.7), 1.0);
  EXPECT_EQ(guess_bvh_unit_m(170), 0.01);
  EXPECT_EQ(guess_bvh_unit_m(1700), 0.001);
}

TEST(Bvh, InnerPositionChannelsReplaceTheOffset) {
  // Every joint has 6 channels (as some exporters write). Constant ones fold into offsets;
  // a moving one is kept per frame.
  const std::string head =
      "HIERARCHY\nROOT root\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n"
      "JOINT a\n{\nOFFSET 0 99 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n"
      "End Site\n{\nOFFSET 0 50 0\n}\n}\n}\nMOTION\nFrames: 2\nFrame Time: 0.0083333\n";
  const Clip constant = parse_bvh(head + "0 90 0 0 0 0  0 40 0 0 0 0\n0 90 0 0 0 0  0 40 0 0 0 0\n", "c.bvh");
  EXPECT_TRUE(constant.local_translations.empty());
  EXPECT_NEAR(constant.skeleton.offsets[1].y(), 0.40, 1e-12);
  EXPECT_NEAR(frame_positions(constant, 1)[2].y(), 0.90 + 0.40 + 0.50, 1e-12);
  const Clip moving = parse_bvh(head + "0 90 0 0 0 0  0 40 0 0 0 0\n0 90 0 0 0 0  10 45 0 0 0 0\n", "v.bvh");
  ASSERT_FALSE(moving.local_translations.empty());
  EXPECT_TRUE(frame_positions(moving, 1)[2].isApprox(Eigen::Vector3d(0.10, 0.90 + 0.45 + 0.50, 0), 1e-12));
  // Round trip keeps the moving translation.
  const Clip again = parse_bvh(format_bvh(moving), "again.bvh");
  EXPECT_LT(max_position_difference(moving, again), 1e-7);
}

TEST(Bvh, WrittenFileIsStandardAndKeepsChannelOrder) {
  const Clip c = parse_bvh(arm_bvh("zxy", "1 2 3 10 20 30 40 50 60 70 80 89"), "arm.bvh");
  const std::string text = format_bvh(c);
  EXPECT_EQ(text.rfind("HIERARCHY\nROOT root\n{\n", 0), 0u) << text;
  EXPECT_NE(text.find("CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"), std::string::npos);
  EXPECT_NE(text.find("\tJOINT upper\n"), std::string::npos);
  EXPECT_NE(text.find("End Site\n"), std::string::npos);
  EXPECT_NE(text.find("MOTION\nFrames: 1\nFrame Time: 0.0333333\n"), std::string::npos);
  const Clip back = parse_bvh(text, "arm2.bvh");
  EXPECT_EQ(back.skeleton.names, c.skeleton.names);
  EXPECT_EQ(back.skeleton.channels, c.skeleton.channels);
  EXPECT_LT(max_position_difference(c, back), 1e-7);
  // The written angles equal the read ones where the Euler solution is unique.
  EXPECT_NE(text.find("1.000000 2.000000 3.000000 10.000000 20.000000 30.000000"), std::string::npos) << text;
}

TEST(Bvh, EulerUnwrapKeepsCurvesContinuous) {
  // A joint spinning about Z by 10 degrees a frame: written angles must keep increasing
  // past 180 instead of jumping to -170.
  std::string text = "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Yrotation Xrotation\n"
                     "End Site\n{\nOFFSET 0 100 0\n}\n}\nMOTION\nFrames: 40\nFrame Time: 0.01\n";
  for (int f = 0; f < 40; ++f) text += std::to_string(f * 10) + " 0 0\n";
  const Clip c = parse_bvh(text, "spin.bvh");
  const Clip back = parse_bvh(format_bvh(c), "spin2.bvh");
  EXPECT_LT(max_position_difference(c, back), 1e-7);
  const std::string out = format_bvh(c);
  EXPECT_NE(out.find("\n390.000000 "), std::string::npos) << out.substr(out.size() - 200);
}

TEST(Bvh, BadInputGivesOneLineErrorWithFileAndLine) {
  const std::string good = arm_bvh("zyx", "0 0 0 0 0 0 0 0 0 0 0 0");
  struct Case { std::string text; std::string expect; };
  auto replace = [](std::string s, const std::string& from, const std::string& to) {
    const auto at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return s.replace(at, from.size(), to);
  };
  const std::vector<Case> cases = {
      {"", "bad.bvh:1: HIERARCHY: unexpected end of file, expected 'HIERARCHY'"},
      {"HIERARCHY\nROOT", "bad.bvh:2: "},
      {good.substr(0, good.size() / 2), "unexpected end of file"},
      {replace(good, "CHANNELS 3", "CHANNELS 4"), "bad.bvh:10: CHANNELS: CHANNELS 4 but 'JOINT'"},
      {replace(good, "CHANNELS 3", "CHANNELS 7"), "bad.bvh:9: CHANNELS: channel count must be 0..6"},
      {replace(good, "OFFSET 0 10 0", "OFFSET 0 nan 0"), "bad.bvh:8: OFFSET: value 'nan' is not finite"},
      {replace(good, "OFFSET 20 0 0", "OFFSET 20 0"), "bad.bvh:13: OFFSET: expected a number, found 'CHANNELS'"},
      {replace(good, "Frame Time: 0.0333333", "Frame Time: 0"), "frame time must be > 0"},
      {replace(good, "Frame Time: 0.0333333", "Frame Time: -0.01"), "frame time must be > 0"},
      {replace(good, "Frames: 1", "Frames: 3"), "truncated: Frames: 3 but 1 frame line(s)"},
      {replace(good, "0 0 0 0 0 0 0 0 0 0 0 0", "0 0 0 0 0 0 0 0 0 0 0"), "bad.bvh:24: frame 0: 11 values, but"},
      {replace(good, "0 0 0 0 0 0 0 0 0 0 0 0", "0 0 0 0 0 0 0 0 0 0 0 inf"), "bad.bvh:24: frame 0: value 'inf' is not finite"},
      {replace(good, "0 0 0 0 0 0 0 0 0 0 0 0", "0 0 0 0 0 0 0 0 0 0 0 0 0"), "more than the 12 values"},
      {replace(good, "0 0 0 0 0 0 0 0 0 0 0 0", "0 0 0 0 0 0 0 0 0 0 0 x"), "expected a number, found 'x'"},
      {replace(good, "JOINT lower", "BONE lower"), "bad.bvh:10: HIERARCHY: unknown token 'BONE'"},
      {replace(good, "Zrotation", "Wrotation"), "bad.bvh:5: CHANNELS:"},
      {replace(good, "Yrotation Xrotation\n  JOINT", "Zrotation Xrotation\n  JOINT"), "appears twice"},
      {replace(good, "MOTION", "MOTOR"), "expected 'MOTION', found 'MOTOR'"},
      {replace(good, "Frames: 1", "Frames: -1"), "frame count must be a whole number"},
      {replace(good, "OFFSET 0 10 0", "OFFSET 0 1e300 0"), "out of range"},
  };
  for (const auto& c : cases) {
    const std::string msg = error_of(c.text);
    EXPECT_NE(msg.find(c.expect), std::string::npos) << "got: " << msg << "\nwanted: " << c.expect;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
}

TEST(Bvh, ExtraFrameLinesBeyondFramesAreIgnored) {
  // The assimp boxer declares 3069 frames and holds 3070 lines; readers take Frames: N.
  const std::string good = arm_bvh("zyx", "0 0 0 0 0 0 0 0 0 0 0 0");
  const Clip c = parse_bvh(good + "1 1 1 1 1 1 1 1 1 1 1 1\n", "extra.bvh");
  EXPECT_EQ(c.frame_count, 1);
  EXPECT_TRUE(c.root_positions[0].isZero());
}

TEST(Bvh, FramesAndTimeWithoutSpace) {
  std::string text = arm_bvh("zyx", "0 0 0 0 0 0 0 0 0 0 0 0");
  text.replace(text.find("Frames: 1"), 9, "Frames:1");
  text.replace(text.find("Time: 0.0333333"), 15, "Time:0.0333333");
  const Clip c = parse_bvh(text, "tight.bvh");
  EXPECT_EQ(c.frame_count, 1);
  EXPECT_NEAR(c.frame_time_s, 0.0333333, 1e-12);
}

TEST(Bvh, MissingFileNamesThePath) {
  try {
    read_bvh("/nonexistent/x.bvh");
    FAIL();
  } catch (const kumite::Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/x.bvh"), std::string::npos);
  }
  // A folder (a character's `bvh` set to content/characters) is said as one: it read as an
  // empty file ("HIERARCHY: unexpected end of file").
  const auto dir = std::filesystem::temp_directory_path();
  try {
    read_bvh(dir);
    FAIL();
  } catch (const kumite::Error& e) {
    EXPECT_EQ(std::string(e.what()), dir.string() + ": is a folder, not a file: give a .bvh file");
  }
}

// ---- The development set -----------------------------------------------------------------

TEST(BvhMocap, Cmu13504KnownValues) {
  KUMITE_REQUIRE_MOCAP();
  const Clip& c = mocap_clip("cmu/135_04");
  EXPECT_EQ(c.name, "135_04");
  EXPECT_EQ(c.frame_count, 1316);
  EXPECT_NEAR(c.frame_rate_hz(), 120.0, 1e-3);
  EXPECT_DOUBLE_EQ(c.unit_m, 0.01);
  EXPECT_EQ(c.skeleton.joint_count() - std::count(c.skeleton.end_site.begin(), c.skeleton.end_site.end(), true), 31);
  EXPECT_EQ(c.skeleton.channels[0], "XYZzyx");
  EXPECT_EQ(c.skeleton.channels[1], "zyx");
  // First motion line: "-14.0240 91.3971 -220.7520 ...".
  EXPECT_TRUE(c.root_positions[0].isApprox(Eigen::Vector3d(-0.140240, 0.913971, -2.207520), 1e-12));
  // ltibia offset "13.760619 -37.807020 0.000000" cm.
  EXPECT_TRUE(c.skeleton.offsets[static_cast<std::size_t>(c.skeleton.find("ltibia"))]
                  .isApprox(Eigen::Vector3d(0.13760619, -0.37807020, 0), 1e-12));
  // PROVENANCE: feet rest on y ~ 0 (lowest toe end site over the first frame within 3 cm).
  const auto p = frame_positions(c, 0);
  double lowest = 1e9;
  for (const auto& q : p) lowest = std::min(lowest, q.y());
  EXPECT_NEAR(lowest, 0.0, 0.05);
}

TEST(BvhMocap, UnitsDetectedOnRealSkeletons) {
  KUMITE_REQUIRE_MOCAP();
  // The CMU 135 clip written in metres, inches and CMU ASF units reads back as the same body.
  const Clip& c = mocap_clip("cmu/135_08");
  for (double unit : {1.0, 0.001, 0.0254, 0.0254 / 0.45}) {
    Clip u = c;
    u.unit_m = unit;
    const Clip back = parse_bvh(format_bvh(u), "u.bvh");
    EXPECT_DOUBLE_EQ(back.unit_m, unit);
    EXPECT_NEAR(back.root_positions[0].y(), c.root_positions[0].y(), 1e-5) << unit;
  }
}

TEST(BvhMocap, BoxerDialect) {
  KUMITE_REQUIRE_MOCAP();
  const Clip& c = mocap_clip("assimp/Boxing_Toes");
  EXPECT_EQ(c.frame_count, 3069);
  EXPECT_NEAR(c.frame_rate_hz(), 100.0, 1e-3);
  EXPECT_DOUBLE_EQ(c.unit_m, 0.01);
  EXPECT_EQ(c.skeleton.names[0], "Hips");
  EXPECT_EQ(c.skeleton.channels[0], "XYZzxy");
  EXPECT_EQ(c.skeleton.channels[1], "zxy");
}

// One test per file (ctest runs each in its own process; keeps each well under 10 s with ASan).
class BvhRoundTrip : public ::testing::TestWithParam<const char*> {};

TEST_P(BvhRoundTrip, WriteThenReadGivesTheSameJointPositions) {
  KUMITE_REQUIRE_MOCAP();
  const std::string rel = GetParam();
  const Clip& c = mocap_clip(rel);
  const Clip back = parse_bvh(format_bvh(c), rel + ".bvh");
  EXPECT_EQ(back.unit_m, c.unit_m);
  EXPECT_EQ(back.skeleton.channels, c.skeleton.channels);
  EXPECT_EQ(back.skeleton.names, c.skeleton.names);
  EXPECT_EQ(back.skeleton.dialect, c.skeleton.dialect);
  EXPECT_NEAR(back.frame_time_s, c.frame_time_s, 1e-9);
  // Positions agree to 1e-5 m (the writer keeps 6 decimals of cm and degrees).
  EXPECT_LT(max_position_difference(c, back, 3), 1e-5);
}

INSTANTIATE_TEST_SUITE_P(AllDialects, BvhRoundTrip,
                         ::testing::Values("cmu/07_05", "cmu/09_06", "cmu/135_03", "cmu/135_04", "cmu/135_05",
                                           "cmu/135_06", "cmu/135_07", "cmu/135_08", "cmu/135_09", "cmu/135_10",
                                           "cmu/135_11", "assimp/Boxing_Toes"),
                         [](const auto& param_info) {
                           std::string n = param_info.param;
                           for (char& ch : n) if (ch == '/') ch = '_';
                           return n;
                         });

TEST(BvhMocap, WriteBvhIsAtomicAndReadable) {
  KUMITE_REQUIRE_MOCAP();
  const Clip& c = mocap_clip("cmu/135_08");
  const auto path = std::filesystem::path(KUMITE_BINARY_DIR) / "test_bvh_135_08.bvh";
  write_bvh(path, c);
  const Clip back = read_bvh(path);
  EXPECT_EQ(back.name, "test_bvh_135_08");
  EXPECT_LT(max_position_difference(c, back), 1e-5);
  std::filesystem::remove(path);
}
