// DTrack ASCII out: fr, ts, 6dcal and 6d lines as DTrack2 writes them (mm with 3 decimals, the
// location block with the three Euler angles, the matrix column-wise with 6 decimals; lines end
// in CR LF), so that Vrui (VRDeviceDaemon/VRDevices/ArtDTrack.cpp reads the angles, as
// Rx·Ry·Rz), VR Juggler, ART's Unity/Unreal plugins and VRPN's vrpn_Tracker_DTrack (they read
// the matrix) can read Kumite's tracker. The angle convention was checked against two 6d lines
// captured from DTrack (the test DtrackFormat.EulerAnglesMatchCapturedPackets).
#include <algorithm>
#include <cmath>
#include <iterator>

#include <fmt/format.h>

#include "kumite/tracking/interop.hpp"

namespace kumite::tracking {

namespace {
constexpr double kDeg = 180.0 / 3.14159265358979323846;
}

std::array<double, 3> dtrack_euler_deg(const std::array<double, 9>& R) {
  // R = Rx(a)·Ry(b)·Rz(c):  R02 = sin b, R12 = -sin a cos b, R22 = cos a cos b,
  //                          R01 = -cos b sin c, R00 = cos b cos c.
  const double sb = std::clamp(R[2], -1.0, 1.0);
  const double b = std::asin(sb);
  double a = 0, c = 0;
  if (std::abs(sb) < 1.0 - 1e-12) {
    a = std::atan2(-R[5], R[8]);
    c = std::atan2(-R[1], R[0]);
  } else {
    // Gimbal lock (b = ±90°): only a ± c is defined; c = 0, then R10 = sin a sin b, R11 = cos a.
    a = std::atan2(R[3] * sb, R[4]);
  }
  return {a * kDeg, b * kDeg, c * kDeg};
}

void format_dtrack(const DtrackFrame& frame, std::string& out) {
  out.clear();
  auto it = std::back_inserter(out);
  fmt::format_to(it, "fr {}\r\n", frame.frame);
  if (frame.timestamp_s >= 0) fmt::format_to(it, "ts {:.6f}\r\n", frame.timestamp_s);
  int tracked = 0;
  for (const auto& b : frame.bodies) tracked += b.tracked() ? 1 : 0;
  const int calibrated = frame.calibrated_bodies >= 0 ? frame.calibrated_bodies : static_cast<int>(frame.bodies.size());
  fmt::format_to(it, "6dcal {}\r\n", calibrated);
  fmt::format_to(it, "6d {}", tracked);
  for (const auto& b : frame.bodies) {
    if (!b.tracked()) continue;
    // DTrack prints quality with 3 decimals; a value that has more keeps 6 (round trips).
    const double q3 = std::round(b.quality * 1000.0) / 1000.0;
    if (std::abs(q3 - b.quality) < 1e-12) fmt::format_to(it, " [{} {:.3f}]", b.id, b.quality);
    else fmt::format_to(it, " [{} {:.6f}]", b.id, b.quality);
    const auto e = dtrack_euler_deg(b.rotation);
    fmt::format_to(it, "[{:.3f} {:.3f} {:.3f} {:.4f} {:.4f} {:.4f}]", b.position_m[0] * 1e3, b.position_m[1] * 1e3,
                   b.position_m[2] * 1e3, e[0], e[1], e[2]);
    const auto& R = b.rotation;  // row-major; the wire is column-wise: R00 R10 R20 R01 ...
    fmt::format_to(it, "[{:.6f} {:.6f} {:.6f} {:.6f} {:.6f} {:.6f} {:.6f} {:.6f} {:.6f}]", R[0], R[3], R[6], R[1], R[4],
                   R[7], R[2], R[5], R[8]);
  }
  out += "\r\n";
}

std::string format_dtrack(const DtrackFrame& frame) {
  std::string s;
  format_dtrack(frame, s);
  return s;
}

}  // namespace kumite::tracking
