#pragma once
// Recording and replaying a session (issue 13).
//
// `kumite ... --record DIR` (or the record key) writes a session folder:
//   manifest.json   format, version, times, the snapshot's files with their sizes and checksums,
//                   the fighter database's path and checksum, counts, drops, the budget
//   snapshot/       the installation file, orders script, tracking.toml, rig calibration and
//                   character BVHs exactly as they were when recording started
//   cameras.bin     with a tracker: every camera frame set the tracker was handed, packed
//                   losslessly (tracking/camera_frames.hpp), for `--replay DIR --retrack`
//   states.bin      every frame's state whole (FrameData: head, eyes, views, the fighter's joints
//                   and rotations, events, what was drawn), exact binary (frame_states.hpp): what
//                   visitors saw, kept even when a later build would make other frames
//   session.jsonl   a first line {"start": s, "unix_s", "has_tracker", "first_frame",
//                   "cameras": [names]}, then one line per frame {"frame", "input": the
//                   FrameInput (times, keyed orders, the tracker's snapshot: head, state, frame
//                   sets, cameras, source counters, the visitor's bodies by role as measured,
//                   its strikes; its clock; numbers written exactly), "hash":
//                   {field: 16 hex digits}}: the state's hashes per field (state_hashes).
// Lines are written by a writer thread (the frame loop only queues a copy; when the queue is
// full the frame is dropped and counted, never waited for), one write(2) each, so a session
// killed with SIGKILL is readable up to its last complete line. manifest.json is written
// (atomically) when recording starts, with "complete": false, and again at the end with the
// counts, drops and the FNV-1a 64 checksum of session.jsonl. Past its disk budget the writer
// stops (one warning; the manifest says "stopped": "budget").
//
// `kumite --replay DIR` re-runs the frames from the recorded inputs with the snapshot's config,
// characters and orders script and checks every frame's hashes against the recording: the
// first difference is reported with its frame and field. A snapshot file missing, cut short or
// changed, a snapshot config that no longer validates, a changed database, a newer version, a
// killed recorder: one line each naming the file, and what can be replayed is.
#include <array>
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "kumite/app/frame_fields.hpp"
#include "kumite/app/installation.hpp"

namespace kumite::tracking {
struct FrameSet;
}

namespace kumite::app {

/// Session format version this build writes and reads (1: no snapshot, the config by path).
/// 5: the tracker's snapshot keeps the visitor's bodies as measured, by role ("bodies": the
/// glasses, gloves and shoes the fighter is given; a session before it gave the fighter the
/// head alone, as predicted, and its replay does the same); 4: the state hashes walk the frame's description (frame_fields.hpp) and the manifest keeps
/// its "frame_version"; 3: the tracker's snapshot as numbers (state, frame sets, cameras,
/// source counters) and the cameras' names in the start line; 2 kept it as a status line.
constexpr int kSessionVersion = 5;

/// Hashes (FNV-1a 64) of a frame's state, per group of fields (Field::hash).
struct StateHashes {
  static constexpr std::array<std::string_view, 6> kFields = kHashedNames;
  std::array<std::uint64_t, kFields.size()> value{};
  bool operator==(const StateHashes&) const = default;
};
/// Per group, FNV-1a 64 of the bytes states.bin keeps of its fields (Field::hash), the fields
/// of frame version `frame_version` and before (a session of an older frame version hashed
/// none added since).
StateHashes state_hashes(const FrameData& frame, int frame_version = kFrameVersion);
/// Sessions of versions 1 to 3 hashed a hand-picked list of fields; kept to replay them.
/// `event_text` (versions 1 and 2: events were hashed by their order's and their line's text):
/// Installation::event_text; empty (version 3): by their fields.
StateHashes state_hashes_v3(const FrameData& frame, const std::function<std::string(const FrameEvent&)>& event_text = {});

/// FNV-1a 64 of a file's bytes (0 when it cannot be read).
std::uint64_t file_checksum(const std::filesystem::path& path);

/// What a recording snapshots and notes about the run.
struct SessionInfo {
  /// The installation as run (`file`: the installation file it was read from; "" when built
  /// in code: then no config snapshot, and the session cannot be replayed from its folder).
  InstallationConfig config;
  std::optional<std::filesystem::path> orders_script;  ///< the script run (overrides the config's)
  bool mono_eyes = false;                              ///< InstallationOptions::mono_eyes
  double budget_mb = 2048;                             ///< MB on disk, then recording stops
};
/// The info for a run of `config` with `options`; `budget_mb` overrides the config's
/// [record] budget_mb (kumite --record-budget-mb).
SessionInfo session_info(const InstallationConfig& config, const InstallationOptions& options,
                         std::optional<double> budget_mb = std::nullopt);

class SessionRecorder {
 public:
  /// Creates DIR (or uses an empty existing one), copies the snapshot and writes the first
  /// manifest. Throws kumite::Error("io", ...) naming the path.
  /// `queue_sets`: camera frame sets that may wait for the writer, and `queue_set_bytes` the
  /// most their images may hold together (each set holds its images until packed: the demo's
  /// 4 × 1.3 MB a set would take 310 MB in 60 slots while a loaded machine starves the writer);
  /// a set past either is dropped and counted (one set is always let in, whatever its size).
  SessionRecorder(std::filesystem::path dir, SessionInfo info, std::size_t queue_frames = 512,
                  std::size_t queue_sets = 60, std::size_t queue_set_bytes = kDefaultQueueSetBytes);
  /// bytes: the images the camera frame set queue may hold (~19 of the demo's sets, 0.3 s).
  static constexpr std::size_t kDefaultQueueSetBytes = 100'000'000;
  ~SessionRecorder();  ///< close() if not done (errors then only logged)
  SessionRecorder(const SessionRecorder&) = delete;
  SessionRecorder& operator=(const SessionRecorder&) = delete;

