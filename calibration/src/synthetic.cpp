#include "kumite/calibration/synthetic.hpp"

#include <cmath>
#include <limits>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace kumite::calibration::synthetic {

cv::Matx33d rotation(cv::Vec3d axis, double degrees) {
  const double n = cv::norm(axis);
  if (n == 0) return cv::Matx33d::eye();
  const cv::Vec3d rv = axis * (degrees * CV_PI / 180.0 / n);
  cv::Matx33d R;
  cv::Rodrigues(rv, R);
  return R;
}

Camera look_at(cv::Vec3d position, cv::Vec3d target, cv::Vec3d up, cv::Size size, double f_px,
               cv::Vec<double, 5> dist) {
  Camera c;
  c.size = size;
  c.K = cv::Matx33d(f_px, 0, (size.width - 1) / 2.0 + 3.7, 0, f_px * 1.001, (size.height - 1) / 2.0 - 2.3, 0, 0, 1);
  c.dist = dist;
  const cv::Vec3d z = cv::normalize(target - position);
  const cv::Vec3d x = cv::normalize(z.cross(up));  // image right
  const cv::Vec3d y = z.cross(x);                  // image down
  c.R = cv::Matx33d(x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]);
  c.t = -(c.R * position);
  return c;
}

cv::Point2d project(const Camera& cam, const cv::Vec3d& world) {
  const cv::Vec3d p = cam.R * world + cam.t;
  const double x = p[0] / p[2], y = p[1] / p[2];
  const auto& d = cam.dist;
  const double r2 = x * x + y * y;
  const double radial = 1 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
  const double xd = x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
  const double yd = y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
  return {cam.K(0, 0) * xd + cam.K(0, 1) * yd + cam.K(0, 2), cam.K(1, 1) * yd + cam.K(1, 2)};
}

namespace {

/// Forward distortion of normalised (x, y) and its 2x2 Jacobian.
void distort(const cv::Vec<double, 5>& d, double x, double y, double& xd, double& yd, cv::Matx22d& J) {
  const double r2 = x * x + y * y;
  const double radial = 1 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
  const double dradial = d[0] + 2 * d[1] * r2 + 3 * d[4] * r2 * r2;  // d radial / d r2
  xd = x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
  yd = y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
  J = cv::Matx22d(radial + 2 * x * x * dradial + 2 * d[2] * y + 6 * d[3] * x,
                  2 * x * y * dradial + 2 * d[2] * x + 2 * d[3] * y,
                  2 * x * y * dradial + 2 * d[2] * x + 2 * d[3] * y,
                  radial + 2 * y * y * dradial + 6 * d[2] * y + 2 * d[3] * x);
}

/// Normalised coordinates of a distorted pixel: Newton's method on the forward model from
/// (x, y) as given (the neighbouring sample's answer, or the distorted coordinates), accepted
/// only when projecting forward lands within 1e-4 px of the pixel. Returns false when it does
/// not converge (far corners of a strongly distorted lens).
bool undistort(const Camera& cam, double u, double v, double& x, double& y) {
  const double yt = (v - cam.K(1, 2)) / cam.K(1, 1);
  const double xt = (u - cam.K(0, 2) - cam.K(0, 1) * yt) / cam.K(0, 0);
  if (!std::isfinite(x) || !std::isfinite(y)) {
    x = xt;
    y = yt;
  }
  double xd = 0, yd = 0;
  cv::Matx22d J;
  for (int i = 0; i < 20; ++i) {
    distort(cam.dist, x, y, xd, yd, J);
    const double ex = xd - xt, ey = yd - yt;
    if (std::abs(ex) * cam.K(0, 0) < 1e-7 && std::abs(ey) * cam.K(1, 1) < 1e-7) return true;
    const double det = J(0, 0) * J(1, 1) - J(0, 1) * J(1, 0);
    if (!(std::abs(det) > 1e-12)) break;
    x -= (J(1, 1) * ex - J(0, 1) * ey) / det;
    y -= (-J(1, 0) * ex + J(0, 0) * ey) / det;
  }
  distort(cam.dist, x, y, xd, yd, J);
  const bool ok = std::abs(xd - xt) * cam.K(0, 0) < 1e-4 && std::abs(yd - yt) * cam.K(1, 1) < 1e-4 &&
                  J(0, 0) * J(1, 1) - J(0, 1) * J(1, 0) > 0;  // not past the fold of the polynomial
  if (!ok) x = y = std::numeric_limits<double>::quiet_NaN();  // the next sample starts afresh
  return ok;
}

}  // namespace

