#pragma once
// SYNTHETIC camera frames for tests, benchmarks and demos (always labelled as such): a body's
// markers drawn as blurred spots with image noise into every calibrated camera, from a
// trajectory (the built-in scripted visitor, a static pose, or a CSV), with options for hidden
// markers, spurious blobs, static lamps, a camera that stops and dropped frames. The ground
// truth is the trajectory itself, an independent path from the tracker's output.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <random>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "kumite/tracking/calibration_file.hpp"
#include "kumite/tracking/config.hpp"
#include "kumite/tracking/recording.hpp"

namespace kumite::tracking {

/// A body pose along a trajectory: position = centroid of the body's model markers (m),
/// orientation rotates body frame -> room.
struct TrajectoryPoint {
  Timestamp t = 0;  ///< s
  Eigen::Vector3d position{0, 1.65, 0};
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
};

/// The scripted visitor at time t (s): walks about the tracked area, dodges sideways (~1 m/s)
/// every 7 s, crouches (0.45 m) every 11 s, and turns/nods the head. Stays within |x|, |z| < 1 m.
TrajectoryPoint scripted_visitor(Timestamp t);
/// A visitor standing still at (0, 1.65, 0), looking at the front wall, slightly turned.
TrajectoryPoint static_visitor(Timestamp t);
/// Reads "timestamp_s,x,y,z,qw,qx,qy,qz" rows (header required); throws kumite::Error naming
/// the file and line. The trajectory is sampled by linear interpolation/slerp.
std::vector<TrajectoryPoint> read_trajectory_csv(const std::filesystem::path& path);
TrajectoryPoint sample(const std::vector<TrajectoryPoint>& trajectory, Timestamp t);

struct SynthOptions {
  double fps = 60;                    ///< Hz: frame-set rate
  double centroid_sigma_px = 0.3;     ///< px: sigma of each spot centre's jitter PER IMAGE AXIS (x and y
                                      ///< each; the 2-D RMS displacement is sqrt(2) x this)
  double image_noise = 2.0;           ///< grey levels: sigma of the sensor noise
  double background = 12;             ///< grey level
  double peak = 220;                  ///< grey levels above the background at a spot's centre
  double marker_diameter_m = 0.014;   ///< m
  double blur_px = 0.6;               ///< px: optics blur sigma added to the spot size
  std::vector<int> hidden_markers;    ///< model markers not drawn (body 0) ...
  double hide_from_s = 0;             ///< ... from this time (s) ...
  double hide_until_s = 1e300;        ///< ... until this time (s): hidden while from <= t < until
  int spurious_blobs = 0;             ///< random spots per camera per frame (moving each frame)
  int static_lamps = 0;               ///< fixed bright spots per camera (lamps, reflections)
  int dead_camera = -1;               ///< camera index that stops delivering ...
  double dead_after_s = 0;            ///< ... from this time on (s)
  double drop_probability = 0;        ///< per camera and frame set: no image
  std::uint32_t seed = 1;
};

class FrameSource;  // tracker.hpp

class SyntheticRenderer {
 public:
  SyntheticRenderer(const RigCalibration& rig, const BodyConfig& body, SynthOptions options);
  /// Several bodies (the visitor's glasses, gloves, shoes) in the same images; options'
  /// hidden_markers are body 0's. Throws kumite::Error for no body.
  SyntheticRenderer(const RigCalibration& rig, std::vector<BodyConfig> bodies, SynthOptions options);
  /// Renders one frame set (images empty for a dead camera / dropped frame) of body 0.
  FrameSet render(std::uint64_t frame, const TrajectoryPoint& pose);
  /// Renders one frame set at time t (s) with each body where `poses` has it (per body, in
  /// the constructor's order; nullopt or missing: not drawn).
  FrameSet render(std::uint64_t frame, Timestamp t, std::span<const std::optional<TrajectoryPoint>> poses);
  /// The room positions of body 0's markers at `pose` (of body `body`: the second form).
  std::vector<Eigen::Vector3d> marker_positions(const TrajectoryPoint& pose) const;
  std::vector<Eigen::Vector3d> marker_positions(std::size_t body, const TrajectoryPoint& pose) const;
  const SynthOptions& options() const { return options_; }

 private:
  void draw_spot(cv::Mat& img, double x, double y, double sigma, double peak);

  RigCalibration rig_;
  std::vector<BodyConfig> bodies_;
  std::vector<Eigen::Vector3d> centroids_;
  SynthOptions options_;
  std::mt19937 rng_;
  std::vector<std::vector<cv::Mat>> backgrounds_;   // per camera, a few noise images
  std::vector<std::vector<cv::Point2d>> lamps_;     // per camera
};

/// Writes a SYNTHETIC recording to `dir` (created; must be empty or absent): frames.csv,
/// <camera>/NNNNNN.png, truth.csv and a README.txt saying it is synthetic and how it was made.
void write_synthetic_recording(const std::filesystem::path& dir, const RigCalibration& rig,
                               const BodyConfig& body, const std::vector<TrajectoryPoint>& trajectory,
                               const SynthOptions& options, const std::string& description);
/// Several bodies: frame set i at `times[i]` (s) with each body where `poses[i]` has it (per body,
/// nullopt: not drawn). truth.csv holds body 0's poses where drawn; with more than one body,
/// truth-bodies.csv holds every drawn body's (frame,timestamp_s,body,x,y,z,qw,qx,qy,qz; body by name).
void write_synthetic_recording(const std::filesystem::path& dir, const RigCalibration& rig,
                               const std::vector<BodyConfig>& bodies, const std::vector<Timestamp>& times,
                               const std::vector<std::vector<std::optional<TrajectoryPoint>>>& poses,
                               const SynthOptions& options, const std::string& description);

/// The shipped default rig: 4 cameras, 1280x1024, high (2.6 m) in the corners of a 3 m x 3 m
/// tracked area, looking at its centre at 1.2 m; 66 x 54 degree lenses (f = 1000 px), mild barrel distortion.
RigCalibration corner_rig(double side_m = 3.0, double height_m = 2.6, int width = 1280, int height = 1024,
                          double focal_px = 1000);

/// SYNTHETIC live cameras: a frame source that renders `trajectory` (a function of the seconds
/// since its first frame set) into every camera of `rig` at `rate_hz` on the real clock
/// (kumite::now(): each set waits for its time and is stamped with it, as a camera's driver
/// stamps), for tests and benchmarks of the live path; a set the consumer was too late for is
/// skipped, as a camera drops it. It never ends.
std::unique_ptr<FrameSource> synthetic_live_source(const RigCalibration& rig, const BodyConfig& body,
                                                   std::function<TrajectoryPoint(Timestamp)> trajectory,
                                                   double rate_hz = 60, SynthOptions options = {});
/// The poses of several bodies at t (s since the first frame set), written over `out` (one per
/// body, nullopt: not drawn).
using BodyPoses = std::function<void(Timestamp t, std::vector<std::optional<TrajectoryPoint>>& out)>;
/// The same with several bodies (a mocap visitor's glasses, gloves and shoes).
std::unique_ptr<FrameSource> synthetic_live_source(const RigCalibration& rig, std::vector<BodyConfig> bodies,
                                                   BodyPoses poses, double rate_hz = 60, SynthOptions options = {});

}  // namespace kumite::tracking
