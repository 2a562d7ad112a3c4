#pragma once
// Off-screen rendering with no display: an EGL context on the surfaceless platform (Mesa
// llvmpipe here), OpenGL 3.3 core, rendering into framebuffer objects; images read back and
// written as PNG.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

namespace kumite::app {

/// An EGL OpenGL 3.3 core context with no surface, current on the creating thread.
/// Throws kumite::Error("gl", ...) saying what is missing.
class HeadlessContext {
 public:
  HeadlessContext();
  ~HeadlessContext();
  HeadlessContext(const HeadlessContext&) = delete;
  HeadlessContext& operator=(const HeadlessContext&) = delete;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// An RGBA8 + depth framebuffer object of a fixed size.
class OffscreenTarget {
 public:
  OffscreenTarget(int width, int height);
  ~OffscreenTarget();
  OffscreenTarget(const OffscreenTarget&) = delete;
  OffscreenTarget& operator=(const OffscreenTarget&) = delete;
  void bind() const;
  int width() const { return width_; }
  int height() const { return height_; }
  /// Reads the image back, top row first, RGBA8 (4 bytes per pixel).
  void read(std::vector<std::uint8_t>& rgba) const;

 private:
  int width_, height_;
  unsigned fbo_ = 0, colour_ = 0, depth_ = 0;
};

/// Writes a top-row-first RGBA8 image as PNG (atomically). Throws kumite::Error naming it.
void write_png(const std::filesystem::path& path, int width, int height,
               const std::vector<std::uint8_t>& rgba);

}  // namespace kumite::app
