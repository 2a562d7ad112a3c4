#include "kumite/tracking/rigid_body.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <Eigen/Dense>
#include <Eigen/Geometry>

namespace kumite::tracking {

RigidBodyModel::RigidBodyModel(const BodyConfig& config) : config_(config) {
  const std::size_t n = config_.markers.size();
  centroid_.setZero();
  for (const auto& m : config_.markers) centroid_ += m;
  centroid_ /= static_cast<double>(n);
  distance_.resize(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = 0; b < n; ++b)
      distance_(a, b) = (config_.markers[a] - config_.markers[b]).norm();
}

namespace {

int count_cameras(std::span<const Marker> markers, const std::vector<int>& marker_of) {
  std::uint32_t seen = 0;
  for (int i : marker_of) {
    if (i < 0) continue;
    for (int c = 0; c < kMaxCameras; ++c)
      if (markers[i].blob[c] >= 0) seen |= 1U << c;
  }
  return std::popcount(seen);
}

}  // namespace

bool RigidBodyModel::solve(std::span<const Marker> markers, BodyFit& fit) const {
  fit.matched = 0;
  for (int i : fit.marker_of) fit.matched += i >= 0;
  if (fit.matched < 3) return false;
  Eigen::Matrix3Xd src(3, fit.matched), dst(3, fit.matched);
  int k = 0;
  for (std::size_t m = 0; m < fit.marker_of.size(); ++m) {
    if (fit.marker_of[m] < 0) continue;
    src.col(k) = config_.markers[m];
    dst.col(k) = markers[fit.marker_of[m]].position;
    ++k;
  }
  const Eigen::Matrix4d T = Eigen::umeyama(src, dst, false);
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  if (R.determinant() < 0.5) return false;
  fit.pose.rotation = Eigen::Quaterniond(R).normalized();
  fit.pose.translation = T.topRightCorner<3, 1>();
  double sum = 0;
  for (std::size_t m = 0; m < fit.marker_of.size(); ++m) {
    if (fit.marker_of[m] < 0) continue;
    sum += (fit.pose.apply(config_.markers[m]) - markers[fit.marker_of[m]].position).squaredNorm();
  }
  fit.rms_m = std::sqrt(sum / fit.matched);
  fit.full = true;
  fit.cameras = count_cameras(markers, fit.marker_of);
  return true;
}

bool RigidBodyModel::consistent(std::span<const Marker> markers, const BodyFit& fit) const {
  for (std::size_t a = 0; a < fit.marker_of.size(); ++a) {
    if (fit.marker_of[a] < 0) continue;
    for (std::size_t b = a + 1; b < fit.marker_of.size(); ++b) {
      if (fit.marker_of[b] < 0) continue;
      const double d = (markers[fit.marker_of[a]].position - markers[fit.marker_of[b]].position).norm();
      if (std::abs(d - distance_(a, b)) > config_.distance_tolerance_m) return false;
    }
  }
  return true;
}

std::optional<BodyFit> RigidBodyModel::from_prediction(std::span<const Marker> markers,
                                                       const RigidPose& predicted,
                                                       std::span<const std::uint8_t> taken) const {
  const std::size_t n = size();
  BodyFit fit;
  fit.marker_of.assign(n, -1);
  std::vector<double> best(n, config_.match_radius_m);
  for (std::size_t m = 0; m < n; ++m) {
    const Eigen::Vector3d p = predicted.apply(config_.markers[m]);
    for (std::size_t i = 0; i < markers.size(); ++i) {
      if (i < taken.size() && taken[i]) continue;
      const double d = (markers[i].position - p).norm();
      if (d < best[m]) best[m] = d, fit.marker_of[m] = static_cast<int>(i);
    }
  }
  // One marker, one model marker: the closer claim wins.
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = a + 1; b < n; ++b)
      if (fit.marker_of[a] >= 0 && fit.marker_of[a] == fit.marker_of[b]) {
        (best[a] <= best[b] ? fit.marker_of[b] : fit.marker_of[a]) = -1;
      }
  // Drop the worst-fitting marker while the distances disagree with the model.
  while (!consistent(markers, fit)) {
    int worst = -1;
    int worst_bad = 0;
    for (std::size_t a = 0; a < n; ++a) {
      if (fit.marker_of[a] < 0) continue;
      int bad = 0;
      for (std::size_t b = 0; b < n; ++b) {
        if (b == a || fit.marker_of[b] < 0) continue;
        const double d = (markers[fit.marker_of[a]].position - markers[fit.marker_of[b]].position).norm();
        bad += std::abs(d - distance_(a, b)) > config_.distance_tolerance_m;
      }
      if (bad > worst_bad) worst_bad = bad, worst = static_cast<int>(a);
    }
    if (worst < 0) break;
    fit.marker_of[worst] = -1;
  }
  fit.matched = 0;
  for (int i : fit.marker_of) fit.matched += i >= 0;
  if (fit.matched == 0) return std::nullopt;
  if (fit.matched >= 3) {
    if (!solve(markers, fit) || fit.rms_m > config_.distance_tolerance_m) return std::nullopt;
    return fit;
  }
  // Fewer than 3: position from the remaining markers with the last orientation.
  fit.pose.rotation = predicted.rotation;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t m = 0; m < n; ++m) {
    if (fit.marker_of[m] < 0) continue;
    sum += markers[fit.marker_of[m]].position - predicted.rotation * config_.markers[m];
  }
  fit.pose.translation = sum / fit.matched;
  fit.full = false;
  double s2 = 0;
  for (std::size_t m = 0; m < n; ++m) {
    if (fit.marker_of[m] < 0) continue;
    s2 += (fit.pose.apply(config_.markers[m]) - markers[fit.marker_of[m]].position).squaredNorm();
  }
  fit.rms_m = std::sqrt(s2 / fit.matched);
  fit.cameras = count_cameras(markers, fit.marker_of);
  return fit;
}

