#include "kumite/app/renderer.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <initializer_list>
#include <string>
#include <vector>

#include <glm/gtc/type_ptr.hpp>
#include <spdlog/spdlog.h>

#include "gl.hpp"
#include "kumite/app/bodies.hpp"
#include "kumite/app/config.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/body/model.hpp"
#include "kumite/common/error.hpp"

namespace kumite::app {

namespace {

// The scene's light, shared by the capsules, the body and the hall: a key from above and in
// front (the visitor's side), a dimmer fill from behind and a hemisphere ambient (the ceiling's
// light above, the floor's bounce below). White, so a flat colour keeps its hue.
constexpr const char* kLightGlsl = R"(
uniform bool u_mask;
vec3 shade(vec3 base, vec3 n) {
  if (u_mask) return vec3(1.0);
  float key = max(dot(n, normalize(vec3(-0.4, 0.8, 0.6))), 0.0);
  float fill = max(dot(n, normalize(vec3(0.5, 0.2, -0.8))), 0.0);
  float ambient = mix(0.22, 0.34, 0.5 + 0.5 * n.y);
  return base * (ambient + 0.70 * key + 0.25 * fill);
}
)";

constexpr const char* kLitVertex = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in mat4 a_model;   // per instance (locations 2-5)
layout(location = 6) in vec3 a_colour;  // per instance
uniform mat4 u_view_projection;
out vec3 v_normal;
flat out vec3 v_colour;
void main() {
  v_normal = transpose(inverse(mat3(a_model))) * a_normal;
  v_colour = a_colour;
  gl_Position = u_view_projection * (a_model * vec4(a_position, 1.0));
}
)";

constexpr const char* kLitFragment = R"(
in vec3 v_normal;
flat in vec3 v_colour;
out vec4 o_colour;
void main() { o_colour = vec4(shade(v_colour, normalize(v_normal)), 1.0); }
)";

// Linear blend skinning: the palette (G_posed · bind per joint, room frame) in a std140
// uniform block, four joints per vertex as integers, weights summing to 1. The same source is
// linked twice: to draw, and with transform feedback of v_world / v_normal (the GPU = CPU check).
constexpr const char* kSkinnedVertex = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in uvec4 a_joints;
layout(location = 3) in vec4 a_weights;
layout(location = 4) in vec2 a_uv;
layout(std140) uniform Palette { mat4 u_joints[128]; };
uniform mat4 u_view_projection;
out vec3 v_world;
out vec3 v_normal;
out vec2 v_uv;
void main() {
  v_uv = a_uv;
  mat4 m = a_weights.x * u_joints[a_joints.x] + a_weights.y * u_joints[a_joints.y] +
           a_weights.z * u_joints[a_joints.z] + a_weights.w * u_joints[a_joints.w];
  vec4 w = m * vec4(a_position, 1.0);
  v_world = w.xyz;
  v_normal = mat3(m) * a_normal;
  gl_Position = u_view_projection * w;
}
)";

// The material's base colour factor times its base-colour texture where it has one (sampled as
// stored: the renderer's colours are display values, the factors' included).
constexpr const char* kSkinnedFragment = R"(
in vec3 v_world;
in vec3 v_normal;
in vec2 v_uv;
uniform vec3 u_colour;
uniform bool u_textured;
uniform sampler2D u_base;
out vec4 o_colour;
void main() {
  vec3 n = normalize(v_normal);
  // Triangles seen from behind (an open mesh's inside) lit as their front.
  if (!gl_FrontFacing) n = -n;
  vec3 base = u_textured ? u_colour * texture(u_base, v_uv).rgb : u_colour;
  o_colour = vec4(shade(base, n), 1.0);
}
)";

// The training hall: a wooden floor of staggered planks with a mat of panels in the middle,
// panelled walls under plaster between pillars, a beamed ceiling; lit by three lamps over the
// mat and an ambient. Its look is geometry: each plank, panel, pillar and beam a rectangle with
// its colour and the lamps' light baked per vertex on the CPU (hall_vertices()), so that a pixel
// only interpolates a colour. On llvmpipe (the CI's and the headless demo's renderer) the hall
// covers every pixel of every wall and eye: a per-pixel procedural look made the demo's frame
// five times slower than the void.
constexpr const char* kHallVertex = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_colour;  // base colour times the lamps' light
uniform mat4 u_view_projection;
out vec3 v_colour;
void main() {
  v_colour = a_colour;
  gl_Position = u_view_projection * vec4(a_position, 1.0);
}
)";

constexpr const char* kHallFragment = R"(#version 330 core
in vec3 v_colour;
out vec4 o_colour;
void main() { o_colour = vec4(v_colour, 1.0); }
)";

// The contact shadow: soft dark discs on the floor under the pelvis and each foot, fading as
// the foot lifts (multiplied into what is drawn: the floor only, as the body comes after).
constexpr const char* kShadowVertex = R"(#version 330 core
layout(location = 0) in vec2 a_corner;  // -1..1
uniform vec3 u_centre;                  // m, on the floor
uniform vec2 u_radius;                  // m, along x and z
out vec2 v_local;
uniform mat4 u_view_projection;
void main() {
  v_local = a_corner;
  gl_Position = u_view_projection * vec4(u_centre + vec3(a_corner.x * u_radius.x, 0.0, a_corner.y * u_radius.y), 1.0);
}
)";

constexpr const char* kShadowFragment = R"(#version 330 core
in vec2 v_local;
uniform float u_strength;
out vec4 o_colour;
void main() {
  float r = length(v_local);
  float a = u_strength * (1.0 - smoothstep(0.0, 1.0, r));
  o_colour = vec4(vec3(1.0 - a), 1.0);
}
)";

constexpr const char* kLineVertex = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_colour;
uniform mat4 u_view_projection;
out vec3 v_colour;
void main() {
  v_colour = a_colour;
  gl_Position = u_view_projection * vec4(a_position, 1.0);
}
)";

constexpr const char* kLineFragment = R"(#version 330 core
in vec3 v_colour;
out vec4 o_colour;
void main() { o_colour = vec4(v_colour, 1.0); }
)";

GLuint compile(GLenum type, std::initializer_list<const char*> sources) {
  const GLuint s = glCreateShader(type);
  std::vector<const char*> src(sources);
  glShaderSource(s, static_cast<GLsizei>(src.size()), src.data(), nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[1024] = {};
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    throw Error("gl", "shader", std::string("shader does not compile: ") + log);
  }
  return s;
}

constexpr const char* kVersion = "#version 330 core\n";

