#include "kumite/calibration/wand.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <map>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <fmt/format.h>
#include <opencv2/calib3d.hpp>

#include "kumite/common/error.hpp"
#include "kumite/tracking/geometry.hpp"
#include "kumite/tracking/recording.hpp"
#include "reprojection.hpp"

namespace kumite::calibration {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kRegionCell_m = 1.0;  // m: grid of the per-region statistics
constexpr double kLooseGatePx = 25.0;  // px: a camera's wand blob this close to the projection is its view

cv::Vec3d to_cv(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

/// A wand blob seen by one camera; parameters: camera pose (angle-axis, t) and the point.
struct WandReprojection {
  tracking::CameraCalibration cam;
  double u, v, inv_sigma;
  template <typename T>
  bool operator()(const T* pose, const T* point, T* r) const {
    T pc[3];
    ceres::AngleAxisRotatePoint(pose, point, pc);
    for (int i = 0; i < 3; ++i) pc[i] += pose[3 + i];
    T k[kIntrinsicCount], uv[2];
    intrinsics_of(cam, k);
    project_to_pixel(k, pc, uv);
    r[0] = (uv[0] - T(u)) * T(inv_sigma);
    r[1] = (uv[1] - T(v)) * T(inv_sigma);
    return true;
  }
};

struct WandLength {
  double length, inv_sigma;
  template <typename T>
  bool operator()(const T* a, const T* b, T* r) const {
    const T dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    r[0] = (ceres::sqrt(dx * dx + dy * dy + dz * dz) - T(length)) * T(inv_sigma);
    return true;
  }
};

}  // namespace

WandStats wand_stats(const std::vector<double>& lengths, double true_length) {
  WandStats s;
  s.samples = static_cast<int>(lengths.size());
  if (lengths.empty()) return s;
  double sum = 0, sum2 = 0, err2 = 0;
  s.min_m = lengths[0];
  s.max_m = lengths[0];
  for (double l : lengths) {
    sum += l;
    sum2 += l * l;
    err2 += (l - true_length) * (l - true_length);
    s.min_m = std::min(s.min_m, l);
    s.max_m = std::max(s.max_m, l);
  }
  const double n = static_cast<double>(lengths.size());
  s.mean_m = sum / n;
  s.std_m = std::sqrt(std::max(0.0, sum2 / n - s.mean_m * s.mean_m));
  s.rms_error_m = std::sqrt(err2 / n);
  return s;
}

WandResult measure_wand(const tracking::RigCalibration& rig, const std::filesystem::path& dir,
                        const WandOptions& opt) {
  const tracking::Recording rec(dir, rig);
  for (const auto& w : rec.warnings()) {
    if (opt.progress) opt.progress(w);
  }
  std::vector<tracking::CameraModel> models;
  for (const auto& c : rig.cameras) models.emplace_back(c);
  tracking::Triangulator tri(models, opt.match);
  std::vector<tracking::BlobDetector> detectors(rig.cameras.size(), tracking::BlobDetector(opt.blobs));
  std::vector<std::vector<tracking::Observation>> obs(rig.cameras.size());
  std::vector<std::vector<tracking::Blob>> blobs(rig.cameras.size());
  WandResult res;
  std::vector<double> cam_sum2(rig.cameras.size(), 0.0);
  std::vector<int> cam_n(rig.cameras.size(), 0);
  for (std::size_t i = 0; i < rec.size(); ++i) {
    const tracking::FrameSet fs = rec.load(i);
    ++res.frames;
    for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
      blobs[c].clear();
      if (c < fs.images.size() && !fs.images[c].empty()) blobs[c] = detectors[c].detect(fs.images[c]);
      models[c].observe(blobs[c], obs[c]);
    }
    const auto& markers = tri.run(obs);
    if (markers.size() == 2) {
      WandSample s;
      s.frame = fs.frame;
      s.pixels.assign(rig.cameras.size(), {cv::Point2d(kNaN, kNaN), cv::Point2d(kNaN, kNaN)});
      for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
        for (int m = 0; m < 2; ++m) {
          const int bi = markers[static_cast<std::size_t>(m)].blob[c];
          if (bi >= 0) s.pixels[c][static_cast<std::size_t>(m)] = {blobs[c][static_cast<std::size_t>(bi)].x, blobs[c][static_cast<std::size_t>(bi)].y};
        }
        // The tracker drops rays that disagree with the others (a camera that moved); for
        // the wand we want every camera's view, so a camera with exactly the two wand blobs
        // near the markers' projections is matched by the nearer assignment.
        if (std::isfinite(s.pixels[c][0].x) && std::isfinite(s.pixels[c][1].x)) continue;
        if (blobs[c].size() != 2) continue;
        Eigen::Vector2d q0, q1;
        if (!models[c].project(markers[0].position, q0) || !models[c].project(markers[1].position, q1)) continue;
        const cv::Point2d b0(blobs[c][0].x, blobs[c][0].y), b1(blobs[c][1].x, blobs[c][1].y);
        const cv::Point2d p0(q0.x(), q0.y()), p1(q1.x(), q1.y());
        const double straight = std::max(cv::norm(b0 - p0), cv::norm(b1 - p1));
        const double crossed = std::max(cv::norm(b1 - p0), cv::norm(b0 - p1));
        if (std::min(straight, crossed) > kLooseGatePx) continue;
        s.pixels[c] = straight <= crossed ? std::array<cv::Point2d, 2>{b0, b1} : std::array<cv::Point2d, 2>{b1, b0};
      }
      // Lengths from every camera that saw the wand (plain ray intersection).
      std::array<cv::Vec3d, 2> p{};
      bool ok = true;
      for (std::size_t m = 0; m < 2 && ok; ++m) {
        std::vector<Eigen::Vector3d> origins, dirs;
        for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
          const cv::Point2d px = s.pixels[c][m];
          if (!std::isfinite(px.x)) continue;
          origins.push_back(models[c].centre());
          dirs.push_back(models[c].ray(models[c].normalise(px.x, px.y)));
        }
        ok = origins.size() >= 2;
        if (ok) p[m] = to_cv(tracking::intersect_rays(origins, dirs));
      }
      if (ok) {
        s.a = p[0];
        s.b = p[1];
        s.length_m = cv::norm(s.a - s.b);
        for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
          for (std::size_t m = 0; m < 2; ++m) {
            Eigen::Vector2d q;
            if (!std::isfinite(s.pixels[c][m].x) || !models[c].project({p[m][0], p[m][1], p[m][2]}, q)) continue;
            cam_sum2[c] += (q - Eigen::Vector2d(s.pixels[c][m].x, s.pixels[c][m].y)).squaredNorm();
            cam_n[c] += 1;
          }
        }
        res.samples.push_back(std::move(s));
      }
    }
    if (opt.progress && ((i + 1) % 100 == 0 || i + 1 == rec.size())) {
      opt.progress(fmt::format("wand: {} of {} frame sets read, {} with both markers", i + 1, rec.size(), res.samples.size()));
    }
  }
  if (res.samples.empty()) {
    throw Error("calibration", "no_wand",
                fmt::format("no frame in {} shows the two wand markers in two or more cameras: check the blob threshold, "
                            "that only the wand's two markers are lit, and wave it where the cameras overlap",
                            dir.string()));
  }
  for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
    res.camera_blobs.push_back(cam_n[c]);
    res.camera_rms_px.push_back(cam_n[c] ? std::sqrt(cam_sum2[c] / cam_n[c]) : kNaN);
  }
  std::vector<double> lengths;
  std::map<std::array<int, 3>, std::vector<double>> cells;
  for (const auto& s : res.samples) {
    lengths.push_back(s.length_m);
    const cv::Vec3d mid = (s.a + s.b) * 0.5;
    cells[{static_cast<int>(std::floor(mid[0] / kRegionCell_m)), static_cast<int>(std::floor(mid[1] / kRegionCell_m)),
           static_cast<int>(std::floor(mid[2] / kRegionCell_m))}]
        .push_back(s.length_m);
  }
  res.stats = wand_stats(lengths, opt.length_m);
  for (const auto& [k, v] : cells) {
    WandRegion r;
    r.centre = {(k[0] + 0.5) * kRegionCell_m, (k[1] + 0.5) * kRegionCell_m, (k[2] + 0.5) * kRegionCell_m};
    r.stats = wand_stats(v, opt.length_m);
    res.regions.push_back(r);
  }
  return res;
}

