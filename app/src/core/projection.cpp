#include "kumite/app/projection.hpp"

#include <glm/gtc/matrix_transform.hpp>
#include <glm/geometric.hpp>

namespace kumite::app {

WallFrame wall_frame(const glm::dvec3& pa, const glm::dvec3& pb, const glm::dvec3& pc) {
  WallFrame w;
  w.pa = pa;
  w.pb = pb;
  w.pc = pc;
  w.width_m = glm::length(pb - pa);
  w.height_m = glm::length(pc - pa);
  w.vr = (pb - pa) / w.width_m;
  w.vu = (pc - pa) / w.height_m;
  w.vn = glm::normalize(glm::cross(w.vr, w.vu));
  return w;
}

WallFrame wall_frame(const WallConfig& c) {
  auto v = [](const Vec3& a) { return glm::dvec3(a[0], a[1], a[2]); };
  return wall_frame(v(c.lower_left), v(c.lower_right), v(c.upper_left));
}

EyeView off_axis(const WallFrame& w, const glm::dvec3& pe, double n, double f) {
  EyeView out;
  const glm::dvec3 va = w.pa - pe, vb = w.pb - pe, vc = w.pc - pe;
  const double d = -glm::dot(va, w.vn);  // eye to wall plane, m
  // A millimetre in front of the plane is the least we project from (the frustum blows up).
  if (d < 1e-3) {
    out.valid = false;
    return out;
  }
  const double s = n / d;
  out.frustum = {glm::dot(w.vr, va) * s, glm::dot(w.vr, vb) * s, glm::dot(w.vu, va) * s,
                 glm::dot(w.vu, vc) * s, n, f};
  out.projection = glm::frustum(out.frustum.left, out.frustum.right, out.frustum.bottom,
                                out.frustum.top, n, f);
  // Rows of the rotation are the wall's basis; then move the eye to the origin.
  glm::dmat4 m(1.0);
  for (int i = 0; i < 3; ++i) {
    m[i][0] = w.vr[i];
    m[i][1] = w.vu[i];
    m[i][2] = w.vn[i];
  }
  out.view = m * glm::translate(glm::dmat4(1.0), -pe);
  return out;
}

Eyes eyes_from_head(const HeadPose& head, double ipd, const glm::dvec3& offset) {
  const glm::dvec3 mid = head.position + head.orientation * offset;
  const glm::dvec3 half = head.orientation * glm::dvec3(ipd * 0.5, 0.0, 0.0);
  return {mid - half, mid + half};
}

}  // namespace kumite::app
