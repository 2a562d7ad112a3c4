#pragma once
// The fighter's motion database: built offline (kumite-motion build) from annotated clips,
// loaded read-only at runtime. Per segment the MKM frames (actor-independent poses, mkm.hpp),
// planted-foot flags and, for strikes, the hit-point path; per strike start candidate the
// retrieval row (pose features, hit window and its box; retrieval.hpp) grouped into k-means
// pose clusters. Blocks the same way in their own index (block_retrieval.hpp): per block the
// forearm path and the intercept window, per start candidate a row whose window is the
// forearm's contact point while it is in place, grouped by (forearm, height). Segments are
// keyed by (kind, effector); blocks come after every other segment. Mirrored copies of every
// segment double the database.
//
// File (.kdb): "KUMITEDB", u32 format version, then the payload (little-endian, counts
// before arrays), then a u64 FNV-1a checksum of everything before it. Written atomically.
#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "kumite/content/adaptation.hpp"
#include "kumite/content/mkm.hpp"
#include "kumite/content/retrieval.hpp"
#include "kumite/content/skeleton.hpp"

namespace kumite::content {

inline constexpr std::uint32_t kDatabaseVersion = 5;

enum class SegmentKind : std::uint8_t { rest = 0, walk = 1, strike = 2, other = 3, block = 4 };
std::string_view to_string(SegmentKind k);

enum class StrikeHeight : std::uint8_t;  // annotation.hpp: low | mid | high

/// One annotated piece of a clip (build input; the annotation reader fills these).
struct SegmentSource {
  const Clip* clip = nullptr;
  std::string name;              ///< e.g. "135_04:punch_right:1"
  int first_frame = 0;           ///< clip frame, inclusive
  int last_frame = 0;            ///< clip frame, inclusive
  SegmentKind kind = SegmentKind::other;
  std::optional<Effector> effector;  ///< strikes: the limb whose end hits; blocks: the forearm's arm (leg = false)
  int hit_frame = -1;            ///< strikes: clip frame of the hit
  /// strikes: where it lands (motions.toml `height`), when annotated; blocks: what it guards (required)
  std::optional<StrikeHeight> height = std::nullopt;
  bool mirror = true;            ///< also add the left/right mirrored copy (BuildOptions::mirror too)
  /// Clip frames [a, b] inside (first_frame, last_frame) rebuilt by interpolating each joint's
  /// position between frames a - 1 and b + 1 (motions.toml `repair_frames`: a capture glitch).
  std::optional<std::array<int, 2>> repair_frames = std::nullopt;
  /// Blocks: clip frames [a, b] inside the segment where the forearm is in place.
  std::optional<std::array<int, 2>> intercept_frames = std::nullopt;
};

struct AnnotationSet;
/// Segments of an annotation set (motions.toml) over its loaded clips (same order as
/// set.clips): punches/kicks become strikes, rest and walk keep their kind, reviewed blocks
/// (forearm, intercept_frames and height: is_reviewed_block) become blocks; unreviewed blocks
/// and "other" are left out.
std::vector<SegmentSource> segment_sources(const AnnotationSet& set, const std::vector<Clip>& clips);

struct BuildOptions {
  bool mirror = true;                 ///< add left/right mirrored copies
  double start_stride_s = 1.0 / 30;   ///< s between candidate start frames of a strike
  double start_window_s = 0.40;       ///< s: starts lie within this much after the segment start
  double min_lead_s = 0.25;           ///< s: a strike starts at least this long before its hit
                                      ///< (>= blend time + window_before_s: the limb must travel)
  double window_before_s = 0.04;      ///< s before the hit frame where contact may happen
  double window_after_s = 0.08;       ///< s after the hit frame where contact may happen
  double block_min_lead_s = 0.10;     ///< s: a block starts at least this long before its intercept
  double plant_height_m = 0.05;       ///< m above the segment's lowest ankle (or toes): foot may be planted
  double plant_speed_mps = 0.30;      ///< m/s: slower ankles (or toes) are planted (when low enough)
  double velocity_weight_s = 0.10;    ///< s: feature velocities count as displacement over this
  int clusters_per_group = 0;         ///< k of k-means per effector group (0: ~sqrt(rows))
  bool steady_straight_poles = true;  ///< steady_straight_limb_poles on each segment (mkm.hpp)
  std::function<void(std::string_view what, double fraction)> progress;  ///< optional
};

/// A segment as stored: frames are MKM (root_xz_m in the database actor's metres, in the
/// clip's own floor frame).
struct MotionSegment {
  std::string name;
  std::string source_clip;
  SegmentKind kind = SegmentKind::other;
  std::int8_t effector_group = -1;  ///< -1 none, else side + 2 * leg (retrieval.hpp)
  bool mirrored = false;
  std::int32_t source_first_frame = 0;  ///< clip frame of frames[0]
  double frame_time_s = 1.0 / 120;      ///< s per frame
  std::int32_t hit_frame = -1;          ///< index into frames (strikes)
  std::int8_t height = -1;              ///< StrikeHeight (strikes: where it lands; blocks: what it guards), -1 unknown
  std::int32_t intercept_first = -1;    ///< blocks: first frame (index into frames) of the forearm in place
  std::int32_t intercept_last = -1;     ///< blocks: last frame of the forearm in place
  std::vector<MkmFrame> frames;
  /// m (db actor), clip floor frame, per frame: strikes the hit point, blocks the wrist
  std::vector<Eigen::Vector3f> hit_path_m;
  std::vector<Eigen::Vector3f> elbow_path_m;  ///< blocks: the elbow, as hit_path_m (forearm = elbow -> wrist)

  int frame_count() const { return static_cast<int>(frames.size()); }
  std::optional<Effector> effector() const;
};

struct Database {
  std::string actor_name;      ///< clip the actor's skeleton came from
  Skeleton actor_skeleton;     ///< for retargeting queries onto the actor (T-pose rest)
  Morphology actor;            ///< measured on actor_skeleton
  double velocity_weight_s = 0.10;  ///< s, as built (queries must use the same)
  std::vector<MotionSegment> segments;
  RetrievalIndex index;        ///< strikes, by effector (kGroupCount groups)
  RetrievalIndex block_index;  ///< blocks, by forearm and height (kBlockGroupCount groups)
  /// m (db actor): median horizontal distance of the blocks' contact points (in place) from
  /// their start pose's pelvis: where a block meets the fist (block_retrieval.hpp)
  double block_reach_m = 0;
  double actor_stature_m = 0;  ///< m, actor_skeleton's rest height (derived, not stored)
};

/// Builds the database. Throws kumite::Error naming the segment on bad input (frame range
/// outside its clip, hit frame outside the segment, a strike without an effector, a skeleton
/// lacking canonical joints).
Database build_database(std::span<const SegmentSource> sources, const BuildOptions& options);

/// Atomic write (temp file + rename). Throws kumite::Error("database", "io", ...).
void save_database(const Database& db, const std::filesystem::path& path);
/// Reads and validates (magic, version, sizes, checksum, indices). A corrupt, truncated or
/// old-version file throws kumite::Error("database", code, "<file>: <what is wrong>").
Database load_database(const std::filesystem::path& path);
/// The same from bytes already in memory (`name` is used in error messages).
Database parse_database(std::string_view bytes, std::string_view name);
std::string serialize_database(const Database& db);

/// The contact point of a forearm: its middle (the part a block meets the fist with).
inline constexpr double kForearmContactFraction = 0.5;

/// Index of the first segment of a kind (std::nullopt when none).
std::optional<int> find_segment(const Database& db, SegmentKind kind);

}  // namespace kumite::content
