#pragma once
// Wand dance: a wand with two markers a known distance apart is waved through the volume and
// recorded (recording layout of kumite/tracking/recording.hpp). Each frame set goes through
// the tracker's own blob detector and triangulator; frames with exactly two markers give a
// wand, each camera's two blobs are matched to it (also in a camera the tracker's outlier
// test dropped), and the markers are re-intersected from every camera to give the length. The spread of those lengths over the volume says how good the calibration is;
// `refine` then adjusts the camera poses (all but the first, which anchors the room frame)
// in a bundle adjustment over the wand's blobs with the known length as a constraint.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "kumite/tracking/blobs.hpp"
#include "kumite/tracking/calibration_file.hpp"
#include "kumite/tracking/config.hpp"

namespace kumite::calibration {

struct WandOptions {
  double length_m = 0.5;               ///< m, the true distance between the wand's markers
  tracking::BlobParams blobs{};         ///< the tracker's blob detector settings
  tracking::MatchConfig match{};        ///< the tracker's correspondence settings
  double length_sigma_m = 0.0005;      ///< m: weight of the length constraint when refining
  double blob_sigma_px = 0.3;          ///< px: weight of a blob centroid when refining
  std::function<void(const std::string&)> progress;
};

/// One frame with both wand markers triangulated.
struct WandSample {
  std::uint64_t frame = 0;
  cv::Vec3d a{0, 0, 0}, b{0, 0, 0};   ///< m, room frame
  double length_m = 0;
  /// Per camera: the two blob centroids (px) matched to a and b; NaN when not seen.
  std::vector<std::array<cv::Point2d, 2>> pixels;
};

struct WandStats {
  int samples = 0;
  double mean_m = 0, std_m = 0, min_m = 0, max_m = 0;
  double rms_error_m = 0;  ///< RMS of (length - true length)
};

/// Length statistics in one cell of the volume (a coarse grid over x, z; y in two layers).
struct WandRegion {
  cv::Vec3d centre{0, 0, 0};
  WandStats stats;
};

struct WandResult {
  int frames = 0;                     ///< frame sets read
  std::vector<WandSample> samples;
  WandStats stats;
  std::vector<WandRegion> regions;    ///< cells with samples
  std::vector<int> camera_blobs;      ///< per camera: wand blobs it contributed
  std::vector<double> camera_rms_px;  ///< per camera: RMS reprojection of the wand markers
  std::optional<tracking::RigCalibration> refined;
  WandStats refined_stats;            ///< lengths after refinement (same samples)
};

WandStats wand_stats(const std::vector<double>& lengths, double true_length_m);

/// Reads the recording and measures the wand. Throws when no frame shows the two markers.
WandResult measure_wand(const tracking::RigCalibration& rig, const std::filesystem::path& recording,
                        const WandOptions& options);

/// Refines camera poses (camera 0 held) from the samples: reprojection of each sample's blobs
/// plus the known length. Fills result.refined and result.refined_stats.
void refine_with_wand(const tracking::RigCalibration& rig, const WandOptions& options, WandResult& result);

}  // namespace kumite::calibration
