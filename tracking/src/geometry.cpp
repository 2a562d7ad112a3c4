#include "kumite/tracking/geometry.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>

#include "kumite/common/error.hpp"

namespace kumite::tracking {

CameraModel::CameraModel(const CameraCalibration& calibration) : cal_(calibration) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) R_(r, c) = cal_.rotation(r, c);
    t_[r] = cal_.translation[r];
  }
  centre_ = -R_.transpose() * t_;
  focal_ = 0.5 * (cal_.camera_matrix(0, 0) + cal_.camera_matrix(1, 1));
}

Eigen::Vector2d CameraModel::normalise(double px, double py) const {
  const std::vector<cv::Point2d> src{{px, py}};
  std::vector<cv::Point2d> dst;
  cv::undistortPoints(src, dst, cv::Mat(cal_.camera_matrix), cv::Mat(cal_.distortion), cv::noArray(),
                      cv::noArray(), cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 1e-12));
  return {dst[0].x, dst[0].y};
}

void CameraModel::observe(std::span<const Blob> blobs, std::vector<Observation>& out) const {
  out.clear();
  if (blobs.empty()) return;
  std::vector<cv::Point2d> src(blobs.size()), dst;
  for (std::size_t i = 0; i < blobs.size(); ++i) src[i] = {blobs[i].x, blobs[i].y};
  cv::undistortPoints(src, dst, cv::Mat(cal_.camera_matrix), cv::Mat(cal_.distortion), cv::noArray(),
                      cv::noArray(), cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 1e-12));
  out.resize(blobs.size());
  for (std::size_t i = 0; i < blobs.size(); ++i) {
    out[i].normalised = {dst[i].x, dst[i].y};
    out[i].ray = ray(out[i].normalised);
  }
}

Eigen::Vector3d CameraModel::ray(const Eigen::Vector2d& n) const {
  return (R_.transpose() * Eigen::Vector3d(n.x(), n.y(), 1.0)).normalized();
}

bool CameraModel::project(const Eigen::Vector3d& room, Eigen::Vector2d& pixel) const {
  const Eigen::Vector3d c = to_camera(room);
  if (c.z() <= 1e-9) return false;
  const double x = c.x() / c.z(), y = c.y() / c.z();
  const auto& d = cal_.distortion;
  const double r2 = x * x + y * y;
  const double radial = 1 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
  const double xd = x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
  const double yd = y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
  const auto& K = cal_.camera_matrix;
  pixel = {K(0, 0) * xd + K(0, 1) * yd + K(0, 2), K(1, 1) * yd + K(1, 2)};
  return true;
}

Eigen::Vector3d intersect_rays(std::span<const Eigen::Vector3d> origins,
                               std::span<const Eigen::Vector3d> directions) {
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < origins.size(); ++i) {
    const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - directions[i] * directions[i].transpose();
    A += P;
    b += P * origins[i];
  }
  return A.ldlt().solve(b);
}

// ---------------------------------------------------------------------------------------

Triangulator::Triangulator(std::span<const CameraModel> cameras, MatchConfig config)
    : cameras_(cameras), config_(config) {
  if (cameras.size() > kMaxCameras) {
    throw Error("tracking", "cameras", fmt::format("at most {} cameras are supported", kMaxCameras));
  }
  used_.resize(cameras.size());
}

