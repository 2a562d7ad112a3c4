#pragma once
// Recording and replaying a session (issue 13, first steps).
//
// `kumite ... --record DIR` writes DIR/manifest.json and DIR/session.jsonl. session.jsonl:
// a first line {"start": s, "has_tracker": bool}, then one line per frame {"frame", "input":
// the FrameInput (times, keyed orders, the tracker's snapshot and clock; numbers written
// exactly), "hash": {field: 16 hex digits}} — the state's hashes per field (state_hashes).
// Lines are written by a writer thread (the frame loop only queues a copy; when the queue is
// full the frame is dropped and counted, never waited for), one write(2) each, so a session
// killed with SIGKILL is readable up to its last complete line. manifest.json is written
// (atomically) when recording starts, with "complete": false, and again at the end with the
// counts, drops and the FNV-1a 64 checksum of session.jsonl.
//
// `kumite --replay DIR` re-runs the frames from the recorded inputs with the config and
// orders script the manifest names (their checksums are compared and a change is said), and
// checks every frame's hashes against the recording: the first difference is reported with
// its frame and field.
#include <array>
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "kumite/app/installation.hpp"

namespace kumite::app {

/// Session format version this build writes and reads.
constexpr int kSessionVersion = 1;

/// Hashes (FNV-1a 64 over the exact bytes) of a frame's state, per field.
struct StateHashes {
  static constexpr std::array<std::string_view, 6> kFields = {"time", "head", "eyes", "views", "fighter", "events"};
  std::array<std::uint64_t, kFields.size()> value{};
  bool operator==(const StateHashes&) const = default;
};
StateHashes state_hashes(const FrameData& frame);

/// FNV-1a 64 of a file's bytes (0 when it cannot be read).
std::uint64_t file_checksum(const std::filesystem::path& path);

struct SessionInfo {
  std::filesystem::path config;                        ///< absolute
  std::optional<std::filesystem::path> orders_script;  ///< absolute
  bool mono_eyes = false;                              ///< InstallationOptions::mono_eyes
};

class SessionRecorder {
 public:
  /// Creates DIR (or uses an empty existing one) and writes the first manifest. Throws
  /// kumite::Error("io", ...) naming the path.
  SessionRecorder(std::filesystem::path dir, SessionInfo info, std::size_t queue_frames = 512);
  ~SessionRecorder();  ///< close() if not done (errors then only logged)
  SessionRecorder(const SessionRecorder&) = delete;
  SessionRecorder& operator=(const SessionRecorder&) = delete;

  /// From Installation::start.
  void started(Timestamp start, bool has_tracker);
  /// From the frame loop: queues a copy, never waits for the disk (full queue: dropped, counted).
  void push(std::uint64_t frame, const FrameInput& input, const StateHashes& hashes);
  /// Writes what is queued, then the final manifest. Throws kumite::Error on a failed write.
  void close();
  std::uint64_t frames_written() const;
  std::uint64_t dropped() const;
  const std::filesystem::path& dir() const { return dir_; }

 private:
  struct Item {
    std::uint64_t frame = 0;
    FrameInput input;
    StateHashes hashes;
    std::optional<std::pair<Timestamp, bool>> start;
  };
  void run();
  void write_manifest(bool complete);
  void write_line(const std::string& line);

  std::filesystem::path dir_;
  SessionInfo info_;
  int fd_ = -1;
  // A single-producer (the frame loop) single-consumer (the writer) ring of preallocated
  // items: the frame loop never takes a lock the writer holds (the writer runs at a low
  // priority; a lock it held while descheduled would stall the frame) and, once the slots'
  // vectors and strings have grown, never allocates.
  std::vector<Item> slots_;
  std::atomic<std::uint64_t> head_{0}, tail_{0};
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> written_{0}, dropped_{0}, pushed_{0};
  std::uint64_t checksum_ = 14695981039346656037ull;  // the writer's (read after join)
  std::string error_;                                 // the writer's (read after join)
  double created_unix_s_ = 0;
  std::thread thread_;
};

struct ReplayReport {
  std::uint64_t frames_recorded = 0;  ///< complete frame lines in session.jsonl
  std::uint64_t frames_replayed = 0;  ///< replayed and compared
  bool identical = true;
  std::optional<std::uint64_t> first_difference_frame;
  std::string first_difference_field;
  std::vector<std::string> notes;     ///< one line each: what could not be replayed, changed files
  double wall_s = 0;                  ///< s, the replay's own time
  double session_s = 0;               ///< s, the recorded frames' time span
};

/// Re-runs DIR's frames without rendering and compares them. `config_override`: replay with
/// another installation file than the manifest's (its checksum difference is noted).
/// Throws kumite::Error for a session that cannot be replayed at all (no manifest, a newer
/// version, no start line), naming the file.
ReplayReport replay_session(const std::filesystem::path& dir,
                            const std::optional<std::filesystem::path>& config_override = std::nullopt,
                            const std::optional<std::filesystem::path>& data_dir = std::nullopt);

}  // namespace kumite::app
