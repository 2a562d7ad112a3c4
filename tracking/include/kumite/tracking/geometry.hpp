#pragma once
// From blobs to 3D markers: undistortion to rays, correspondence across cameras (epipolar
// constraint = rays that nearly meet, then consistency over every other camera), and
// triangulation (linear least squares over rays, then Gauss-Newton on the reprojection
// error), with a residual per marker (mean distance from the marker to its rays).
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "kumite/tracking/blobs.hpp"
#include "kumite/tracking/calibration_file.hpp"
#include "kumite/tracking/config.hpp"

namespace kumite::tracking {

/// One blob, undistorted, as the correspondence step sees it.
struct Observation {
  Eigen::Vector2d normalised;  ///< undistorted normalised coordinates
  Eigen::Vector3d ray;         ///< unit direction, room frame
};

/// A calibrated camera, ready for per-frame work.
class CameraModel {
 public:
  explicit CameraModel(const CameraCalibration& calibration);

  const CameraCalibration& calibration() const { return cal_; }
  /// Camera centre in the room (m).
  const Eigen::Vector3d& centre() const { return centre_; }
  /// Undistorted normalised image coordinates (x/z, y/z in the camera frame) of a pixel.
  Eigen::Vector2d normalise(double px, double py) const;
  /// Undistorts all the blobs of one image at once into `out` (rays included).
  void observe(std::span<const Blob> blobs, std::vector<Observation>& out) const;
  /// Unit ray direction in the room frame through a normalised point.
  Eigen::Vector3d ray(const Eigen::Vector2d& normalised) const;
  /// Pixel of a room point (with distortion); false when it is behind the camera.
  bool project(const Eigen::Vector3d& room, Eigen::Vector2d& pixel) const;
  /// Camera-frame point.
  Eigen::Vector3d to_camera(const Eigen::Vector3d& room) const { return R_ * room + t_; }
  /// Focal length (px), mean of fx and fy: converts normalised errors into pixels.
  double focal_px() const { return focal_; }

 private:
  CameraCalibration cal_;
  Eigen::Matrix3d R_;
  Eigen::Vector3d t_;
  Eigen::Vector3d centre_;
  double focal_;
};

constexpr int kMaxCameras = 16;

/// A triangulated marker.
struct Marker {
  Eigen::Vector3d position{0, 0, 0};  ///< m, room frame
  double residual_m = 0;              ///< m: mean distance from the position to its rays
  int cameras = 0;                    ///< how many cameras saw it
  std::array<std::int16_t, kMaxCameras> blob;  ///< blob index per camera, -1 = not seen
};

/// Per-frame correspondence and triangulation. Owns its scratch buffers.
class Triangulator {
 public:
  Triangulator(std::span<const CameraModel> cameras, MatchConfig config);

  /// `observations[c]` are camera c's undistorted blobs (empty when the camera gave no image).
  /// Returns the markers (valid until the next call).
  const std::vector<Marker>& run(std::span<const std::vector<Observation>> observations);

 private:
  struct Candidate {
    Marker marker;
    double score;
  };
  bool refine(Marker& m, std::span<const std::vector<Observation>> obs) const;
  void gather_support(Marker& m, std::span<const std::vector<Observation>> obs,
                      const std::vector<std::vector<std::uint8_t>>& used) const;

  std::span<const CameraModel> cameras_;
  MatchConfig config_;
  std::vector<Candidate> candidates_;
  std::vector<Marker> markers_;
  std::vector<std::vector<std::uint8_t>> used_;
};

/// Least-squares intersection of rays (the point minimising the summed squared distances).
Eigen::Vector3d intersect_rays(std::span<const Eigen::Vector3d> origins,
                               std::span<const Eigen::Vector3d> directions);

}  // namespace kumite::tracking