std::optional<BodyFit> RigidBodyModel::identify(std::span<const Marker> markers,
                                                std::span<const std::uint8_t> taken) const {
  const std::size_t n = size();
  const double tol = config_.distance_tolerance_m;
  const auto free = [&](std::size_t i) { return !(i < taken.size() && taken[i]); };
  // From scratch, ask for 4 markers when the model has them: 3 points at the right distances
  // among many spurious ones happen by chance, 4 do not.
  const int needed = static_cast<int>(std::min<std::size_t>(n, 4));
  std::optional<BodyFit> best;
  const std::size_t M = markers.size();
  for (std::size_t p = 0; p < M; ++p) {
    if (!free(p)) continue;
    for (std::size_t q = 0; q < M; ++q) {
      if (q == p || !free(q)) continue;
      const double dpq = (markers[p].position - markers[q].position).norm();
      for (std::size_t a = 0; a < n; ++a) {
        for (std::size_t b = 0; b < n; ++b) {
          if (a == b || std::abs(dpq - distance_(a, b)) > tol) continue;
          for (std::size_t r = 0; r < M; ++r) {
            if (r == p || r == q || !free(r)) continue;
            const double dpr = (markers[p].position - markers[r].position).norm();
            const double dqr = (markers[q].position - markers[r].position).norm();
            for (std::size_t c = 0; c < n; ++c) {
              if (c == a || c == b) continue;
              if (std::abs(dpr - distance_(a, c)) > tol || std::abs(dqr - distance_(b, c)) > tol) continue;
              BodyFit fit;
              fit.marker_of.assign(n, -1);
              fit.marker_of[a] = static_cast<int>(p);
              fit.marker_of[b] = static_cast<int>(q);
              fit.marker_of[c] = static_cast<int>(r);
              if (!solve(markers, fit) || fit.rms_m > tol) continue;
              // Extend with the other model markers near where this pose puts them.
              for (std::size_t m = 0; m < n; ++m) {
                if (fit.marker_of[m] >= 0) continue;
                const Eigen::Vector3d e = fit.pose.apply(config_.markers[m]);
                double bd = tol;
                for (std::size_t i = 0; i < M; ++i) {
                  if (!free(i) || std::find(fit.marker_of.begin(), fit.marker_of.end(), int(i)) != fit.marker_of.end()) continue;
                  const double d = (markers[i].position - e).norm();
                  if (d < bd) bd = d, fit.marker_of[m] = static_cast<int>(i);
                }
              }
              if (!solve(markers, fit) || fit.rms_m > tol) continue;
              if (fit.matched < needed) {
                // Only 3 of the markers: accept them only when each was seen by >= 3 cameras
                // (chance matches between spurious blobs rarely are).
                bool strong = fit.matched >= 3;
                for (int i : fit.marker_of) strong = strong && (i < 0 || markers[i].cameras >= 3);
                if (!strong) continue;
              }
              if (!best || fit.matched > best->matched ||
                  (fit.matched == best->matched && fit.rms_m < best->rms_m)) {
                best = fit;
              }
            }
          }
        }
      }
    }
  }
  return best;
}

