#pragma once
// The OpenCV pinhole + distortion model (k1 k2 p1 p2 k3) for Ceres cost functions: one
// definition for every reprojection residual in calibration/. (synthetic.cpp keeps its own
// copy on purpose: it renders the ground truth the estimators are tested against.)
#include "kumite/tracking/calibration_file.hpp"

namespace kumite::calibration {

/// Intrinsics as Ceres sees them: fx fy cx cy k1 k2 p1 p2 k3 (px, px, px, px, unitless).
inline constexpr int kIntrinsicCount = 9;

/// Pixel (u, v) of the camera-frame point pc (m) through intrinsics k (layout above).
template <typename T>
void project_to_pixel(const T* k, const T* pc, T* uv) {
  const T x = pc[0] / pc[2], y = pc[1] / pc[2];
  const T r2 = x * x + y * y;
  const T radial = T(1) + k[4] * r2 + k[5] * r2 * r2 + k[8] * r2 * r2 * r2;
  const T xd = x * radial + T(2) * k[6] * x * y + k[7] * (r2 + T(2) * x * x);
  const T yd = y * radial + k[6] * (r2 + T(2) * y * y) + T(2) * k[7] * x * y;
  uv[0] = k[0] * xd + k[2];
  uv[1] = k[1] * yd + k[3];
}

/// A fixed camera's intrinsics in the layout above, as T.
template <typename T>
void intrinsics_of(const tracking::CameraCalibration& cam, T* k) {
  const auto& K = cam.camera_matrix;
  const auto& d = cam.distortion;
  const double v[kIntrinsicCount] = {K(0, 0), K(1, 1), K(0, 2), K(1, 2), d[0], d[1], d[2], d[3], d[4]};
  for (int i = 0; i < kIntrinsicCount; ++i) k[i] = T(v[i]);
}

}  // namespace kumite::calibration
