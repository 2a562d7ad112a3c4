#pragma once
// Test helper: runs the pipeline over SYNTHETIC frames rendered in memory and compares with
// the trajectory they were drawn from (an independent ground truth).
#include <cmath>
#include <functional>
#include <vector>

#include "kumite/tracking/config.hpp"
#include "kumite/tracking/pipeline.hpp"
#include "kumite/tracking/rigid_body.hpp"
#include "kumite/tracking/synth.hpp"

namespace kumite::tracking::ktest {

inline TrackingConfig shipped_config() {
  return read_tracking_config(std::filesystem::path(KUMITE_SOURCE_DIR) / "config/tracking.toml");
}

struct RunStats {
  int frames = 0;
  int tracked = 0;
  int coasting = 0;
  int lost = 0;
  double raw_pos_rms_m = 0;       // unsmoothed position vs truth
  double raw_rot_rms_deg = 0;     // unsmoothed orientation vs truth
  double max_rot_err_deg = 0;     // worst unsmoothed orientation error (identity swaps show here)
  double max_pos_err_m = 0;
  double filtered_pos_rms_m = 0;  // published (filtered) pose vs truth: includes the filter's lag
  double filtered_rot_rms_deg = 0;
  // Cramer-Rao bound for the counted frames (truth poses, rig, options.centroid_sigma_px):
  // no single-frame estimator does better on average.
  double bound_pos_rms_m = 0;
  double bound_rot_rms_deg = 0;
  std::vector<BodyPose> raw, filtered;
  std::vector<TrajectoryPoint> truth;
};

inline double angle_deg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.angularDistance(b) * 180.0 / M_PI;
}

/// Renders `frames` frame sets at options.fps along `trajectory` and tracks them.
/// `skip` frames at the start are not counted in the error statistics.
inline RunStats run_synthetic(const RigCalibration& rig, const TrackingConfig& config, const SynthOptions& options,
                              const std::function<TrajectoryPoint(double)>& trajectory, int frames, int skip = 0) {
  SyntheticRenderer renderer(rig, config.bodies.at(0), options);
  Pipeline pipeline(rig, config);
  const RigidBodyModel body(config.bodies.at(0));
  std::vector<CameraModel> cameras(rig.cameras.begin(), rig.cameras.end());
  RunStats s;
  double se_p = 0, se_r = 0, sf_p = 0, sf_r = 0, sb_p = 0, sb_r = 0;
  int n = 0;
  for (int i = 0; i < frames; ++i) {
    const TrajectoryPoint truth = trajectory(i / options.fps);
    const FrameSet set = renderer.render(static_cast<std::uint64_t>(i), truth);
    const FrameResult& r = pipeline.process(set);
    const BodyPose& raw = r.raw.at(0);
    s.raw.push_back(raw);
    s.filtered.push_back(r.filtered.at(0));
    s.truth.push_back(truth);
    ++s.frames;
    s.tracked += raw.status == TrackingStatus::tracked;
    s.coasting += raw.status == TrackingStatus::coasting;
    s.lost += raw.status == TrackingStatus::lost;
    if (i < skip || raw.status != TrackingStatus::tracked) continue;
    const Eigen::Vector3d p(raw.position[0], raw.position[1], raw.position[2]);
    const Eigen::Quaterniond q(raw.orientation[0], raw.orientation[1], raw.orientation[2], raw.orientation[3]);
    const double ep = (p - truth.position).norm();
    const double er = angle_deg(q, truth.orientation);
    se_p += ep * ep;
    se_r += er * er;
    s.max_pos_err_m = std::max(s.max_pos_err_m, ep);
    s.max_rot_err_deg = std::max(s.max_rot_err_deg, er);
    const BodyPose& f = r.filtered.at(0);
    const Eigen::Quaterniond qf(f.orientation[0], f.orientation[1], f.orientation[2], f.orientation[3]);
    sf_p += (Eigen::Vector3d(f.position.data()) - truth.position).squaredNorm();
    sf_r += std::pow(angle_deg(qf, truth.orientation), 2);
    RigidPose pose;
    pose.rotation = truth.orientation;
    pose.translation = truth.position - truth.orientation * body.centroid();
    const PoseErrorBound b = pose_error_bound(body, pose, cameras, options.centroid_sigma_px, options.hidden_markers);
    sb_p += b.position_m * b.position_m;
    sb_r += std::pow(b.orientation_rad * 180.0 / M_PI, 2);
    ++n;
  }
  if (n) {
    s.raw_pos_rms_m = std::sqrt(se_p / n);
    s.raw_rot_rms_deg = std::sqrt(se_r / n);
    s.filtered_pos_rms_m = std::sqrt(sf_p / n);
    s.filtered_rot_rms_deg = std::sqrt(sf_r / n);
    s.bound_pos_rms_m = std::sqrt(sb_p / n);
    s.bound_rot_rms_deg = std::sqrt(sb_r / n);
  }
  return s;
}

}  // namespace kumite::tracking::ktest