namespace {

// Pose refinement on the image evidence (RigidBodyModel::refine).
// An image of a matched marker that triangulation left out (a pair that claimed it first, a
// leave-one-out test on a noisy ray) is taken back when it lies this close to where the fitted
// pose projects the marker and no other marker claimed it: every image is information, and the
// estimate only reaches the Cramer-Rao bound with all of them. As tight as the triangulation's
// own outlier test (outlier_px), so what it dropped as wrong does not come back.
constexpr double kRegatherPx = 1.2;
// Huber loss threshold (px): residuals up to it count fully (pixel noise is ~0.1-0.5 px);
// beyond it their weight falls as 1/residual, so one wrong blob pulls little on the first step.
constexpr double kHuberPx = 1.0;
// From the second step on, an image further than this from the projection is dropped (a good
// one at sigma 0.3 px per axis is that far once in ~10^5).
constexpr double kRejectPx = 1.5;

struct Ray {
  int model;   // model marker
  int camera;
  int blob;    // index into the camera's observations
  bool active = true;
};

}  // namespace

void RigidBodyModel::refine(std::span<const Marker> markers, std::span<const CameraModel> cameras,
                            std::span<const std::vector<Observation>> obs, BodyFit& fit) const {
  if (!fit.full) return;
  const std::size_t ncam = std::min(cameras.size(), obs.size());
  // Which images every marker of this frame set already owns (another marker's are not ours).
  std::array<std::vector<std::uint8_t>, kMaxCameras> claimed;
  for (std::size_t c = 0; c < ncam; ++c) claimed[c].assign(obs[c].size(), 0);
  for (const Marker& mk : markers)
    for (std::size_t c = 0; c < ncam; ++c)
      if (mk.blob[c] >= 0 && static_cast<std::size_t>(mk.blob[c]) < obs[c].size()) claimed[c][mk.blob[c]] = 1;
  std::vector<Ray> rays;
  for (std::size_t m = 0; m < fit.marker_of.size(); ++m) {
    if (fit.marker_of[m] < 0) continue;
    const Marker& mk = markers[fit.marker_of[m]];
    const Eigen::Vector3d X = fit.pose.apply(config_.markers[m]);
    for (std::size_t c = 0; c < ncam; ++c) {
      if (mk.blob[c] >= 0) {
        rays.push_back({static_cast<int>(m), static_cast<int>(c), mk.blob[c]});
        continue;
      }
      const Eigen::Vector3d p = cameras[c].to_camera(X);
      if (p.z() < 1e-6) continue;
      const Eigen::Vector2d n(p.x() / p.z(), p.y() / p.z());
      const double gate = kRegatherPx / cameras[c].focal_px();
      double best = gate * gate;
      int best_i = -1;
      for (std::size_t i = 0; i < obs[c].size(); ++i) {
        if (claimed[c][i]) continue;
        const double d2 = (obs[c][i].normalised - n).squaredNorm();
        if (d2 < best) best = d2, best_i = static_cast<int>(i);
      }
      if (best_i >= 0) {
        claimed[c][best_i] = 1;
        rays.push_back({static_cast<int>(m), static_cast<int>(c), best_i});
      }
    }
  }
  // A marker whose image (nearly) merges with another model marker's in a camera: its blob
  // there is not where the marker is, so that image is not used (matched or not, every model
  // marker counts: an unmatched one may still have been drawn into the same blob).
  for (Ray& ray : rays) {
    const CameraModel& cam = cameras[ray.camera];
    const Eigen::Vector3d pa = cam.to_camera(fit.pose.apply(config_.markers[ray.model]));
    for (std::size_t k = 0; k < config_.markers.size() && ray.active; ++k) {
      if (static_cast<int>(k) == ray.model) continue;
      const Eigen::Vector3d pb = cam.to_camera(fit.pose.apply(config_.markers[k]));
      const Eigen::Vector2d d = pa.head<2>() / pa.z() - pb.head<2>() / pb.z();
      if (cam.focal_px() * d.norm() < kMinImageSeparationPx) ray.active = false;
    }
  }
  // Gauss-Newton (iteratively reweighted for the Huber loss) on the reprojection error in
  // pixels of every image, over the 6 pose parameters: rotation increment w (left-multiplied)
  // and translation.
  for (int iter = 0; iter < 5; ++iter) {
    Eigen::Matrix<double, 6, 6> JtJ = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> Jtr = Eigen::Matrix<double, 6, 1>::Zero();
    int rows = 0;
    const Eigen::Matrix3d R = fit.pose.rotation.toRotationMatrix();
    for (Ray& ray : rays) {
      if (!ray.active) continue;
      const CameraModel& cam = cameras[ray.camera];
      const Eigen::Vector3d arm = R * config_.markers[ray.model];  // room-frame lever arm
      const Eigen::Vector3d X = arm + fit.pose.translation;
      const Eigen::Vector3d p = cam.to_camera(X);
      if (p.z() < 1e-6) continue;
      const double iz = 1.0 / p.z(), f = cam.focal_px();
      const Eigen::Vector2d r = f * (Eigen::Vector2d(p.x() * iz, p.y() * iz) - obs[ray.camera][ray.blob].normalised);
      const double e = r.norm();
      if (iter > 0 && e > kRejectPx) {
        ray.active = false;
        continue;
      }
      const double w = e <= kHuberPx ? 1.0 : kHuberPx / e;
      Eigen::Matrix<double, 2, 3> Jp;
      Jp << iz, 0, -p.x() * iz * iz, 0, iz, -p.y() * iz * iz;
      Eigen::Matrix3d Rc;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) Rc(i, j) = cam.calibration().rotation(i, j);
      const Eigen::Matrix<double, 2, 3> JX = f * Jp * Rc;  // d pixel / d X (room)
      // X = exp([w]x) arm + t: dX/dw = -[arm]x, dX/dt = I.
      Eigen::Matrix3d skew;
      skew << 0, -arm.z(), arm.y(), arm.z(), 0, -arm.x(), -arm.y(), arm.x(), 0;
      Eigen::Matrix<double, 2, 6> J;
      J.leftCols<3>() = -JX * skew;
      J.rightCols<3>() = JX;
      JtJ += w * J.transpose() * J;
      Jtr += w * J.transpose() * r;
      rows += 2;
    }
    if (rows < 8) return;
    const Eigen::Matrix<double, 6, 1> step = JtJ.ldlt().solve(-Jtr);
    if (!step.allFinite()) return;
    const Eigen::Vector3d w = step.head<3>();
    if (w.norm() > 0.2 || step.tail<3>().norm() > 0.05) return;  // not a small correction: keep the fit
    if (w.norm() > 1e-15) fit.pose.rotation = (Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized())) * fit.pose.rotation).normalized();
    fit.pose.translation += step.tail<3>();
    if (step.norm() < 1e-9) break;
  }
}

