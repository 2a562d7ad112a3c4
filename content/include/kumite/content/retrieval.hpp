#pragma once
// Strike retrieval (after Multon et al.'s kung-fu fighter): given the character's current
// pose retargeted onto the actor and the target scaled to the actor's size, choose the
// strike candidate (segment, start frame) minimising
//
//     cost = pose_weight * |features(query) - features(candidate)|
//          + trajectory_weight_per_m * min_k |target - hit_window_k|
//
// over the ELIGIBLE candidates of the ordered effector: those whose hit-window bounding box
// (inflated by box_margin_m) contains the target, or, when none does, those whose box is
// nearest. retrieve() returns exactly what retrieve_brute_force() returns (same cost, ties to
// the lower candidate index). A spatial index over the rows' boxes (two levels of block
// boxes) finds the eligible rows, or the nearest box(es) best-first; few eligible rows are
// costed directly with partial pose distances; many go through the k-means pose clusters
// nearest-first, skipping a cluster or block when a lower bound of its cost (triangle
// inequality on the cluster radius, the block's feature ranges, + the distance to the union
// of its boxes) cannot beat the best so far.
//
// Layout (as in orangeduck's Motion-Matching): flat float arrays, one row per candidate,
// candidates sorted by (group, cluster) so a cluster is a contiguous block.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "kumite/content/mkm.hpp"
#include "kumite/content/tunables.hpp"

namespace kumite::content {

/// Pose feature: 10 joint positions + 5 joint velocities (x, y, z each), normalised by leg
/// length, in the pose's ground frame (so horizontal position and heading do not count).
inline constexpr int kFeatureDim = 45;
/// Hit-window samples per candidate (at most).
inline constexpr int kWindowMax = 16;
/// Strike retrieval groups (Database::index): side + 2 * leg (0 left hand, 1 right hand, 2 left
/// foot, 3 right foot).
inline constexpr int kGroupCount = 4;
/// Block retrieval groups (Database::block_index): forearm side + 2 * height (StrikeHeight: 0
/// low, 1 mid, 2 high), so 0 left low, 1 right low, 2 left mid, ... 5 right high.
inline constexpr int kBlockGroupCount = 6;
/// The most groups one index may have.
inline constexpr int kMaxGroupCount = 6;


struct RetrievalIndex {
  struct Cluster {
    std::int32_t first = 0, count = 0;           ///< candidate rows [first, first + count)
    std::array<float, kFeatureDim> centroid{};
    float radius = 0;                            ///< max feature distance member -> centroid
    std::array<float, 6> box{};                  ///< m, union of the members' raw boxes
    std::int32_t block_first = 0, block_count = 0;  ///< its blocks (derived, not stored)
  };
  /// Rows of a cluster are sorted along a space-filling curve of their box centres and cut
  /// into blocks of kBlockRows, each with the union of its boxes and the per-dimension
  /// feature range (orangeduck-style block bounding boxes): whole blocks are skipped when
  /// their bound cannot beat the best cost, or their boxes cannot hold the target.
  struct Block {
    std::int32_t first = 0, count = 0;
    std::array<float, 6> box{};                  ///< m, union of the rows' raw boxes
    std::array<float, kFeatureDim> fmin{}, fmax{};
  };
  static constexpr int kBlockRows = 16;
  /// A second, purely spatial index over the same rows (derived, not stored): per group,
  /// the rows sorted along a Morton curve of their box centres (over the whole group, not
  /// per cluster), cut into small blocks of kBlockRows rows and large blocks of
  /// kBlockRows small blocks, each with the union of its boxes. It answers "which rows'
  /// boxes may hold the target" and "which box is nearest" without touching the pose
  /// clusters, whose unions of boxes are broad.
  struct SpatialBlock {
    std::array<float, 6> box{};    ///< m, union of the boxes below it
    std::int32_t first = 0, count = 0;  ///< small block: spatial_rows; large: spatial_small
  };
  std::vector<std::int32_t> spatial_rows;    ///< row ids, group by group, Morton order
  std::vector<float> spatial_box;            ///< m, [i * 6]: box of spatial_rows[i] (a copy)
  std::vector<SpatialBlock> spatial_small;   ///< kBlockRows rows each
  std::vector<SpatialBlock> spatial_large;   ///< kBlockRows small blocks each
  std::array<std::int32_t, kMaxGroupCount + 1> group_spatial_large{};  ///< large blocks of g
  std::int32_t group_count = kGroupCount;    ///< groups 0..group_count-1 (kGroupCount, kBlockGroupCount)
  std::int32_t size = 0;                     ///< candidates
  std::vector<float> features;               ///< [row * kFeatureDim]
  std::vector<float> window;                 ///< m, [row * kWindowMax * 3], start ground frame
  std::vector<std::uint8_t> window_count;    ///< samples used per row
  std::vector<float> box;                    ///< m, [row * 6]: min xyz, max xyz of the window
  std::vector<std::int32_t> segment;         ///< Database::segments index per row
  std::vector<std::int32_t> start_frame;     ///< segment frame where the strike starts
  std::vector<std::int32_t> window_first;    ///< segment frame of window sample 0
  std::vector<std::int32_t> window_stride;   ///< frames between window samples
  std::vector<std::uint8_t> group;           ///< effector group per row
  std::vector<Cluster> clusters;             ///< sorted by group
  std::array<std::int32_t, kMaxGroupCount + 1> group_clusters{};  ///< clusters of g: [g], [g+1)
  std::vector<Block> blocks;                 ///< derived from rows + clusters (build_blocks)

