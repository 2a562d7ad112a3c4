#pragma once
// frames.jsonl: one JSON object per frame (headless runs, and windowed runs with --log):
// frame, time_s, head {position m, quaternion w,x,y,z}, eyes {left, right} (m), walls
// {name: {left|right: {view, projection}}} (16 numbers each, column-major, OpenGL
// convention), fighter {state, character, character_name}, events [...], pose_age_ms,
// tracking_latency_ms (its part from the frame set's camera time to the pose published),
// latch_ms, predicted_ahead_ms (the head predicted this far past the moment it was taken:
// to the frame's vsync plus display_latency_ms), console {...}.
//
// A log, not a document: it is written under its final name from the first frame on, one
// write(2) per line, so at any moment (`tail -f`, a run stopped by SIGINT/SIGTERM) the file
// holds every frame logged so far as complete lines. A process killed by SIGKILL (or a crash)
// mid-write may leave its last line cut (a fatal signal can end a long write(2) part-way), as
// can a power cut or a full disk: every reader leaves a cut last line out and says so
// (export_log). close() syncs to disk and reports a failed write. A previous run's file of the
// same name is replaced when the log opens.
//
// Bounded: with a budget (`[log] frames_budget_mb`), when the file would grow past half of it,
// it is renamed to frames.1.jsonl (replacing the one before) and a new frames.jsonl begins, so
// a run of any length keeps its newest frames in frames.jsonl and the ones before them in
// frames.1.jsonl, and never holds more than the budget on disk (each rotation is logged).
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "kumite/app/installation.hpp"

namespace kumite::app {

class FrameLog {
 public:
  /// Creates (or empties) `path`. Throws kumite::Error("io", "open") naming it. `budget_bytes`
  /// > 0: at most that much on disk, in two halves (above); 0: unbounded.
  explicit FrameLog(std::filesystem::path path, std::uint64_t budget_bytes = 0);
  ~FrameLog();  ///< without close(): the lines written stay (an error is not reported)
  FrameLog(const FrameLog&) = delete;
  FrameLog& operator=(const FrameLog&) = delete;
  /// Appends the frame's line. Throws kumite::Error("io", "write") naming the file.
  void write(const FrameData& frame, const ConsoleState& console,
             const std::vector<std::string>& wall_names, bool stereo);
  /// Appends one line (a newline is added).
  void write_line(std::string line);
  /// Syncs and closes the file. Throws kumite::Error("io", "write") naming the file.
  void close();
  const std::filesystem::path& path() const { return path_; }
  /// The previous half (frames.1.jsonl beside frames.jsonl).
  std::filesystem::path previous_path() const;
  std::uint64_t rotations() const { return rotations_; }

 private:
  void rotate();
  std::filesystem::path path_;
  int fd_ = -1;
  std::uint64_t budget_ = 0, bytes_ = 0, rotations_ = 0;
};

/// The JSON line for one frame (exposed for tests).
std::string frame_json(const FrameData& frame, const ConsoleState& console,
                       const std::vector<std::string>& wall_names, bool stereo);

}  // namespace kumite::app