  /// From Installation::start (first_frame 0), or Installation::record_to on a running
  /// installation (the record key): the run's start and the first frame recorded.
  void started(Timestamp start, bool has_tracker, std::uint64_t first_frame = 0,
               std::vector<std::string> camera_names = {});
  /// From the frame loop: queues a copy, never waits for the disk (full queue: dropped, counted).
  /// The frame's state is copied whole for states.bin (frame_states.hpp).
  void push(std::uint64_t frame, const FrameInput& input, const StateHashes& hashes, const FrameData& state);
  /// Gives every free slot of the ring room for frames up to `capacity` (from the frame
  /// loop's thread, as push; Installation::record_to does it): a frame that fits is then
  /// copied without an allocation, even the first time a slot holds the largest character.
  void reserve(const FrameCapacity& capacity);
  /// From the tracker thread: queues the frame set (its images shared, not copied: sources
  /// hand over fresh images), never waiting; the writer packs and appends it to cameras.bin.
  /// A full queue drops the set (counted: a re-track then misses it).
  void push_frame_set(const tracking::FrameSet& set);
  /// Frame sets already encoded (tracking::encode_frame_set), written before any pushed
  /// later: the tracker's pre-roll, from its start to the recording's (any thread).
  void push_encoded_frame_sets(std::vector<std::string> records);
  std::uint64_t frame_sets_written() const { return sets_written_.load(std::memory_order_relaxed); }
  std::uint64_t frame_sets_dropped() const { return sets_dropped_.load(std::memory_order_relaxed); }
  /// Writes what is queued, then the final manifest. Throws kumite::Error on a failed write.
  void close();
  std::uint64_t frames_written() const;
  std::uint64_t dropped() const;
  std::uint64_t bytes() const { return bytes_.load(std::memory_order_relaxed); }  ///< on disk so far
  /// True once the disk budget is spent: nothing more is written.
  bool budget_reached() const { return budget_reached_.load(std::memory_order_relaxed); }
  const std::filesystem::path& dir() const { return dir_; }
  /// One line for the console: folder, frames, MB of the budget, drops, stopped.
  std::string status_line() const;