/// A program from a vertex shader and a fragment shader (the scene's light prepended when
/// `lit`); `feedback`: varyings captured by transform feedback (interleaved).
GLuint program(const char* vs, const char* fs, bool lit = false, std::initializer_list<const char*> feedback = {}) {
  const GLuint p = glCreateProgram();
  const GLuint v = compile(GL_VERTEX_SHADER, {vs});
  const GLuint f = lit ? compile(GL_FRAGMENT_SHADER, {kVersion, kLightGlsl, fs}) : compile(GL_FRAGMENT_SHADER, {fs});
  glAttachShader(p, v);
  glAttachShader(p, f);
  if (feedback.size() > 0) {
    std::vector<const char*> names(feedback);
    glTransformFeedbackVaryings(p, static_cast<GLsizei>(names.size()), names.data(), GL_INTERLEAVED_ATTRIBS);
  }
  glLinkProgram(p);
  glDeleteShader(v);
  glDeleteShader(f);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[1024] = {};
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    throw Error("gl", "shader", std::string("shader program does not link: ") + log);
  }
  return p;
}

struct MeshBuffers {
  GLuint vao = 0, vbo = 0, ebo = 0;
  GLuint instances = 0;  ///< per-instance model matrix (16 floats) and colour (3)
  GLsizei count = 0;
};

/// Floats per instance: the model matrix (column-major) and the colour.
constexpr int kInstanceFloats = 19;

/// Interleaved position + normal, indexed triangles.
MeshBuffers upload(const std::vector<float>& vertices, const std::vector<unsigned>& indices) {
  MeshBuffers m;
  glGenVertexArrays(1, &m.vao);
  glBindVertexArray(m.vao);
  glGenBuffers(1, &m.vbo);
  glBindBuffer(GL_ARRAY_BUFFER, m.vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices.size() * sizeof(float)),
               vertices.data(), GL_STATIC_DRAW);
  glGenBuffers(1, &m.ebo);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, m.ebo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(indices.size() * sizeof(unsigned)),
               indices.data(), GL_STATIC_DRAW);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                        reinterpret_cast<const void*>(3 * sizeof(float)));
  glEnableVertexAttribArray(0);
  glEnableVertexAttribArray(1);
  // Drawn instanced: one draw per mesh and view, each body part an instance (one draw per
  // part made llvmpipe, the VM's software renderer, keep per-draw state for every part).
  glGenBuffers(1, &m.instances);
  glBindBuffer(GL_ARRAY_BUFFER, m.instances);
  constexpr GLsizei stride = kInstanceFloats * sizeof(float);
  for (GLuint c = 0; c < 4; ++c) {
    glVertexAttribPointer(2 + c, 4, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(4 * c * sizeof(float)));
    glVertexAttribDivisor(2 + c, 1);
    glEnableVertexAttribArray(2 + c);
  }
  glVertexAttribPointer(6, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(16 * sizeof(float)));
  glVertexAttribDivisor(6, 1);
  glEnableVertexAttribArray(6);
  glBindVertexArray(0);
  m.count = static_cast<GLsizei>(indices.size());
  return m;
}

constexpr float kPi = 3.14159265358979f;

MeshBuffers make_sphere(int slices, int stacks) {
  std::vector<float> v;
  std::vector<unsigned> idx;
  for (int i = 0; i <= stacks; ++i) {
    const float phi = kPi * static_cast<float>(i) / static_cast<float>(stacks);
    for (int j = 0; j <= slices; ++j) {
      const float th = 2 * kPi * static_cast<float>(j) / static_cast<float>(slices);
      const float x = std::sin(phi) * std::cos(th), y = std::cos(phi), z = std::sin(phi) * std::sin(th);
      v.insert(v.end(), {x, y, z, x, y, z});
    }
  }
  const unsigned row = static_cast<unsigned>(slices + 1);
  for (unsigned i = 0; i < static_cast<unsigned>(stacks); ++i)
    for (unsigned j = 0; j < static_cast<unsigned>(slices); ++j) {
      const unsigned a = i * row + j, b = a + row;
      idx.insert(idx.end(), {a, b, a + 1, a + 1, b, b + 1});
    }
  return upload(v, idx);
}

MeshBuffers make_cylinder(int slices) {
  std::vector<float> v;
  std::vector<unsigned> idx;
  for (int j = 0; j <= slices; ++j) {
    const float th = 2 * kPi * static_cast<float>(j) / static_cast<float>(slices);
    const float x = std::cos(th), z = std::sin(th);
    v.insert(v.end(), {x, 0, z, x, 0, z, x, 1, z, x, 0, z});
  }
  for (unsigned j = 0; j < static_cast<unsigned>(slices); ++j) {
    const unsigned a = 2 * j;
    idx.insert(idx.end(), {a, a + 1, a + 2, a + 2, a + 1, a + 3});
  }
  return upload(v, idx);
}


/// One model on the GPU: interleaved bind-pose vertices and its triangles.
struct SkinnedBuffers {
  GLuint vao = 0, vbo = 0, ebo = 0;
  GLsizei vertices = 0;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> primitives;  ///< first index, count
  std::vector<GLuint> textures;           ///< one per model texture (RGBA8, mipmapped, its sampler)
  std::vector<GLuint> primitive_texture;  ///< per primitive: its material's base-colour texture (0: none)
};

/// Per vertex: position, normal, four joints (u16), four weights, texture coordinates: 56 bytes.
struct SkinnedVertex {
  float position[3];
  float normal[3];
  std::uint16_t joints[4];
  float weights[4];
  float uv[2];
};
static_assert(sizeof(SkinnedVertex) == 56);

/// The hall's geometry: position (m, room frame) and lit colour per vertex.
struct HallVertex {
  float position[3];
  float colour[3];
};

/// The hall's size (m, room frame): walls at x = ±6, z = -11 (behind the fighter) and +6, 4.5 m
/// tall; the mat 6 m x 8 m (x -3..3, z -6..2).
constexpr float kHallX0 = -6, kHallX1 = 6, kHallZ0 = -11, kHallZ1 = 6, kHallHeight = 4.5f;
constexpr float kMatX0 = -3, kMatX1 = 3, kMatZ0 = -6, kMatZ1 = 2, kMatBorder = 0.3f;

/// Cheap per-cell variation in [0, 1) (the R2 sequence).
float hall_hash(float a, float b) {
  const float v = a * 0.7548776f + b * 0.5698403f + 0.31f;
  return v - std::floor(v);
}

/// The light falling on a point of the hall with inward normal n: an ambient and three lamps
/// over the mat (warm, falling off with distance); the ceiling only the ambient it bounces.
glm::vec3 hall_light(const glm::vec3& p, const glm::vec3& n) {
  if (n.y < -0.5f) return glm::vec3(0.35f);
  glm::vec3 light(0.20f);
  for (const glm::vec3& lamp : {glm::vec3(0.0f, 4.3f, -2.5f), glm::vec3(0.0f, 4.3f, 0.5f), glm::vec3(0.0f, 4.3f, -5.5f)}) {
    const glm::vec3 l = lamp - p;
    const float d2 = glm::dot(l, l);
    light += glm::vec3(1.0f, 0.93f, 0.82f) * (9.0f * std::max(glm::dot(n, l / std::sqrt(d2)), 0.0f) / (1.0f + d2));
  }
  return light;
}

