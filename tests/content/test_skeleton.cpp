#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include <limits>

#include "kumite/common/error.hpp"
#include "kumite/content/skeleton.hpp"

using namespace kumite::content;

TEST(CanonicalJoint, NamesRoundTrip) {
  for (std::size_t i = 0; i < kCanonicalJointCount; ++i) {
    const auto j = static_cast<CanonicalJoint>(i);
    ASSERT_EQ(canonical_joint_from_string(to_string(j)), j);
  }
  EXPECT_FALSE(canonical_joint_from_string("lhumerus"));
}

TEST(ForwardKinematics, ChainOfTwoBones) {
  // root -> a (0.5 m up) -> b (0.3 m along x); rotate root 90 deg about z.
  Skeleton s;
  s.names = {"root", "a", "b"};
  s.parents = {-1, 0, 1};
  s.offsets = {Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0.5, 0), Eigen::Vector3d(0.3, 0, 0)};
  s.end_site = {false, false, true};
  EXPECT_EQ(s.find("b"), 2);
  EXPECT_EQ(s.find("zz"), -1);
  const double half_pi = std::numbers::pi / 2;
  std::vector<Eigen::Quaterniond> local = {
      Eigen::Quaterniond(Eigen::AngleAxisd(half_pi, Eigen::Vector3d::UnitZ())),
      Eigen::Quaterniond::Identity(), Eigen::Quaterniond::Identity()};
  std::vector<Eigen::Vector3d> pos(3);
  std::vector<Eigen::Quaterniond> rot(3);
  forward_kinematics(s, Eigen::Vector3d(1, 0, 0), local, pos, rot);
  EXPECT_TRUE(pos[0].isApprox(Eigen::Vector3d(1, 0, 0)));
  EXPECT_TRUE(pos[1].isApprox(Eigen::Vector3d(0.5, 0, 0)));   // (0,0.5,0) rotated -> (-0.5,0,0)
  EXPECT_TRUE(pos[2].isApprox(Eigen::Vector3d(0.5, 0.3, 0)));  // (0.3,0,0) rotated -> (0,0.3,0)
}

// ---- resample_clip --------------------------------------------------------------------------

namespace {
/// SYNTHETIC: a two-joint chain at 120 fps whose child turns about Y at 90 deg/s and whose
/// root walks along +X at 1 m/s.
kumite::content::Clip turning_chain(int frames) {
  using namespace kumite::content;
  Clip c;
  c.name = "chain";
  c.skeleton.names = {"root", "arm"};
  c.skeleton.parents = {-1, 0};
  c.skeleton.offsets = {Eigen::Vector3d::Zero(), Eigen::Vector3d(0.5, 0, 0)};
  c.skeleton.end_site = {false, false};
  c.skeleton.canonical.fill(-1);
  c.frame_time_s = 1.0 / 120;
  c.frame_count = frames;
  for (int f = 0; f < frames; ++f) {
    const double t = f * c.frame_time_s;
    c.root_positions.emplace_back(t, 1.0, 0);
    c.local_rotations.push_back(Eigen::Quaterniond::Identity());
    c.local_rotations.emplace_back(Eigen::AngleAxisd(std::numbers::pi / 2 * t, Eigen::Vector3d::UnitY()));
  }
  return c;
}
}  // namespace

TEST(Skeleton, ResampleKeepsSourceFramesAndInterpolatesBetween) {
  using namespace kumite::content;
  const Clip c = turning_chain(121);  // 1 s
  // 30 fps: every fourth source frame, exactly.
  const Clip r30 = resample_clip(c, 1.0 / 30);
  ASSERT_EQ(r30.frame_count, 31);
  EXPECT_EQ(r30.frame_time_s, 1.0 / 30);
  for (int k = 0; k < r30.frame_count; ++k) {
    EXPECT_EQ(r30.root_positions[static_cast<std::size_t>(k)], c.root_positions[static_cast<std::size_t>(4 * k)]);
    EXPECT_TRUE(r30.rotations(k)[1].coeffs().isApprox(c.rotations(4 * k)[1].coeffs(), 1e-15));
  }
  // 80 fps: between source frames, the angle and the root where the motion has them at that time.
  const Clip r80 = resample_clip(c, 1.0 / 80);
  ASSERT_EQ(r80.frame_count, 81);
  for (int k = 0; k < r80.frame_count; ++k) {
    const double t = k / 80.0;
    EXPECT_NEAR(r80.root_positions[static_cast<std::size_t>(k)].x(), t, 1e-12);
    const Eigen::AngleAxisd aa(r80.rotations(k)[1]);
    EXPECT_NEAR(aa.angle(), std::numbers::pi / 2 * t, 1e-9) << k;
  }
  // The last new frame at or before the source's last: 0.5 s at 120 fps is 15 frames at 30 fps.
  EXPECT_EQ(resample_clip(turning_chain(61), 1.0 / 30).frame_count, 16);
  EXPECT_EQ(resample_clip(turning_chain(62), 1.0 / 30).frame_count, 16);
  for (const double bad : {0.0, -1.0 / 30, std::nan(""), std::numeric_limits<double>::infinity(), 11.0})
    EXPECT_THROW(resample_clip(c, bad), kumite::Error) << bad;
}
