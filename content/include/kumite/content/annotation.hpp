#pragma once
// Motion annotations (motions.toml): which frames of which clip are a punch, a kick, a rest
// pose ..., which limb hits and at which frame. Plus the automatic proposer behind
// `kumite-motion annotate`, which finds strikes from the hit point's speed and extension
// (what the original system's annotation toolkit did by hand) for a person to review.
//
// File format (TOML; frames are 0-based BVH motion frames, inclusive):
//
//   version = 1
//   [[clip]]
//   file = "135_04.bvh"          # relative to the motions.toml folder
//   name = "135_04"              # optional (default: file stem); unique
//   mirror = true                # optional (default true): database adds the mirrored clip
//   unit_m = 0.01                # optional: metres per file unit, instead of the guess from the
//                                # rest pose (1e-4..10; a rest pose that is no standing body)
//   [[clip.motion]]
//   name = "135_04_kick_right_1" # unique in the file
//   semantics = "kick"           # punch | kick | block | walk | rest | other
//   frames = [330, 410]          # first, last (inclusive)
//   hit_segment = "right_foot"   # strikes (punch, kick) only: left_hand | right_hand | left_foot | right_foot
//   hit_frame = 374              # strikes only: contact frame, inside `frames`
//   height = "mid"               # strikes, optional: low | mid | high, where the hit point is
//                                # at hit_frame (classify_strike_height); blocks: what it guards
//   forearm = "left"             # blocks only: left | right, the forearm that meets the fist
//   intercept_frames = [360, 395] # blocks only: the frames the forearm is in place (inside `frames`)
//
// A block with forearm, intercept_frames and height is reviewed and goes into the database; a
// block with none of them (as the proposer writes it) is left out; one with some is an error.
//   note = "..."                 # optional, free text
//   peak_speed_mps = 9.9         # optional, informational: hit point's peak speed (m/s)
//   extension = 0.97             # optional, informational: limb extension at hit_frame (1 = straight)
//
// Errors name file, line and key: "motions.toml:14: clip[0].motion[2].hit_frame: 1500 is
// outside the clip (frames 0..1315)".
#include <array>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "kumite/content/skeleton.hpp"