/// Appends a rectangle of the hall: corner `o`, edges `u` and `w` (m), inward normal `n`,
/// one base colour; cut into cells of at most `cell` m so that the lamps' light, computed at the
/// vertices, falls off smoothly across it.
void hall_rect(std::vector<HallVertex>& out, glm::vec3 o, glm::vec3 u, glm::vec3 w, glm::vec3 n, glm::vec3 base,
               float cell = 0.75f) {
  const int nu = std::max(1, static_cast<int>(std::ceil(glm::length(u) / cell)));
  const int nw = std::max(1, static_cast<int>(std::ceil(glm::length(w) / cell)));
  auto at = [&](int i, int j) {
    const glm::vec3 p = o + u * (static_cast<float>(i) / static_cast<float>(nu)) + w * (static_cast<float>(j) / static_cast<float>(nw));
    const glm::vec3 c = base * hall_light(p, n);
    return HallVertex{{p.x, p.y, p.z}, {c.x, c.y, c.z}};
  };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nw; ++j)
      for (const HallVertex& v : {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i, j + 1)})
        out.push_back(v);
}

/// A floor rectangle x0..x1, z0..z1 (y = 0).
void floor_rect(std::vector<HallVertex>& out, float x0, float x1, float z0, float z1, glm::vec3 base, float cell = 0.75f) {
  if (x1 <= x0 || z1 <= z0) return;
  hall_rect(out, {x0, 0, z0}, {0, 0, z1 - z0}, {x1 - x0, 0, 0}, {0, 1, 0}, base, cell);
}

/// The floor outside the mat: planks 0.18 m wide along z, 2.4 m long, staggered per row, each
/// its own tone; the mat's rectangle cut out of every plank that crosses it.
void wood_floor(std::vector<HallVertex>& out) {
  constexpr float width = 0.18f, length = 2.4f;
  const int rows = static_cast<int>(std::ceil((kHallX1 - kHallX0) / width));
  for (int r = 0; r < rows; ++r) {
    const float x0 = kHallX0 + static_cast<float>(r) * width, x1 = std::min(kHallX1, x0 + width);
    const float row = std::floor(x0 / width);
    const float shift = hall_hash(row, 7.0f) * length;
    for (float z = kHallZ0 - shift; z < kHallZ1; z += length) {
      const float z0 = std::max(z, kHallZ0), z1 = std::min(z + length, kHallZ1);
      const float tone = hall_hash(row, std::floor((z + shift) / length));
      // A thin dark seam at the plank's end and along one side: the plank reads as a plank.
      const glm::vec3 wood = glm::mix(glm::vec3(0.30f, 0.19f, 0.11f), glm::vec3(0.42f, 0.28f, 0.16f), tone);
      const glm::vec3 seam = wood * 0.5f;
      // The plank (less its seams) and its seams, each cut by the mat.
      auto cut = [&](float a0, float a1, float b0, float b1, glm::vec3 c, float cell) {
        if (a1 <= kMatX0 || a0 >= kMatX1 || b1 <= kMatZ0 || b0 >= kMatZ1) {
          floor_rect(out, a0, a1, b0, b1, c, cell);
          return;
        }
        floor_rect(out, a0, std::min(a1, kMatX0), b0, b1, c, cell);
        floor_rect(out, std::max(a0, kMatX1), a1, b0, b1, c, cell);
        floor_rect(out, std::max(a0, kMatX0), std::min(a1, kMatX1), b0, std::min(b1, kMatZ0), c, cell);
        floor_rect(out, std::max(a0, kMatX0), std::min(a1, kMatX1), std::max(b0, kMatZ1), b1, c, cell);
      };
      constexpr float s = 0.006f;
      cut(x0, x1 - s, z0, z1 - s, wood, 1.2f);
      cut(x1 - s, x1, z0, z1, seam, 100.0f);
      cut(x0, x1 - s, z1 - s, z1, seam, 100.0f);
    }
  }
}

/// The mat: panels 1 m x 2 m (each its own shade of blue) with dark seams, a red border.
void mat_floor(std::vector<HallVertex>& out) {
  const glm::vec3 red(0.36f, 0.06f, 0.05f);
  const float b = kMatBorder;
  floor_rect(out, kMatX0, kMatX1, kMatZ0, kMatZ0 + b, red);
  floor_rect(out, kMatX0, kMatX1, kMatZ1 - b, kMatZ1, red);
  floor_rect(out, kMatX0, kMatX0 + b, kMatZ0 + b, kMatZ1 - b, red);
  floor_rect(out, kMatX1 - b, kMatX1, kMatZ0 + b, kMatZ1 - b, red);
  const float cx = 0.5f * (kMatX0 + kMatX1), cz = 0.5f * (kMatZ0 + kMatZ1);
  constexpr float seam = 0.012f;
  // Seams at every metre across x and every 2 m along z from the mat's centre.
  std::vector<float> xs{kMatX0 + b}, zs{kMatZ0 + b};
  for (float x = std::ceil(kMatX0 + b - cx) + cx; x < kMatX1 - b; x += 1.0f) xs.push_back(x);
  for (float z = 2.0f * std::ceil((kMatZ0 + b - cz) / 2.0f) + cz; z < kMatZ1 - b; z += 2.0f) zs.push_back(z);
  xs.push_back(kMatX1 - b);
  zs.push_back(kMatZ1 - b);
  const glm::vec3 dark = glm::vec3(0.10f, 0.17f, 0.22f) * 0.55f;
  for (std::size_t i = 0; i + 1 < xs.size(); ++i)
    for (std::size_t j = 0; j + 1 < zs.size(); ++j) {
      const float x0 = xs[i] + (i > 0 ? seam / 2 : 0), x1 = xs[i + 1] - (i + 2 < xs.size() ? seam / 2 : 0);
      const float z0 = zs[j] + (j > 0 ? seam / 2 : 0), z1 = zs[j + 1] - (j + 2 < zs.size() ? seam / 2 : 0);
      const float tone = hall_hash(std::floor(0.5f * (x0 + x1) - cx), std::floor(0.25f * (z0 + z1 - 2 * cz)));
      floor_rect(out, x0, x1, z0, z1, glm::vec3(0.10f, 0.17f, 0.22f) * (0.92f + 0.08f * tone), 0.5f);
      if (i > 0) floor_rect(out, xs[i] - seam / 2, xs[i] + seam / 2, z0, z1, dark, 0.5f);
      if (j > 0) floor_rect(out, x0, x1, zs[j] - seam / 2, zs[j] + seam / 2, dark, 0.5f);
      if (i > 0 && j > 0) floor_rect(out, xs[i] - seam / 2, xs[i] + seam / 2, zs[j] - seam / 2, zs[j] + seam / 2, dark);
    }
}

