#pragma once
// The GL scene renderer (OpenGL 3.3 core): the training hall (procedural floor and walls, a
// soft contact shadow), the fighter as a GPU-skinned body (linear blend skinning in the vertex
// shader, the joint palette in a std140 uniform block, joints as integer attributes) or as lit
// capsules, and the debug marks, drawn with a given view and projection into whatever
// framebuffer and viewport is bound.
// Needs a current GL context (EGL headless or a GLFW window) for its whole life.
#include <memory>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "kumite/app/scene.hpp"

namespace kumite::body {
struct SkinnedModel;
}

namespace kumite::app {

struct InstallationConfig;
struct FighterPose;
class FighterBodies;
struct BodyFrame;

/// What the renderer draws besides the items ([render] in the installation file).
struct SceneOptions {
  bool hall = true;          ///< the training hall (floor, walls, light, contact shadow)
  bool debug_marks = false;  ///< the strike's target sphere, the floor grid, the walls' outlines
  /// A mask: the body (or capsules) in white on black, nothing else (silhouette checks).
  bool mask = false;
};

class Renderer {
 public:
  /// Builds shaders and meshes. Throws kumite::Error("gl", ...) when the context lacks GL 3.3.
  explicit Renderer(std::span<const WallFrame> walls);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// [render] of the installation: the options, and with fighter = "skinned" every
  /// character's body loaded and uploaded (a body that cannot be: one warning, capsules).
  void configure(const InstallationConfig& config);
  void set_options(const SceneOptions& options);
  const SceneOptions& options() const;
  /// The bodies configure() loaded (nullptr: capsules).
  FighterBodies* bodies();

  /// Once per frame, before its draws: the fighter's body retargeted onto its pose (its joint
  /// palette uploaded once for every wall and eye) and the contact shadow placed. Without a
  /// body for the pose, its capsule items are drawn.
  void begin_frame(const FighterPose& pose);
  /// The body begin_frame() drew (nullptr: capsules or none).
  const BodyFrame* body_frame() const;

  /// Clears colour (dark room) and depth of the current viewport (scissored).
  void clear(int x, int y, int width, int height);
  /// Draws the room and `items` with `view` and `projection` (room -> clip).
  void draw(const EyeView& view, std::span<const DrawItem> items);

  /// Uploads a model for skin_on_gpu (tests; configure() uploads the bodies' models itself).
  int upload_model(const body::SkinnedModel& model);
  /// The draw path's vertex shader run over `model`'s vertices with `palette`, captured by
  /// transform feedback (rasteriser off): skinned positions and normals (not renormalised).
  /// Needs a complete framebuffer bound (a surfaceless context has none of its own).
  void skin_on_gpu(int model, std::span<const Eigen::Matrix4f> palette, std::vector<Eigen::Vector3f>& positions,
                   std::vector<Eigen::Vector3f>& normals);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// "OpenGL 3.3 (Core Profile) Mesa 22.3.6 / llvmpipe (LLVM 15, 256 bits)": for the logs.
std::string gl_description();

}  // namespace kumite::app