namespace kumite::content {

enum class Semantics : std::uint8_t { punch, kick, block, walk, rest, other };
enum class HitSegment : std::uint8_t { left_hand, right_hand, left_foot, right_foot };
/// Where a strike lands, from the hit point's height above the floor at the hit frame
/// relative to the actor's stature (see StrikeHeightThresholds).
enum class StrikeHeight : std::uint8_t { low, mid, high };
/// The forearm (elbow -> wrist) a block meets the incoming fist with.
enum class Forearm : std::uint8_t { left, right };

std::string_view to_string(Semantics s);
std::string_view to_string(HitSegment s);
std::optional<Semantics> semantics_from_string(std::string_view s);
std::optional<HitSegment> hit_segment_from_string(std::string_view s);
std::string_view to_string(StrikeHeight h);
std::optional<StrikeHeight> strike_height_from_string(std::string_view s);
std::string_view to_string(Forearm f);
std::optional<Forearm> forearm_from_string(std::string_view s);

/// Bounds of the strike heights, as fractions of the actor's stature (rest-pose height,
/// Proportions::stature_m) for the hit point (wrist / ankle joint) above the floor at the hit
/// frame. Chosen from the development mocap (content/README.md, "Strike heights"): CMU 135's
/// shoulders are at 0.83 of its stature. Its middle-level (chudan) punches put the wrist at
/// 0.72..0.80 (just under the shoulder), its front kicks the ankle at 0.73..0.77; the boxer's
/// head punches reach 0.82..0.95 and the head-level roundhouse kicks 0.87..0.88. Ankles at
/// 0.53 (HDM05 bk: front kicks to the groin) are below the belt.
struct StrikeHeightThresholds {
  double low_below = 0.55;  ///< 1: below this fraction of stature: low (below the belt)
  double high_from = 0.81;  ///< 1: from this fraction on: high (shoulders, neck, head)
};
/// The height class of a hit point `hit_height_m` above the floor for an actor `stature_m` tall.
StrikeHeight classify_strike_height(double hit_height_m, double stature_m, const StrikeHeightThresholds& t = {});
/// Strikes carry a hit segment and a hit frame.
inline bool is_strike(Semantics s) { return s == Semantics::punch || s == Semantics::kick; }
/// The canonical joint whose position is the hit point: wrists for hands, ankles for feet
/// (the joints PROVENANCE.md measures; the fist / toe tip are a bone further).
CanonicalJoint hit_joint(HitSegment s);
/// The limb root the extension is measured from: shoulders for hands, hips for feet.
CanonicalJoint limb_root(HitSegment s);
bool is_left(HitSegment s);
bool is_hand(HitSegment s);

/// The most frames one `repair_frames` range may rebuild (a glitch, not a motion).
inline constexpr int kMaxRepairFrames = 8;

struct MotionAnnotation {
  std::string name;                       ///< unique id, e.g. "135_04_kick_right_1"
  Semantics semantics = Semantics::other;
  int first_frame = 0;                    ///< first frame (inclusive, 0-based)
  int last_frame = 0;                     ///< last frame (inclusive)
  std::optional<HitSegment> hit_segment;  ///< strikes only
  std::optional<int> hit_frame;           ///< strikes only: contact frame in [first, last]
  std::optional<StrikeHeight> height;     ///< strikes: where it lands (optional); blocks: what it guards
  std::optional<Forearm> forearm;         ///< blocks only: the forearm that meets the fist
  /// Blocks only: clip frames [a, b] (inside the segment) where the forearm is in place.
  std::optional<std::array<int, 2>> intercept_frames = std::nullopt;
  std::string note;                       ///< free text for people
  double peak_speed_mps = 0;              ///< m/s, informational: hit point's peak speed (0 = unknown)
  double extension = 0;                   ///< 1, informational: limb length fraction at the hit (0 = unknown)
  /// Frames [a, b] (clip frames, inclusive, inside the segment and not its first or last) where
  /// the capture glitched (a joint jumps and comes back: HDM05's tr actor's kicking foot 8-10 cm
  /// up for two frames at the top of the kick): the database rebuilds them, each joint's
  /// position interpolated between frames a - 1 and b + 1. At most kMaxRepairFrames frames.
  std::optional<std::array<int, 2>> repair_frames = std::nullopt;
  int line = 0;                           ///< line in the TOML file (0 = not from a file)
};

/// A reviewed block: it says its forearm, intercept frames and height (the database keeps it).
inline bool is_reviewed_block(const MotionAnnotation& m) {
  return m.semantics == Semantics::block && m.forearm && m.intercept_frames && m.height;
}

struct ClipAnnotation {
  std::string file;   ///< BVH path as written (relative to the motions.toml folder)
  std::string name;   ///< clip name (default: file stem)
  bool mirror = true; ///< the database also adds the mirrored clip
  /// Metres per file unit, stated (kClipUnitRangeM): read with it instead of the unit guessed
  /// from the rest pose's size, which is no body's where a studio exports its rest offsets
  /// along each joint's local X (a line, not a standing figure). Unset: guessed and checked.
  std::optional<double> unit_m;
  std::vector<MotionAnnotation> motions;
  int line = 0;       ///< line of the [[clip]] header (0 = not from a file)
};

struct AnnotationSet {
  int version = 1;
  std::vector<ClipAnnotation> clips;
  std::filesystem::path source;  ///< the motions.toml it came from (resolves clip paths)

