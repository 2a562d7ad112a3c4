#pragma once
// Rigid bodies from markers: identification by inter-marker distances (or, while tracked, by
// nearness to the predicted marker positions), Kabsch/Umeyama fit (Eigen::umeyama without
// scaling) when >= 3 markers match, and position-only updates with the last orientation when
// fewer do.
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "kumite/tracking/config.hpp"
#include "kumite/tracking/geometry.hpp"

namespace kumite::tracking {

/// px: two markers of a body whose images lie closer than this in a camera have merged into
/// one blob (or nearly): its centroid sits between them, so the pose refinement uses neither
/// image from that camera (and pose_error_bound() counts neither).
inline constexpr double kMinImageSeparationPx = 5.0;

/// A rigid transform body -> room: x_room = rotation * x_body + translation.
struct RigidPose {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation{0, 0, 0};  ///< m
  Eigen::Vector3d apply(const Eigen::Vector3d& body) const { return rotation * body + translation; }
};

/// Result of matching one body in one frame set.
struct BodyFit {
  RigidPose pose;                 ///< body -> room
  std::vector<int> marker_of;     ///< per model marker: index into the markers, -1 = unseen
  int matched = 0;                ///< model markers matched
  bool full = false;              ///< 6-DoF fit (>= 3 markers); false: position only
  double rms_m = 0;               ///< m: RMS distance of matched markers from the model
  int cameras = 0;                ///< distinct cameras that saw the matched markers
};

class RigidBodyModel {
 public:
  explicit RigidBodyModel(const BodyConfig& config);

  const BodyConfig& config() const { return config_; }
  std::size_t size() const { return config_.markers.size(); }
  /// Centroid of all the model markers (body frame, m): the reported body position.
  const Eigen::Vector3d& centroid() const { return centroid_; }

  /// Finds the body among `markers`. `predicted` (the unsmoothed pose extrapolated to this
  /// frame) enables the fast nearest-marker path and the position-only fallback;
  /// `taken[i]` != 0 marks markers already claimed by another body (never matched).
  std::optional<BodyFit> fit(std::span<const Marker> markers,
                             const std::optional<RigidPose>& predicted,
                             std::span<const std::uint8_t> taken) const;

  /// Refines a 6-DoF fit on the image evidence: Gauss-Newton on the reprojection error (px)
  /// of every ray of every matched marker, the maximum-likelihood pose under pixel noise
  /// (better than fitting the triangulated points, which weights every marker the same).
  void refine(std::span<const Marker> markers, std::span<const CameraModel> cameras,
              std::span<const std::vector<Observation>> observations, BodyFit& fit) const;

  /// Identification from scratch by inter-marker distances (no prediction).
  std::optional<BodyFit> identify(std::span<const Marker> markers,
                                  std::span<const std::uint8_t> taken) const;

 private:
  std::optional<BodyFit> from_prediction(std::span<const Marker> markers, const RigidPose& predicted,
                                         std::span<const std::uint8_t> taken) const;
  bool solve(std::span<const Marker> markers, BodyFit& fit) const;
  bool consistent(std::span<const Marker> markers, const BodyFit& fit) const;

  BodyConfig config_;
  Eigen::Vector3d centroid_;
  Eigen::MatrixXd distance_;  // model inter-marker distances (m)
};

/// The Cramer-Rao lower bound on the error of ANY unbiased single-frame estimate of a body's
/// pose from the image positions of its markers, when each image position carries independent
/// Gaussian noise of `sigma_px` per image axis (x and y): the floor under what the estimator
/// (identification + fit + refine) can reach for this rig, marker layout and noise, whatever
/// its cleverness. Only a temporal model (a filter) or more information (longer lenses, more
/// cameras, a wider marker layout) goes below it. Every camera that has a marker in front of
/// it and inside its image is counted, except images of two markers closer than
/// kMinImageSeparationPx (merged: no usable information); `hidden` model markers are not.
struct PoseErrorBound {
  double orientation_rad = 0;  ///< RMS rotation error (rad): sqrt of the trace of its covariance
  double position_m = 0;       ///< RMS error of the reported position (centroid of the model markers), m
  int observations = 0;        ///< marker images counted
};
PoseErrorBound pose_error_bound(const RigidBodyModel& body, const RigidPose& pose,
                                std::span<const CameraModel> cameras, double sigma_px,
                                std::span<const int> hidden = {});

}  // namespace kumite::tracking
