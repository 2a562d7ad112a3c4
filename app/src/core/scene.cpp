#include "kumite/app/scene.hpp"

#include <algorithm>
#include <cmath>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include "kumite/content/fighter_types.hpp"

namespace kumite::app {

int plan_views(std::span<const WallFrame> walls, const Eyes& eyes, double near_m, double far_m,
               WallViews& views, std::span<std::uint8_t> kept_walls) {
  views.resize(walls.size());
  const bool mark = kept_walls.size() == walls.size();
  int kept = 0;
  for (std::size_t w = 0; w < walls.size(); ++w) {
    const glm::dvec3 e[2] = {eyes.left, eyes.right};
    if (mark) kept_walls[w] = 0;
    for (int i = 0; i < 2; ++i) {
      const EyeView v = off_axis(walls[w], e[i], near_m, far_m);
      if (v.valid) {
        views[w][static_cast<std::size_t>(i)] = v;
      } else {
        ++kept;
        if (mark) kept_walls[w] = 1;
      }
    }
  }
  return kept;
}

glm::vec3 character_colour(int index) {
  static constexpr glm::vec3 palette[] = {
      {0.95f, 0.55f, 0.12f},  // orange
      {0.90f, 0.20f, 0.55f},  // magenta
      {0.95f, 0.85f, 0.15f},  // yellow
      {0.30f, 0.75f, 0.95f},  // sky blue
      {0.40f, 0.90f, 0.30f},  // green
      {0.62f, 0.42f, 0.95f},  // violet
  };
  const int n = static_cast<int>(std::size(palette));
  return palette[((index % n) + n) % n];
}

bool is_fighter_item(const DrawItem& item, int character) {
  const glm::vec3 c = character_colour(character);
  return item.colour == c || item.colour == c * 0.8f;
}

bool is_target_item(const DrawItem& item) { return item.mesh == Mesh::sphere && item.colour == kTargetColour; }

namespace {

/// The cylinder's +Y axis onto the bone from a to b, scaled to radius r.
glm::mat4 bone_model(const glm::vec3& a, const glm::vec3& b, float r) {
  const glm::vec3 d = b - a;
  const float len = glm::length(d);
  const glm::vec3 y = d / len;
  // Any unit vector not parallel to y completes the frame.
  const glm::vec3 helper = std::abs(y.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
  const glm::vec3 x = glm::normalize(glm::cross(helper, y));
  const glm::vec3 z = glm::cross(x, y);
  glm::mat4 m(1.0f);
  m[0] = glm::vec4(x * r, 0);
  m[1] = glm::vec4(d, 0);
  m[2] = glm::vec4(z * r, 0);
  m[3] = glm::vec4(a, 1);
  return m;
}

glm::mat4 sphere_model(const glm::vec3& c, float r) {
  glm::mat4 m(r);
  m[3] = glm::vec4(c, 1);
  return m;
}

}  // namespace

glm::vec3 glow_colour(double strength) {
  const float t = static_cast<float>(std::clamp(strength, 0.0, 1.0));
  return glm::vec3(1.0f, 0.75f * (1.0f - t) + 0.1f * t, 0.1f) * (0.5f + 0.5f * t);
}

void plan_wall_glow(const WallFrame& wall, const glm::dvec3& near, double strength, std::vector<DrawItem>& items) {
  constexpr double kHalf = 0.8, kStep = 0.2, kInFront = 0.01;
  constexpr float kRadius = 0.004f;
  // The room's side of the wall: where `near` is, unless it is beyond the plane.
  const glm::dvec3 rel = near - wall.pa;
  const double side = glm::dot(rel, wall.vn) >= 0 ? 1.0 : -1.0;
  const glm::dvec3 n = wall.vn * (side * kInFront);
  const double u0 = std::clamp(glm::dot(rel, wall.vr) - kHalf, 0.0, wall.width_m);
  const double u1 = std::clamp(glm::dot(rel, wall.vr) + kHalf, 0.0, wall.width_m);
  const double v0 = std::clamp(glm::dot(rel, wall.vu) - kHalf, 0.0, wall.height_m);
  const double v1 = std::clamp(glm::dot(rel, wall.vu) + kHalf, 0.0, wall.height_m);
  if (u1 - u0 < 1e-3 || v1 - v0 < 1e-3) return;
  const glm::vec3 colour = glow_colour(strength);
  const auto at = [&](double u, double v) { return glm::vec3(wall.pa + wall.vr * u + wall.vu * v + n); };
  for (double u = std::ceil(u0 / kStep) * kStep; u <= u1 + 1e-9; u += kStep)
    items.push_back({bone_model(at(u, v0), at(u, v1), kRadius), colour, Mesh::cylinder});
  for (double v = std::ceil(v0 / kStep) * kStep; v <= v1 + 1e-9; v += kStep)
    items.push_back({bone_model(at(u0, v), at(u1, v), kRadius), colour, Mesh::cylinder});
}

void plan_fighter(const content::FighterFrame& f, glm::vec3 colour, std::vector<DrawItem>& items) {
  items.clear();
  const std::size_t n = f.joints.size();
  // Joints and bones: slightly darker joints make the limbs readable.
  const glm::vec3 joint_colour = colour * 0.8f;
  for (std::size_t j = 0; j < n; ++j) {
    const glm::vec3 p(f.joints[j].cast<float>().x(), f.joints[j].cast<float>().y(),
                      f.joints[j].cast<float>().z());
    const float r = j < f.joint_radii_m.size() ? f.joint_radii_m[j] : 0.04f;
    // Joints a little fatter than their bones: no z-fighting seam where they meet.
    items.push_back({sphere_model(p, r * 1.08f), joint_colour, Mesh::sphere});
    const int parent = j < f.parents.size() ? f.parents[j] : -1;
    if (parent < 0) continue;
    const auto& q = f.joints[static_cast<std::size_t>(parent)];
    const glm::vec3 a(static_cast<float>(q.x()), static_cast<float>(q.y()),
                      static_cast<float>(q.z()));
    if (glm::length(p - a) < 1e-4f) continue;  // zero-length bone (BVH end sites, roots)
    items.push_back({bone_model(a, p, r), colour, Mesh::cylinder});
    // A bone fatter than its parent joint's sphere (the head on its neck, the chest on the
    // spine) gets its own rounded end there, so it reads as a capsule, not a cut cylinder.
    const float parent_r = static_cast<std::size_t>(parent) < f.joint_radii_m.size()
                               ? f.joint_radii_m[static_cast<std::size_t>(parent)] * 1.08f
                               : 0.04f;
    // Its radius stays just inside the cylinder's facets (32 slices: cos(pi/32) = 0.995): at
    // the full radius the two tangent surfaces z-fight in a sawtooth along the bone.
    if (r > parent_r) items.push_back({sphere_model(a, r * 0.985f), colour, Mesh::sphere});
  }
  if (f.target) {
    const glm::vec3 t(static_cast<float>(f.target->x()), static_cast<float>(f.target->y()),
                      static_cast<float>(f.target->z()));
    items.push_back({sphere_model(t, 0.05f), kTargetColour, Mesh::sphere});
  }
}

std::vector<LineVertex> room_lines(std::span<const WallFrame> walls) {
  std::vector<LineVertex> out;
  auto line = [&](glm::vec3 a, glm::vec3 b, glm::vec3 c) {
    out.push_back({a, c});
    out.push_back({b, c});
  };
  // The virtual floor continues the real one: a 0.5 m grid reaching well behind the front
  // wall, where the fighter stands.
  const glm::vec3 grid(0.32f, 0.34f, 0.40f);
  const float x0 = -4.0f, x1 = 4.0f, z0 = -8.0f, z1 = 3.0f;
  for (float x = x0; x <= x1 + 1e-3f; x += 0.5f) line({x, 0.001f, z0}, {x, 0.001f, z1}, grid);
  for (float z = z0; z <= z1 + 1e-3f; z += 0.5f) line({x0, 0.001f, z}, {x1, 0.001f, z}, grid);
  // The room's walls, lightly: their outlines.
  const glm::vec3 edge(0.45f, 0.50f, 0.60f);
  for (const auto& w : walls) {
    const glm::vec3 a(w.pa), b(w.pb), c(w.pc), d(w.pb + (w.pc - w.pa));
    line(a, b, edge);
    line(b, d, edge);
    line(d, c, edge);
    line(c, a, edge);
  }
  return out;
}

}  // namespace kumite::app
