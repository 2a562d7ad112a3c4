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
layout(std140) uniform Palette { mat4 u_joints[128]; };
uniform mat4 u_view_projection;
out vec3 v_world;
out vec3 v_normal;
void main() {
  mat4 m = a_weights.x * u_joints[a_joints.x] + a_weights.y * u_joints[a_joints.y] +
           a_weights.z * u_joints[a_joints.z] + a_weights.w * u_joints[a_joints.w];
  vec4 w = m * vec4(a_position, 1.0);
  v_world = w.xyz;
  v_normal = mat3(m) * a_normal;
  gl_Position = u_view_projection * w;
}
)";

constexpr const char* kSkinnedFragment = R"(
in vec3 v_world;
in vec3 v_normal;
uniform vec3 u_colour;
out vec4 o_colour;
void main() {
  vec3 n = normalize(v_normal);
  // Triangles seen from behind (an open mesh's inside) lit as their front.
  if (!gl_FrontFacing) n = -n;
  o_colour = vec4(shade(u_colour, n), 1.0);
}
)";

// The training hall: a floor, walls and a ceiling whose look is made here from the position
// (no textures): a wooden floor of staggered planks with a square mat of panels in the
// middle, walls of dark wood panelling under plaster between pillars, a beamed ceiling; lit by
// three lamps over the mat (falling off with distance) and an ambient.
constexpr const char* kHallVertex = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in float a_surface;  // 0 floor, 1 wall, 2 ceiling
uniform mat4 u_view_projection;
out vec3 v_world;
out vec3 v_normal;
out vec3 v_light;
flat out int v_surface;
void main() {
  v_world = a_position;
  v_normal = a_normal;
  v_surface = int(a_surface + 0.5);
  // The lamps per vertex (the hall is a 0.5 m grid): the fragment shader only makes the look.
  vec3 light = vec3(0.20);
  const vec3 lamps[3] = vec3[3](vec3(0.0, 4.3, -2.5), vec3(0.0, 4.3, 0.5), vec3(0.0, 4.3, -5.5));
  for (int i = 0; i < 3; ++i) {
    vec3 l = lamps[i] - a_position;
    float d2 = dot(l, l);
    light += vec3(1.0, 0.93, 0.82) * (9.0 * max(dot(a_normal, l * inversesqrt(d2)), 0.0) / (1.0 + d2));
  }
  v_light = v_surface == 2 ? vec3(0.35) : light;
  gl_Position = u_view_projection * vec4(a_position, 1.0);
}
)";

constexpr const char* kHallFragment = R"(#version 330 core
in vec3 v_world;
in vec3 v_normal;
in vec3 v_light;
flat in int v_surface;
out vec4 o_colour;
// Cheap per-cell variation (the R2 sequence): no sin, llvmpipe runs this per pixel.
float hash(vec2 p) { return fract(p.x * 0.7548776 + p.y * 0.5698403 + 0.31); }
// 1 on a seam of width w (m) at every multiple of `period` along x; aa: the pixel's footprint.
float seam(float x, float period, float w, float aa) {
  float d = abs(fract(x / period + 0.5) - 0.5) * period;
  return 1.0 - smoothstep(w * 0.5, w * 0.5 + aa, d);
}
float seam(float x, float period, float w) { return seam(x, period, w, max(fwidth(x), 1e-4)); }
vec3 floor_colour(vec2 p) {
  float aa = max(fwidth(p.x) + fwidth(p.y), 1e-4);
  // The mat: 6 m x 8 m (x -3..3, z -6..2), panels 1 m x 2 m, a red border 0.3 m wide.
  vec2 q = p - vec2(0.0, -2.0);
  vec2 a = abs(q);
  if (a.x < 3.0 && a.y < 4.0) {
    if (a.x > 2.7 || a.y > 3.7) return vec3(0.36, 0.06, 0.05);
    vec3 panel = vec3(0.10, 0.17, 0.22) * (0.92 + 0.08 * hash(floor(vec2(q.x, q.y * 0.5))));
    return panel * (1.0 - 0.45 * max(seam(q.x, 1.0, 0.012, aa), seam(q.y, 2.0, 0.012, aa)));
  }
  // Wood: planks 0.18 m wide along z, 2.4 m long, staggered per row.
  float row = floor(p.x / 0.18);
  float z = p.y + hash(vec2(row, 7.0)) * 2.4;
  float tone = hash(vec2(row, floor(z / 2.4)));
  vec3 wood = mix(vec3(0.30, 0.19, 0.11), vec3(0.42, 0.28, 0.16), tone);
  return wood * (1.0 - 0.5 * max(seam(p.x, 0.18, 0.004, aa), seam(z, 2.4, 0.004, aa)));
}
vec3 wall_colour(vec3 p) {
  float u = abs(v_normal.x) > 0.5 ? p.z : p.x;  // along the wall
  float aa = max(fwidth(p.y), 1e-4);
  vec3 plaster = vec3(0.58, 0.54, 0.48);
  vec3 panel = vec3(0.24, 0.15, 0.09) * (1.0 - 0.35 * seam(u, 0.6, 0.01));
  vec3 c = mix(panel, plaster, smoothstep(1.1, 1.1 + aa, p.y));
  c = mix(c, vec3(0.20, 0.12, 0.07), 1.0 - smoothstep(0.0, aa, abs(p.y - 1.1) - 0.04));  // a rail
  float pillar = 1.0 - smoothstep(0.15, 0.15 + fwidth(u), abs(fract(u / 3.0 + 0.5) - 0.5) * 3.0);
  c = mix(c, vec3(0.27, 0.17, 0.10), pillar);
  c = mix(c, vec3(0.22, 0.14, 0.08), 1.0 - smoothstep(0.0, aa, abs(p.y - 3.4) - 0.12));  // a beam
  return c;
}
vec3 ceiling_colour(vec3 p) {
  return vec3(0.14, 0.12, 0.10) * (1.0 - 0.4 * seam(p.z, 2.0, 0.2));
}
void main() {
  vec3 base = v_surface == 0 ? floor_colour(v_world.xz) : (v_surface == 1 ? wall_colour(v_world) : ceiling_colour(v_world));
  o_colour = vec4(base * v_light, 1.0);
}
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
};

