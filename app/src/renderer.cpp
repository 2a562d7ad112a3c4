#include "kumite/app/renderer.hpp"

#include <cmath>
#include <string>
#include <vector>

#include <glm/gtc/type_ptr.hpp>

#include "gl.hpp"
#include "kumite/common/error.hpp"

namespace kumite::app {

namespace {

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

constexpr const char* kLitFragment = R"(#version 330 core
in vec3 v_normal;
flat in vec3 v_colour;
out vec4 o_colour;
void main() {
  // A key light from above-front-left and a dimmer fill from behind: shapes read in 3D.
  vec3 n = normalize(v_normal);
  float key = max(dot(n, normalize(vec3(-0.4, 0.8, 0.6))), 0.0);
  float fill = max(dot(n, normalize(vec3(0.5, 0.2, -0.8))), 0.0);
  o_colour = vec4(v_colour * (0.30 + 0.70 * key + 0.25 * fill), 1.0);
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

GLuint compile(GLenum type, const char* source) {
  const GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &source, nullptr);
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

GLuint program(const char* vs, const char* fs) {
  const GLuint p = glCreateProgram();
  const GLuint v = compile(GL_VERTEX_SHADER, vs), f = compile(GL_FRAGMENT_SHADER, fs);
  glAttachShader(p, v);
  glAttachShader(p, f);
  glLinkProgram(p);
  glDeleteShader(v);
  glDeleteShader(f);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) throw Error("gl", "shader", "shader program does not link");
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

}  // namespace

struct Renderer::Impl {
  GLuint lit = 0, lines = 0;
  GLint lit_vp = -1, lines_vp = -1;
  MeshBuffers sphere, cylinder;
  std::vector<float> sphere_instances, cylinder_instances;  ///< kept: a warm frame allocates nothing
  GLuint line_vao = 0, line_vbo = 0;
  GLsizei line_count = 0;
};

Renderer::Renderer(std::span<const WallFrame> walls) : impl_(std::make_unique<Impl>()) {
  GLint major = 0, minor = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  if (major * 10 + minor < 33)
    throw Error("gl", "version", "OpenGL 3.3 is needed; the context has " + gl_description());
  auto& m = *impl_;
  m.lit = program(kLitVertex, kLitFragment);
  m.lit_vp = glGetUniformLocation(m.lit, "u_view_projection");
  m.lines = program(kLineVertex, kLineFragment);
  m.lines_vp = glGetUniformLocation(m.lines, "u_view_projection");
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
  glBindVertexArray(0);
  m.line_count = static_cast<GLsizei>(lines.size());
}

Renderer::~Renderer() {
  auto& m = *impl_;
  for (auto* b : {&m.sphere, &m.cylinder}) {
    glDeleteBuffers(1, &b->vbo);
    glDeleteBuffers(1, &b->ebo);
    glDeleteBuffers(1, &b->instances);
    glDeleteVertexArrays(1, &b->vao);
  }
  glDeleteBuffers(1, &m.line_vbo);
  glDeleteVertexArrays(1, &m.line_vao);
  glDeleteProgram(m.lit);
  glDeleteProgram(m.lines);
}

void Renderer::clear(int x, int y, int width, int height) {
  glViewport(x, y, width, height);
  glEnable(GL_SCISSOR_TEST);
  glScissor(x, y, width, height);
  glClearColor(0.06f, 0.07f, 0.09f, 1.0f);
  glClearDepth(1.0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glDisable(GL_SCISSOR_TEST);
}

void Renderer::draw(const EyeView& view, std::span<const DrawItem> items) {
  auto& m = *impl_;
  const glm::mat4 vp = glm::mat4(view.projection * view.view);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_CULL_FACE);  // open cylinders: their insides may show at the ends
  glUseProgram(m.lines);
  glUniformMatrix4fv(m.lines_vp, 1, GL_FALSE, glm::value_ptr(vp));
  glBindVertexArray(m.line_vao);
  glDrawArrays(GL_LINES, 0, m.line_count);
  glUseProgram(m.lit);
  glUniformMatrix4fv(m.lit_vp, 1, GL_FALSE, glm::value_ptr(vp));
  m.sphere_instances.clear();
  m.cylinder_instances.clear();
  for (const auto& item : items) {
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

std::string gl_description() {
  auto str = [](GLenum e) {
    const auto* s = reinterpret_cast<const char*>(glGetString(e));
    return std::string(s ? s : "?");
  };
  return str(GL_VERSION) + " / " + str(GL_RENDERER);
}

}  // namespace kumite::app
