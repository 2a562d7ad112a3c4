#pragma once
// The frames as the installation made them (`states.bin` in a session folder, issue 13):
// every FrameData whole, so a recording shows what visitors saw even after the code that made
// it has changed, and a replay that differs says where, by value (joint, wall, event).
//
// File: the line "kumite-frame-states N\n" (N: kFrameVersion, frame_fields.hpp), then records, each
//   u32 magic 0x3154534B ("KST1"), u32 payload bytes, u64 FNV-1a 64 of the payload; payload =
//   u32 bytes unpacked, then zlib's compressed stream (level 1) of: u8 kind, then
//   kind 1, skeleton (before the first frame of each character drawn): i32 character, u32
//     joints, per joint a string (u32 bytes, bytes) name and i32 parent;
//   kind 2, frame: its fields in the order frame_fields.hpp describes them, each as its type
//     says: a bool or enum u8, an int i32, a frame number u64, a double f64 (draw items' f32),
//     vectors x y z, quaternions w x y z, matrices column by column; a list u32 count then
//     each; an optional u8 flag then its value (an event's order: its default when absent);
//   kind 3, console (a render node's STATE only, never in states.bin: the master's console
//     for the frame, ConsoleState): f64 fps, f64 frame_cpu_ms, strings tracking,
//     tracking_source, recognition; u32 cameras, each: string name, u8 state, string status,
//     i32 blobs, f64 since_last_ms; i32 markers_seen, u8 head_live, f64 pose_age_ms,
//     tracking_latency_ms, latch_ms, draw_budget_ms, u8 late_latch, string fighter_state,
//     i32 character, string character_name, u8 paused, strings last_order, last_outcome,
//     planner (the spar planner's line, "" without a fighter); then three lists of strings
//     (u32 count, each): problems, recent, frame_events (one per frame event, in order). At
//     most 1024 lines a list, 64 KiB a string. (The cluster's protocol version 3: 2 had no
//     planner string.)
// Every f64 and f32 must be finite; counts no larger than the record's bytes can hold.
// Little-endian, numbers exactly as computed. One record is written whole with one write(2):
// a recorder killed mid-write leaves whole records and at most one cut one, which the reader
// reports and stops at.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "kumite/app/frame_fields.hpp"

namespace kumite::app {

/// The first line this build writes: "kumite-frame-states <kFrameVersion>\n". Files of every
/// version before it still read (the fields added since take their defaults).
inline const std::string kFrameStatesHeader = "kumite-frame-states " + std::to_string(kFrameVersion) + "\n";

/// Appends the records for `frame` to `out`: its character's skeleton first when `with_skeleton`
/// (the writer's first frame of that character), then the frame. `out`'s room is reused.
/// `version`: the frame description's version to write (an older one leaves out the fields
/// added since: what a file of that version holds; tests re-encode old files with it).
void encode_frame_state(const FrameData& frame, bool with_skeleton, std::string& out, int version = kFrameVersion);
/// A render node's STATE (the cluster master's): the character's skeleton, the master's
/// console for the frame (its texts: the node's console and its frames.jsonl show them), then
/// the frame. The whole state each time, never a delta.
void encode_frame_state(const FrameData& frame, const ConsoleState& console, std::string& out);
/// Both of the above: a console record before the frame's when `console` is not null.
void encode_frame_state(const FrameData& frame, bool with_skeleton, const ConsoleState* console, std::string& out,
                        int version);

class FrameStatesReader {
 public:
  /// Opens the file and checks its first line. Throws kumite::Error ("io": cannot open;
  /// "format": not a frame states file, or a newer version) naming the file.
  explicit FrameStatesReader(const std::filesystem::path& file);
  /// The next frame (skeleton records are taken on the way); false at the end of the file, or
  /// at a damaged or cut record (then problem() names the file, the record and what is wrong,
  /// and nothing more is read).
  bool next(FrameData& out);
  /// "" while all is well; one line otherwise.
  const std::string& problem() const { return problem_; }
  std::uint64_t frames_read() const { return frames_; }

 private:
  bool fail(std::string what);
  std::filesystem::path path_;
  std::ifstream in_;
  std::string buffer_, raw_;
  std::string problem_;
  std::uint64_t frames_ = 0, records_ = 0, offset_ = 0;
  int version_ = kFrameVersion;  ///< the file's
  std::map<int, std::shared_ptr<const FighterSkeleton>> skeletons_;
};

/// Frames from bytes in memory (a render node's STATE payload): the records encode_frame_state
/// wrote for one frame, its skeleton's record included or sent before, the master's console's
/// record with it or not. The skeletons are kept from frame to frame; a frame's vectors reuse
/// the room of the frame decoded into before (this build's version only: every field is there).
class FrameStateDecoder {
 public:
  /// Reads one frame's records into `out` (and its console record, if any, into `console`
  /// when given); false (problem() says why, in words) when they are cut, damaged, not a frame
  /// state, hold no frame or two consoles (then `out` is not to be used). A console record
  /// that does not read whole, or whose texts are not one per the frame's event, leaves the
  /// frame good: has_console() false and console_problem() says why.
  bool decode(std::string_view records, FrameData& out, ConsoleState* console = nullptr);
  const std::string& problem() const { return problem_; }
  /// The last decode() read a console record whole, one text per event of its frame.
  bool has_console() const { return has_console_; }
  /// "" unless the last decode()'s console record did not read (then one line why).
  const std::string& console_problem() const { return console_problem_; }

 private:
  bool fail(std::string what);
  std::string raw_, problem_, console_problem_;
  bool has_console_ = false;
  ConsoleState scratch_;  ///< a console read when the caller wants none
  std::map<int, std::shared_ptr<const FighterSkeleton>> skeletons_;
};

/// The first difference between a recorded frame and the same frame made again, as one line
/// naming the field and both values ("fighter.joints[LeftHand]: recorded (0.312, 1.204,
/// -0.553) m, now (0.318, 1.204, -0.553) m, 6.0 mm apart"); nullopt when they are identical,
/// bit for bit (draw items included).
std::optional<std::string> first_difference(const FrameData& recorded, const FrameData& now);

}  // namespace kumite::app