/// Per vertex: position, normal, four joints (u16), four weights: 48 bytes.
struct SkinnedVertex {
  float position[3];
  float normal[3];
  std::uint16_t joints[4];
  float weights[4];
};
static_assert(sizeof(SkinnedVertex) == 48);

/// The hall: floor, four walls, ceiling (m, room frame), inward normals, a surface id.
struct HallVertex {
  float position[3];
  float normal[3];
  float surface;
};

std::vector<HallVertex> hall_vertices() {
  constexpr float x0 = -6, x1 = 6, z0 = -11, z1 = 6, y1 = 4.5f;
  std::vector<HallVertex> v;
  // Each surface a grid of about 0.5 m cells: the lamps are lit per vertex.
  auto quad = [&](glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d, glm::vec3 n, float surface) {
    const int nu = std::max(1, static_cast<int>(std::ceil(glm::length(b - a) / 0.5f)));
    const int nv = std::max(1, static_cast<int>(std::ceil(glm::length(d - a) / 0.5f)));
    auto at = [&](int i, int j) {
      const float u = static_cast<float>(i) / static_cast<float>(nu), w = static_cast<float>(j) / static_cast<float>(nv);
      return a + (b - a) * u + (d - a) * w;
    };
    (void)c;
    for (int i = 0; i < nu; ++i)
      for (int j = 0; j < nv; ++j)
        for (const glm::vec3& p : {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i, j + 1)})
          v.push_back({{p.x, p.y, p.z}, {n.x, n.y, n.z}, surface});
  };
  quad({x0, 0, z0}, {x0, 0, z1}, {x1, 0, z1}, {x1, 0, z0}, {0, 1, 0}, 0);       // floor
  quad({x0, y1, z0}, {x1, y1, z0}, {x1, y1, z1}, {x0, y1, z1}, {0, -1, 0}, 2);  // ceiling
  quad({x0, 0, z0}, {x1, 0, z0}, {x1, y1, z0}, {x0, y1, z0}, {0, 0, 1}, 1);     // behind the fighter
  quad({x0, 0, z1}, {x0, y1, z1}, {x1, y1, z1}, {x1, 0, z1}, {0, 0, -1}, 1);    // behind the visitor
  quad({x0, 0, z0}, {x0, y1, z0}, {x0, y1, z1}, {x0, 0, z1}, {1, 0, 0}, 1);     // left
  quad({x1, 0, z0}, {x1, 0, z1}, {x1, y1, z1}, {x1, y1, z0}, {-1, 0, 0}, 1);    // right
  return v;
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
        hall_vp = -1, shadow_vp = -1, shadow_centre = -1, shadow_radius = -1, shadow_strength = -1;
  MeshBuffers sphere, cylinder;
  std::vector<float> sphere_instances, cylinder_instances;  ///< kept: a warm frame allocates nothing
  GLuint line_vao = 0, line_vbo = 0;
  GLsizei line_count = 0;
  GLuint hall_vao = 0, hall_vbo = 0;
  GLsizei hall_count = 0;
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
  const auto hall = hall_vertices();
  glGenVertexArrays(1, &m.hall_vao);
  glBindVertexArray(m.hall_vao);
  glGenBuffers(1, &m.hall_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, m.hall_vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(hall.size() * sizeof(HallVertex)), hall.data(), GL_STATIC_DRAW);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(HallVertex), nullptr);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, sizeof(HallVertex), reinterpret_cast<const void*>(offsetof(HallVertex, normal)));
  glVertexAttribPointer(2, 1, GL_FLOAT, GL_FALSE, sizeof(HallVertex), reinterpret_cast<const void*>(offsetof(HallVertex, surface)));
  for (GLuint a = 0; a < 3; ++a) glEnableVertexAttribArray(a);
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
    glDeleteBuffers(1, &b.vbo);
    glDeleteBuffers(1, &b.ebo);
    glDeleteVertexArrays(1, &b.vao);
  }
  glDeleteBuffers(1, &m.line_vbo);
  glDeleteVertexArrays(1, &m.line_vao);
  glDeleteBuffers(1, &m.hall_vbo);
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
  for (GLuint a = 0; a < 4; ++a) glEnableVertexAttribArray(a);
  glBindVertexArray(0);
  b.vertices = static_cast<GLsizei>(v.size());
  for (const auto& p : model.primitives) b.primitives.emplace_back(p.first_index, p.index_count);
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
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glDisable(GL_SCISSOR_TEST);
}

