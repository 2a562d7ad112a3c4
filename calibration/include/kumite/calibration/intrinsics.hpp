#pragma once
// Single-camera intrinsic calibration (pinhole + k1 k2 p1 p2 k3) from board detections, with
// outlier views rejected and named, and the checks that tell a technician what to capture.
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "kumite/calibration/detect.hpp"

namespace kumite::calibration {

struct IntrinsicsOptions {
  double outlier_factor = 3.0;   ///< reject views whose RMS > factor x median view RMS
  int min_views = 4;             ///< usable views needed (15+ recommended)
  int min_corners_per_view = 8;  ///< fewer corners: the view is not used
  double min_perspective = 0.03; ///< below this in every view: all fronto-parallel (see .cpp)
  bool fix_aspect_ratio = false; ///< fx = fy
};

struct IntrinsicsResult {
  cv::Size image_size;
  cv::Matx33d camera_matrix = cv::Matx33d::eye();
  cv::Vec<double, 5> distortion{0, 0, 0, 0, 0};
  double rms_px = 0;                      ///< over the views kept
  std::vector<double> per_view_errors_px; ///< per input view (NaN: board not found)
  std::vector<bool> used;                 ///< per input view: part of the final solve
  std::vector<int> rejected;              ///< outlier views (indices into the input)
  std::vector<int> not_detected;          ///< views where the board was not found
  int worst_view = -1;                    ///< largest per-view error among detected views
  std::vector<cv::Vec3d> rvecs, tvecs;    ///< board pose per input view (zero when unused)
};

/// Calibrates one camera. Throws kumite::Error with a
/// one-line message saying what to capture when there are too few views, the board is never
/// seen, or every view is fronto-parallel.
IntrinsicsResult calibrate_intrinsics(const std::vector<BoardDetection>& views, cv::Size image_size,
                                      const IntrinsicsOptions& options = {});

/// RMS reprojection error (px) of one view with a known board pose.
double view_rms(const BoardDetection& view, const cv::Matx33d& K, const cv::Vec<double, 5>& dist,
                const cv::Vec3d& rvec, const cv::Vec3d& tvec);

/// How far a view is from fronto-parallel: relative depth change across the detected corners,
/// from the board-to-image homography ((max w / min w) - 1 with w the homography's third row).
double view_perspective(const BoardDetection& view);

}  // namespace kumite::calibration
