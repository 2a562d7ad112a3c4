#pragma once
// Generalized off-axis perspective projection (R. Kooima, "Generalized Perspective
// Projection", 2008): per wall and per eye, the view and projection that make the wall a
// window onto the room. Room frame, metres; OpenGL conventions (column-major, clip z in
// [-w, w]). Double precision: a float's 7 digits are short of a millimetre at 10 m.
#include <glm/gtc/quaternion.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "kumite/app/config.hpp"

namespace kumite::app {

/// A wall's rectangle: corners and its orthonormal basis (vr right, vu up, vn toward viewer).
struct WallFrame {
  glm::dvec3 pa{0}, pb{0}, pc{0};  ///< m: lower-left, lower-right, upper-left
  glm::dvec3 vr{1, 0, 0}, vu{0, 1, 0}, vn{0, 0, 1};
  double width_m = 0, height_m = 0;
};
WallFrame wall_frame(const glm::dvec3& lower_left, const glm::dvec3& lower_right,
                     const glm::dvec3& upper_left);
WallFrame wall_frame(const WallConfig& wall);

/// Frustum extents on the near plane (m), as glFrustum takes them.
struct Frustum {
  double left = 0, right = 0, bottom = 0, top = 0, near = 0, far = 0;
};

struct EyeView {
  Frustum frustum;
  glm::dmat4 view{1.0};        ///< room -> eye (eye at origin, axes along the wall's basis)
  glm::dmat4 projection{1.0};  ///< eye -> clip (glFrustum)
  bool valid = true;           ///< false when the eye is on or behind the wall plane
};

/// The view and projection for `eye` (m, room frame) looking through `wall`. When the eye is
/// on or behind the wall's plane the result is marked invalid (the caller keeps the last good
/// one): the projection is undefined there.
EyeView off_axis(const WallFrame& wall, const glm::dvec3& eye, double near_m, double far_m);

/// A tracked head: position of the marker centroid and orientation (head -> room).
struct HeadPose {
  glm::dvec3 position{0, 1.7, 0};             ///< m, room frame
  glm::dquat orientation{1.0, 0.0, 0.0, 0.0}; ///< w, x, y, z
};

struct Eyes {
  glm::dvec3 left{0}, right{0};  ///< m, room frame
};

/// Eye positions from a head pose: midpoint = head ∘ eye_offset; eyes ∓ IPD/2 along the
/// head's +X (head frame: +X right, +Y up, looking -Z).
Eyes eyes_from_head(const HeadPose& head, double interpupillary_distance_m,
                    const glm::dvec3& eye_offset_m);

}  // namespace kumite::app
