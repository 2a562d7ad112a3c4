// kumite_compare_calibration ESTIMATE.yaml TRUTH.yaml: per camera (matched by name), how far
// an estimated calibration is from a reference one (e.g. kumite_make_synthetic_rig's
// truth.yaml): camera position (mm), rotation (deg), fx and fy (%), both in the room frame.
// Prints one JSON object; exit 1 when a camera of the reference is missing.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>

#include <opencv2/calib3d.hpp>

#include "kumite/tracking/calibration_file.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: kumite_compare_calibration ESTIMATE.yaml TRUTH.yaml\n");
    return 2;
  }
  try {
    const auto est = kumite::tracking::read_calibration(argv[1]);
    const auto truth = kumite::tracking::read_calibration(argv[2]);
    bool missing = false, first = true;
    double worst_mm = 0, worst_deg = 0, worst_f = 0;
    std::printf("{\"cameras\": [");
    for (std::size_t i = 0; i < truth.cameras.size(); ++i) {
      const auto& t = truth.cameras[i];
      const auto* e = est.find(t.name);
      if (e == nullptr) {
        std::fprintf(stderr, "%s: no camera %s (it is in %s)\n", argv[1], t.name.c_str(), argv[2]);
        missing = true;
        continue;
      }
      const double mm = cv::norm(e->position() - t.position()) * 1e3;
      cv::Vec3d rvec;
      cv::Rodrigues(cv::Mat(e->rotation * t.rotation.t()), rvec);
      const double deg = cv::norm(rvec) * 180 / CV_PI;
      const double fx = 100 * (e->camera_matrix(0, 0) / t.camera_matrix(0, 0) - 1);
      const double fy = 100 * (e->camera_matrix(1, 1) / t.camera_matrix(1, 1) - 1);
      worst_mm = std::max(worst_mm, mm);
      worst_deg = std::max(worst_deg, deg);
      worst_f = std::max({worst_f, std::abs(fx), std::abs(fy)});
      // Camera names are plain (they are folder names); no escaping needed.
      std::printf("%s{\"name\": \"%s\", \"position_mm\": %.3f, \"rotation_deg\": %.4f, \"fx_pct\": %.3f, \"fy_pct\": %.3f}",
                  first ? "" : ", ", t.name.c_str(), mm, deg, fx, fy);
      first = false;
    }
    std::printf("], \"worst_position_mm\": %.3f, \"worst_rotation_deg\": %.4f, \"worst_focal_pct\": %.3f}\n", worst_mm,
                worst_deg, worst_f);
    return missing ? 1 : 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
}