cv::Mat render_view(const BoardPattern& pattern, const Board& board, const Camera& cam, const Pose& pose,
                    const RenderOptions& opt) {
  const int ss = std::max(1, opt.supersample);
  cv::Mat acc(cam.size, CV_32F);
  const cv::Rect2d ext = board.pattern_extent();
  const double m = board.default_margin_m();
  const cv::Rect2d sheet(ext.x - m, ext.y - m, ext.width + 2 * m, ext.height + 2 * m);
  // Camera centre and ray directions in the board frame.
  const cv::Matx33d Rbc = pose.R.t() * cam.R.t();  // camera -> board rotation
  const cv::Vec3d c_board = pose.R.t() * (cam.position() - pose.t);
  // Only pixels near the sheet's projection need rays (a big saving for far boards); when
  // part of the sheet is behind the camera, or the lens folds it, render everything.
  cv::Rect roi(0, 0, cam.size.width, cam.size.height);
  {
    std::vector<cv::Point2d> outline;
    bool ok = true;
    for (int i = 0; i <= 40 && ok; ++i) {
      for (int j = 0; j <= 40 && ok; ++j) {
        const cv::Vec3d w = pose.R * cv::Vec3d(sheet.x + sheet.width * i / 40.0, sheet.y + sheet.height * j / 40.0, 0) + pose.t;
        const cv::Vec3d pc = cam.R * w + cam.t;
        if (pc[2] < 0.05) ok = false;
        const double r2 = (pc[0] * pc[0] + pc[1] * pc[1]) / (pc[2] * pc[2]);
        if (r2 > 1.5) ok = false;  // far outside the field of view: the polynomial is meaningless
        outline.push_back(project(cam, w));
      }
    }
    if (ok) {
      double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
      for (const auto& p : outline) {
        x0 = std::min(x0, p.x);
        y0 = std::min(y0, p.y);
        x1 = std::max(x1, p.x);
        y1 = std::max(y1, p.y);
      }
      const int pad = 4;
      roi = cv::Rect(cv::Point(static_cast<int>(std::floor(x0)) - pad, static_cast<int>(std::floor(y0)) - pad),
                     cv::Point(static_cast<int>(std::ceil(x1)) + pad, static_cast<int>(std::ceil(y1)) + pad)) &
            roi;
    }
  }
  acc.setTo(static_cast<float>(opt.background));
  cv::parallel_for_(cv::Range(roi.y, roi.y + roi.height), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      float* out = acc.ptr<float>(v);
      // Each sample's undistortion starts from the previous one's (1/ss px away): 1-2 steps.
      std::vector<cv::Vec2d> warm(static_cast<std::size_t>(ss * ss), cv::Vec2d(std::nan(""), std::nan("")));
      for (int u = roi.x; u < roi.x + roi.width; ++u) {
        double sum = 0;
        for (int sy = 0; sy < ss; ++sy) {
          for (int sx = 0; sx < ss; ++sx) {
            // Sample positions spread over the pixel's area (pixel centres at integers).
            const double pu = u - 0.5 + (sx + 0.5) / ss, pv = v - 0.5 + (sy + 0.5) / ss;
            cv::Vec2d& xy = warm[static_cast<std::size_t>(sy * ss + sx)];
            double& x = xy[0];
            double& y = xy[1];
            double value = opt.background;
            if (undistort(cam, pu, pv, x, y)) {
              const cv::Vec3d dir = Rbc * cv::Vec3d(x, y, 1.0);
              if (std::abs(dir[2]) > 1e-12) {
                const double lambda = -c_board[2] / dir[2];
                if (lambda > 0) {
                  const double bx = c_board[0] + lambda * dir[0], by = c_board[1] + lambda * dir[1];
                  if (sheet.contains(cv::Point2d(bx, by))) {
                    value = opt.black + (opt.white - opt.black) * pattern(bx, by);
                  }
                }
              }
            }
            sum += value;
          }
        }
        out[u] = static_cast<float>(sum / (ss * ss));
      }
    }
  });
  if (opt.blur_sigma_px > 0) cv::GaussianBlur(acc, acc, cv::Size(0, 0), opt.blur_sigma_px);
  if (opt.noise_sigma > 0) {
    cv::Mat noise(acc.size(), CV_32F);
    cv::RNG rng(opt.seed);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, opt.noise_sigma);
    acc += noise;
  }
  cv::Mat out;
  acc.convertTo(out, CV_8U);
  return out;
}

std::vector<std::vector<BoardDetection>> project_views(const Board& board, const std::vector<Camera>& cameras,
                                                       const std::vector<Pose>& poses, double noise_px,
                                                       std::uint64_t seed) {
  const auto obj = board.corner_points();
  const cv::Rect2d e = board.pattern_extent();
  cv::RNG rng(seed);
  std::vector<std::vector<BoardDetection>> out(cameras.size());
  for (const auto& pose : poses) {
    const cv::Vec3d normal = pose.R * cv::Vec3d(0, 0, -1);  // the printed side faces -Z_board
    const cv::Vec3d centre = pose.R * cv::Vec3d(e.x + e.width / 2, e.y + e.height / 2, 0) + pose.t;
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      BoardDetection d;
      if (normal.dot(cv::normalize(cameras[c].position() - centre)) > 0.35) {
        for (int i = 0; i < board.corner_count(); ++i) {
          const auto& o = obj[static_cast<std::size_t>(i)];
          const cv::Vec3d w = pose.R * cv::Vec3d(o.x, o.y, 0) + pose.t;
          if ((cameras[c].R * w + cameras[c].t)[2] <= 0.05) continue;
          const cv::Point2d p = project(cameras[c], w);
          if (p.x < 0 || p.y < 0 || p.x > cameras[c].size.width - 1 || p.y > cameras[c].size.height - 1) continue;
          d.corner_ids.push_back(i);
          d.image_points.emplace_back(static_cast<float>(p.x + rng.gaussian(noise_px)),
                                      static_cast<float>(p.y + rng.gaussian(noise_px)));
          d.object_points.push_back(o);
        }
      }
      if (d.size() < 8) d = {};
      out[c].push_back(std::move(d));
    }
  }
  return out;
}

}  // namespace kumite::calibration::synthetic
