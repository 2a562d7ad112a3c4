// The tracker (kumite::tracking::Tracker) behind TrackingInput: its own thread reads the
// recording (paced in real time and rebased onto kumite::now()) or the live cameras; poll()
// reads the newest filtered head pose and predicts it to the display time, never waiting.
#include "kumite/app/tracking_input.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "kumite/common/error.hpp"
#include "kumite/tracking/tracker.hpp"

namespace kumite::app {

namespace {

class TrackerInput final : public TrackingInput {
 public:
  TrackerInput(const InstallationConfig& c, tracking::RigCalibration rig,
               tracking::TrackingConfig tc, std::unique_ptr<tracking::FrameSource> source)
      : tracker_(rig, tc), head_(c.tracking.head_body), source_(c.tracking.source) {
    for (const auto& cam : rig.cameras) names_.push_back(cam.name);
    if (head_ >= static_cast<int>(tracker_.body_count()))
      throw file_error("config", "range", c.file.string(), c.line_of("tracking.head_body"),
                       "tracking.head_body",
                       fmt::format("body {} does not exist ({} bodies in {})", head_,
                                   tracker_.body_count(), c.resolve(c.tracking.tracking).string()));
    if (source) {
      tracker_.start(std::move(source));
      what_ = "frame source given by the caller";
    } else if (source_ == TrackingSource::recording) {
      // Looping keeps a long demo tracked; the recording's clock is rebased onto now().
      tracker_.start(tracking::open_recording_source(c.resolve(c.tracking.recording), rig, tc,
                                                     {.realtime = true, .loop = true}));
      what_ = "recording " + c.resolve(c.tracking.recording).string();
    } else {
      tracker_.start(tracking::open_live_source(rig, tc));
      what_ = "live cameras";
    }
  }
  ~TrackerInput() override { tracker_.stop(); }

  TrackingSnapshot poll(Timestamp display_time) override {
    TrackingSnapshot s;
    const auto latest = tracker_.latest(head_);
    if (latest) {
      s.head = tracker_.predict(head_, display_time);
      s.measured_at = latest->timestamp;
      s.status = std::string(to_string(s.head->status));
    } else {
      s.status = tracker_.running() ? "waiting for the first frame set" : "tracker stopped";
    }
    s.status += fmt::format(", {} frame sets", tracker_.frames_processed());
    if (!tracker_.running()) s.status += " (tracker stopped)";
    const auto cams = tracker_.camera_status(display_time);
    for (std::size_t i = 0; i < cams.size(); ++i) {
      CameraView v;
      v.name = i < names_.size() ? names_[i] : fmt::format("cam{}", i);
      v.status = std::string(tracking::to_string(cams[i].state));
      v.blobs = cams[i].blobs;
      v.since_last_ms = cams[i].since_last_s >= 0 ? cams[i].since_last_s * 1e3 : -1;
      s.cameras.push_back(v);
    }
    return s;
  }
  Timestamp clock() const override { return now(); }
  std::string describe() const override { return what_; }

 private:
  tracking::Tracker tracker_;
  int head_;
  TrackingSource source_;
  std::vector<std::string> names_;
  std::string what_;
};

}  // namespace

std::unique_ptr<TrackingInput> make_tracking_input(const InstallationConfig& config) {
  if (config.tracking.source == TrackingSource::none)
    return make_fixed_head_input("tracking.source = \"none\"");
  auto rig = tracking::read_calibration(config.resolve(config.tracking.calibration));
  auto tc = tracking::read_tracking_config(config.resolve(config.tracking.tracking));
  return std::make_unique<TrackerInput>(config, std::move(rig), std::move(tc), nullptr);
}

std::unique_ptr<TrackingInput> make_tracking_input(const InstallationConfig& config,
                                                   std::unique_ptr<tracking::FrameSource> source) {
  auto rig = tracking::read_calibration(config.resolve(config.tracking.calibration));
  auto tc = tracking::read_tracking_config(config.resolve(config.tracking.tracking));
  return std::make_unique<TrackerInput>(config, std::move(rig), std::move(tc), std::move(source));
}

}  // namespace kumite::app
