// Calibration benchmarks (targets from the calibration issue):
//   BM_DetectTagBoard_1280x720_decimate2: <= 25 ms per image on one core (and, for comparison,
//   the tool's default full-resolution detection, with and without the corner re-fit;
//   counter corner_rms_px: against the rendered ground truth).
//   BM_ExtrinsicSolve_4cams_200views: pose graph + bundle adjustment <= 30 s.
// Inputs are SYNTHETIC (synthetic.hpp): a rendered board view; board corners projected
// through four known cameras with 0.2 px Gaussian noise.
#include <cmath>
#include <random>

#include <benchmark/benchmark.h>
#include <opencv2/core/utility.hpp>

#include "kumite/calibration/detect.hpp"
#include "kumite/calibration/rig.hpp"
#include "kumite/calibration/synthetic.hpp"

using namespace kumite::calibration;
namespace syn = kumite::calibration::synthetic;

namespace {

Board bench_board() {
  Board b;
  b.rows = 5;
  b.cols = 7;
  b.tag_size_m = 0.09;
  b.gap_m = 0.02;
  return b;
}

std::vector<syn::Camera> corner_cameras() {
  std::vector<syn::Camera> cams;
  int i = 0;
  for (const auto& xz : {cv::Vec2d(-1.7, -1.7), cv::Vec2d(1.7, -1.7), cv::Vec2d(1.7, 1.7), cv::Vec2d(-1.7, 1.7)}) {
    cams.push_back(syn::look_at({xz[0], 2.5, xz[1]}, {0, 0.9, 0}, {0, 1, 0}, {1280, 720}, 1000 + 20 * i,
                                {-0.12 + 0.01 * i, 0.03, 0.0004 * i, -0.0003, 0.0}));
    ++i;
  }
  return cams;
}

/// One 1280x720 view of the bench board and a detector with the given options (one thread).
void run_detect_bench(benchmark::State& state, DetectorOptions opt) {
  cv::setNumThreads(1);
  const Board b = bench_board();
  // The board 1.2 m in front of a 1280x720 camera, tilted: ~35 tags of ~70 px.
  const syn::Camera cam = syn::look_at({0, 0, 0}, {0, 0, 1}, {0, -1, 0}, {1280, 720}, 1000, {-0.12, 0.03, 0, 0, 0});
  syn::Pose pose;
  pose.R = syn::rotation({1, 0.4, 0}, 25);
  const cv::Rect2d e = b.pattern_extent();
  pose.t = cv::Vec3d(0, 0, 1.2) - pose.R * cv::Vec3d(e.width / 2, e.height / 2, 0);
  const cv::Mat img = syn::render_view(BoardPattern(b), b, cam, pose);
  opt.threads = 1;
  BoardDetector det(b, opt);
  BoardDetection d;
  for (auto _ : state) {
    d = det.detect(img);
    benchmark::DoNotOptimize(d.image_points.data());
  }
  state.counters["corners"] = static_cast<double>(d.size());
  // Against the corners projected through the rendering camera (the ground truth).
  double sum2 = 0;
  for (std::size_t i = 0; i < d.size(); ++i) {
    const cv::Point3d o = b.corner_point(d.corner_ids[i]);
    const cv::Point2d truth = syn::project(cam, pose.R * cv::Vec3d(o.x, o.y, o.z) + pose.t);
    const cv::Point2d err = cv::Point2d(d.image_points[i]) - truth;
    sum2 += err.dot(err);
  }
  state.counters["corner_rms_px"] = d.empty() ? 0. : std::sqrt(sum2 / static_cast<double>(d.size()));
  cv::setNumThreads(-1);
}

void BM_DetectTagBoard_1280x720_decimate2(benchmark::State& state) {
  DetectorOptions opt;
  opt.quad_decimate = 2;
  opt.quad_sigma = static_cast<float>(state.range(0)) / 10.f;  // px, Gaussian blur before segmentation
  run_detect_bench(state, opt);
}
// Argument: quad_sigma x 10 (0 = apriltag's default; 8 = 0.8 px, the tool's --blur default).
BENCHMARK(BM_DetectTagBoard_1280x720_decimate2)->Arg(0)->Arg(8)->Unit(benchmark::kMillisecond)->MinTime(2.0);

/// What kumite-calibrate does by default (full resolution): the price of accuracy first, for
/// comparison with the decimate-2 figure above.
void BM_DetectTagBoard_1280x720_technician_default(benchmark::State& state) {
  run_detect_bench(state, technician_detector());
}
BENCHMARK(BM_DetectTagBoard_1280x720_technician_default)->Unit(benchmark::kMillisecond)->MinTime(2.0);

/// The same without re-fitting the corners (apriltag 3.3.0's own, duplicates included): what
/// the re-fit costs and what it changes against the ground truth.
void BM_DetectTagBoard_1280x720_technician_library_corners(benchmark::State& state) {
  DetectorOptions opt = technician_detector();
  opt.refit_corners = false;
  run_detect_bench(state, opt);
}
BENCHMARK(BM_DetectTagBoard_1280x720_technician_library_corners)->Unit(benchmark::kMillisecond)->MinTime(2.0);

/// Poses of a board carried through the volume, printed side up-ish, random tilts.
std::vector<syn::Pose> carried_board(const Board& b, int views) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> ux(-0.9, 0.9), uy(0.6, 1.6), uyaw(0, 360), utilt(-35, 35), uaxis(0, 180);
  const cv::Rect2d e = b.pattern_extent();
  std::vector<syn::Pose> poses;
  for (int f = 0; f < views; ++f) {
    const RigidPose up = floor_board_pose({0, 0, 0}, uyaw(rng));
    const double a = uaxis(rng) * CV_PI / 180;
    syn::Pose p;
    p.R = syn::rotation({std::cos(a), 0, std::sin(a)}, utilt(rng)) * up.R;
    p.t = cv::Vec3d(ux(rng), uy(rng), ux(rng)) - p.R * cv::Vec3d(e.width / 2, e.height / 2, 0);
    poses.push_back(p);
  }
  return poses;
}

void BM_ExtrinsicSolve_4cams_200views(benchmark::State& state) {
  const auto cams = corner_cameras();
  const Board b = bench_board();
  const auto views = syn::project_views(b, cams, carried_board(b, 200), 0.2, 5);
  std::vector<kumite::tracking::CameraCalibration> cal;
  for (std::size_t c = 0; c < cams.size(); ++c) {
    kumite::tracking::CameraCalibration k;
    k.name = "cam" + std::to_string(c);
    k.image_width = 1280;
    k.image_height = 720;
    k.camera_matrix = cams[c].K;
    k.distortion = cams[c].dist;
    cal.push_back(k);
  }
  ExtrinsicsOptions opt;
  opt.refine_intrinsics = true;
  double rms = 0;
  int obs = 0;
  for (auto _ : state) {
    const ExtrinsicsResult r = solve_extrinsics(cal, views, opt);
    rms = r.rms_px_all;
    obs = r.observations;
  }
  state.counters["rms_px"] = rms;
  state.counters["corners"] = obs;
}
BENCHMARK(BM_ExtrinsicSolve_4cams_200views)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
