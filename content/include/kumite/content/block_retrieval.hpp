#pragma once
// Block retrieval: given the fighter's pose and an incoming fist's path, choose the block
// (segment, start frame) whose forearm is across that path, through the same search as a
// strike (retrieval.hpp) over the database's block index.
//
// A block row's window is the forearm's contact point (its middle, kForearmContactFraction)
// over the frames the forearm is in place (the annotation's intercept_frames), in the row's
// start pose ground frame; its group is (forearm, height). The query's target is where the
// fist path crosses the guard: the vertical cylinder of radius Database::block_reach_m about
// the fighter's pelvis (the median reach of the blocks' contact points), the first crossing
// ahead of the fist, or the path's point nearest the pelvis when it passes outside. The
// target's height above the floor, relative to the actor's stature, gives the height class
// (StrikeHeightThresholds, as a strike's); both forearms' groups of that height are searched
// and the lower cost wins (ties: the lower row). When no block guards that height the nearest
// height that has one is searched instead.
//
// Frames: everything in the fighter's ground frame (ground_frame_of its current pose: origin
// at the pelvis on the floor, +Z forward, +X to its left, y up from the floor), scaled to the
// database actor's size, as a strike's target is.
#include <array>
#include <span>

#include <Eigen/Core>

#include "kumite/content/annotation.hpp"
#include "kumite/content/database.hpp"
#include "kumite/content/retrieval.hpp"
#include "kumite/content/tunables.hpp"

namespace kumite::content {

/// An incoming fist: where it is and where it is heading.
struct FistPath {
  Eigen::Vector3f point_m{0, 0, 0};      ///< m, the fist now
  Eigen::Vector3f velocity_mps{0, 0, 0};  ///< m/s
};
/// The path of a fist now at `fist_m` that arrives at a predicted `impact_m` in `arrival_s`
/// (recognition's prediction) as a straight line at constant speed.
FistPath fist_path_to_impact(const Eigen::Vector3f& fist_m, const Eigen::Vector3f& impact_m, double arrival_s);

/// Where and when a fist path meets the guard (see the top of this file).
struct BlockIntercept {
  Eigen::Vector3f point_m{0, 0, 0};  ///< m, the target of the block's forearm
  double time_s = 0;                 ///< s from now until the fist is there
  StrikeHeight height = StrikeHeight::mid;  ///< the target's height class
  bool crosses = false;              ///< false: the path passes outside the guard (nearest point)
};
BlockIntercept block_intercept(const FistPath& fist, double reach_m, double stature_m,
                               const StrikeHeightThresholds& thresholds = {});

struct BlockQuery {
  std::array<float, kFeatureDim> features{};  ///< the fighter's pose (pose_features), as a strike query's
  FistPath fist;
};

struct BlockChoice {
  RetrievalChoice choice;   ///< row in Database::block_index; -1: no block (none in the database, or bad input)
  int segment = -1;         ///< Database::segments index
  int start_frame = -1;     ///< segment frame the block starts from
  int intercept_frame = -1; ///< segment frame where the forearm's contact point is nearest the target
  std::array<int, 2> intercept_window{-1, -1};  ///< segment frames the forearm stays in place
  Forearm forearm = Forearm::left;
  StrikeHeight height = StrikeHeight::mid;  ///< the chosen block's (what it guards)
  BlockIntercept intercept;  ///< the target on the fist's path
  double lead_s = 0;         ///< s from start_frame to intercept_frame: the block is in place this
                             ///< long after it starts (in time when lead_s <= intercept.time_s)
};

BlockChoice retrieve_block(const Database& db, const BlockQuery& query, const RetrievalTunables& tunables,
                           RetrievalStats* stats = nullptr);
/// The same choice by retrieve_brute_force (tests).
BlockChoice retrieve_block_brute_force(const Database& db, const BlockQuery& query, const RetrievalTunables& tunables);

/// The block index group of a forearm and height: side + 2 * height.
inline int block_group(Forearm f, StrikeHeight h) { return static_cast<int>(f) + 2 * static_cast<int>(h); }

}  // namespace kumite::content
