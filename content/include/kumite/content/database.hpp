#pragma once
// The fighter's motion database: built offline (kumite-motion build) from annotated clips,
// loaded read-only at runtime. Per segment the MKM frames (actor-independent poses, mkm.hpp),
// planted-foot flags and, for strikes, the hit-point path; per strike start candidate the
// retrieval row (pose features, hit window and its box; retrieval.hpp) grouped into k-means
// pose clusters. Mirrored copies of every segment double the database.
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

inline constexpr std::uint32_t kDatabaseVersion = 4;

enum class SegmentKind : std::uint8_t { rest = 0, walk = 1, strike = 2, other = 3 };
std::string_view to_string(SegmentKind k);

enum class StrikeHeight : std::uint8_t;  // annotation.hpp: low | mid | high

/// One annotated piece of a clip (build input; the annotation reader fills these).
struct SegmentSource {
  const Clip* clip = nullptr;
  std::string name;              ///< e.g. "135_04:punch_right:1"
  int first_frame = 0;           ///< clip frame, inclusive
  int last_frame = 0;            ///< clip frame, inclusive
  SegmentKind kind = SegmentKind::other;
  std::optional<Effector> effector;  ///< strikes: the limb whose end hits
  int hit_frame = -1;            ///< strikes: clip frame of the hit
  std::optional<StrikeHeight> height = std::nullopt;  ///< strikes: where it lands (motions.toml `height`), when annotated
  bool mirror = true;            ///< also add the left/right mirrored copy (BuildOptions::mirror too)
  /// Clip frames [a, b] inside (first_frame, last_frame) rebuilt by interpolating each joint's
  /// position between frames a - 1 and b + 1 (motions.toml `repair_frames`: a capture glitch).
  std::optional<std::array<int, 2>> repair_frames = std::nullopt;
};

struct AnnotationSet;
/// Segments of an annotation set (motions.toml) over its loaded clips (same order as
/// set.clips): punches/kicks become strikes, rest and walk keep their kind, blocks and
/// "other" are left out (the fighter does not use them yet).
std::vector<SegmentSource> segment_sources(const AnnotationSet& set, const std::vector<Clip>& clips);

struct BuildOptions {
  bool mirror = true;                 ///< add left/right mirrored copies
  double start_stride_s = 1.0 / 30;   ///< s between candidate start frames of a strike
  double start_window_s = 0.40;       ///< s: starts lie within this much after the segment start
  double min_lead_s = 0.25;           ///< s: a strike starts at least this long before its hit
                                      ///< (>= blend time + window_before_s: the limb must travel)
  double window_before_s = 0.04;      ///< s before the hit frame where contact may happen
  double window_after_s = 0.08;       ///< s after the hit frame where contact may happen
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
  std::vector<MkmFrame> frames;
  std::vector<Eigen::Vector3f> hit_path_m;  ///< m (db actor), clip floor frame, per frame (strikes)

  int frame_count() const { return static_cast<int>(frames.size()); }
  std::optional<Effector> effector() const;
};

struct Database {
  std::string actor_name;      ///< clip the actor's skeleton came from
  Skeleton actor_skeleton;     ///< for retargeting queries onto the actor (T-pose rest)
  Morphology actor;            ///< measured on actor_skeleton
  double velocity_weight_s = 0.10;  ///< s, as built (queries must use the same)
  std::vector<MotionSegment> segments;
  RetrievalIndex index;
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

/// Index of the first segment of a kind (std::nullopt when none).
std::optional<int> find_segment(const Database& db, SegmentKind kind);

}  // namespace kumite::content
