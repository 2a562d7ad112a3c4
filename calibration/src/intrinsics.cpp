#include "kumite/calibration/intrinsics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>

#include "kumite/common/error.hpp"

namespace kumite::calibration {
namespace {

[[noreturn]] void fail(const std::string& code, const std::string& msg) {
  throw Error("calibration", code, msg);
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

double view_rms(const BoardDetection& view, const cv::Matx33d& K, const cv::Vec<double, 5>& dist,
                const cv::Vec3d& rvec, const cv::Vec3d& tvec) {
  if (view.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::vector<cv::Point2f> proj;
  cv::projectPoints(view.object_points, rvec, tvec, K, dist, proj);
  double s = 0;
  for (std::size_t i = 0; i < proj.size(); ++i) {
    const cv::Point2f d = proj[i] - view.image_points[i];
    s += d.x * d.x + d.y * d.y;
  }
  return std::sqrt(s / static_cast<double>(proj.size()));
}

double view_perspective(const BoardDetection& view) {
  if (view.size() < 4) return 0;
  std::vector<cv::Point2f> plane;
  for (const auto& p : view.object_points) plane.emplace_back(p.x, p.y);
  const cv::Mat H = cv::findHomography(plane, view.image_points, 0);
  if (H.empty()) return 0;
  double lo = std::numeric_limits<double>::max(), hi = 0;
  for (const auto& p : plane) {
    const double w = std::abs(H.at<double>(2, 0) * p.x + H.at<double>(2, 1) * p.y + H.at<double>(2, 2));
    lo = std::min(lo, w);
    hi = std::max(hi, w);
  }
  return lo > 0 ? hi / lo - 1.0 : 0;
}

IntrinsicsResult calibrate_intrinsics(const std::vector<BoardDetection>& views, cv::Size image_size,
                                      const IntrinsicsOptions& opt) {
  IntrinsicsResult r;
  r.image_size = image_size;
  const std::size_t n = views.size();
  r.per_view_errors_px.assign(n, std::numeric_limits<double>::quiet_NaN());
  r.used.assign(n, false);
  r.rvecs.assign(n, cv::Vec3d(0, 0, 0));
  r.tvecs.assign(n, cv::Vec3d(0, 0, 0));
  for (std::size_t i = 0; i < n; ++i) {
    if (static_cast<int>(views[i].size()) >= opt.min_corners_per_view) {
      r.used[i] = true;
    } else {
      r.not_detected.push_back(static_cast<int>(i));
    }
  }
  const auto count_used = [&] { return static_cast<int>(std::count(r.used.begin(), r.used.end(), true)); };
  if (count_used() == 0) {
    fail("no_board", fmt::format("the board was not found in any of the {} images: check that board.toml matches the "
                                 "printed board (type, rows, cols, first_id) and capture the whole board sharp and evenly lit",
                                 n));
  }
  if (count_used() < opt.min_views) {
    fail("too_few_views", fmt::format("the board was found in only {} of {} images, {} are needed: capture at least 15 "
                                      "views covering the whole image, tilted 20-45 degrees in different directions",
                                      count_used(), n, opt.min_views));
  }
  double best_perspective = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (r.used[i]) best_perspective = std::max(best_perspective, view_perspective(views[i]));
  }
  if (best_perspective < opt.min_perspective) {
    fail("degenerate", "every view shows the board face-on (fronto-parallel), so the focal length cannot be measured: "
                       "capture views with the board tilted 20-45 degrees left, right, up and down");
  }

  int flags = cv::CALIB_USE_LU;  // faster; same answer as SVD on well-posed problems
  if (opt.fix_aspect_ratio) flags |= cv::CALIB_FIX_ASPECT_RATIO;
  for (int round = 0; round < 4; ++round) {
    std::vector<std::vector<cv::Point3f>> obj;
    std::vector<std::vector<cv::Point2f>> img;
    std::vector<std::size_t> idx;
    for (std::size_t i = 0; i < n; ++i) {
      if (!r.used[i]) continue;
      obj.push_back(views[i].object_points);
      img.push_back(views[i].image_points);
      idx.push_back(i);
    }
    cv::Mat K = cv::Mat::eye(3, 3, CV_64F), D = cv::Mat::zeros(5, 1, CV_64F);
    std::vector<cv::Mat> rv, tv;
    try {
      r.rms_px = cv::calibrateCamera(obj, img, image_size, K, D, rv, tv, flags);
    } catch (const cv::Exception& e) {
      fail("solve", fmt::format("calibration failed ({}): capture more views with the board tilted and covering the image",
                                e.err));
    }
    r.camera_matrix = cv::Matx33d(K);
    for (int k = 0; k < 5; ++k) r.distortion[k] = D.at<double>(k);
    for (std::size_t j = 0; j < idx.size(); ++j) {
      r.rvecs[idx[j]] = cv::Vec3d(rv[j]);
      r.tvecs[idx[j]] = cv::Vec3d(tv[j]);
    }
    // Per-view errors for every detected view, the rejected ones included (their pose from
    // solvePnP with the current intrinsics), so the technician sees why they were dropped.
    std::vector<double> kept;
    for (std::size_t i = 0; i < n; ++i) {
      if (views[i].size() < 4) continue;
      if (!r.used[i]) {
        cv::Vec3d rvec, tvec;
        if (!cv::solvePnP(views[i].object_points, views[i].image_points, r.camera_matrix, r.distortion, rvec, tvec)) continue;
        r.rvecs[i] = rvec;
        r.tvecs[i] = tvec;
      }
      r.per_view_errors_px[i] = view_rms(views[i], r.camera_matrix, r.distortion, r.rvecs[i], r.tvecs[i]);
      if (r.used[i]) kept.push_back(r.per_view_errors_px[i]);
    }
    const double limit = opt.outlier_factor * median(kept);
    bool changed = false;
    for (std::size_t i = 0; i < n; ++i) {
      if (r.used[i] && r.per_view_errors_px[i] > limit && count_used() > opt.min_views) {
        r.used[i] = false;
        r.rejected.push_back(static_cast<int>(i));
        changed = true;
      }
    }
    if (!changed) break;
  }
  double worst = -1;
  for (std::size_t i = 0; i < n; ++i) {
    if (std::isfinite(r.per_view_errors_px[i]) && r.per_view_errors_px[i] > worst) {
      worst = r.per_view_errors_px[i];
      r.worst_view = static_cast<int>(i);
    }
  }
  return r;
}

}  // namespace kumite::calibration