/// The first edge after u of stripes `half` wide on either side of every multiple of `period`
/// (k: the multiple nearest u).
float next_edge(float u, float k, float period, float half) {
  float best = k + period + half;
  for (const float c : {k - half, k + half, k + period - half})
    if (c > u + 1e-4f) best = std::min(best, c);
  return best;
}

/// A wall from `a` along `along` (unit, m of length `length`), inward normal `n`: dark wood
/// panelling (seams every 0.6 m) up to a rail at 1.1 m, plaster above, a beam at 3.4 m, pillars
/// every 3 m along it.
void hall_wall(std::vector<HallVertex>& out, glm::vec3 a, glm::vec3 along, float length, glm::vec3 n) {
  const glm::vec3 up(0, 1, 0);
  const glm::vec3 panel(0.24f, 0.15f, 0.09f), plaster(0.58f, 0.54f, 0.48f), rail(0.20f, 0.12f, 0.07f),
      pillar(0.27f, 0.17f, 0.10f), beam(0.22f, 0.14f, 0.08f);
  // Bands up the wall: panelling, rail, plaster, beam, plaster.
  const std::array<std::pair<float, glm::vec3>, 5> bands{{{1.06f, panel}, {1.14f, rail}, {3.28f, plaster}, {3.52f, beam}, {kHallHeight, plaster}}};
  // Along the wall: pillars 0.3 m wide centred on every multiple of 3 m of the room's axis.
  const float start = glm::dot(a, along);
  std::vector<std::pair<float, bool>> spans;  // (end along the wall, a pillar)
  float t = 0;
  while (t < length - 1e-4f) {
    const float u = start + t;
    const float k = std::round(u / 3.0f) * 3.0f;
    const float end = std::min(length, next_edge(u, k, 3.0f, 0.15f) - start);
    const float mid = 0.5f * (u + start + end);
    const bool is_pillar = std::abs(mid - std::round(mid / 3.0f) * 3.0f) < 0.15f;
    spans.push_back({end, is_pillar});
    t = end;
  }
  float from = 0;
  for (const auto& [to, is_pillar] : spans) {
    float y0 = 0;
    for (const auto& [y1, colour] : bands) {
      const glm::vec3 c = is_pillar && colour != beam ? pillar : colour;
      hall_rect(out, a + along * from + up * y0, along * (to - from), up * (y1 - y0), n, c);
      y0 = y1;
    }
    if (!is_pillar)  // the panelling's seams
      for (float u = std::ceil((start + from) / 0.6f) * 0.6f; u < start + to - 0.02f; u += 0.6f)
        if (u - start > from + 0.02f)
          hall_rect(out, a + along * (u - start - 0.005f) + n * 0.001f, along * 0.01f, up * 1.06f, n, panel * 0.65f, 10.0f);
    from = to;
  }
}

/// The hall: the floor (wood, then the mat), the walls, the ceiling with beams every 2 m. Every
/// surface is a face of one box seen from inside: nothing hides anything else, so it is drawn
/// without the depth test (the seams, drawn after what they lie on, land on top).
std::vector<HallVertex> hall_vertices(std::size_t* floor_vertices) {
  std::vector<HallVertex> v;
  wood_floor(v);
  mat_floor(v);
  *floor_vertices = v.size();
  hall_wall(v, {kHallX0, 0, kHallZ0}, {1, 0, 0}, kHallX1 - kHallX0, {0, 0, 1});   // behind the fighter
  hall_wall(v, {kHallX0, 0, kHallZ1}, {1, 0, 0}, kHallX1 - kHallX0, {0, 0, -1});  // behind the visitor
  hall_wall(v, {kHallX0, 0, kHallZ0}, {0, 0, 1}, kHallZ1 - kHallZ0, {1, 0, 0});   // left
  hall_wall(v, {kHallX1, 0, kHallZ0}, {0, 0, 1}, kHallZ1 - kHallZ0, {-1, 0, 0});  // right
  const glm::vec3 ceiling(0.14f, 0.12f, 0.10f);
  for (float z = kHallZ0; z < kHallZ1 - 1e-4f;) {  // beams 0.2 m wide on every even metre
    const float k = std::round(z / 2.0f) * 2.0f;
    const float end = std::min(kHallZ1, next_edge(z, k, 2.0f, 0.1f));
    const float mid = 0.5f * (z + end);
    const bool beam = std::abs(mid - std::round(mid / 2.0f) * 2.0f) < 0.1f;
    hall_rect(v, {kHallX0, kHallHeight, z}, {kHallX1 - kHallX0, 0, 0}, {0, 0, end - z}, {0, -1, 0},
              beam ? ceiling * 0.6f : ceiling, 1.5f);
    z = end;
  }
  return v;
}

/// The hall's floor drawn once for a view that maps the floor to its pixels the way an earlier
/// view did, and copied 1:1 after (a blit is a memory copy on llvmpipe). A wall lying on the
/// floor (the CAVE's floor projection) has the floor on its own plane: every eye sees it at the
/// same pixels, so its hall is drawn once for the whole run.
struct FloorCache {
  GLuint fbo = 0, colour = 0;
  int width = 0, height = 0;
  std::array<float, 9> key{};  ///< the view's map from the floor (x, z, 1) to clip (x, y, w), unit norm
  std::uint64_t used = 0;      ///< draw number of its last use (the least recent is replaced)
};

/// How a view maps the floor plane (y = 0) to the image, up to scale (the two eyes of a wall
/// on the floor differ only in scale): rows x, y, w of clip space, columns x, z, 1.
std::array<float, 9> floor_map(const glm::mat4& vp) {
  std::array<float, 9> k{};
  const int rows[3] = {0, 1, 3}, cols[3] = {0, 2, 3};
  float norm = 0;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      k[static_cast<std::size_t>(3 * r + c)] = vp[cols[c]][rows[r]];
      norm += vp[cols[c]][rows[r]] * vp[cols[c]][rows[r]];
    }
  norm = std::sqrt(norm);
  if (k[8] < 0) norm = -norm;  // the floor's origin in front of the eye: w > 0
  for (float& x : k) x /= norm;
  return k;
}

bool same_map(const std::array<float, 9>& a, const std::array<float, 9>& b) {
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::abs(a[i] - b[i]) > 1e-6f) return false;
  return true;
}