namespace {

/// Linear estimate from the rays of every camera that saw the marker; returns false when
/// fewer than two rays.
bool linear(Marker& m, std::span<const CameraModel> cams, std::span<const std::vector<Observation>> obs) {
  Eigen::Vector3d origins[kMaxCameras], dirs[kMaxCameras];
  int n = 0;
  for (std::size_t c = 0; c < cams.size(); ++c) {
    if (m.blob[c] < 0) continue;
    origins[n] = cams[c].centre();
    dirs[n] = obs[c][m.blob[c]].ray;
    ++n;
  }
  m.cameras = n;
  if (n < 2) return false;
  m.position = intersect_rays({origins, std::size_t(n)}, {dirs, std::size_t(n)});
  return true;
}

double mean_ray_distance(const Marker& m, std::span<const CameraModel> cams,
                         std::span<const std::vector<Observation>> obs) {
  double sum = 0;
  int n = 0;
  for (std::size_t c = 0; c < cams.size(); ++c) {
    if (m.blob[c] < 0) continue;
    const Eigen::Vector3d v = m.position - cams[c].centre();
    const Eigen::Vector3d& d = obs[c][m.blob[c]].ray;
    sum += (v - v.dot(d) * d).norm();
    ++n;
  }
  return n ? sum / n : 0.0;
}

}  // namespace

void Triangulator::gather_support(Marker& m, std::span<const std::vector<Observation>> obs,
                                  const std::vector<std::vector<std::uint8_t>>& used) const {
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    if (m.blob[c] >= 0 || obs[c].empty()) continue;
    const Eigen::Vector3d pc = cameras_[c].to_camera(m.position);
    if (pc.z() < config_.min_depth_m) continue;
    const Eigen::Vector2d n(pc.x() / pc.z(), pc.y() / pc.z());
    const double limit = config_.max_reprojection_px / cameras_[c].focal_px();
    double best = limit * limit;
    int best_i = -1;
    for (std::size_t i = 0; i < obs[c].size(); ++i) {
      if (!used.empty() && used[c][i]) continue;
      const double d2 = (obs[c][i].normalised - n).squaredNorm();
      if (d2 < best) best = d2, best_i = static_cast<int>(i);
    }
    if (best_i >= 0) m.blob[c] = static_cast<std::int16_t>(best_i);
  }
}

bool Triangulator::refine(Marker& m, std::span<const std::vector<Observation>> obs) const {
  // Gauss-Newton on the reprojection error in normalised coordinates, weighted by the focal
  // length (so the cost is in pixels).
  for (int iter = 0; iter < 3; ++iter) {
    Eigen::Matrix3d JtJ = Eigen::Matrix3d::Zero();
    Eigen::Vector3d Jtr = Eigen::Vector3d::Zero();
    for (std::size_t c = 0; c < cameras_.size(); ++c) {
      if (m.blob[c] < 0) continue;
      const CameraModel& cam = cameras_[c];
      const Eigen::Vector3d p = cam.to_camera(m.position);
      if (p.z() < 1e-6) return false;
      const double iz = 1.0 / p.z();
      const double f = cam.focal_px();
      const Eigen::Vector2d r = f * (Eigen::Vector2d(p.x() * iz, p.y() * iz) - obs[c][m.blob[c]].normalised);
      Eigen::Matrix<double, 2, 3> Jp;
      Jp << iz, 0, -p.x() * iz * iz, 0, iz, -p.y() * iz * iz;
      Eigen::Matrix3d R;
      const auto& Rc = cam.calibration().rotation;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) R(i, j) = Rc(i, j);
      const Eigen::Matrix<double, 2, 3> J = f * Jp * R;
      JtJ += J.transpose() * J;
      Jtr += J.transpose() * r;
    }
    const Eigen::Vector3d step = JtJ.ldlt().solve(-Jtr);
    if (!step.allFinite()) return false;
    m.position += step;
    if (step.norm() < 1e-7) break;
  }
  return true;
}

