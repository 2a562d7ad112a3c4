// Room alignment: from a board on the floor or three marked floor points.
#include <cmath>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <fmt/format.h>
#include <opencv2/calib3d.hpp>

#include "kumite/calibration/rig.hpp"
#include "kumite/common/error.hpp"
#include "reprojection.hpp"

namespace kumite::calibration {
namespace {

/// A board corner seen by a fixed camera; the only parameter is the board pose in the rig.
struct FixedCameraCost {
  tracking::CameraCalibration cam;
  double u, v, X, Y;
  template <typename T>
  bool operator()(const T* board, T* r) const {
    const T pb[3] = {T(X), T(Y), T(0)};
    T pr[3];
    ceres::AngleAxisRotatePoint(board, pb, pr);
    T pc[3];
    for (int i = 0; i < 3; ++i) {
      pc[i] = T(cam.translation[i]);
      for (int j = 0; j < 3; ++j) pc[i] += T(cam.rotation(i, j)) * (pr[j] + board[3 + j]);
    }
    T k[kIntrinsicCount], uv[2];
    intrinsics_of(cam, k);
    project_to_pixel(k, pc, uv);
    r[0] = uv[0] - T(u);
    r[1] = uv[1] - T(v);
    return true;
  }
};

RigidPose camera_from_rig(const tracking::CameraCalibration& c) { return {c.rotation, c.translation}; }

}  // namespace

RigidPose floor_board_pose(const cv::Vec3d& origin_room, double yaw_deg) {
  // Columns: board axes in the room. X -> +X, Y -> +Z, Z -> -Y (face up, into the floor).
  const cv::Matx33d R0(1, 0, 0, 0, 0, -1, 0, 1, 0);
  const double a = yaw_deg * CV_PI / 180.0;
  const cv::Matx33d Ry(std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a));
  return {Ry * R0, origin_room};
}

RigidPose board_pose_in_rig(const std::vector<tracking::CameraCalibration>& cameras,
                            const std::vector<BoardDetection>& views) {
  cv::Matx33d Rsum = cv::Matx33d::zeros();
  cv::Vec3d tsum(0, 0, 0);
  double wsum = 0;
  for (std::size_t c = 0; c < cameras.size() && c < views.size(); ++c) {
    const auto p = board_pose_in_camera(views[c], cameras[c]);
    if (!p) continue;
    const RigidPose in_rig = camera_from_rig(cameras[c]).inverse() * *p;
    const double w = static_cast<double>(views[c].size());
    Rsum += in_rig.R * w;
    tsum += in_rig.t * w;
    wsum += w;
  }
  if (wsum == 0) {
    throw Error("calibration", "not_seen",
                "no camera sees the floor board: put it where at least one (better three) cameras see it whole");
  }
  // Chordal mean of the rotations: the nearest rotation to their weighted sum.
  cv::Mat W, U, Vt;
  cv::SVD::compute(cv::Mat(Rsum), W, U, Vt);
  cv::Mat Rm = U * Vt;
  if (cv::determinant(Rm) < 0) {
    U.col(2) *= -1;
    Rm = U * Vt;
  }
  RigidPose init{cv::Matx33d(Rm), tsum / wsum};

  cv::Vec3d rv;
  cv::Rodrigues(init.R, rv);
  double q[6] = {rv[0], rv[1], rv[2], init.t[0], init.t[1], init.t[2]};
  ceres::Problem problem;
  for (std::size_t c = 0; c < cameras.size() && c < views.size(); ++c) {
    for (std::size_t i = 0; i < views[c].size(); ++i) {
      const auto& v = views[c];
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<FixedCameraCost, 2, 6>(new FixedCameraCost{
                                   cameras[c], v.image_points[i].x, v.image_points[i].y, v.object_points[i].x,
                                   v.object_points[i].y}),
                               new ceres::HuberLoss(1.0), q);
    }
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 50;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (!summary.IsSolutionUsable()) throw Error("calibration", "solve", "floor board pose: " + summary.message);
  RigidPose out;
  cv::Rodrigues(cv::Vec3d(q[0], q[1], q[2]), out.R);
  out.t = {q[3], q[4], q[5]};
  return out;
}

void apply_room_frame(std::vector<tracking::CameraCalibration>& cameras, const RigidPose& room_from_rig) {
  const RigidPose rig_from_room = room_from_rig.inverse();
  for (auto& c : cameras) {
    const RigidPose cam_from_room = camera_from_rig(c) * rig_from_room;
    c.rotation = cam_from_room.R;
    c.translation = cam_from_room.t;
  }
}

RigidPose fit_rigid(const std::vector<cv::Vec3d>& from, const std::vector<cv::Vec3d>& to) {
  if (from.size() != to.size() || from.size() < 3) {
    throw Error("calibration", "points", "fit_rigid needs at least three point pairs");
  }
  cv::Vec3d ca(0, 0, 0), cb(0, 0, 0);
  for (std::size_t i = 0; i < from.size(); ++i) {
    ca += from[i];
    cb += to[i];
  }
  ca /= static_cast<double>(from.size());
  cb /= static_cast<double>(from.size());
  cv::Matx33d H = cv::Matx33d::zeros();
  for (std::size_t i = 0; i < from.size(); ++i) H += (from[i] - ca) * (to[i] - cb).t();
  cv::Mat W, U, Vt;
  cv::SVD::compute(cv::Mat(H), W, U, Vt);
  if (W.at<double>(1) < 1e-9 * std::max(1.0, W.at<double>(0))) {
    throw Error("calibration", "points", "the floor points are collinear: mark three points forming a wide triangle");
  }
  cv::Mat R = Vt.t() * U.t();
  if (cv::determinant(R) < 0) {
    cv::Mat V = Vt.t();
    V.col(2) *= -1;
    R = V * U.t();
  }
  RigidPose p;
  p.R = cv::Matx33d(R);
  p.t = cb - p.R * ca;
  return p;
}

cv::Vec3d triangulate(const std::vector<tracking::CameraCalibration>& cameras,
                      const std::vector<std::pair<int, cv::Point2d>>& pixels) {
  if (pixels.size() < 2) throw Error("calibration", "points", "a point needs pixels in at least two cameras");
  // Linear: each view gives two rows of A X = 0 from the undistorted normalised ray.
  cv::Mat A(static_cast<int>(pixels.size() * 2), 4, CV_64F);
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    const auto& cam = cameras.at(static_cast<std::size_t>(pixels[i].first));
    std::vector<cv::Point2d> in{pixels[i].second}, out;
    cv::undistortPoints(in, out, cam.camera_matrix, cam.distortion);
    cv::Matx34d P;
    for (int r = 0; r < 3; ++r) {
      for (int k = 0; k < 3; ++k) P(r, k) = cam.rotation(r, k);
      P(r, 3) = cam.translation[r];
    }
    for (int k = 0; k < 4; ++k) {
      A.at<double>(static_cast<int>(2 * i), k) = out[0].x * P(2, k) - P(0, k);
      A.at<double>(static_cast<int>(2 * i + 1), k) = out[0].y * P(2, k) - P(1, k);
    }
  }
  cv::Mat X;
  cv::SVD::solveZ(A, X);
  return {X.at<double>(0) / X.at<double>(3), X.at<double>(1) / X.at<double>(3), X.at<double>(2) / X.at<double>(3)};
}

}  // namespace kumite::calibration