/// A contact shadow disc: centre on the floor, radii, strength.
struct Blob {
  glm::vec3 centre{0.0f};
  glm::vec2 radius{0.0f};
  float strength = 0;
};

}  // namespace

struct Renderer::Impl {
  GLuint lit = 0, lines = 0, skinned = 0, skinned_feedback = 0, hall = 0, shadow = 0;
  GLint lit_vp = -1, lines_vp = -1, lit_mask = -1, skinned_vp = -1, skinned_colour = -1, skinned_mask = -1,
        skinned_textured = -1, skinned_base = -1,
        hall_vp = -1, shadow_vp = -1, shadow_centre = -1, shadow_radius = -1, shadow_strength = -1;
  MeshBuffers sphere, cylinder;
  std::vector<float> sphere_instances, cylinder_instances;  ///< kept: a warm frame allocates nothing
  GLuint line_vao = 0, line_vbo = 0;
  GLsizei line_count = 0;
  GLuint hall_vao = 0, hall_vbo = 0;
  GLsizei hall_count = 0, floor_count = 0;  ///< vertices: all, the floor's (first)
  std::array<FloorCache, 4> floor_caches{};
  std::array<std::array<float, 9>, 8> recent_maps{};  ///< floor maps of the last views drawn
  std::size_t recent_next = 0;
  std::uint64_t draws = 0;
  bool draw_cached_floor(const glm::mat4& vp);
  GLuint quad_vao = 0, quad_vbo = 0;
  GLuint palette_ubo = 0;
  GLuint feedback_buffer = 0;
  std::vector<SkinnedBuffers> models;
  std::vector<int> body_models;  ///< FighterBodies' model -> index into models
  SceneOptions options{.hall = false, .debug_marks = true};  ///< the look before configure(): as ever
  std::unique_ptr<FighterBodies> bodies;
  const BodyFrame* body = nullptr;  ///< this frame's
  int character = -1;               ///< this frame's (its capsules left out when `body`)
  std::array<Blob, 3> blobs{};
  std::size_t blob_count = 0;
  std::vector<float> feedback;
};

Renderer::Renderer(std::span<const WallFrame> walls) : impl_(std::make_unique<Impl>()) {
  GLint major = 0, minor = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  if (major * 10 + minor < 33)
    throw Error("gl", "version", "OpenGL 3.3 is needed; the context has " + gl_description());
  auto& m = *impl_;
  m.lit = program(kLitVertex, kLitFragment, true);
  m.lit_vp = glGetUniformLocation(m.lit, "u_view_projection");
  m.lit_mask = glGetUniformLocation(m.lit, "u_mask");
  m.lines = program(kLineVertex, kLineFragment);
  m.lines_vp = glGetUniformLocation(m.lines, "u_view_projection");
  m.skinned = program(kSkinnedVertex, kSkinnedFragment, true);
  m.skinned_vp = glGetUniformLocation(m.skinned, "u_view_projection");
  m.skinned_colour = glGetUniformLocation(m.skinned, "u_colour");
  m.skinned_mask = glGetUniformLocation(m.skinned, "u_mask");
  m.skinned_textured = glGetUniformLocation(m.skinned, "u_textured");
  m.skinned_base = glGetUniformLocation(m.skinned, "u_base");
  m.skinned_feedback = program(kSkinnedVertex, kSkinnedFragment, true, {"v_world", "v_normal"});
  for (GLuint p : {m.skinned, m.skinned_feedback})
    glUniformBlockBinding(p, glGetUniformBlockIndex(p, "Palette"), 0);
  m.hall = program(kHallVertex, kHallFragment);
  m.hall_vp = glGetUniformLocation(m.hall, "u_view_projection");
  m.shadow = program(kShadowVertex, kShadowFragment);
  m.shadow_vp = glGetUniformLocation(m.shadow, "u_view_projection");
  m.shadow_centre = glGetUniformLocation(m.shadow, "u_centre");
  m.shadow_radius = glGetUniformLocation(m.shadow, "u_radius");
  m.shadow_strength = glGetUniformLocation(m.shadow, "u_strength");
  // Fine enough that where a joint's sphere cuts a bone the seam reads as a smooth circle at
  // life size on a 3 m wall (20 x 12 and 16 left a visible zigzag).
  m.sphere = make_sphere(32, 16);
  m.cylinder = make_cylinder(32);
  const auto lines = room_lines(walls);
  glGenVertexArrays(1, &m.line_vao);
  glBindVertexArray(m.line_vao);
  glGenBuffers(1, &m.line_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, m.line_vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(lines.size() * sizeof(LineVertex)),
               lines.data(), GL_STATIC_DRAW);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(LineVertex), nullptr);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, sizeof(LineVertex),
                        reinterpret_cast<const void*>(sizeof(glm::vec3)));
  glEnableVertexAttribArray(0);
  glEnableVertexAttribArray(1);
  m.line_count = static_cast<GLsizei>(lines.size());
  std::size_t floor_vertices = 0;
  const auto hall = hall_vertices(&floor_vertices);
  m.floor_count = static_cast<GLsizei>(floor_vertices);
  glGenVertexArrays(1, &m.hall_vao);
  glBindVertexArray(m.hall_vao);
  glGenBuffers(1, &m.hall_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, m.hall_vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(hall.size() * sizeof(HallVertex)), hall.data(), GL_STATIC_DRAW);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(HallVertex), nullptr);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, sizeof(HallVertex), reinterpret_cast<const void*>(offsetof(HallVertex, colour)));
  for (GLuint a = 0; a < 2; ++a) glEnableVertexAttribArray(a);
  m.hall_count = static_cast<GLsizei>(hall.size());
  const float quad[] = {-1, -1, 1, -1, 1, 1, -1, -1, 1, 1, -1, 1};
  glGenVertexArrays(1, &m.quad_vao);
  glBindVertexArray(m.quad_vao);
  glGenBuffers(1, &m.quad_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, m.quad_vbo);
  glBufferData(GL_ARRAY_BUFFER, sizeof quad, quad, GL_STATIC_DRAW);
  glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 2 * sizeof(float), nullptr);
  glEnableVertexAttribArray(0);
  glBindVertexArray(0);
  glGenBuffers(1, &m.palette_ubo);
  glBindBuffer(GL_UNIFORM_BUFFER, m.palette_ubo);
  glBufferData(GL_UNIFORM_BUFFER, body::kMaxJoints * 16 * sizeof(float), nullptr, GL_DYNAMIC_DRAW);
  glBindBuffer(GL_UNIFORM_BUFFER, 0);
}

