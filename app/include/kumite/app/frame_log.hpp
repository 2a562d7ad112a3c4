#pragma once
// frames.jsonl: one JSON object per frame (headless runs, and windowed runs with --log):
// frame, time_s, head {position m, quaternion w,x,y,z}, eyes {left, right} (m), walls
// {name: {left|right: {view, projection}}} (16 numbers each, column-major, OpenGL
// convention), fighter {state, character, character_name}, events [...], pose_age_ms,
// tracking_latency_ms (its part from the frame set's camera time to the pose published),
// latch_ms, predicted_ahead_ms (the head predicted this far past the moment it was taken:
// to the frame's vsync plus display_latency_ms), console {...}. Written to a temporary file, renamed into place by close() (nothing
// half-written).
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "kumite/app/installation.hpp"

namespace kumite::app {

class FrameLog {
 public:
  explicit FrameLog(std::filesystem::path path);
  ~FrameLog();  ///< without close(): the temporary file is removed
  FrameLog(const FrameLog&) = delete;
  FrameLog& operator=(const FrameLog&) = delete;
  void write(const FrameData& frame, const ConsoleState& console,
             const std::vector<std::string>& wall_names, bool stereo);
  void close();

 private:
  std::filesystem::path path_, tmp_;
  std::ofstream out_;
  bool closed_ = false;
};

/// The JSON line for one frame (exposed for tests).
std::string frame_json(const FrameData& frame, const ConsoleState& console,
                       const std::vector<std::string>& wall_names, bool stereo);

}  // namespace kumite::app
