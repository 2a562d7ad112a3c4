#pragma once
// Off-screen rendering with no display: an EGL context on the surfaceless platform (Mesa
// llvmpipe here), OpenGL 3.3 core, rendering into framebuffer objects; images read back and
// written as PNG, on a writer thread so the frame loop never waits for encoding or the disk.
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
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

/// Writes a top-row-first RGBA8 image as an RGB PNG (atomically; the alpha of a rendered
/// frame carries nothing). Throws kumite::Error naming it.
void write_png(const std::filesystem::path& path, int width, int height,
               const std::vector<std::uint8_t>& rgba);

/// PNGs written on a thread of their own (a 1080p image takes about 0.1 s to encode here).
/// Real time: push() never waits; an image that finds `queue_images` already waiting is
/// dropped and counted (the writer is behind). Simulated time: push() waits for room, so
/// every image asked for is written.
class PngWriter {
 public:
  PngWriter(std::size_t queue_images, bool wait_when_full);
  ~PngWriter();  ///< writes what is queued, then stops
  PngWriter(const PngWriter&) = delete;
  PngWriter& operator=(const PngWriter&) = delete;
  /// Queues the image (RGBA8, top row first); false when it was dropped.
  bool push(std::filesystem::path path, int width, int height, std::vector<std::uint8_t> rgba);
  /// Waits until every queued image is written.
  void flush();
  std::uint64_t written() const;
  std::uint64_t dropped() const;
  /// Write errors since the last call (one line each, naming the file); the writer goes on.
  std::vector<std::string> take_errors();

 private:
  struct Job {
    std::filesystem::path path;
    int width = 0, height = 0;
    std::vector<std::uint8_t> rgba;
  };
  void run();

  const std::size_t capacity_;
  const bool wait_when_full_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Job> queue_;
  bool busy_ = false, stop_ = false;
  std::uint64_t written_ = 0, dropped_ = 0;
  std::vector<std::string> errors_;
  std::thread thread_;
};

}  // namespace kumite::app