Renderer::~Renderer() {
  auto& m = *impl_;
  for (auto* b : {&m.sphere, &m.cylinder}) {
    glDeleteBuffers(1, &b->vbo);
    glDeleteBuffers(1, &b->ebo);
    glDeleteBuffers(1, &b->instances);
    glDeleteVertexArrays(1, &b->vao);
  }
  for (auto& b : m.models) {
    if (!b.textures.empty()) glDeleteTextures(static_cast<GLsizei>(b.textures.size()), b.textures.data());
    glDeleteBuffers(1, &b.vbo);
    glDeleteBuffers(1, &b.ebo);
    glDeleteVertexArrays(1, &b.vao);
  }
  glDeleteBuffers(1, &m.line_vbo);
  glDeleteVertexArrays(1, &m.line_vao);
  glDeleteBuffers(1, &m.hall_vbo);
  for (const FloorCache& c : m.floor_caches)
    if (c.fbo) {
      glDeleteFramebuffers(1, &c.fbo);
      glDeleteRenderbuffers(1, &c.colour);
    }
  glDeleteVertexArrays(1, &m.hall_vao);
  glDeleteBuffers(1, &m.quad_vbo);
  glDeleteVertexArrays(1, &m.quad_vao);
  glDeleteBuffers(1, &m.palette_ubo);
  if (m.feedback_buffer) glDeleteBuffers(1, &m.feedback_buffer);
  for (GLuint p : {m.lit, m.lines, m.skinned, m.skinned_feedback, m.hall, m.shadow}) glDeleteProgram(p);
}

int Renderer::upload_model(const body::SkinnedModel& model) {
  auto& m = *impl_;
  if (model.skeleton.joint_count() > body::kMaxJoints)
    throw Error("gl", "model", model.source + ": more joints than the palette holds");
  std::vector<SkinnedVertex> v(model.vertex_count());
  for (std::size_t i = 0; i < v.size(); ++i) {
    auto& o = v[i];
    for (int k = 0; k < 3; ++k) {
      o.position[k] = model.positions[i][k];
      o.normal[k] = model.normals[i][k];
    }
    for (int k = 0; k < 4; ++k) {
      o.joints[k] = model.joints[i][static_cast<std::size_t>(k)];
      o.weights[k] = model.weights[i][static_cast<std::size_t>(k)];
    }
    o.uv[0] = i < model.uvs.size() ? model.uvs[i].x() : 0.0f;
    o.uv[1] = i < model.uvs.size() ? model.uvs[i].y() : 0.0f;
  }
  SkinnedBuffers b;
  glGenVertexArrays(1, &b.vao);
  glBindVertexArray(b.vao);
  glGenBuffers(1, &b.vbo);
  glBindBuffer(GL_ARRAY_BUFFER, b.vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(v.size() * sizeof(SkinnedVertex)), v.data(), GL_STATIC_DRAW);
  glGenBuffers(1, &b.ebo);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, b.ebo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(model.indices.size() * sizeof(std::uint32_t)),
               model.indices.data(), GL_STATIC_DRAW);
  constexpr GLsizei stride = sizeof(SkinnedVertex);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(offsetof(SkinnedVertex, position)));
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(offsetof(SkinnedVertex, normal)));
  glVertexAttribIPointer(2, 4, GL_UNSIGNED_SHORT, stride, reinterpret_cast<const void*>(offsetof(SkinnedVertex, joints)));
  glVertexAttribPointer(3, 4, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(offsetof(SkinnedVertex, weights)));
  glVertexAttribPointer(4, 2, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(offsetof(SkinnedVertex, uv)));
  for (GLuint a = 0; a < 5; ++a) glEnableVertexAttribArray(a);
  glBindVertexArray(0);
  b.vertices = static_cast<GLsizei>(v.size());
  // The base-colour textures, row 0 first as in the image (glTF's v = 0 is the image's top
  // row, and GL's t = 0 the first row given: no flip).
  b.textures.resize(model.textures.size());
  if (!b.textures.empty()) glGenTextures(static_cast<GLsizei>(b.textures.size()), b.textures.data());
  for (std::size_t t = 0; t < model.textures.size(); ++t) {
    const body::Texture& tex = model.textures[t];
    glBindTexture(GL_TEXTURE_2D, b.textures[t]);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, tex.width, tex.height, 0, GL_RGBA, GL_UNSIGNED_BYTE, tex.rgba.data());
    glGenerateMipmap(GL_TEXTURE_2D);
    // The file's sampler (glTF's values are GL's enums; the loader allowed only glTF's).
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, tex.min_filter);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, tex.mag_filter);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, tex.wrap_s);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, tex.wrap_t);
  }
  glBindTexture(GL_TEXTURE_2D, 0);
  for (const auto& p : model.primitives) {
    b.primitives.emplace_back(p.first_index, p.index_count);
    GLuint texture = 0;
    if (p.material >= 0 && static_cast<std::size_t>(p.material) < model.materials.size()) {
      const int t = model.materials[static_cast<std::size_t>(p.material)].base_color_texture;
      if (t >= 0 && static_cast<std::size_t>(t) < b.textures.size()) texture = b.textures[static_cast<std::size_t>(t)];
    }
    b.primitive_texture.push_back(texture);
  }
  m.models.push_back(std::move(b));
  return static_cast<int>(m.models.size()) - 1;
}

void Renderer::configure(const InstallationConfig& config) {
  auto& m = *impl_;
  m.options = SceneOptions{.hall = config.render.hall, .debug_marks = config.render.debug_marks, .mask = false};
  m.bodies.reset();
  m.body_models.clear();
  if (config.render.fighter != FighterLook::skinned) return;
  m.bodies = std::make_unique<FighterBodies>(config);
  for (const auto& model : m.bodies->models()) m.body_models.push_back(upload_model(model));
  int worn = 0;
  for (const auto& c : m.bodies->characters()) worn += c.model >= 0;
  spdlog::info("render: {} of {} characters wear a skinned body ({} models)", worn, m.bodies->characters().size(),
               m.bodies->models().size());
}

void Renderer::set_options(const SceneOptions& options) { impl_->options = options; }
const SceneOptions& Renderer::options() const { return impl_->options; }
FighterBodies* Renderer::bodies() { return impl_->bodies.get(); }
const BodyFrame* Renderer::body_frame() const { return impl_->body; }

