#pragma once
// The rig calibration file: written by kumite-calibrate, read by the tracker and the app.
//
// OpenCV FileStorage YAML with a sequence `cameras`, each with `name`, `image_width`,
// `image_height`, `camera_matrix` (3x3), `distortion_coefficients` (1x5: k1 k2 p1 p2 k3),
// `rotation` (3x3) and `translation` (3x1, metres), meaning x_cam = R * x_room + t.
// Room frame: metres, +Y up, floor y = 0, front wall toward -Z. Optional per camera:
// `rms_px` (reprojection RMS) and `per_view_errors_px` (1xN), written by the calibration tools.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace kumite::tracking {

struct CameraCalibration {
  std::string name;                ///< also the camera's folder name in recordings
  int image_width = 0;             ///< px
  int image_height = 0;            ///< px
  cv::Matx33d camera_matrix = cv::Matx33d::eye();  ///< px (fx 0 cx; 0 fy cy; 0 0 1)
  cv::Vec<double, 5> distortion{0, 0, 0, 0, 0};    ///< k1 k2 p1 p2 k3 (OpenCV model)
  cv::Matx33d rotation = cv::Matx33d::eye();       ///< room -> camera
  cv::Vec3d translation{0, 0, 0};                  ///< m: x_cam = R x_room + t
  std::optional<double> rms_px;                    ///< reprojection RMS, when known
  std::vector<double> per_view_errors_px;          ///< px per calibration view, when known (-1: board not seen)

  /// Camera centre in the room frame (m): -R^T t.
  cv::Vec3d position() const { return -(rotation.t() * translation); }
};

struct RigCalibration {
  std::vector<CameraCalibration> cameras;
  /// The camera called `name`, or nullptr.
  const CameraCalibration* find(const std::string& name) const;
};

/// Reads and validates a calibration file. Throws kumite::Error("calibration", ...) with a
/// one-line message naming the file and the camera/field at fault (missing field, wrong
/// matrix size, non-finite value, rotation not orthonormal, duplicate camera name, ...).
RigCalibration read_calibration(const std::filesystem::path& path);

/// Writes the file atomically (temporary file, then rename). Does not keep backups: callers
/// that replace a technician's file call keep_previous_version() first.
void write_calibration(const std::filesystem::path& path, const RigCalibration& rig);

}  // namespace kumite::tracking