void refine_with_wand(const tracking::RigCalibration& rig, const WandOptions& opt, WandResult& res) {
  const std::size_t nc = rig.cameras.size();
  std::vector<std::array<double, 6>> poses(nc);
  for (std::size_t c = 0; c < nc; ++c) {
    cv::Vec3d rv;
    cv::Rodrigues(rig.cameras[c].rotation, rv);
    poses[c] = {rv[0], rv[1], rv[2], rig.cameras[c].translation[0], rig.cameras[c].translation[1],
                rig.cameras[c].translation[2]};
  }
  std::vector<std::array<double, 3>> pts(res.samples.size() * 2);
  ceres::Problem problem;
  for (std::size_t i = 0; i < res.samples.size(); ++i) {
    const auto& s = res.samples[i];
    pts[2 * i] = {s.a[0], s.a[1], s.a[2]};
    pts[2 * i + 1] = {s.b[0], s.b[1], s.b[2]};
    for (std::size_t c = 0; c < nc; ++c) {
      for (std::size_t m = 0; m < 2; ++m) {
        const cv::Point2d p = s.pixels[c][m];
        if (!std::isfinite(p.x)) continue;
        problem.AddResidualBlock(new ceres::AutoDiffCostFunction<WandReprojection, 2, 6, 3>(
                                     new WandReprojection{rig.cameras[c], p.x, p.y, 1.0 / opt.blob_sigma_px}),
                                 new ceres::HuberLoss(3.0), poses[c].data(), pts[2 * i + m].data());
      }
    }
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<WandLength, 1, 3, 3>(
                                 new WandLength{opt.length_m, 1.0 / opt.length_sigma_m}),
                             nullptr, pts[2 * i].data(), pts[2 * i + 1].data());
  }
  problem.SetParameterBlockConstant(poses[0].data());  // anchors the room frame
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_SCHUR;
  so.max_num_iterations = 100;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (!summary.IsSolutionUsable()) throw Error("calibration", "solve", "wand refinement failed: " + summary.message);
  tracking::RigCalibration out = rig;
  for (std::size_t c = 0; c < nc; ++c) {
    cv::Rodrigues(cv::Vec3d(poses[c][0], poses[c][1], poses[c][2]), out.cameras[c].rotation);
    out.cameras[c].translation = {poses[c][3], poses[c][4], poses[c][5]};
  }
  // Re-measure every sample's length with the refined cameras (triangulated again, not the
  // constrained points, so the figure is not the constraint talking).
  std::vector<double> lengths;
  std::vector<tracking::CameraModel> models;
  for (const auto& c : out.cameras) models.emplace_back(c);
  for (const auto& s : res.samples) {
    std::array<cv::Vec3d, 2> p{};
    bool ok = true;
    for (std::size_t m = 0; m < 2 && ok; ++m) {
      std::vector<Eigen::Vector3d> origins, dirs;
      for (std::size_t c = 0; c < nc; ++c) {
        const cv::Point2d px = s.pixels[c][m];
        if (!std::isfinite(px.x)) continue;
        origins.push_back(models[c].centre());
        dirs.push_back(models[c].ray(models[c].normalise(px.x, px.y)));
      }
      ok = origins.size() >= 2;
      if (ok) p[m] = to_cv(tracking::intersect_rays(origins, dirs));
    }
    if (ok) lengths.push_back(cv::norm(p[0] - p[1]));
  }
  res.refined = out;
  res.refined_stats = wand_stats(lengths, opt.length_m);
}

}  // namespace kumite::calibration