void Renderer::begin_frame(const FighterPose& pose) {
  auto& m = *impl_;
  m.body = m.bodies ? m.bodies->pose(pose) : nullptr;
  m.character = pose.present ? pose.character : -1;
  m.blob_count = 0;
  if (m.body) {
    // The palette once for every wall and eye of the frame.
    glBindBuffer(GL_UNIFORM_BUFFER, m.palette_ubo);
    glBufferSubData(GL_UNIFORM_BUFFER, 0, static_cast<GLsizeiptr>(m.body->palette.size() * sizeof(Eigen::Matrix4f)),
                    m.body->palette.data());
    glBindBuffer(GL_UNIFORM_BUFFER, 0);
    // A wide soft disc under the pelvis, a tighter one under each foot fading as it lifts.
    const Eigen::Vector3f& pelvis = m.body->shadow_points[0];
    m.blobs[m.blob_count++] = {{pelvis.x(), 0.0f, pelvis.z()}, {0.42f, 0.42f}, 0.45f};
    for (int k = 1; k < 3; ++k) {
      const Eigen::Vector3f& f = m.body->shadow_points[static_cast<std::size_t>(k)];
      const float lift = std::clamp((f.y() - 0.08f) / 0.35f, 0.0f, 1.0f);
      m.blobs[m.blob_count++] = {{f.x(), 0.0f, f.z()}, {0.16f, 0.16f}, 0.55f * (1.0f - lift)};
    }
  } else if (pose.present) {
    m.blobs[m.blob_count++] = {{static_cast<float>(pose.root.x), 0.0f, static_cast<float>(pose.root.z)},
                               {0.45f, 0.45f}, 0.5f};
  }
}

void Renderer::clear(int x, int y, int width, int height) {
  glViewport(x, y, width, height);
  glEnable(GL_SCISSOR_TEST);
  glScissor(x, y, width, height);
  if (impl_->options.mask) glClearColor(0.0f, 0.0f, 0.0f, 1.0f);
  else glClearColor(0.06f, 0.07f, 0.09f, 1.0f);
  glClearDepth(1.0);
  // Cleared under the hall too: where its rectangles meet edge to a cut edge (T-junctions)
  // the rasteriser may leave a pixel uncovered, which would keep the last image's colour.
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glDisable(GL_SCISSOR_TEST);
}

/// The floor of the hall for this view from a cache, when an earlier view mapped the floor to
/// the same pixels (the hall program and its vertex array bound). False: draw it.
bool Renderer::Impl::draw_cached_floor(const glm::mat4& vp) {
  Impl& m = *this;
  ++m.draws;
  // A blit ignores the colour mask (anaglyph) and cannot write a multisampled window.
  GLboolean mask[4] = {};
  glGetBooleanv(GL_COLOR_WRITEMASK, mask);
  GLint samples = 0;
  glGetIntegerv(GL_SAMPLE_BUFFERS, &samples);
  if (!mask[0] || !mask[1] || !mask[2] || !mask[3] || samples != 0) return false;
  GLint rect[4] = {};
  glGetIntegerv(GL_VIEWPORT, rect);
  const std::array<float, 9> key = floor_map(vp);
  FloorCache* cache = nullptr;
  for (FloorCache& c : m.floor_caches)
    if (c.fbo && c.width == rect[2] && c.height == rect[3] && same_map(c.key, key)) cache = &c;
  if (!cache) {
    // Cached only once seen before: a moving head's views never repeat.
    const bool seen = std::any_of(m.recent_maps.begin(), m.recent_maps.end(), [&](const auto& k) { return same_map(k, key); });
    m.recent_maps[m.recent_next++ % m.recent_maps.size()] = key;
    if (!seen) return false;
    cache = &*std::min_element(m.floor_caches.begin(), m.floor_caches.end(),
                               [](const FloorCache& a, const FloorCache& b) { return a.used < b.used; });
    if (!cache->fbo || cache->width != rect[2] || cache->height != rect[3]) {
      if (cache->fbo) {
        glDeleteFramebuffers(1, &cache->fbo);
        glDeleteRenderbuffers(1, &cache->colour);
      }
      glGenRenderbuffers(1, &cache->colour);
      glBindRenderbuffer(GL_RENDERBUFFER, cache->colour);
      glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, rect[2], rect[3]);
      glGenFramebuffers(1, &cache->fbo);
      cache->width = rect[2];
      cache->height = rect[3];
    }
    GLint draw_fbo = 0;
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &draw_fbo);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, cache->fbo);
    glFramebufferRenderbuffer(GL_DRAW_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, cache->colour);
    const bool complete = glCheckFramebufferStatus(GL_DRAW_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
    if (complete) {
      glViewport(0, 0, rect[2], rect[3]);
      glClearColor(0.06f, 0.07f, 0.09f, 1.0f);
      glClear(GL_COLOR_BUFFER_BIT);
      glDrawArrays(GL_TRIANGLES, 0, m.floor_count);
      glViewport(rect[0], rect[1], rect[2], rect[3]);
    }
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, static_cast<GLuint>(draw_fbo));
    if (!complete) {
      glDeleteFramebuffers(1, &cache->fbo);
      glDeleteRenderbuffers(1, &cache->colour);
      *cache = {};
      return false;
    }
    cache->key = key;
  }
  cache->used = m.draws;
  GLint read_fbo = 0;
  glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &read_fbo);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, cache->fbo);
  glBlitFramebuffer(0, 0, rect[2], rect[3], rect[0], rect[1], rect[0] + rect[2], rect[1] + rect[3], GL_COLOR_BUFFER_BIT,
                    GL_NEAREST);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, static_cast<GLuint>(read_fbo));
  return true;
}

