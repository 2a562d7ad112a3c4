// Tracking benchmark (a `bench` command printing JSON): renders SYNTHETIC frame sets of the
// scripted visitor for the shipped rig (4 cameras, 1280x1024) in memory, then times only
// Pipeline::process() per frame set, pinned to one core. Also times the sparse blob detector
// against a full connectedComponentsWithStats on the same images.
//
//   build/bin/kumite_tracking_bench [frame_sets=600] [spurious_blobs=0]
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "kumite/tracking/blobs.hpp"
#include "kumite/tracking/config.hpp"
#include "kumite/tracking/pipeline.hpp"
#include "kumite/tracking/synth.hpp"

using namespace kumite;
using namespace kumite::tracking;
using Clock = std::chrono::steady_clock;

namespace {

/// CPU time of this thread (ms): excludes the time other processes hold the core, so the
/// figure stays meaningful on a shared machine (the wall-clock one is printed too).
double thread_cpu_ms() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

double pct(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5)];
}

void pin_to_one_core() {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(sched_getcpu(), &set);
  sched_setaffinity(0, sizeof(set), &set);
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 600;
  const int spurious = argc > 2 ? std::atoi(argv[2]) : 0;
  pin_to_one_core();
  const RigCalibration rig = corner_rig();
  const TrackingConfig config = read_tracking_config(std::filesystem::path(KUMITE_SOURCE_DIR) / "config/tracking.toml");
  SynthOptions options;
  options.spurious_blobs = spurious;
  SyntheticRenderer renderer(rig, config.bodies[0], options);
  Pipeline pipeline(rig, config);
  BlobDetector detector(config.blobs);
  std::vector<double> frame_ms, frame_cpu_ms, blob_ms, ccl_ms;
  double pos2 = 0, rot2 = 0;
  int tracked = 0;
  cv::Mat bin, labels, stats, centroids;
  for (int i = 0; i < n; ++i) {
    const TrajectoryPoint truth = scripted_visitor(i / options.fps);
    const FrameSet set = renderer.render(static_cast<std::uint64_t>(i), truth);
    const double c0 = thread_cpu_ms();
    auto t0 = Clock::now();
    const FrameResult& r = pipeline.process(set);
    frame_ms.push_back(ms_since(t0));
    frame_cpu_ms.push_back(thread_cpu_ms() - c0);
    const BodyPose& p = r.raw[0];
    if (p.status == TrackingStatus::tracked) {
      ++tracked;
      pos2 += (Eigen::Vector3d(p.position.data()) - truth.position).squaredNorm();
      const Eigen::Quaterniond q(p.orientation[0], p.orientation[1], p.orientation[2], p.orientation[3]);
      const double a = q.angularDistance(truth.orientation) * 180 / M_PI;
      rot2 += a * a;
    }
    if (i % 10 == 0) {  // the blob stage alone, against a full labelling, on camera 0
      double c1 = thread_cpu_ms();
      detector.detect(set.images[0]);
      blob_ms.push_back(thread_cpu_ms() - c1);
      c1 = thread_cpu_ms();
      cv::threshold(set.images[0], bin, config.blobs.threshold, 255, cv::THRESH_BINARY);
      cv::connectedComponentsWithStats(bin, labels, stats, centroids, 8, CV_32S);
      ccl_ms.push_back(thread_cpu_ms() - c1);
    }
  }
  const double blob50 = pct(blob_ms, 0.5), ccl50 = pct(ccl_ms, 0.5);
  std::printf(
      "{\n  \"what\": \"SYNTHETIC frame sets, scripted visitor, Pipeline::process per frame set, one core\",\n"
      "  \"frame_sets\": %d, \"cameras\": %zu, \"image\": \"1280x1024\", \"spurious_blobs_per_camera\": %d,\n"
      "  \"frame_set_to_pose_cpu_ms\": {\"p50\": %.3f, \"p90\": %.3f, \"p99\": %.3f, \"max\": %.3f},\n"
      "  \"frame_set_to_pose_wall_ms\": {\"p50\": %.3f, \"p90\": %.3f, \"p99\": %.3f, \"max\": %.3f},\n"
      "  \"blob_detection_cpu_ms_per_image\": {\"p50\": %.3f},\n"
      "  \"threshold_plus_connected_components_cpu_ms_per_image\": {\"p50\": %.3f},\n"
      "  \"connected_components_over_sparse_blobs\": %.1f,\n"
      "  \"tracked\": %d, \"unsmoothed_position_rms_mm\": %.3f, \"unsmoothed_orientation_rms_deg\": %.3f\n}\n",
      n, rig.cameras.size(), spurious, pct(frame_cpu_ms, 0.5), pct(frame_cpu_ms, 0.9), pct(frame_cpu_ms, 0.99),
      pct(frame_cpu_ms, 1.0), pct(frame_ms, 0.5), pct(frame_ms, 0.9), pct(frame_ms, 0.99), pct(frame_ms, 1.0),
      blob50, ccl50, ccl50 / blob50, tracked, tracked ? 1e3 * std::sqrt(pos2 / tracked) : 0.0,
      tracked ? std::sqrt(rot2 / tracked) : 0.0);
  return 0;
}