  /// Appends a candidate row (before build_clusters).
  void add(int group, std::span<const float> features, std::span<const Eigen::Vector3f> window_points,
           int segment, int start_frame, int window_first, int window_stride);
  /// k-means (k-means++ seeding, fixed seed) per group, then reorders rows by cluster.
  /// clusters_per_group <= 0 picks ~sqrt(rows in the group).
  void build_clusters(int clusters_per_group, std::uint32_t seed = 1);
  /// Recomputes the blocks of every cluster from the rows (after loading).
  void build_blocks();
};

struct RetrievalQuery {
  int group = 1;                      ///< 0 .. index.group_count - 1
  std::array<float, kFeatureDim> features{};
  Eigen::Vector3f target_m{0, 0, 0};  ///< m, actor size, in the query pose's ground frame
};

struct RetrievalChoice {
  int row = -1;                  ///< -1: no candidate for this effector
  double cost = 0;
  double pose_distance = 0;
  double trajectory_distance_m = 0;  ///< m (actor size): target to the nearest window sample
  int window_sample = 0;             ///< which sample was nearest
  bool target_in_box = false;        ///< false: fell back to the nearest box
};

struct RetrievalStats {
  int clusters_visited = 0;
  int rows_visited = 0;  ///< rows whose box admitted the target
  int rows_costed = 0;   ///< rows whose full cost was computed
  int blocks_considered = 0;  ///< blocks whose boxes may hold the target
  int blocks_visited = 0;     ///< blocks whose bound did not rule them out
};

RetrievalChoice retrieve(const RetrievalIndex& index, const RetrievalQuery& query,
                         const RetrievalTunables& tunables, RetrievalStats* stats = nullptr);
RetrievalChoice retrieve_brute_force(const RetrievalIndex& index, const RetrievalQuery& query,
                                     const RetrievalTunables& tunables);

/// A larger index for benchmarks and tests: `copies` replicas of `base`'s rows, each with
/// gaussian noise on the features (`feature_noise`, feature units) and a perturbed hit
/// window (turned about +Y by ~10 deg, scaled by ~5 %, shifted by `window_noise_m`), then
/// re-clustered: like other performances of the same strikes.
RetrievalIndex replicated_index(const RetrievalIndex& base, int copies, double feature_noise,
                                double window_noise_m, std::uint32_t seed, int clusters_per_group = 0);

/// Features of a pose (canonical positions now and `dt_s` earlier, m) in `ground` (the
/// pose's own ground frame). `velocity_weight_s` turns velocities into displacements.
void pose_features(const CanonicalPose& now, const CanonicalPose& before, double dt_s,
                   const GroundFrame& ground, double leg_length_m, double velocity_weight_s,
                   std::span<float> out);

}  // namespace kumite::content