 private:
  struct Item {
    std::uint64_t frame = 0;
    FrameInput input;
    StateHashes hashes;
    FrameData state;
    struct Start {
      Timestamp start = 0;
      bool has_tracker = false;
      std::uint64_t first_frame = 0;
      double unix_s = 0;
      std::vector<std::string> camera_names;
    };
    std::optional<Start> start;
  };
  struct SnapshotFile {
    std::string role;  ///< config, orders, tracking, calibration, character
    int index = -1;    ///< character: its index in the config
    std::filesystem::path source;  ///< absolute
    std::string snapshot;          ///< relative to the session folder ("": not there when recorded)
    std::uint64_t fnv = 0, bytes = 0;
  };
  void snapshot();
  void run();
  void write_manifest(bool complete);
  void write_line(const std::string& line);
  void write_frame_set(const tracking::FrameSet& set);

  std::filesystem::path dir_;
  SessionInfo info_;
  std::vector<SnapshotFile> files_;
  std::filesystem::path database_;  ///< absolute ("" none)
  std::uint64_t database_fnv_ = 0, database_bytes_ = 0;
  std::uint64_t budget_bytes_ = 0;
  int fd_ = -1;
  // A single-producer (the frame loop) single-consumer (the writer) ring of preallocated
  // items: the frame loop never takes a lock the writer holds (the writer runs at a low
  // priority; a lock it held while descheduled would stall the frame) and, once the slots'
  // vectors and strings have grown, never allocates.
  std::vector<Item> slots_;
  std::atomic<std::uint64_t> head_{0}, tail_{0};
  std::atomic<bool> stop_{false}, budget_reached_{false};
  std::atomic<std::uint64_t> written_{0}, dropped_{0}, pushed_{0}, bytes_{0};
  std::uint64_t checksum_ = 14695981039346656037ull;  // kFnv1a64Offset; the writer's (read after join)
  std::string error_;                                 // the writer's (read after join)
  std::optional<Item::Start> start_;                  // the writer's (read after join)
  double created_unix_s_ = 0;
  // Camera frame sets: the same kind of ring, filled by the tracker thread.
  struct SetSlot;
  std::vector<std::unique_ptr<SetSlot>> set_slots_;
  std::atomic<std::uint64_t> set_head_{0}, set_tail_{0};
  std::size_t set_bytes_limit_ = 0;                  // bytes of images the queued sets may hold
  std::atomic<std::uint64_t> queued_set_bytes_{0};  // bytes of images the queued sets hold now
  std::atomic<std::uint64_t> peak_queued_set_bytes_{0};
  std::atomic<std::uint64_t> sets_written_{0}, sets_dropped_{0}, set_bytes_{0};
  int frames_fd_ = -1;  // cameras.bin, opened at the first set (the writer's)
  // states.bin: every frame's state whole (the writer's, as the two below)
  int states_fd_ = -1;
  std::string state_record_;
  std::vector<int> skeletons_written_;  // characters whose skeleton record is in states.bin
  std::atomic<std::uint64_t> state_bytes_{0};
  void write_state_record();
  std::mutex encoded_mutex_;
  std::vector<std::string> encoded_;  // pre-encoded records waiting for the writer (guarded)
  void write_frame_record(const std::string& record);
  std::thread thread_;
};

/// The record key and --record: starts and stops session recordings of one installation.
/// A recording started while the installation runs (the key) begins at that frame: its
/// replay cannot reproduce the state before it, so its frames are re-run but not compared.
class RecordSwitch {
 public:
  /// `folder`: where a recording goes (if it is taken, "<folder>-2", "-3", ...).
  RecordSwitch(Installation& installation, SessionInfo info, std::filesystem::path folder);
  ~RecordSwitch();  ///< stops (errors only logged)
  void start();     ///< throws kumite::Error when the folder cannot be made
  void stop();      ///< closes the recording on a thread of its own (the frame loop goes on)
  void toggle();    ///< the record key: start or stop (errors logged, the run goes on)
  bool recording() const { return static_cast<bool>(recorder_); }
  /// Stops, and waits for the recordings being closed (their errors are logged).
  void finish();