void Renderer::draw(const EyeView& view, std::span<const DrawItem> items) {
  auto& m = *impl_;
  const SceneOptions& o = m.options;
  const glm::mat4 vp = glm::mat4(view.projection * view.view);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_CULL_FACE);  // open cylinders: their insides may show at the ends
  if (o.hall && !o.mask) {
    glUseProgram(m.hall);
    glUniformMatrix4fv(m.hall_vp, 1, GL_FALSE, glm::value_ptr(vp));
    glBindVertexArray(m.hall_vao);
    glDrawArrays(GL_TRIANGLES, 0, m.hall_count);
    if (m.blob_count > 0) {
      // Multiplied into the floor just drawn; no depth written (the body stands in it).
      glUseProgram(m.shadow);
      glUniformMatrix4fv(m.shadow_vp, 1, GL_FALSE, glm::value_ptr(vp));
      glEnable(GL_BLEND);
      glBlendFunc(GL_DST_COLOR, GL_ZERO);
      glDepthMask(GL_FALSE);
      glDepthFunc(GL_LEQUAL);
      glBindVertexArray(m.quad_vao);
      for (std::size_t i = 0; i < m.blob_count; ++i) {
        const Blob& b = m.blobs[i];
        if (b.strength <= 0.01f) continue;
        glUniform3f(m.shadow_centre, b.centre.x, 0.002f, b.centre.z);
        glUniform2f(m.shadow_radius, b.radius.x, b.radius.y);
        glUniform1f(m.shadow_strength, b.strength);
        glDrawArrays(GL_TRIANGLES, 0, 6);
      }
      glDepthMask(GL_TRUE);
      glDepthFunc(GL_LESS);
      glDisable(GL_BLEND);
    }
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
    for (std::size_t p = 0; p < b.primitives.size(); ++p) {
      const auto& c = m.body->colours[p];
      glUniform3f(m.skinned_colour, c[0], c[1], c[2]);
      glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(b.primitives[p].second), GL_UNSIGNED_INT,
                     reinterpret_cast<const void*>(static_cast<std::size_t>(b.primitives[p].first) * sizeof(std::uint32_t)));
    }
  }
  glUseProgram(m.lit);
  glUniformMatrix4fv(m.lit_vp, 1, GL_FALSE, glm::value_ptr(vp));
  glUniform1i(m.lit_mask, o.mask ? 1 : 0);
  m.sphere_instances.clear();
  m.cylinder_instances.clear();
  for (const auto& item : items) {
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
