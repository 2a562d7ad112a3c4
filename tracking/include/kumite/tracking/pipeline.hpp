#pragma once
// The per-frame-set pipeline, synchronous (the Tracker runs it on its own thread; tests, the
// tool and the benchmark call it directly):
//   images -> blobs (+ static mask) -> rays -> markers -> rigid bodies -> One Euro filter.
// The unsmoothed pose (used to match markers in the next frame set) and the filtered pose
// (published, and extrapolated for the display) are kept apart.
#include <memory>
#include <string>
#include <vector>

#include "kumite/common/wire.hpp"
#include "kumite/tracking/blobs.hpp"
#include "kumite/tracking/calibration_file.hpp"
#include "kumite/tracking/config.hpp"
#include "kumite/tracking/filter.hpp"
#include "kumite/tracking/geometry.hpp"
#include "kumite/tracking/recording.hpp"
#include "kumite/tracking/rigid_body.hpp"

namespace kumite::tracking {

/// Everything one frame set produced.
struct FrameResult {
  std::uint64_t frame = 0;
  Timestamp timestamp = 0;                 ///< s
  std::vector<BodyPose> raw;               ///< per body: unsmoothed measurement
  std::vector<BodyPose> filtered;          ///< per body: One Euro filtered (what is published)
  std::vector<FilteredState> states;       ///< per body: filter state, for predict()
  std::vector<Marker> markers;             ///< triangulated markers
  std::vector<std::vector<Blob>> blobs;    ///< per camera, after the static mask
  std::vector<int> masked;                 ///< per camera: blobs removed by the static mask
  std::vector<std::uint8_t> has_image;    ///< per camera: 1 = it delivered an image for this set
  int cameras_with_images = 0;
  /// Per camera: images of body 0's (the head's) matched markers it gave; 0 when body 0 is
  /// not tracked in this set.
  std::vector<std::int32_t> head_images;
  /// Per camera: body 0 is tracked and its centre projects inside the camera's image, in
  /// front of it (the camera should see its markers).
  std::vector<std::uint8_t> head_in_view;
  double latency_ms = 0;                   ///< processing time of this frame set
};

class Pipeline {
 public:
  /// Throws kumite::Error when the config has no body or too many cameras.
  Pipeline(const RigCalibration& rig, const TrackingConfig& config);
  ~Pipeline();
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  /// Processes one frame set (images in calibration order; images of the wrong size must
  /// have been removed by the caller: they throw). The result is valid until the next call.
  const FrameResult& process(const FrameSet& frames);

  const RigCalibration& rig() const;
  const TrackingConfig& config() const;
  std::size_t body_count() const;
  void reset();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kumite::tracking