 private:
  Installation& inst_;
  SessionInfo info_;
  std::filesystem::path folder_;
  std::unique_ptr<SessionRecorder> recorder_;
  std::vector<std::thread> closing_;
};

struct ReplayOptions {
  /// Replay with this installation file instead of the snapshot (said in a note).
  std::optional<std::filesystem::path> config_override;
  std::optional<std::filesystem::path> data_dir;  ///< what ${data_dir} means (default: as recorded)
  /// Where the replay starts being shown and paced: "S" (seconds since the start, e.g. "12.5")
  /// or a wall-clock time "HH:MM:SS" on the recording's clock (its manifest's start time).
  /// Frames before it are still re-run (the state needs them), as fast as possible.
  std::optional<std::string> from;
  bool real_time = false;  ///< from `from` on, frames at the pace they were recorded
  /// Re-track: the head poses come from the session's camera frames (cameras.bin) run through
  /// the tracker of this build with the snapshot's calibration and tracking.toml, in step with
  /// the recorded frames (each frame set before the first frame that takes its pose), instead
  /// of the recorded poses. States are then compared, not required to match: the report says
  /// how far the re-tracked head is from the recorded one, and which frames differ.
  bool retrack = false;
  /// Called with each frame from `from` on (a presenter; nullptr: none).
  std::function<void(const FrameData&)> on_frame;
  /// on_frame gets the frame as it was recorded (states.bin) where the session has it, not
  /// the frame made again, and the replay goes on past a difference (the first is still
  /// reported): a presenter then shows what the visitors saw, whatever this build makes of
  /// the session. Without states (version 2), the frames made again.
  bool show_recorded = false;
  /// Called once with the replay's installation, before its first frame (a presenter sets
  /// itself up with its walls and config; nullptr: none).
  std::function<void(const Installation&)> on_start;
  /// Asked after each frame shown: true ends the replay there (a viewer closed its window;
  /// said in a note, the frames up to there compared). nullptr: never.
  std::function<bool()> stop_requested;
  /// Called once after the last frame, with the replay's installation still there (a
  /// presenter's last picture; nullptr: none).
  std::function<void(const Installation&)> on_end;
};

struct ReplayReport {
  std::uint64_t frames_recorded = 0;  ///< complete frame lines in session.jsonl
  std::uint64_t frames_replayed = 0;  ///< replayed (and compared unless !compared)
  bool compared = true;               ///< false: a recording started mid-run (not comparable)
  bool identical = true;
  std::optional<std::uint64_t> first_difference_frame;
  std::string first_difference_field;
  /// The first difference by value, from the recorded frame states (states.bin): one line
  /// naming the field and both values ("fighter.joints[LeftHand]: recorded ..., now ...");
  /// "" when the session has no states (version 2) or the frames are identical.
  std::string first_difference_detail;
  /// Every replayed frame was compared by value with its recorded state (states.bin); false:
  /// by the state hashes alone (a session without states.bin, or one cut or lost: notes say).
  bool states_compared = false;
  std::optional<std::uint64_t> from_frame;  ///< the first frame at or after ReplayOptions::from
  /// ReplayOptions::stop_requested ended the replay after this frame (the frames up to it
  /// were compared; the rest not replayed).
  std::optional<std::uint64_t> stopped_after_frame;
  double from_s = 0;                        ///< s since the start, that frame's
  std::vector<std::string> notes;     ///< one line each: what could not be replayed, changed files
  double wall_s = 0;                  ///< s, the replay's own time
  /// retrack: frame sets re-tracked; frames whose state matched the recording; the re-tracked
  /// head's distance from the recorded one over frames where both were tracked (m: p50, p95,
  /// max) and frames where one was tracked and the other not.
  struct Retrack {
    std::uint64_t sets = 0;
    std::uint64_t frames_identical = 0;
    std::uint64_t frames_compared = 0;
    double head_p50_m = 0, head_p95_m = 0, head_max_m = 0;
    std::uint64_t status_differs = 0;
  };
  std::optional<Retrack> retrack;
  double session_s = 0;               ///< s, the recorded frames' time span
};

/// Re-runs DIR's frames without rendering and compares them. Throws kumite::Error for a
/// session that cannot be replayed at all (no manifest, no start line, no config that loads),
/// naming the file.
ReplayReport replay_session(const std::filesystem::path& dir, const ReplayOptions& options = {});

/// "S" or "HH:MM:SS" (see ReplayOptions::from) as seconds since a start at `start_unix_s`
/// (local time; a clock time before the start's time of day is on the next day). nullopt:
/// neither form, or out of range.
std::optional<double> parse_replay_from(std::string_view text, double start_unix_s);

}  // namespace kumite::app