  /// Path of a clip's BVH: relative paths are taken from the motions.toml's folder.
  std::filesystem::path resolve(const ClipAnnotation& clip) const;
};

inline constexpr int kAnnotationVersion = 1;
/// The range a stated `unit_m` must lie in (metres per file unit): from a tenth of a millimetre
/// to 10 m (millimetres 0.001, centimetres 0.01, inches 0.0254, metres 1).
inline constexpr double kClipUnitRangeM[2] = {1e-4, 10.0};

/// Parses and validates the schema (types, unknown keys, names, frame order, strike fields).
AnnotationSet parse_annotations(std::string_view text, std::string_view source);
AnnotationSet read_annotations(const std::filesystem::path& path);
/// TOML text (comments explain the fields); parse_annotations(format_annotations(s)) == s.
std::string format_annotations(const AnnotationSet& set);
/// Writes atomically.
void write_annotations(const std::filesystem::path& path, const AnnotationSet& set);

/// Checks a clip's annotations against the clip itself (frames inside it, the hit segment's
/// joints mapped). Throws kumite::Error "file:line: clip[i].motion[j].key: message".
void validate_annotations(const AnnotationSet& set, std::size_t clip_index, const Clip& clip);

/// Reads every clip of the set (mapping canonical joints) and validates it. A clip with a stated
/// unit_m is read in it; one without has its unit guessed, and is refused (file:line:
/// clip[i].file: refused: ...) where the guess gives no human's size.
std::vector<Clip> load_annotated_clips(const AnnotationSet& set);

// ---- The proposer --------------------------------------------------------------------------

/// Tunables of the strike finder. Thresholds are relative to the actor's measured size so
/// they hold for any body; the defaults were checked on CMU subject 135 and the assimp boxer.
struct ProposerSettings {
  double smoothing_s = 0.025;          ///< s, moving-average window applied to positions before speeds
  double peak_window_s = 0.30;         ///< s, a peak must be the extreme within +- this
  // Punches (per hand): the arm nearly straight, straightened fast, not pointing at the floor.
  double punch_min_extension = 0.88;   ///< 1, |wrist - shoulder| / arm length at the peak
  double punch_min_speed = 3.5;        ///< m/s, wrist speed somewhere in the approach
  double punch_min_radial_speed = 1.2; ///< m/s, how fast the arm straightened in the approach
  double punch_max_drop_deg = 30;      ///< deg, shoulder -> wrist may point at most this far below horizontal
  double approach_s = 0.35;            ///< s, window before the peak that must hold the speeds
  // Kicks (per foot): the ankle high, reached fast, the leg extended.
  double kick_min_height = 0.22;       ///< 1, ankle above the floor / stature at the peak
  double kick_min_extension = 0.80;    ///< 1, |ankle - hip| / leg length at the peak (running strides bend the knee)
  double kick_min_speed = 4.0;         ///< m/s, ankle speed in the approach
  /// 1, chambered kicks (knee raised first, the leg straightens below the ankle's apex): the
  /// hit is where |ankle - hip| / leg length arrives at this (HDM05 bk: 0.97..0.99), ankle
  /// still above kick_min_height
  double kick_arrival_extension = 0.93;
  // Segment bounds: where the hit point's speed falls below this fraction of its peak.
  double bound_speed_fraction = 0.15;  ///< 1
  double max_half_window_s = 0.8;      ///< s, bounds at most this far from the hit frame
  // Rest: every end effector and the pelvis slower than this for at least rest_min_s.
  double rest_max_speed = 0.25;        ///< m/s
  double rest_min_s = 0.4;             ///< s
  // Walk: pelvis moving horizontally faster than this for at least walk_min_s.
  double walk_min_speed = 0.6;         ///< m/s
  double walk_min_s = 1.0;             ///< s
  // Blocks: fast hands (>= this) that are not punches and not inside kicks.
  double block_min_speed = 4.0;        ///< m/s
  // Jabs / punches in place: a fully straight arm, straightened as fast as a punch's, but
  // without the lunge the wrist's speed stays under punch_min_speed (CMU 135_09 after f1500:
  // 2.7..3.0 m/s, radial 2.6..3.2 m/s; arm swings, turns and guards straighten at < 0.6 m/s).
  double jab_min_extension = 0.95;     ///< 1, |wrist - shoulder| / arm length at the peak
  double jab_min_speed = 2.0;          ///< m/s, wrist speed in the approach
  double jab_min_radial_speed = 2.0;   ///< m/s, how fast the arm straightened in the approach
  StrikeHeightThresholds height;       ///< strike height classes
};

/// Proposes the annotations of one clip (canonical joints must be mapped). `file` is stored
/// as the clip's file. Motions are sorted by first frame; names are "<clip>_<kind>_<n>".
ClipAnnotation propose_annotations(const Clip& clip, std::string file, const ProposerSettings& settings = {});

}  // namespace kumite::content
