#pragma once
// Bright-blob detection in 8-bit greyscale camera images (IR markers, wand LEDs/balls).
//
// Sparse and fast: only every `seed_row_step`-th row is scanned for seed pixels (8 pixels at a
// time), and each seed is grown by a flood fill over the pixels above the threshold, so the
// cost is one partial pass over the image plus the area of the blobs themselves (a full
// connectedComponentsWithStats costs 2-10 ms on 1280x1024 here; this costs ~0.1 ms).
//
// Coordinates follow OpenCV: the centre of pixel (col, row) is at (x, y) = (col, row).
// Centroids are intensity weighted with weight (grey - threshold), so they are sub-pixel.
//
// Usage (the detector owns its buffers; no allocation per frame once warm):
//   kumite::tracking::BlobDetector detector({.threshold = 60});
//   const auto& blobs = detector.detect(grey);   // valid until the next detect()
#include <cstdint>
#include <span>
#include <vector>

#include <opencv2/core.hpp>

#include "kumite/common/time.hpp"

namespace kumite::tracking {

struct Blob {
  double x = 0;          ///< px, intensity-weighted centroid column
  double y = 0;          ///< px, intensity-weighted centroid row
  double area = 0;       ///< px^2: pixels above the threshold
  double roundness = 0;  ///< 0..1: sqrt(minor / major eigenvalue of the second moments); 1 = disc
  double weight = 0;     ///< sum of (grey - threshold) over the blob (grey levels x px)
  int peak = 0;          ///< brightest grey level in the blob
};

struct BlobParams {
  int threshold = 60;          ///< grey level; pixels strictly above it are bright
  int seed_row_step = 2;       ///< px: rows scanned for seeds; <= the smallest blob's height
  int min_area = 3;            ///< px^2: smaller blobs are noise
  int max_area = 2500;         ///< px^2: larger ones are lamps, windows, reflections
  double min_roundness = 0.6;  ///< 0..1: rejects streaks and merged pairs of markers
  int max_blobs = 128;         ///< per image; more are dropped (counted in BlobStats)
};

/// What the last detect() rejected (for status lines and tuning).
struct BlobStats {
  int too_small = 0;
  int too_large = 0;
  int not_round = 0;
  int over_limit = 0;
};

class BlobDetector {
 public:
  explicit BlobDetector(BlobParams params = {});

  /// Detects blobs in an 8-bit single-channel image (throws kumite::Error("blobs", ...)
  /// otherwise). The result is valid until the next call.
  const std::vector<Blob>& detect(const cv::Mat& grey);

  const BlobParams& params() const { return params_; }
  void set_params(const BlobParams& params) { params_ = params; }
  const BlobStats& last_stats() const { return stats_; }

 private:
  void grow(const cv::Mat& grey, int seed);

  BlobParams params_;
  BlobStats stats_;
  std::vector<Blob> blobs_;
  std::vector<std::uint8_t> visited_;  // one byte per pixel, cleared through touched_
  std::vector<int> touched_;           // pixel indices marked in this call
  std::vector<int> stack_;
  int width_ = 0;
  int height_ = 0;
};

/// One-shot convenience (allocates its buffers each call).
std::vector<Blob> detect_blobs(const cv::Mat& grey, const BlobParams& params = {});

/// A static mask learnt from blobs that never move (lamps, reflections on shiny surfaces), as
/// commercial trackers do: a blob that stays within `still_px` of where it appeared for
/// `learn_s` seconds, and was never used by a tracked body, becomes a masked disc; blobs whose
/// centroid falls in a masked disc are dropped from then on. One mask per camera.
struct StaticMaskParams {
  double still_px = 1.0;       ///< px: how far a blob may wander and still count as static
  double learn_s = 3.0;        ///< s: how long it must stay put before it is masked
  double margin_px = 3.0;      ///< px: added to the blob's radius for the masked disc
  double forget_s = 0.25;      ///< s: an unmasked candidate not seen for this long is dropped
  std::size_t max_regions = 1024;  ///< candidates and masked discs together
};

class StaticMask {
 public:
  explicit StaticMask(StaticMaskParams params = {}) : params_(params) {}

  /// Feeds the blobs of one frame at time `t` (s). `used[i]` != 0 when blob i belonged to a
  /// tracked body in this frame (such blobs are never learnt); `used` may be empty.
  void update(std::span<const Blob> blobs, std::span<const std::uint8_t> used, Timestamp t);
  /// True when the point lies in a masked disc.
  bool masked(double x, double y) const;
  /// Removes masked blobs in place; returns how many were removed.
  int apply(std::vector<Blob>& blobs) const;
  /// Number of masked discs.
  std::size_t regions() const;
  void clear() { candidates_.clear(); }

 private:
  struct Candidate {
    double x, y, radius;
    Timestamp first_seen, last_seen;
    bool is_masked;
  };
  StaticMaskParams params_;
  std::vector<Candidate> candidates_;
};

}  // namespace kumite::tracking
