// check_rig: each camera against the board as the other cameras see it, view by view, and a
// change-point over view order (a camera moved during the capture). See rig.hpp.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>

#include "kumite/calibration/rig.hpp"

namespace kumite::calibration {
namespace {

constexpr int kMinClusterViews = 3;  // views on each side of a change-point
constexpr double kMoveSpreadFactor = 4.0;  // the jump must exceed this x the spread within the clusters

RigidPose camera_pose(const tracking::CameraCalibration& c) { return {c.rotation, c.translation}; }

double median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

/// The best split of a sequence of mean residuals into two runs: the split maximising the
/// between-cluster sum of squares. Returns the first index of the second run (0 = none),
/// the jump |mean_b - mean_a| and the RMS spread within the runs.
struct Split {
  std::size_t at = 0;
  double jump = 0, spread = 0;
  cv::Vec2d mean_a, mean_b;
};
Split best_split(const std::vector<cv::Vec2d>& m) {
  Split best;
  const std::size_t n = m.size();
  if (n < 2 * kMinClusterViews) return best;
  std::vector<cv::Vec2d> prefix(n + 1, cv::Vec2d(0, 0));
  for (std::size_t i = 0; i < n; ++i) prefix[i + 1] = prefix[i] + m[i];
  double best_score = -1;
  for (std::size_t k = kMinClusterViews; k + kMinClusterViews <= n; ++k) {
    const cv::Vec2d a = prefix[k] / static_cast<double>(k);
    const cv::Vec2d b = (prefix[n] - prefix[k]) / static_cast<double>(n - k);
    const double score = static_cast<double>(k) * static_cast<double>(n - k) / static_cast<double>(n) * cv::norm(a - b) * cv::norm(a - b);
    if (score > best_score) {
      best_score = score;
      best.at = k;
      best.mean_a = a;
      best.mean_b = b;
    }
  }
  double ss = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const cv::Vec2d d = m[i] - (i < best.at ? best.mean_a : best.mean_b);
    ss += d.dot(d);
  }
  best.jump = cv::norm(best.mean_a - best.mean_b);
  best.spread = std::sqrt(ss / static_cast<double>(n));
  return best;
}

}  // namespace