const std::vector<Marker>& Triangulator::run(std::span<const std::vector<Observation>> obs) {
  markers_.clear();
  candidates_.clear();
  const std::size_t n = std::min(cameras_.size(), obs.size());
  const std::vector<std::vector<std::uint8_t>> none;
  // 1. Pairs of rays that nearly meet in front of both cameras (the epipolar constraint).
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = a + 1; b < n; ++b) {
      const Eigen::Vector3d w0 = cameras_[a].centre() - cameras_[b].centre();
      for (std::size_t i = 0; i < obs[a].size(); ++i) {
        const Eigen::Vector3d& u = obs[a][i].ray;
        const double d = u.dot(w0);
        for (std::size_t j = 0; j < obs[b].size(); ++j) {
          const Eigen::Vector3d& v = obs[b][j].ray;
          const double bb = u.dot(v);
          const double e = v.dot(w0);
          const double den = 1.0 - bb * bb;
          if (den < 1e-9) continue;  // parallel rays
          const double s = (bb * e - d) / den;
          const double t = (e - bb * d) / den;
          if (s < config_.min_depth_m || t < config_.min_depth_m) continue;
          const Eigen::Vector3d pa = cameras_[a].centre() + s * u;
          const Eigen::Vector3d pb = cameras_[b].centre() + t * v;
          const double gap = (pa - pb).norm();
          if (gap > config_.max_ray_distance_m) continue;
          Candidate cand;
          cand.marker.blob.fill(-1);
          cand.marker.blob[a] = static_cast<std::int16_t>(i);
          cand.marker.blob[b] = static_cast<std::int16_t>(j);
          cand.marker.position = 0.5 * (pa + pb);
          // 2. Consistency over the other cameras.
          gather_support(cand.marker, obs, none);
          linear(cand.marker, cameras_, obs);
          cand.marker.residual_m = mean_ray_distance(cand.marker, cameras_, obs);
          cand.score = cand.marker.cameras * 1.0 - cand.marker.residual_m / config_.max_ray_distance_m * 0.5;
          candidates_.push_back(cand);
        }
      }
    }
  }
  // 3. Greedy: markers seen by most cameras, then with the smallest residual, claim their blobs.
  std::sort(candidates_.begin(), candidates_.end(),
            [](const Candidate& x, const Candidate& y) { return x.score > y.score; });
  for (std::size_t c = 0; c < n; ++c) used_[c].assign(obs[c].size(), 0);
  for (auto& cand : candidates_) {
    Marker m = cand.marker;
    bool changed = false;
    for (std::size_t c = 0; c < n; ++c) {
      if (m.blob[c] >= 0 && used_[c][m.blob[c]]) {
        m.blob[c] = -1;
        changed = true;
      }
    }
    if (changed) {
      if (!linear(m, cameras_, obs)) continue;
      gather_support(m, obs, used_);
      linear(m, cameras_, obs);
    }
    if (m.cameras < config_.min_cameras) continue;
    if (!refine(m, obs)) continue;
    // Leave-one-out: a ray that the other cameras' intersection reprojects far from (two
    // markers merged into one blob in that camera, a spurious blob next to the marker) goes,
    // as long as 2 remain.
    bool ok = true;
    while (ok && m.cameras > 2) {
      double worst = 0;
      int worst_c = -1;
      for (std::size_t c = 0; c < n; ++c) {
        if (m.blob[c] < 0) continue;
        Marker others = m;
        others.blob[c] = -1;
        if (!linear(others, cameras_, obs)) continue;
        const Eigen::Vector3d pc = cameras_[c].to_camera(others.position);
        if (pc.z() <= 0) continue;
        const double e = cameras_[c].focal_px() *
                         (Eigen::Vector2d(pc.x() / pc.z(), pc.y() / pc.z()) - obs[c][m.blob[c]].normalised).norm();
        if (e > worst) worst = e, worst_c = static_cast<int>(c);
      }
      if (worst <= config_.outlier_px) break;
      m.blob[worst_c] = -1;
      ok = linear(m, cameras_, obs) && refine(m, obs);
    }
    if (!ok) continue;
    m.residual_m = mean_ray_distance(m, cameras_, obs);
    if (m.residual_m > config_.max_residual_m) continue;
    for (std::size_t c = 0; c < n; ++c) {
      if (m.blob[c] >= 0) used_[c][m.blob[c]] = 1;
    }
    markers_.push_back(m);
  }
  return markers_;
}

}  // namespace kumite::tracking
