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
constexpr double kMoveSpreadFactor = 2.0;  // the jump must exceed this x the spread within the runs
// and the split explain this much of the residuals' variance. Synthetic rigs (27 Nov: 16-40
// views, intrinsics calibrated from the same images): a camera moved half-way 58-69 %, every
// camera not moved 2-29 % (unmoved rigs at most 23 %); 0.6 missed the 24-view rig's move (58 %).
constexpr double kMoveExplained = 0.45;
// A view is clearly on one side of a move when its mean residual lies within this share of the
// jump from that side's mean (along the line between the two runs' means).
constexpr double kClearShare = 0.25;

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

namespace {
/// Mean squared reprojection error (px^2) and the residuals of a board pose (board -> rig,
/// as rvec/t) in the cameras `use` at frame f.
struct Obs {
  const tracking::CameraCalibration* cam;
  cv::Vec3d rv;  // camera rotation (rig -> camera) as a Rodrigues vector
  const BoardDetection* d;
};
void residuals(const std::vector<Obs>& obs, const cv::Vec3d& brv, const cv::Vec3d& bt, std::vector<double>& r) {
  r.clear();
  cv::Matx33d Rb;
  cv::Rodrigues(brv, Rb);
  std::vector<cv::Point3d> world;
  std::vector<cv::Point2d> proj;
  for (const Obs& o : obs) {
    world.clear();
    for (const auto& p : o.d->object_points) {
      const cv::Vec3d x = Rb * cv::Vec3d(p.x, p.y, p.z) + bt;
      world.emplace_back(x[0], x[1], x[2]);
    }
    cv::projectPoints(world, o.rv, cv::Vec3d(o.cam->translation), o.cam->camera_matrix, o.cam->distortion, proj);
    for (std::size_t i = 0; i < proj.size(); ++i) {
      r.push_back(o.d->image_points[i].x - proj[i].x);
      r.push_back(o.d->image_points[i].y - proj[i].y);
    }
  }
}
/// The board pose (board -> rig) that best fits every camera in `obs` together: Gauss-Newton
/// on the reprojection error from `start`, numeric Jacobian.
RigidPose fit_board(const std::vector<Obs>& obs, const RigidPose& start) {
  cv::Vec3d rv, t = start.t;
  cv::Rodrigues(start.R, rv);
  std::vector<double> r0, r1;
  residuals(obs, rv, t, r0);
  double cost = 0;
  for (double v : r0) cost += v * v;
  for (int it = 0; it < 10; ++it) {
    cv::Matx66d JtJ = cv::Matx66d::zeros();
    cv::Vec6d Jtr(0, 0, 0, 0, 0, 0);
    std::vector<std::vector<double>> J(6);
    for (int k = 0; k < 6; ++k) {
      cv::Vec3d rv2 = rv, t2 = t;
      const double h = k < 3 ? 1e-6 : 1e-6;
      (k < 3 ? rv2[k] : t2[k - 3]) += h;
      residuals(obs, rv2, t2, r1);
      J[static_cast<std::size_t>(k)].resize(r1.size());
      for (std::size_t i = 0; i < r1.size(); ++i) J[static_cast<std::size_t>(k)][i] = (r1[i] - r0[i]) / h;
    }
    for (int a = 0; a < 6; ++a) {
      for (std::size_t i = 0; i < r0.size(); ++i) Jtr[a] += J[static_cast<std::size_t>(a)][i] * r0[i];
      for (int b = 0; b < 6; ++b) {
        double s = 0;
        for (std::size_t i = 0; i < r0.size(); ++i) s += J[static_cast<std::size_t>(a)][i] * J[static_cast<std::size_t>(b)][i];
        JtJ(a, b) = s;
      }
    }
    for (int a = 0; a < 6; ++a) JtJ(a, a) *= 1.0 + 1e-6;
    cv::Vec6d step;
    if (!cv::solve(JtJ, Jtr, step, cv::DECOMP_CHOLESKY)) break;
    // r = detected - projected: the update that lowers it is +step (J is d(detected-proj)).
    const cv::Vec3d rv_new = rv - cv::Vec3d(step[0], step[1], step[2]);
    const cv::Vec3d t_new = t - cv::Vec3d(step[3], step[4], step[5]);
    residuals(obs, rv_new, t_new, r1);
    double c1 = 0;
    for (double v : r1) c1 += v * v;
    if (!(c1 < cost)) break;
    const bool small = cost - c1 < 1e-9 * cost;
    rv = rv_new, t = t_new, cost = c1, r0.swap(r1);
    if (small) break;
  }
  RigidPose p;
  cv::Rodrigues(rv, p.R);
  p.t = t;
  return p;
}
}  // namespace

