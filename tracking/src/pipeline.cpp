#include "kumite/tracking/pipeline.hpp"

#include <algorithm>
#include <chrono>

#include <fmt/format.h>

#include "kumite/common/error.hpp"

namespace kumite::tracking {

namespace {

/// What the pipeline remembers of one body between frame sets.
struct BodyTrack {
  std::optional<RigidPose> last;      // unsmoothed pose of the last measurement
  Timestamp last_time = -1;           // s
  Eigen::Vector3d velocity{0, 0, 0};  // m/s, from the last two unsmoothed poses
  bool has_velocity = false;
  BodyPose last_filtered;
  PoseFilter filter;
  explicit BodyTrack(const FilterConfig& f) : filter(f) {}
};

BodyPose to_pose(const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  BodyPose out;
  out.position = {p.x(), p.y(), p.z()};
  out.orientation = {q.w(), q.x(), q.y(), q.z()};
  return out;
}

}  // namespace

struct Pipeline::Impl {
  RigCalibration rig;
  TrackingConfig config;
  std::vector<CameraModel> cameras;
  std::vector<BlobDetector> detectors;
  std::vector<StaticMask> masks;
  std::vector<RigidBodyModel> bodies;
  std::vector<BodyTrack> tracks;
  std::size_t head = 0;  // the glasses (the body named head): blind-camera watch
  std::vector<std::vector<Observation>> observations;
  std::unique_ptr<Triangulator> triangulator;
  std::vector<std::uint8_t> taken;
  std::vector<std::vector<std::uint8_t>> used;
  FrameResult result;

  Impl(const RigCalibration& r, const TrackingConfig& c) : rig(r), config(c) {
    if (config.bodies.empty()) throw Error("config", "bodies", "tracking config: no [[bodies]] to track");
    if (rig.cameras.empty()) throw Error("calibration", "cameras", "calibration: no cameras");
    if (rig.cameras.size() > static_cast<std::size_t>(kMaxCameras)) {
      throw Error("calibration", "cameras", fmt::format("calibration: {} cameras, at most {} supported",
                                                        rig.cameras.size(), kMaxCameras));
    }
    for (const auto& cam : rig.cameras) {
      cameras.emplace_back(cam);
      detectors.emplace_back(config.blobs);
      masks.emplace_back(config.mask);
    }
    for (const auto& b : config.bodies) {
      bodies.emplace_back(b);
      tracks.emplace_back(b.filter_or(config.filter));
    }
    head = static_cast<std::size_t>(config.head_body());
    observations.resize(cameras.size());
    used.resize(cameras.size());
    triangulator = std::make_unique<Triangulator>(std::span<const CameraModel>(cameras), config.match);
    result.blobs.resize(cameras.size());
    result.masked.resize(cameras.size());
    result.has_image.resize(cameras.size());
    result.head_images.resize(cameras.size());
    result.head_in_view.resize(cameras.size());
  }

  void detect(const FrameSet& frames) {
    result.cameras_with_images = 0;
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      result.blobs[c].clear();
      result.masked[c] = 0;
      observations[c].clear();
      result.has_image[c] = 0;
      if (c >= frames.images.size() || frames.images[c].empty()) continue;
      const cv::Mat& img = frames.images[c];
      const auto& cal = rig.cameras[c];
      if (img.cols != cal.image_width || img.rows != cal.image_height) {
        throw Error("tracking", "image_size", fmt::format("camera {}: {}x{} image, calibrated for {}x{}", cal.name,
                                                          img.cols, img.rows, cal.image_width, cal.image_height));
      }
      ++result.cameras_with_images;
      result.has_image[c] = 1;
      result.blobs[c] = detectors[c].detect(img);
      if (config.static_mask) result.masked[c] = masks[c].apply(result.blobs[c]);
      cameras[c].observe(result.blobs[c], observations[c]);
    }
  }

