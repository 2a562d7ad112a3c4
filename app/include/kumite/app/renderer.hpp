#pragma once
// The GL scene renderer (OpenGL 3.3 core): the fighter's lit primitives and the room's lines,
// drawn with a given view and projection into whatever framebuffer and viewport is bound.
// Needs a current GL context (EGL headless or a GLFW window) for its whole life.
#include <memory>
#include <span>

#include "kumite/app/scene.hpp"

namespace kumite::app {

class Renderer {
 public:
  /// Builds shaders and meshes. Throws kumite::Error("gl", ...) when the context lacks GL 3.3.
  explicit Renderer(std::span<const WallFrame> walls);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// Clears colour (dark room) and depth of the current viewport (scissored).
  void clear(int x, int y, int width, int height);
  /// Draws the room and `items` with `view` and `projection` (room -> clip).
  void draw(const EyeView& view, std::span<const DrawItem> items);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// "OpenGL 3.3 (Core Profile) Mesa 22.3.6 / llvmpipe (LLVM 15, 256 bits)": for the logs.
std::string gl_description();

}  // namespace kumite::app