RigCheck check_rig(const std::vector<tracking::CameraCalibration>& cameras,
                   const std::vector<std::vector<BoardDetection>>& views) {
  const std::size_t nc = std::min(cameras.size(), views.size());
  std::size_t nf = 0;
  for (std::size_t c = 0; c < nc; ++c) nf = std::max(nf, views[c].size());
  // Board -> rig per camera and frame, from that camera's view alone (starting points).
  std::vector<std::vector<std::optional<RigidPose>>> board(nc, std::vector<std::optional<RigidPose>>(nf));
  std::vector<cv::Vec3d> cam_rv(nc);
  for (std::size_t c = 0; c < nc; ++c) {
    cv::Rodrigues(cameras[c].rotation, cam_rv[c]);
    const RigidPose rig_from_cam = camera_pose(cameras[c]).inverse();
    for (std::size_t f = 0; f < views[c].size(); ++f) {
      if (const auto p = board_pose_in_camera(views[c][f], cameras[c])) board[c][f] = rig_from_cam * *p;
    }
  }
  RigCheck out;
  out.cameras.resize(nc);
  std::vector<double> rms_all;
  std::vector<double> r;
  for (std::size_t c = 0; c < nc; ++c) {
    CameraCheck& k = out.cameras[c];
    k.rms_px.assign(nf, std::numeric_limits<double>::quiet_NaN());
    k.mean_px.assign(nf, cv::Vec2d(0, 0));
    k.flagged.assign(nf, false);
    double sum2 = 0;
    std::size_t corners = 0;
    for (std::size_t f = 0; f < views[c].size(); ++f) {
      const BoardDetection& d = views[c][f];
      if (d.size() < 4) continue;
      // The other cameras that saw the board in this view, the one with most corners first.
      std::vector<std::size_t> others;
      for (std::size_t o = 0; o < nc; ++o) {
        if (o != c && board[o][f] && f < views[o].size()) others.push_back(o);
      }
      if (others.empty()) continue;
      std::sort(others.begin(), others.end(), [&](std::size_t a, std::size_t b) { return views[a][f].size() > views[b][f].size(); });
      // The board as all of them see it together, and as each subset leaving one out (so one
      // camera that moved does not pull the others' board away): the best agreement counts.
      std::vector<std::vector<std::size_t>> sets{others};
      if (others.size() >= 2) {
        for (std::size_t skip = 0; skip < others.size(); ++skip) {
          std::vector<std::size_t> s;
          for (std::size_t i = 0; i < others.size(); ++i) {
            if (i != skip) s.push_back(others[i]);
          }
          sets.push_back(std::move(s));
        }
      }
      const std::vector<Obs> self{{&cameras[c], cam_rv[c], &d}};
      double best = std::numeric_limits<double>::infinity();
      cv::Vec2d best_mean;
      for (const auto& set : sets) {
        std::vector<Obs> obs;
        for (std::size_t o : set) obs.push_back({&cameras[o], cam_rv[o], &views[o][f]});
        const RigidPose b = fit_board(obs, *board[set[0]][f]);
        cv::Vec3d brv;
        cv::Rodrigues(b.R, brv);
        residuals(self, brv, b.t, r);
        double s2 = 0;
        cv::Vec2d mean(0, 0);
        for (std::size_t i = 0; i + 1 < r.size(); i += 2) {
          s2 += r[i] * r[i] + r[i + 1] * r[i + 1];
          mean += cv::Vec2d(r[i], r[i + 1]);
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
    if (s.at == 0) continue;
    k.jump_px = s.jump;
    k.spread_px = s.spread;
    cv::Vec2d all_mean(0, 0);
    for (const auto& m : means) all_mean += m;
    all_mean /= static_cast<double>(means.size());
    double total = 0;
    for (const auto& m : means) total += (m - all_mean).dot(m - all_mean);
    total /= static_cast<double>(means.size());
    k.explained = total > 0 ? 1.0 - s.spread * s.spread / total : 0.0;
    if (s.jump < kMoveMinPx || s.jump < kMoveSpreadFactor * s.spread || k.explained < kMoveExplained) continue;
    // Views next to the split whose mean residual lies well between the two runs' (a camera
    // still moving, or settling) cannot be told to either side: the move is said to lie between
    // the last view clearly before and the first clearly after, and those views are flagged.
    // (40-view rig, cam1 moved at view 20, views 18-19 without the board: view 17 sat at -0.5 px
    // between runs at -7.5 and +6 px, and the split alone said "between 16 and 17".)
    const cv::Vec2d axis = s.mean_b - s.mean_a;
    const double axis2 = axis.dot(axis);
    const auto share = [&](std::size_t i) { return axis2 > 0 ? (means[i] - s.mean_a).dot(axis) / axis2 : 0.0; };
    std::size_t last_a = s.at - 1, first_b = s.at;
    while (last_a > 0 && share(last_a) > kClearShare) --last_a;
    while (first_b + 1 < frames.size() && share(first_b) < 1 - kClearShare) ++first_b;
    k.moved_between = std::make_pair(static_cast<int>(frames[last_a]), static_cast<int>(frames[first_b]));
    k.blamed = k.blamed || k.rms_all_px > kBlameFloorPx;
    // The cluster further from the calibration is the one to flag, and the views in between.
    const bool second = cv::norm(s.mean_b) >= cv::norm(s.mean_a);
    for (std::size_t i = 0; i < frames.size(); ++i)
      k.flagged[frames[i]] = (i > last_a && i < first_b) || (i >= s.at) == second;
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