RigCheck check_rig(const std::vector<tracking::CameraCalibration>& cameras,
                   const std::vector<std::vector<BoardDetection>>& views) {
  const std::size_t nc = std::min(cameras.size(), views.size());
  std::size_t nf = 0;
  for (std::size_t c = 0; c < nc; ++c) nf = std::max(nf, views[c].size());
  // Board -> rig per camera and frame, from that camera's view alone.
  std::vector<std::vector<std::optional<RigidPose>>> board(nc, std::vector<std::optional<RigidPose>>(nf));
  for (std::size_t c = 0; c < nc; ++c) {
    const RigidPose rig_from_cam = camera_pose(cameras[c]).inverse();
    for (std::size_t f = 0; f < views[c].size(); ++f) {
      if (const auto p = board_pose_in_camera(views[c][f], cameras[c])) board[c][f] = rig_from_cam * *p;
    }
  }
  RigCheck out;
  out.cameras.resize(nc);
  std::vector<double> rms_all;
  for (std::size_t c = 0; c < nc; ++c) {
    CameraCheck& k = out.cameras[c];
    k.rms_px.assign(nf, std::numeric_limits<double>::quiet_NaN());
    k.mean_px.assign(nf, cv::Vec2d(0, 0));
    k.flagged.assign(nf, false);
    const auto& cam = cameras[c];
    cv::Vec3d rv;
    cv::Rodrigues(cam.rotation, rv);
    double sum2 = 0;
    std::size_t corners = 0;
    for (std::size_t f = 0; f < views[c].size(); ++f) {
      const BoardDetection& d = views[c][f];
      if (d.size() < 4) continue;
      double best = std::numeric_limits<double>::infinity();
      cv::Vec2d best_mean;
      for (std::size_t o = 0; o < nc; ++o) {
        if (o == c || !board[o][f]) continue;
        std::vector<cv::Point3d> world;
        world.reserve(d.size());
        for (const auto& p : d.object_points) {
          const cv::Vec3d x = board[o][f]->R * cv::Vec3d(p.x, p.y, p.z) + board[o][f]->t;
          world.emplace_back(x[0], x[1], x[2]);
        }
        std::vector<cv::Point2d> proj;
        cv::projectPoints(world, rv, cv::Vec3d(cam.translation), cam.camera_matrix, cam.distortion, proj);
        double s2 = 0;
        cv::Vec2d mean(0, 0);
        for (std::size_t i = 0; i < d.size(); ++i) {
          const cv::Vec2d r(d.image_points[i].x - proj[i].x, d.image_points[i].y - proj[i].y);
          s2 += r.dot(r);
          mean += r;
        }
        const double rms = std::sqrt(s2 / static_cast<double>(d.size()));
        if (std::isfinite(rms) && rms < best) {
          best = rms;
          best_mean = mean / static_cast<double>(d.size());
        }
      }
      if (!std::isfinite(best)) continue;
      k.rms_px[f] = best;
      k.mean_px[f] = best_mean;
      sum2 += best * best * static_cast<double>(d.size());
      corners += d.size();
      ++k.views;
    }
    if (corners) {
      k.rms_all_px = std::sqrt(sum2 / static_cast<double>(corners));
      rms_all.push_back(k.rms_all_px);
    }
  }
  out.median_rms_px = rms_all.empty() ? 0.0 : median(rms_all);
  for (std::size_t c = 0; c < nc; ++c) {
    CameraCheck& k = out.cameras[c];
    if (!std::isfinite(k.rms_all_px)) continue;
    k.blamed = k.rms_all_px > kBlameFloorPx && k.rms_all_px > kBlameFactor * out.median_rms_px;
    // A move: the mean residual over view order splits into two clusters.
    std::vector<std::size_t> frames;
    std::vector<cv::Vec2d> means;
    for (std::size_t f = 0; f < nf; ++f) {
      if (!std::isfinite(k.rms_px[f])) continue;
      frames.push_back(f);
      means.push_back(k.mean_px[f]);
    }
    const Split s = best_split(means);
    if (s.at == 0 || s.jump < kMoveMinPx || s.jump < kMoveSpreadFactor * s.spread) continue;
    k.moved_between = std::make_pair(static_cast<int>(frames[s.at - 1]), static_cast<int>(frames[s.at]));
    k.jump_px = s.jump;
    k.blamed = k.blamed || k.rms_all_px > kBlameFloorPx;
    // The cluster further from the calibration is the one to flag.
    const bool second = cv::norm(s.mean_b) >= cv::norm(s.mean_a);
    for (std::size_t i = 0; i < frames.size(); ++i) k.flagged[frames[i]] = (i >= s.at) == second;
  }
  return out;
}

std::string describe_check(const std::string& camera, const CameraCheck& k, const RigCheck& rig,
                           const std::vector<std::string>& frame_names) {
  if (!k.blamed) return "";
  const auto name = [&](int f) {
    return f >= 0 && static_cast<std::size_t>(f) < frame_names.size() ? frame_names[static_cast<std::size_t>(f)]
                                                                        : std::to_string(f);
  };
  if (k.moved_between) {
    const auto flagged = std::count(k.flagged.begin(), k.flagged.end(), true);
    return fmt::format("{} moved between views {} and {} (its residuals against the other cameras jump by {:.1f} px; "
                       "{} of {} views flagged)",
                       camera, name(k.moved_between->first), name(k.moved_between->second), k.jump_px, flagged, k.views);
  }
  return fmt::format("{}: residuals {:.2f} px against the other cameras' view of the board (the rig's median {:.2f} px)",
                     camera, k.rms_all_px, rig.median_rms_px);
}

}  // namespace kumite::calibration
