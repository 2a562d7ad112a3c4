#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

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