  /// head_images / head_in_view for a tracked body 0.
  void note_head(const BodyFit& fit, const Eigen::Vector3d& centre) {
    for (int i : fit.marker_of) {
      if (i < 0) continue;
      for (std::size_t c = 0; c < cameras.size(); ++c) {
        if (result.markers[i].blob[c] >= 0) ++result.head_images[c];
      }
    }
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      Eigen::Vector2d px;
      const auto& cal = rig.cameras[c];
      result.head_in_view[c] = cameras[c].project(centre, px) && px.x() >= 0 && px.y() >= 0 &&
                               px.x() < cal.image_width && px.y() < cal.image_height;
    }
  }

  void track_body(std::size_t b, const FrameSet& frames) {
    BodyTrack& tr = tracks[b];
    const RigidBodyModel& model = bodies[b];
    const Timestamp t = frames.timestamp;
    const double age = tr.last_time < 0 ? 1e9 : t - tr.last_time;
    const double coasting_s = config.bodies[b].coasting_or(config.coasting_s);
    std::optional<RigidPose> predicted;
    if (tr.last && age <= coasting_s) {
      predicted = tr.last;
      if (tr.has_velocity && age > 0) predicted->translation += tr.velocity * age;
    }
    auto fit = model.fit(result.markers, predicted, taken);
    if (fit && fit->full) model.refine(result.markers, cameras, observations, *fit);
    BodyPose raw, filtered;
    if (fit) {
      for (int i : fit->marker_of) {
        if (i < 0) continue;
        taken[i] = 1;
        for (std::size_t c = 0; c < cameras.size(); ++c) {
          if (result.markers[i].blob[c] >= 0) used[c][result.markers[i].blob[c]] = 1;
        }
      }
      if (tr.last && age > 0 && age <= coasting_s) {
        tr.velocity = (fit->pose.translation - tr.last->translation) / age;
        tr.has_velocity = true;
      } else {
        tr.has_velocity = false;
      }
      tr.last = fit->pose;
      tr.last_time = t;
      const Eigen::Vector3d centre = fit->pose.apply(model.centroid());
      if (b == head) note_head(*fit, centre);
      raw = to_pose(centre, fit->pose.rotation);
      raw.status = TrackingStatus::tracked;
      raw.markers = fit->matched;
      raw.cameras = fit->cameras;
      const FilteredState& s = tr.filter.update(t, centre, fit->pose.rotation);
      filtered = to_pose(s.position, s.orientation);
      filtered.status = TrackingStatus::tracked;
      filtered.markers = raw.markers;
      filtered.cameras = raw.cameras;
    } else if (tr.last && age <= coasting_s) {
      // Coasting: hold the last unsmoothed pose for matching; publish the filtered one.
      raw = to_pose(tr.last->apply(model.centroid()), tr.last->rotation);
      raw.status = TrackingStatus::coasting;
      filtered = tr.last_filtered;
      filtered.status = TrackingStatus::coasting;
      filtered.markers = 0;
      filtered.cameras = 0;
    } else {
      if (tr.last) {
        tr.last.reset();
        tr.filter.reset();
        tr.has_velocity = false;
      }
      raw.status = filtered.status = TrackingStatus::lost;
      filtered.position = tr.last_filtered.position;  // where it was last seen
      filtered.orientation = tr.last_filtered.orientation;
    }
    for (BodyPose* p : {&raw, &filtered}) {
      p->timestamp = t;
      p->frame = frames.frame;
      p->body = static_cast<std::int32_t>(b);
    }
    if (raw.status == TrackingStatus::tracked) tr.last_filtered = filtered;
    result.raw[b] = raw;
    result.filtered[b] = filtered;
    result.states[b] = tr.filter.state();
  }
};

Pipeline::Pipeline(const RigCalibration& rig, const TrackingConfig& config)
    : impl_(std::make_unique<Impl>(rig, config)) {}
Pipeline::~Pipeline() = default;

const RigCalibration& Pipeline::rig() const { return impl_->rig; }
const TrackingConfig& Pipeline::config() const { return impl_->config; }
std::size_t Pipeline::body_count() const { return impl_->bodies.size(); }

void Pipeline::reset() {
  for (std::size_t b = 0; b < impl_->tracks.size(); ++b)
    impl_->tracks[b] = BodyTrack(impl_->config.bodies[b].filter_or(impl_->config.filter));
  for (auto& m : impl_->masks) m.clear();
}

const FrameResult& Pipeline::process(const FrameSet& frames) {
  const auto t0 = std::chrono::steady_clock::now();
  Impl& m = *impl_;
  FrameResult& r = m.result;
  r.frame = frames.frame;
  r.timestamp = frames.timestamp;
  m.detect(frames);
  r.markers = m.triangulator->run(m.observations);
  m.taken.assign(r.markers.size(), 0);
  for (std::size_t c = 0; c < m.cameras.size(); ++c) m.used[c].assign(r.blobs[c].size(), 0);
  std::fill(r.head_images.begin(), r.head_images.end(), 0);
  std::fill(r.head_in_view.begin(), r.head_in_view.end(), 0);
  r.raw.resize(m.bodies.size());
  r.filtered.resize(m.bodies.size());
  r.states.resize(m.bodies.size());
  for (std::size_t b = 0; b < m.bodies.size(); ++b) m.track_body(b, frames);
  if (m.config.static_mask) {
    for (std::size_t c = 0; c < m.cameras.size(); ++c) {
      if (c < frames.images.size() && !frames.images[c].empty()) m.masks[c].update(r.blobs[c], m.used[c], frames.timestamp);
    }
  }
  r.latency_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace kumite::tracking
