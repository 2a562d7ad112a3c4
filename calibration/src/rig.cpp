#include "kumite/calibration/rig.hpp"

#include <cmath>
#include <deque>
#include <limits>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <fmt/format.h>
#include <opencv2/calib3d.hpp>

#include "kumite/common/error.hpp"
#include "reprojection.hpp"

namespace kumite::calibration {
namespace {

/// One board corner seen by one camera. Parameters: intrinsics (fx fy cx cy k1 k2 p1 p2 k3),
/// camera pose (angle-axis, t: rig -> camera), board pose (angle-axis, t: board -> rig).
struct ReprojectionCost {
  double u, v, X, Y;
  template <typename T>
  bool operator()(const T* k, const T* cam, const T* board, T* r) const {
    const T pb[3] = {T(X), T(Y), T(0)};
    T pr[3], pc[3];
    ceres::AngleAxisRotatePoint(board, pb, pr);
    for (int i = 0; i < 3; ++i) pr[i] += board[3 + i];
    ceres::AngleAxisRotatePoint(cam, pr, pc);
    for (int i = 0; i < 3; ++i) pc[i] += cam[3 + i];
    T uv[2];
    project_to_pixel(k, pc, uv);
    r[0] = uv[0] - T(u);
    r[1] = uv[1] - T(v);
    return true;
  }
};

using Params6 = std::array<double, 6>;

Params6 to_params(const RigidPose& p) {
  cv::Vec3d rv;
  cv::Rodrigues(p.R, rv);
  return {rv[0], rv[1], rv[2], p.t[0], p.t[1], p.t[2]};
}

RigidPose from_params(const Params6& q) {
  RigidPose p;
  cv::Rodrigues(cv::Vec3d(q[0], q[1], q[2]), p.R);
  p.t = {q[3], q[4], q[5]};
  return p;
}

std::array<double, 9> to_intrinsics(const tracking::CameraCalibration& c) {
  return {c.camera_matrix(0, 0), c.camera_matrix(1, 1), c.camera_matrix(0, 2), c.camera_matrix(1, 2),
          c.distortion[0],       c.distortion[1],       c.distortion[2],       c.distortion[3],
          c.distortion[4]};
}

}  // namespace

std::optional<RigidPose> board_pose_in_camera(const BoardDetection& view, const tracking::CameraCalibration& cam) {
  if (view.size() < 4) return std::nullopt;
  cv::Vec3d rv, tv;
  bool ok = false;
  try {
    ok = cv::solvePnP(view.object_points, view.image_points, cam.camera_matrix, cam.distortion, rv, tv, false,
                      cv::SOLVEPNP_IPPE);
    if (ok) {
      cv::solvePnPRefineLM(view.object_points, view.image_points, cam.camera_matrix, cam.distortion, rv, tv);
    }
  } catch (const cv::Exception&) {
    ok = false;
  }
  if (!ok || !(tv[2] > 0)) return std::nullopt;
  RigidPose p;
  cv::Rodrigues(rv, p.R);
  p.t = tv;
  return p;
}

ExtrinsicsResult solve_extrinsics(const std::vector<tracking::CameraCalibration>& cameras,
                                  const std::vector<std::vector<BoardDetection>>& views,
                                  const ExtrinsicsOptions& opt) {
  const auto say = [&](const std::string& s) {
    if (opt.progress) opt.progress(s);
  };
  const std::size_t nc = cameras.size();
  if (nc == 0) throw Error("calibration", "args", "no cameras");
  if (views.size() != nc) throw Error("calibration", "args", "views and cameras differ in count");
  std::size_t nf = 0;
  for (const auto& v : views) nf = std::max(nf, v.size());

  // Edges of the camera-view graph: board pose in camera c at frame f.
  std::vector<std::vector<std::optional<RigidPose>>> edge(nc, std::vector<std::optional<RigidPose>>(nf));
  for (std::size_t c = 0; c < nc; ++c) {
    int seen = 0;
    for (std::size_t f = 0; f < views[c].size(); ++f) {
      if (static_cast<int>(views[c][f].size()) < opt.min_corners) continue;
      edge[c][f] = board_pose_in_camera(views[c][f], cameras[c]);
      seen += edge[c][f].has_value();
    }
    if (seen == 0) {
      throw Error("calibration", "not_seen",
                  fmt::format("camera {} never sees the board: capture views where {} sees the board together with "
                              "at least one other camera",
                              cameras[c].name, cameras[c].name));
    }
  }

  // Breadth-first over cameras and frames from camera 0 (the rig frame).
  std::vector<std::optional<RigidPose>> cam_pose(nc);  // rig -> camera
  std::vector<std::optional<RigidPose>> board_pose(nf);  // board -> rig
  cam_pose[0] = RigidPose{};
  std::deque<std::pair<bool, std::size_t>> queue{{true, 0}};  // (is camera, index)
  while (!queue.empty()) {
    const auto [is_cam, i] = queue.front();
    queue.pop_front();
    if (is_cam) {
      for (std::size_t f = 0; f < nf; ++f) {
        if (edge[i][f] && !board_pose[f]) {
          board_pose[f] = cam_pose[i]->inverse() * *edge[i][f];
          queue.emplace_back(false, f);
        }
      }
    } else {
      for (std::size_t c = 0; c < nc; ++c) {
        if (edge[c][i] && !cam_pose[c]) {
          cam_pose[c] = *edge[c][i] * board_pose[i]->inverse();
          queue.emplace_back(true, c);
        }
      }
    }
  }
  std::string connected, missing;
  const auto append = [](std::string& list, const std::string& name) { list += list.empty() ? name : ", " + name; };
  for (std::size_t c = 0; c < nc; ++c) append(cam_pose[c] ? connected : missing, cameras[c].name);
  if (!missing.empty()) {
    throw Error("calibration", "not_connected",
                fmt::format("camera(s) {} never share a board view with {}: the rig is not connected; capture views "
                            "where the board is seen by {} and one of {} at the same moment",
                            missing, connected, missing, connected));
  }
  say(fmt::format("pose graph: {} cameras and {} board poses chained from {}", nc,
                  std::count_if(board_pose.begin(), board_pose.end(), [](const auto& p) { return p.has_value(); }),
                  cameras[0].name));

  // Bundle adjustment.
  std::vector<std::array<double, 9>> intr(nc);
  std::vector<Params6> cam_params(nc), board_params(nf);
  for (std::size_t c = 0; c < nc; ++c) {
    intr[c] = to_intrinsics(cameras[c]);
    cam_params[c] = to_params(*cam_pose[c]);
  }
  for (std::size_t f = 0; f < nf; ++f) {
    if (board_pose[f]) board_params[f] = to_params(*board_pose[f]);
  }
  ceres::Problem problem;
  ExtrinsicsResult res;
  struct Obs {
    std::size_t c, f;
    ceres::ResidualBlockId id;
  };
  std::vector<Obs> obs;
  for (std::size_t c = 0; c < nc; ++c) {
    for (std::size_t f = 0; f < views[c].size(); ++f) {
      if (!edge[c][f] || !board_pose[f]) continue;
      const auto& v = views[c][f];
      for (std::size_t i = 0; i < v.size(); ++i) {
        auto* cost = new ceres::AutoDiffCostFunction<ReprojectionCost, 2, 9, 6, 6>(
            new ReprojectionCost{v.image_points[i].x, v.image_points[i].y, v.object_points[i].x, v.object_points[i].y});
        const auto id = problem.AddResidualBlock(cost, new ceres::HuberLoss(opt.huber_px), intr[c].data(),
                                                 cam_params[c].data(), board_params[f].data());
        obs.push_back({c, f, id});
      }
    }
  }
  problem.SetParameterBlockConstant(cam_params[0].data());
  for (std::size_t c = 0; c < nc; ++c) {
    if (!opt.refine_intrinsics) problem.SetParameterBlockConstant(intr[c].data());
  }
  for (std::size_t f = 0; f < nf; ++f) res.frames_used += board_pose[f].has_value();
  res.observations = static_cast<int>(obs.size());

  auto rms_of = [&](std::vector<double>* per_cam_sum, std::vector<int>* per_cam_n) {
    double s = 0;
    for (const auto& o : obs) {
      double r[2];
      problem.EvaluateResidualBlock(o.id, false, nullptr, r, nullptr);
      const double e2 = r[0] * r[0] + r[1] * r[1];
      s += e2;
      if (per_cam_sum) {
        (*per_cam_sum)[o.c] += e2;
        (*per_cam_n)[o.c] += 1;
      }
    }
    return obs.empty() ? 0.0 : std::sqrt(s / static_cast<double>(obs.size()));
  };
  res.initial_rms_px = rms_of(nullptr, nullptr);
  say(fmt::format("bundle adjustment: {} cameras, {} board poses, {} corners; initial RMS {:.3f} px", nc,
                  res.frames_used, obs.size(), res.initial_rms_px));

  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  so.max_num_iterations = opt.max_iterations;
  so.num_threads = std::max(1, opt.threads);
  so.function_tolerance = 1e-10;
  so.parameter_tolerance = 1e-10;
  struct Progress : ceres::IterationCallback {
    std::function<void(const std::string&)> say;
    ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
      if (say && s.iteration % 5 == 0) say(fmt::format("  iteration {}: cost {:.6g}", s.iteration, s.cost));
      return ceres::SOLVER_CONTINUE;
    }
  } progress;
  progress.say = opt.progress;
  so.callbacks.push_back(&progress);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    throw Error("calibration", "solve", "the bundle adjustment failed: " + summary.message);
  }

  // Results.
  std::vector<double> sum(nc, 0.0);
  std::vector<int> n(nc, 0);
  res.rms_px_all = rms_of(&sum, &n);
  res.rms_px.resize(nc);
  res.view_errors_px.assign(nc, std::vector<double>(nf, std::numeric_limits<double>::quiet_NaN()));
  {
    std::vector<std::vector<double>> vs(nc, std::vector<double>(nf, 0.0));
    std::vector<std::vector<int>> vn(nc, std::vector<int>(nf, 0));
    for (const auto& o : obs) {
      double r[2];
      problem.EvaluateResidualBlock(o.id, false, nullptr, r, nullptr);
      vs[o.c][o.f] += r[0] * r[0] + r[1] * r[1];
      vn[o.c][o.f] += 1;
    }
    for (std::size_t c = 0; c < nc; ++c) {
      for (std::size_t f = 0; f < nf; ++f) {
        if (vn[c][f]) res.view_errors_px[c][f] = std::sqrt(vs[c][f] / vn[c][f]);
      }
    }
  }
  res.cameras = cameras;
  for (std::size_t c = 0; c < nc; ++c) {
    res.rms_px[c] = n[c] ? std::sqrt(sum[c] / n[c]) : 0.0;
    const RigidPose p = from_params(cam_params[c]);
    auto& out = res.cameras[c];
    out.rotation = p.R;
    out.translation = p.t;
    const auto& k = intr[c];
    out.camera_matrix = cv::Matx33d(k[0], 0, k[2], 0, k[1], k[3], 0, 0, 1);
    out.distortion = {k[4], k[5], k[6], k[7], k[8]};
    out.rms_px = res.rms_px[c];
    out.per_view_errors_px.clear();
    for (double e : res.view_errors_px[c]) out.per_view_errors_px.push_back(std::isfinite(e) ? e : -1.0);
  }
  res.board_poses.resize(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    if (board_pose[f]) res.board_poses[f] = from_params(board_params[f]);
  }
  say(fmt::format("bundle adjustment: {} iterations, RMS {:.3f} px ({})", summary.iterations.size(),
                  res.rms_px_all, summary.message));
  return res;
}

}  // namespace kumite::calibration
