#pragma once
// BVH (Biovision hierarchy) read and write.
//
// Reads any rotation channel order, 0..6 channels per joint (position channels replace the
// offset), End Sites, CRLF / tabs / spaces, any frame rate. Lengths are converted to metres
// (Clip::unit_m records the file's unit, detected from the rest-pose size unless given).
// Angles on disk are degrees; in memory, quaternions. Bad input throws kumite::Error
// (component "bvh") with one line "file:line: key: message"; never crashes.
//
// Writing uses standard BVH syntax (HIERARCHY / ROOT / JOINT / End Site / MOTION / Frames: /
// Frame Time:, tab indentation), keeps each joint's channel order and writes lengths back in
// the clip's unit, so Blender opens it and reading it back gives the same joint positions.
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "kumite/content/skeleton.hpp"

namespace kumite::content {

struct BvhReadOptions {
  /// Metres per file unit; nullopt = detect from the rest pose's size (guess_bvh_unit_m).
  std::optional<double> unit_m;
  /// Fill Skeleton::canonical with map_canonical() and default_dialects() (best effort:
  /// when the core joints cannot be found, canonical stays -1 and dialect "").
  bool map_canonical = true;
};

/// Parses BVH text. `source` names the input in error messages (a path or "<memory>").
/// The clip's name is the stem of `source`.
Clip parse_bvh(std::string_view text, std::string_view source, const BvhReadOptions& options = {});

/// Reads a BVH file (throws kumite::Error naming the file when it cannot be read).
Clip read_bvh(const std::filesystem::path& path, const BvhReadOptions& options = {});

/// The clip as BVH text in its own unit (clip.unit_m) and channel orders
/// (clip.skeleton.channels; defaults: root "XYZzyx", joints "zyx", end sites none).
/// Euler angles are unwrapped frame to frame so curves stay continuous.
std::string format_bvh(const Clip& clip);

/// Writes format_bvh(clip) atomically (temporary file, then rename).
void write_bvh(const std::filesystem::path& path, const Clip& clip);

/// Detected unit (metres per file unit) for a rest-pose largest extent of `extent` file
/// units. A humanoid (canonical joints found) gets the unit among cm, m, mm, inch and CMU ASF
/// units (2.54/0.45 cm) that makes it closest to 1.7 m, preferring metric ones; anything
/// else: below 5 units metres, below 500 centimetres, else millimetres.
double guess_bvh_unit_m(double extent, bool humanoid = false);

/// Rest-pose largest extent (m) a human actor's skeleton has: from a child to a tall adult,
/// arm span or height (CMU 135 rest pose: 1.63 m, HDM05 actors 1.6..1.8 m).
inline constexpr double kHumanRestExtentM[2] = {1.0, 2.4};

/// Whether a clip's unit is believable, for clips read with a guessed unit
/// (BvhReadOptions::unit_m unset) of a recognised humanoid (canonical joints mapped; others
/// pass). A rest pose shorter or taller than kHumanRestExtentM in the guessed unit was in no
/// unit the reader knows and its motion would be silently scaled: plausible = false and a
/// one-line warning "<source>: unit_m: rest height X file units is not a human's ..." naming
/// the rest height the guess saw. A human only in inches or CMU ASF units stays plausible
/// with a warning too. The proposer (kumite-motion annotate) prints it; load_annotated_clips
/// refuses implausible clips.
struct BvhUnitCheck {
  bool plausible = true;
  std::string warning;  ///< "" = nothing to say
};
BvhUnitCheck check_bvh_unit(const Clip& clip, std::string_view source);

}  // namespace kumite::content