std::optional<BodyFit> RigidBodyModel::fit(std::span<const Marker> markers,
                                           const std::optional<RigidPose>& predicted,
                                           std::span<const std::uint8_t> taken) const {
  std::optional<BodyFit> near;
  if (predicted) {
    near = from_prediction(markers, *predicted, taken);
    if (near && near->full && near->matched >= static_cast<int>(std::min<std::size_t>(size(), 4))) return near;
  }
  std::optional<BodyFit> found = identify(markers, taken);
  if (found && (!near || found->matched > near->matched)) {
    // A fresh identification far from the prediction must be convincing: all markers seen.
    return found;
  }
  return near;
}

PoseErrorBound pose_error_bound(const RigidBodyModel& body, const RigidPose& pose,
                                std::span<const CameraModel> cameras, double sigma_px,
                                std::span<const int> hidden) {
  // Fisher information of (rotation vector, centroid position) from every visible marker
  // image; the Jacobian of the full projection (distortion included) by central differences.
  const Eigen::Vector3d centroid_room = pose.apply(body.centroid());
  const auto project = [&](const CameraModel& cam, std::size_t m, const Eigen::Matrix<double, 6, 1>& d,
                           Eigen::Vector2d& px) {
    const Eigen::Vector3d w = d.head<3>();
    const Eigen::Quaterniond q =
        w.norm() > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized())) * pose.rotation : pose.rotation;
    const Eigen::Vector3d X = q * (body.config().markers[m] - body.centroid()) + centroid_room + d.tail<3>();
    return cam.project(X, px);
  };
  Eigen::Matrix<double, 6, 6> info = Eigen::Matrix<double, 6, 6>::Zero();
  PoseErrorBound out;
  constexpr double h = 1e-6;
  const Eigen::Matrix<double, 6, 1> zero = Eigen::Matrix<double, 6, 1>::Zero();
  const auto is_hidden = [&](std::size_t m) {
    return std::find(hidden.begin(), hidden.end(), static_cast<int>(m)) != hidden.end();
  };
  for (const CameraModel& cam : cameras) {
    const auto& c = cam.calibration();
    std::vector<Eigen::Vector2d> px(body.size());
    std::vector<std::uint8_t> seen(body.size(), 0);
    for (std::size_t m = 0; m < body.size(); ++m) {
      seen[m] = !is_hidden(m) && cam.to_camera(pose.apply(body.config().markers[m])).z() > 0 &&
                project(cam, m, zero, px[m]) && px[m].x() >= 0 && px[m].y() >= 0 &&
                px[m].x() <= c.image_width - 1 && px[m].y() <= c.image_height - 1;
    }
    for (std::size_t m = 0; m < body.size(); ++m) {
      if (!seen[m]) continue;
      bool merged = false;
      for (std::size_t k = 0; k < body.size(); ++k) {
        merged = merged || (k != m && seen[k] && (px[k] - px[m]).norm() < kMinImageSeparationPx);
      }
      if (merged) continue;
      Eigen::Matrix<double, 2, 6> J;
      for (int k = 0; k < 6; ++k) {
        Eigen::Matrix<double, 6, 1> d = zero;
        Eigen::Vector2d a, b;
        d[k] = h;
        project(cam, m, d, a);
        d[k] = -h;
        project(cam, m, d, b);
        J.col(k) = (a - b) / (2 * h);
      }
      info += J.transpose() * J;
      ++out.observations;
    }
  }
  const Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(info);
  if (out.observations < 3 || lu.rank() < 6) {
    out.orientation_rad = out.position_m = std::numeric_limits<double>::infinity();
    return out;
  }
  const Eigen::Matrix<double, 6, 6> cov = sigma_px * sigma_px * lu.inverse();
  out.orientation_rad = std::sqrt(cov.topLeftCorner<3, 3>().trace());
  out.position_m = std::sqrt(cov.bottomRightCorner<3, 3>().trace());
  return out;
}

}  // namespace kumite::tracking
