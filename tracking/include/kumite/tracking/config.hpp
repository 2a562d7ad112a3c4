#pragma once
// tracking.toml as plain structs (as SGCT does: defaults in the struct, a free reader that
// validates). Only `[[bodies]] name, markers` is required; every other key has a default.
// The keys, units and defaults are listed in tracking/README.md.
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "kumite/tracking/blobs.hpp"

namespace kumite::tracking {

/// One Euro filter (Casiez et al. 2012) for position (per axis, m) and orientation (angle).
struct FilterConfig {
  bool enabled = true;
  double min_cutoff_hz = 1.0;       ///< Hz: cutoff at rest (lower = less jitter, more lag)
  double beta = 600.0;              ///< 1/m: cutoff grows by beta * speed (m/s)
  double d_cutoff_hz = 4.0;         ///< Hz: cutoff of the speed estimate
  double rot_min_cutoff_hz = 1.0;   ///< Hz
  double rot_beta = 80.0;           ///< 1/rad: cutoff grows by rot_beta * angular speed (rad/s)
  double rot_d_cutoff_hz = 1.0;     ///< Hz
  double max_prediction_s = 0.1;    ///< s: predict() never extrapolates further than this
};

/// A rigid body: its markers in its own frame (m). For the head: +X right, +Y up, looking
/// toward -Z. The reported position is the centroid of ALL the model markers.
struct BodyConfig {
  std::string name;
  std::vector<Eigen::Vector3d> markers;  ///< m, body frame; at least 3, distinct distances
  double distance_tolerance_m = 0.004;   ///< m: inter-marker distance match tolerance
  double match_radius_m = 0.03;          ///< m: marker-to-prediction radius when tracked
  /// Its own One Euro filter and coasting ([bodies.filter], coasting_s in [[bodies]]): a fist
  /// moves at 8 m/s, and the head's settings would lag it. None: the file's [filter] and
  /// coasting_s.
  std::optional<FilterConfig> filter;
  std::optional<double> coasting_s;      ///< s
  const FilterConfig& filter_or(const FilterConfig& shared) const { return filter ? *filter : shared; }
  double coasting_or(double shared) const { return coasting_s.value_or(shared); }
};

/// Correspondence and triangulation.
struct MatchConfig {
  double max_ray_distance_m = 0.008;  ///< m: two rays closer than this may meet (epipolar)
  double max_reprojection_px = 2.0;   ///< px: a third camera's blob must lie this close
  double outlier_px = 1.2;            ///< px: leave-one-out reprojection error that drops a ray
  int min_cameras = 2;                ///< markers seen by fewer cameras are dropped
  double max_residual_m = 0.006;      ///< m: mean ray distance above which a marker is dropped
  double min_depth_m = 0.2;           ///< m: in front of every camera by at least this
};


/// A live V4L2 camera (`[[cameras]]`, only for --live).
struct LiveCameraConfig {
  std::string name;                  ///< as in the calibration file
  std::string device;                ///< e.g. "/dev/video0"
  std::string pixel_format = "GREY"; ///< GREY (= Y8), Y16, MJPG or YUYV
  int width = 1280;                  ///< px
  int height = 1024;                 ///< px
  double fps = 60;                   ///< Hz
  int exposure = -1;                 ///< driver units (100 us for most UVC); -1 = leave as is
  int gain = -1;                     ///< driver units; -1 = leave as is
  int buffers = 2;                   ///< driver buffers (fewer = less latency)
};

struct TrackingConfig {
  std::vector<BodyConfig> bodies;
  BlobParams blobs;
  bool static_mask = true;
  StaticMaskParams mask;
  MatchConfig match;
  FilterConfig filter;
  double frame_tolerance_s = 0.004;  ///< s: frames this close in time form one frame set
  double coasting_s = 0.1;           ///< s: how long a body coasts before it is lost
  double camera_timeout_s = 0.5;     ///< s: no frame for this long = camera "no frames"
  /// s: a camera that delivers images but sees none of the head's markers this long, while
  /// the head is tracked by >= 2 other cameras and lies in its view, is "blind"
  double camera_blind_s = 2.0;
  std::vector<LiveCameraConfig> cameras;

  /// Index of the body called `name`, or -1.
  int find_body(std::string_view name) const;
  /// The glasses: the body named by its role, "head", else body 0.
  int head_body() const {
    const int i = find_body("head");
    return i >= 0 ? i : 0;
  }
};

/// Parses tracking.toml text (`source` names it in errors). Throws kumite::Error("config",...)
/// with "file:line: key: message" for syntax errors, unknown keys, wrong types and bad values.
TrackingConfig parse_tracking_config(std::string_view text, std::string_view source = "tracking.toml");
/// Reads and parses a file (errors name the file).
TrackingConfig read_tracking_config(const std::filesystem::path& path);

}  // namespace kumite::tracking
