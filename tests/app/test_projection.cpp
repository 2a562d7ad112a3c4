// Kooima off-axis projection: the known answer from the issue, zero parallax on the wall
// plane, and the wall's corners onto the viewport's corners.
#include <gtest/gtest.h>

#include <glm/gtc/quaternion.hpp>

#include "kumite/app/projection.hpp"

using namespace kumite::app;

namespace {
glm::dvec3 ndc(const EyeView& v, const glm::dvec3& p) {
  const glm::dvec4 c = v.projection * v.view * glm::dvec4(p, 1.0);
  return glm::dvec3(c) / c.w;
}
const WallFrame kWall = wall_frame({-1.5, -0.75, -18}, {1.5, -0.75, -18}, {-1.5, 0.75, -18});
}  // namespace

TEST(Kooima, KnownAnswer) {
  const EyeView left = off_axis(kWall, {-1.25, 0, 0}, 1.0, 100.0);
  const EyeView right = off_axis(kWall, {1.25, 0, 0}, 1.0, 100.0);
  EXPECT_NEAR(left.frustum.left, -0.013889, 1e-6);
  EXPECT_NEAR(left.frustum.right, 0.152778, 1e-6);
  EXPECT_NEAR(left.frustum.bottom, -0.041667, 1e-6);
  EXPECT_NEAR(left.frustum.top, 0.041667, 1e-6);
  EXPECT_NEAR(right.frustum.left, -0.152778, 1e-6);
  EXPECT_NEAR(right.frustum.right, 0.013889, 1e-6);
  EXPECT_NEAR(right.frustum.bottom, -0.041667, 1e-6);
  EXPECT_NEAR(right.frustum.top, 0.041667, 1e-6);
  EXPECT_NEAR(ndc(left, {0, 0, -16}).x, 0.104167, 1e-6);
  EXPECT_NEAR(ndc(right, {0, 0, -16}).x, -0.104167, 1e-6);
}

TEST(Kooima, ZeroParallaxOnTheWallPlane) {
  const WallFrame front = wall_frame({-1.5, 0, -1.5}, {1.5, 0, -1.5}, {-1.5, 2.4, -1.5});
  const glm::dvec3 eyes[2] = {{-0.032 + 0.3, 1.62, 0.4}, {0.032 + 0.3, 1.65, 0.41}};
  const EyeView l = off_axis(front, eyes[0], 0.05, 50), r = off_axis(front, eyes[1], 0.05, 50);
  for (double u : {0.0, 0.13, 0.5, 0.91, 1.0})
    for (double v : {0.0, 0.27, 0.5, 1.0}) {
      const glm::dvec3 p = front.pa + u * (front.pb - front.pa) + v * (front.pc - front.pa);
      const glm::dvec3 a = ndc(l, p), b = ndc(r, p);
      EXPECT_NEAR(a.x, b.x, 1e-9);
      EXPECT_NEAR(a.y, b.y, 1e-9);
      // ... and it is where the wall puts it: NDC = 2*(u, v) - 1.
      EXPECT_NEAR(a.x, 2 * u - 1, 1e-9);
      EXPECT_NEAR(a.y, 2 * v - 1, 1e-9);
    }
  // A point in front of the wall (between wall and viewer) has crossed parallax: it appears
  // right of its wall projection for the left eye.
  const glm::dvec3 q{0.3, 1.5, -1.0};
  EXPECT_GT(ndc(l, q).x, ndc(r, q).x);
}

TEST(Kooima, CornersOntoViewportCornersForAnyWall) {
  // A side wall (left, facing +X) and a floor, seen from an off-centre eye.
  const WallFrame walls[] = {
      wall_frame({-1.5, 0, 1.5}, {-1.5, 0, -1.5}, {-1.5, 2.4, 1.5}),
      wall_frame({-1.5, 0, 1.5}, {1.5, 0, 1.5}, {-1.5, 0, -1.5}),
  };
  for (const auto& w : walls) {
    const EyeView v = off_axis(w, {0.2, 1.7, 0.3}, 0.05, 50);
    ASSERT_TRUE(v.valid);
    const glm::dvec3 pd = w.pb + (w.pc - w.pa);
    EXPECT_NEAR(ndc(v, w.pa).x, -1, 1e-9);
    EXPECT_NEAR(ndc(v, w.pa).y, -1, 1e-9);
    EXPECT_NEAR(ndc(v, w.pb).x, 1, 1e-9);
    EXPECT_NEAR(ndc(v, w.pb).y, -1, 1e-9);
    EXPECT_NEAR(ndc(v, w.pc).x, -1, 1e-9);
    EXPECT_NEAR(ndc(v, w.pc).y, 1, 1e-9);
    EXPECT_NEAR(ndc(v, pd).x, 1, 1e-9);
    EXPECT_NEAR(ndc(v, pd).y, 1, 1e-9);
  }
}

TEST(Kooima, EyeBehindTheWallIsInvalid) {
  EXPECT_FALSE(off_axis(kWall, {0, 0, -19}, 1, 100).valid);
  EXPECT_FALSE(off_axis(kWall, {0, 0, -18}, 1, 100).valid);
}

TEST(Eyes, FromHeadPoseAndOffset) {
  HeadPose h;
  h.position = {1, 1.7, 0};
  // Turned 90 deg to the left (about +Y): the head's +X (right) points to room -Z.
  h.orientation = glm::angleAxis(glm::radians(90.0), glm::dvec3(0, 1, 0));
  const Eyes e = eyes_from_head(h, 0.064, {0, -0.03, -0.02});
  // Midpoint: offset (0,-0.03,-0.02) rotated -> (-0.02, -0.03, 0).
  const glm::dvec3 mid = (e.left + e.right) * 0.5;
  EXPECT_NEAR(mid.x, 0.98, 1e-12);
  EXPECT_NEAR(mid.y, 1.67, 1e-12);
  EXPECT_NEAR(mid.z, 0.0, 1e-12);
  EXPECT_NEAR(e.right.z - e.left.z, -0.064, 1e-12);
  EXPECT_NEAR(e.right.x - e.left.x, 0.0, 1e-12);
}