void Renderer::draw(const EyeView& view, std::span<const DrawItem> items) {
  auto& m = *impl_;
  const SceneOptions& o = m.options;
  const glm::mat4 vp = glm::mat4(view.projection * view.view);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_CULL_FACE);  // open cylinders: their insides may show at the ends
  if (o.hall && !o.mask) {
    // The inside of a box: no surface hides another, no depth test (nor depth written: the
    // fighter, drawn after, is inside it).
    glDisable(GL_DEPTH_TEST);
    glUseProgram(m.hall);
    glUniformMatrix4fv(m.hall_vp, 1, GL_FALSE, glm::value_ptr(vp));
    glBindVertexArray(m.hall_vao);
    if (!m.draw_cached_floor(vp)) glDrawArrays(GL_TRIANGLES, 0, m.floor_count);
    glDrawArrays(GL_TRIANGLES, m.floor_count, m.hall_count - m.floor_count);
    if (m.blob_count > 0) {
      // Multiplied into the floor just drawn.
      glUseProgram(m.shadow);
      glUniformMatrix4fv(m.shadow_vp, 1, GL_FALSE, glm::value_ptr(vp));
      glEnable(GL_BLEND);
      glBlendFunc(GL_DST_COLOR, GL_ZERO);
      glBindVertexArray(m.quad_vao);
      for (std::size_t i = 0; i < m.blob_count; ++i) {
        const Blob& b = m.blobs[i];
        if (b.strength <= 0.01f) continue;
        glUniform3f(m.shadow_centre, b.centre.x, 0.002f, b.centre.z);
        glUniform2f(m.shadow_radius, b.radius.x, b.radius.y);
        glUniform1f(m.shadow_strength, b.strength);
        glDrawArrays(GL_TRIANGLES, 0, 6);
      }
      glDisable(GL_BLEND);
    }
    glEnable(GL_DEPTH_TEST);
  }
  if ((o.debug_marks || !o.hall) && !o.mask) {
    glUseProgram(m.lines);
    glUniformMatrix4fv(m.lines_vp, 1, GL_FALSE, glm::value_ptr(vp));
    glBindVertexArray(m.line_vao);
    glDrawArrays(GL_LINES, 0, m.line_count);
  }
  if (m.body) {
    const SkinnedBuffers& b = m.models[static_cast<std::size_t>(m.body_models[static_cast<std::size_t>(m.body->model)])];
    glUseProgram(m.skinned);
    glUniformMatrix4fv(m.skinned_vp, 1, GL_FALSE, glm::value_ptr(vp));
    glUniform1i(m.skinned_mask, o.mask ? 1 : 0);
    glBindBufferBase(GL_UNIFORM_BUFFER, 0, m.palette_ubo);
    glBindVertexArray(b.vao);
    glUniform1i(m.skinned_base, 0);
    glActiveTexture(GL_TEXTURE0);
    for (std::size_t p = 0; p < b.primitives.size(); ++p) {
      const auto& c = m.body->colours[p];
      glUniform3f(m.skinned_colour, c[0], c[1], c[2]);
      const GLuint texture = b.primitive_texture[p];
      glUniform1i(m.skinned_textured, texture != 0 ? 1 : 0);
      glBindTexture(GL_TEXTURE_2D, texture);
      glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(b.primitives[p].second), GL_UNSIGNED_INT,
                     reinterpret_cast<const void*>(static_cast<std::size_t>(b.primitives[p].first) * sizeof(std::uint32_t)));
    }
    glBindTexture(GL_TEXTURE_2D, 0);
  }
  glUseProgram(m.lit);
  glUniformMatrix4fv(m.lit_vp, 1, GL_FALSE, glm::value_ptr(vp));
  glUniform1i(m.lit_mask, o.mask ? 1 : 0);
  m.sphere_instances.clear();
  m.cylinder_instances.clear();
  // A mask with a body is the body alone (the silhouette checks'): no item is drawn, whatever
  // its colour (the capsules are told from other items only by colour).
  const std::span<const DrawItem> drawn = o.mask && m.body ? std::span<const DrawItem>() : items;
  for (const auto& item : drawn) {
    if (m.body && is_fighter_item(item, m.character)) continue;  // the body instead
    if (!o.debug_marks && is_target_item(item)) continue;
    if (o.mask && !is_fighter_item(item, m.character)) continue;
    std::vector<float>& out = item.mesh == Mesh::sphere ? m.sphere_instances : m.cylinder_instances;
    const float* model = glm::value_ptr(item.model);
    out.insert(out.end(), model, model + 16);
    out.insert(out.end(), {item.colour.x, item.colour.y, item.colour.z});
  }
  for (const auto& [mesh, data] : {std::pair<const MeshBuffers*, const std::vector<float>*>{&m.sphere, &m.sphere_instances},
                                   {&m.cylinder, &m.cylinder_instances}}) {
    if (data->empty()) continue;
    glBindBuffer(GL_ARRAY_BUFFER, mesh->instances);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data->size() * sizeof(float)), data->data(), GL_STREAM_DRAW);
    glBindVertexArray(mesh->vao);
    glDrawElementsInstanced(GL_TRIANGLES, mesh->count, GL_UNSIGNED_INT, nullptr,
                            static_cast<GLsizei>(data->size() / kInstanceFloats));
  }
  glBindVertexArray(0);
}

void Renderer::skin_on_gpu(int model, std::span<const Eigen::Matrix4f> palette, std::vector<Eigen::Vector3f>& positions,
                           std::vector<Eigen::Vector3f>& normals) {
  auto& m = *impl_;
  const SkinnedBuffers& b = m.models.at(static_cast<std::size_t>(model));
  if (palette.size() > static_cast<std::size_t>(body::kMaxJoints)) throw Error("gl", "palette", "palette too large");
  glBindBuffer(GL_UNIFORM_BUFFER, m.palette_ubo);
  glBufferSubData(GL_UNIFORM_BUFFER, 0, static_cast<GLsizeiptr>(palette.size() * sizeof(Eigen::Matrix4f)), palette.data());
  glBindBuffer(GL_UNIFORM_BUFFER, 0);
  const std::size_t n = static_cast<std::size_t>(b.vertices);
  const GLsizeiptr bytes = static_cast<GLsizeiptr>(n * 6 * sizeof(float));
  if (!m.feedback_buffer) glGenBuffers(1, &m.feedback_buffer);
  glBindBuffer(GL_TRANSFORM_FEEDBACK_BUFFER, m.feedback_buffer);
  glBufferData(GL_TRANSFORM_FEEDBACK_BUFFER, bytes, nullptr, GL_STREAM_READ);
  glUseProgram(m.skinned_feedback);
  glBindBufferBase(GL_UNIFORM_BUFFER, 0, m.palette_ubo);
  glBindBufferBase(GL_TRANSFORM_FEEDBACK_BUFFER, 0, m.feedback_buffer);
  glBindVertexArray(b.vao);
  glEnable(GL_RASTERIZER_DISCARD);
  glBeginTransformFeedback(GL_POINTS);
  glDrawArrays(GL_POINTS, 0, b.vertices);
  glEndTransformFeedback();
  glDisable(GL_RASTERIZER_DISCARD);
  glBindVertexArray(0);
  m.feedback.resize(n * 6);
  glGetBufferSubData(GL_TRANSFORM_FEEDBACK_BUFFER, 0, bytes, m.feedback.data());
  glBindBufferBase(GL_TRANSFORM_FEEDBACK_BUFFER, 0, 0);
  if (const GLenum e = glGetError(); e != GL_NO_ERROR)
    throw Error("gl", "feedback", "transform feedback failed: GL error 0x" + std::to_string(e));
  positions.resize(n);
  normals.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    positions[i] = Eigen::Vector3f(m.feedback[6 * i], m.feedback[6 * i + 1], m.feedback[6 * i + 2]);
    normals[i] = Eigen::Vector3f(m.feedback[6 * i + 3], m.feedback[6 * i + 4], m.feedback[6 * i + 5]);
  }
}

std::string gl_description() {
  auto str = [](GLenum e) {
    const auto* s = reinterpret_cast<const char*>(glGetString(e));
    return std::string(s ? s : "?");
  };
  return str(GL_VERSION) + " / " + str(GL_RENDERER);
}

}  // namespace kumite::app
