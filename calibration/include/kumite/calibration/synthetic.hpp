#pragma once
// SYNTHETIC test data: images of a board seen by a known camera (pinhole + k1 k2 p1 p2 k3),
// rendered per pixel by casting each (supersampled) pixel's ray onto the board plane, with
// blur and noise. The ground truth is the camera and board pose given here; the estimators
// never see them. Used by the tests and the benchmark only.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "kumite/calibration/board.hpp"
#include "kumite/calibration/detect.hpp"

namespace kumite::calibration::synthetic {

struct Camera {
  cv::Size size{1280, 720};
  cv::Matx33d K = cv::Matx33d::eye();
  cv::Vec<double, 5> dist{0, 0, 0, 0, 0};
  cv::Matx33d R = cv::Matx33d::eye();  ///< world -> camera: x_cam = R x_world + t
  cv::Vec3d t{0, 0, 0};
  cv::Vec3d position() const { return -(R.t() * t); }
};

/// A camera at `position` looking at `target` with world `up` (OpenCV axes: +Z forward,
/// +Y down in the image).
Camera look_at(cv::Vec3d position, cv::Vec3d target, cv::Vec3d up, cv::Size size, double f_px,
               cv::Vec<double, 5> dist = {0, 0, 0, 0, 0});

/// A board pose: x_world = R x_board + t.
struct Pose {
  cv::Matx33d R = cv::Matx33d::eye();
  cv::Vec3d t{0, 0, 0};
};

struct RenderOptions {
  int supersample = 3;          ///< samples per pixel along each axis (area-averaged)
  double blur_sigma_px = 0.5;   ///< optics blur
  double noise_sigma = 2.0;     ///< grey levels, Gaussian sensor noise
  double black = 25, white = 225, background = 110;  ///< grey levels
  std::uint64_t seed = 1;
};

/// Renders the board (its printed sheet: pattern + default margin) as seen by `cam`.
cv::Mat render_view(const BoardPattern& pattern, const Board& board, const Camera& cam, const Pose& board_pose,
                    const RenderOptions& options = {});

/// Board detections without images: the corners of `board` at each pose projected through
/// each camera, with Gaussian noise (px), kept when the printed side faces the camera within
/// ~70 degrees and at least 8 corners fall in the image. [camera][pose].
std::vector<std::vector<BoardDetection>> project_views(const Board& board, const std::vector<Camera>& cameras,
                                                       const std::vector<Pose>& poses, double noise_px,
                                                       std::uint64_t seed = 1);

/// Where a board point lands in the image (forward model; for checks).
cv::Point2d project(const Camera& cam, const cv::Vec3d& world);

/// Rotation from an axis (any length) and an angle in degrees.
cv::Matx33d rotation(cv::Vec3d axis, double degrees);

}  // namespace kumite::calibration::synthetic
