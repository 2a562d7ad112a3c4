#pragma once
// Multi-camera extrinsics: per-view board poses (solvePnP) chained through a pose graph
// (breadth-first over the camera-view graph from the reference camera) give initial camera
// and board poses; a Ceres bundle adjustment then refines all camera poses and board poses
// jointly (intrinsics fixed or refined) under a robust (Huber) loss.
// The rig frame is the reference camera's (camera 0) until `align` fixes the room frame.
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "kumite/calibration/detect.hpp"
#include "kumite/tracking/calibration_file.hpp"

namespace kumite::calibration {

/// A rigid transform: x_to = R x_from + t.
struct RigidPose {
  cv::Matx33d R = cv::Matx33d::eye();
  cv::Vec3d t{0, 0, 0};
  RigidPose inverse() const { return {R.t(), -(R.t() * t)}; }
  RigidPose operator*(const RigidPose& o) const { return {R * o.R, R * o.t + t}; }
};

struct ExtrinsicsOptions {
  bool refine_intrinsics = false;
  double huber_px = 1.0;        ///< robust loss scale (px): errors beyond count linearly
  int min_corners = 8;          ///< fewer corners in a view: not used
  int max_iterations = 100;
  int threads = 1;
  /// Called with a line of progress (pose graph, each solver iteration).
  std::function<void(const std::string&)> progress;
};

struct ExtrinsicsResult {
  std::vector<tracking::CameraCalibration> cameras;  ///< names, intrinsics, R/t (rig frame)
  std::vector<double> rms_px;                        ///< per camera, after adjustment
  std::vector<std::vector<double>> view_errors_px;   ///< [camera][frame]; NaN: not seen
  std::vector<std::optional<RigidPose>> board_poses; ///< per frame: board -> rig
  double rms_px_all = 0;
  double initial_rms_px = 0;                         ///< before the bundle adjustment
  int frames_used = 0;
  int observations = 0;                              ///< corners in the adjustment
};

/// `cameras`: each camera's name and intrinsics (R/t ignored); `views[c][f]`: camera c's
/// detection at frame f (empty when not seen). Throws kumite::Error naming the camera when
/// one never sees the board or never shares a view with the others (rig not connected).
ExtrinsicsResult solve_extrinsics(const std::vector<tracking::CameraCalibration>& cameras,
                                  const std::vector<std::vector<BoardDetection>>& views,
                                  const ExtrinsicsOptions& options = {});

/// Board pose in a camera from one view (IPPE then Levenberg-Marquardt).
std::optional<RigidPose> board_pose_in_camera(const BoardDetection& view, const tracking::CameraCalibration& cam);

/// Does each camera agree with the rest of the rig, view by view? For camera c at frame f:
/// the board pose as each OTHER camera sees it (its own view, solvePnP, through its
/// calibrated pose) is projected into c, and c's detected corners are compared with that;
/// the other camera that agrees best counts (so one bad camera does not make the others look
/// bad). A camera knocked out of place during the capture shows as a jump in the mean
/// residual over view order (time): two clusters of views.
struct CameraCheck {
  std::vector<double> rms_px;        ///< per frame: RMS of c's corners against the others' board (NaN: no pair)
  std::vector<cv::Vec2d> mean_px;    ///< per frame: mean residual (detected - predicted), px
  double rms_all_px = std::numeric_limits<double>::quiet_NaN();  ///< over every paired view
  int views = 0;                     ///< frames with a pair
  /// Its residuals are really high: above kBlameFloorPx and kBlameFactor x the rig's median.
  bool blamed = false;
  /// Moved: the residuals split at a frame into two clusters whose mean residuals differ by
  /// jump_px (>= kMoveMinPx and well outside the spread within each cluster): the last frame
  /// clearly before and the first clearly after (indices into the frame list; views between
  /// them, whose mean residual lies well between the clusters', are flagged).
  std::optional<std::pair<int, int>> moved_between;
  double jump_px = 0;    ///< px: the best split's jump in the mean residual (also when not a move)
  double spread_px = 0;  ///< px: RMS spread of the mean residuals around their run's mean
  double explained = 0;  ///< fraction of the mean residuals' variance the split explains
  /// Per frame: true for the views of the cluster that disagrees more with the calibration,
  /// and those between the clusters.
  std::vector<bool> flagged;
};
struct RigCheck {
  std::vector<CameraCheck> cameras;  ///< in the order given
  double median_rms_px = 0;          ///< median over the cameras' rms_all_px
};
inline constexpr double kBlameFloorPx = 1.0;  ///< px: below this no camera is blamed
inline constexpr double kBlameFactor = 3.0;   ///< x the median camera
inline constexpr double kMoveMinPx = 3.0;     ///< px: smallest jump called a move
/// `cameras`: calibrated (intrinsics and R/t in one frame); `views[c][f]` as solve_extrinsics.
RigCheck check_rig(const std::vector<tracking::CameraCalibration>& cameras,
                   const std::vector<std::vector<BoardDetection>>& views);
/// One line about a camera's check for people, naming frames by `frame_names` (file stems):
/// "" when it is not blamed, e.g. "cam2 moved between views 000039 and 000040 (its residuals
/// jump by 12.1 px; 20 of 40 views flagged)" or "cam2: residuals 4.2 px against the other
/// cameras' view of the board (the rig's median 0.3 px)".
std::string describe_check(const std::string& camera, const CameraCheck& check, const RigCheck& rig,
                           const std::vector<std::string>& frame_names);

}  // namespace kumite::calibration

namespace kumite::calibration {

/// Room-from-board pose of a board lying face up on the floor: its origin (top-left tag
/// corner) at `origin_room`, its +X along room +X turned by `yaw_deg` about room +Y, its +Y
/// (down the printed page) toward room +Z (away from the front wall), its +Z into the floor.
RigidPose floor_board_pose(const cv::Vec3d& origin_room, double yaw_deg);

/// The board's pose in the rig frame (board -> rig) from views of it by calibrated cameras
/// (`views[c]` for cameras[c]; empty when not seen): per-camera PnP, averaged, then refined
/// jointly over all cameras' corners. Throws when no camera sees it.
RigidPose board_pose_in_rig(const std::vector<tracking::CameraCalibration>& cameras,
                            const std::vector<BoardDetection>& views);

/// Re-expresses every camera in the room frame given room_from_rig (x_room = R x_rig + t).
void apply_room_frame(std::vector<tracking::CameraCalibration>& cameras, const RigidPose& room_from_rig);

/// Least-squares rigid transform with to ~ R from + t (Kabsch; at least 3 points, not collinear).
RigidPose fit_rigid(const std::vector<cv::Vec3d>& from, const std::vector<cv::Vec3d>& to);

/// A point seen by several calibrated cameras: (camera index, pixel). Linear (DLT)
/// triangulation of the undistorted rays.
cv::Vec3d triangulate(const std::vector<tracking::CameraCalibration>& cameras,
                      const std::vector<std::pair<int, cv::Point2d>>& pixels);

}  // namespace kumite::calibration
