#include "kumite/tracking/tracker.hpp"

#include <chrono>
#include <thread>

#include <spdlog/spdlog.h>

#include "kumite/common/error.hpp"
#include "kumite/tracking/pipeline.hpp"

namespace kumite::tracking {

std::string_view to_string(CameraState s) {
  switch (s) {
    case CameraState::ok: return "ok";
    case CameraState::no_frames: return "no frames";
    case CameraState::reconnecting: return "reconnecting";
  }
  return "?";
}

// ---------------------------------------------------------------------------------------
// Recorded source

namespace {

class RecordingSource final : public FrameSource {
 public:
  RecordingSource(const std::filesystem::path& dir, const RigCalibration& rig, RecordingOptions options)
      : recording_(dir, rig), options_(options) {
    for (const auto& w : recording_.warnings()) messages_.push_back(w);
    for (const auto& s : recording_.index().skipped) messages_.push_back(s);
    if (recording_.size() == 0) {
      throw Error("recording", "empty", fmt::format("{}: frames.csv lists no frame sets", dir.string()));
    }
  }

  bool next(FrameSet& out, double /*timeout_s*/) override {
    if (closed_.load()) return false;
    if (next_ >= recording_.size()) {
      if (!options_.loop) return false;
      next_ = 0;
      ++loops_;
      start_wall_ = -1;
    }
    out = recording_.load(next_, &messages_);
    const Timestamp rec_t = out.timestamp;
    if (options_.realtime) {
      if (start_wall_ < 0) {
        start_wall_ = kumite::now();
        start_rec_ = rec_t;
      }
      const Timestamp due = start_wall_ + (rec_t - start_rec_);
      while (!closed_.load()) {
        const double wait = due - kumite::now();
        if (wait <= 0) break;
        std::this_thread::sleep_for(std::chrono::duration<double>(std::min(wait, 0.05)));
      }
      out.timestamp = due;  // rebased onto the steady clock
      for (auto& t : out.camera_times) t = due;
    }
    out.frame += loops_ * (recording_.index().rows.back().frame + 1);
    ++next_;
    return true;
  }
  bool end_of_stream() const override { return closed_.load() || (!options_.loop && next_ >= recording_.size()); }
  void close() override { closed_.store(true); }
  std::vector<std::string> take_messages() override { return std::exchange(messages_, {}); }

 private:
  Recording recording_;
  RecordingOptions options_;
  std::size_t next_ = 0;
  std::uint64_t loops_ = 0;
  Timestamp start_wall_ = -1, start_rec_ = 0;
  std::atomic<bool> closed_{false};
  std::vector<std::string> messages_;
};

}  // namespace

std::unique_ptr<FrameSource> open_recording_source(const std::filesystem::path& dir, const RigCalibration& rig,
                                                   const TrackingConfig& /*config*/, RecordingOptions options) {
  return std::make_unique<RecordingSource>(dir, rig, options);
}

// ---------------------------------------------------------------------------------------
// Tracker

struct Tracker::Snapshot {
  BodyPose pose;  // the published pose, so predict() reads one consistent slot
  Timestamp timestamp = 0;
  Timestamp last_measured = -1;
  double p[3] = {0, 0, 0}, v[3] = {0, 0, 0}, q[4] = {1, 0, 0, 0}, w[3] = {0, 0, 0};
  bool valid = false;
};
struct Tracker::SnapshotSlot {
  LatestValue<Snapshot> value;
};
struct Tracker::CameraSlot {
  LatestValue<CameraStatus> value;
};

Tracker::Tracker(RigCalibration rig, TrackingConfig config)
    : rig_(std::move(rig)), config_(std::move(config)), pipeline_(std::make_unique<Pipeline>(rig_, config_)) {
  for (std::size_t b = 0; b < config_.bodies.size(); ++b) {
    poses_.push_back(std::make_unique<LatestValue<BodyPose>>());
    snapshots_.push_back(std::make_unique<SnapshotSlot>());
  }
  for (std::size_t c = 0; c < rig_.cameras.size(); ++c) cameras_.push_back(std::make_unique<CameraSlot>());
}

Tracker::~Tracker() { stop(); }

std::size_t Tracker::body_count() const { return config_.bodies.size(); }
int Tracker::find_body(std::string_view name) const { return config_.find_body(name); }

void Tracker::start(std::unique_ptr<FrameSource> source) {
  stop();
  source_ = std::move(source);
  pipeline_->reset();
  stop_.store(false);
  running_.store(true, std::memory_order_release);
  thread_ = std::thread([this] { run(); });
}

void Tracker::stop() {
  stop_.store(true);
  if (source_) source_->close();
  if (thread_.joinable()) thread_.join();
  running_.store(false, std::memory_order_release);
}

Timestamp Tracker::clock_now() const {
  if (clock_is_source_.load(std::memory_order_acquire)) return last_source_time_.load(std::memory_order_acquire);
  return kumite::now();
}

void Tracker::run() {
  std::vector<Timestamp> last_frame(rig_.cameras.size(), -1);
  bool first = true;
  try {
    while (!stop_.load()) {
      FrameSet frames;
      const bool got = source_->next(frames, 0.1);
      for (const auto& m : source_->take_messages()) spdlog::warn("{}", m);
      if (!got) {
        if (source_->end_of_stream()) break;
        continue;
      }
      if (first) {
        // A recording played as fast as possible runs on its own clock, far from now().
        clock_is_source_.store(std::abs(frames.timestamp - kumite::now()) > 60.0, std::memory_order_release);
        first = false;
      }
      const FrameResult& r = pipeline_->process(frames);
      for (std::size_t b = 0; b < r.filtered.size(); ++b) {
        Snapshot s;
        const FilteredState& st = r.states[b];
        s.timestamp = r.filtered[b].timestamp;
        s.last_measured = st.valid ? st.timestamp : -1;
        for (int k = 0; k < 3; ++k) {
          s.p[k] = st.position[k];
          s.v[k] = st.velocity[k];
          s.w[k] = st.angular_velocity[k];
        }
        s.q[0] = st.orientation.w(), s.q[1] = st.orientation.x(), s.q[2] = st.orientation.y(),
        s.q[3] = st.orientation.z();
        s.valid = st.valid && r.filtered[b].status != TrackingStatus::lost;
        s.pose = r.filtered[b];
        snapshots_[b]->value.publish(s);
        poses_[b]->publish(r.filtered[b]);
      }
      for (std::size_t c = 0; c < cameras_.size(); ++c) {
        const bool has = c < frames.images.size() && !frames.images[c].empty();
        if (has) last_frame[c] = c < frames.camera_times.size() ? frames.camera_times[c] : frames.timestamp;
        CameraStatus st;
        st.last_frame = last_frame[c];
        st.blobs = has ? static_cast<std::int32_t>(r.blobs[c].size()) : 0;
        st.masked = has ? r.masked[c] : 0;
        st.state = source_->reconnecting(c) ? CameraState::reconnecting : CameraState::ok;
        cameras_[c]->value.publish(st);
      }
      last_source_time_.store(frames.timestamp, std::memory_order_release);
      processed_.fetch_add(1, std::memory_order_acq_rel);
      if (hook_) hook_(r);
    }
  } catch (const std::exception& e) {
    spdlog::error("tracker stopped: {}", e.what());
  }
  running_.store(false, std::memory_order_release);
}

std::optional<BodyPose> Tracker::latest(int body) const { return slot(body).read(); }

const LatestValue<BodyPose>& Tracker::slot(int body) const {
  if (body < 0 || static_cast<std::size_t>(body) >= poses_.size()) {
    throw Error("tracking", "body", fmt::format("no body {} (the config has {})", body, poses_.size()));
  }
  return *poses_[body];
}

BodyPose Tracker::predict(int body, Timestamp t) const {
  (void)slot(body);  // checks the index
  const auto snap = snapshots_[body]->value.read();
  if (!snap) {
    BodyPose lost;
    lost.body = body;
    return lost;
  }
  BodyPose out = snap->pose;
  if (!snap->valid || t - snap->last_measured > config_.coasting_s) {
    if (out.status != TrackingStatus::lost) out.status = TrackingStatus::lost;
    return out;
  }
  FilteredState st;
  st.timestamp = snap->last_measured;
  st.position = {snap->p[0], snap->p[1], snap->p[2]};
  st.velocity = {snap->v[0], snap->v[1], snap->v[2]};
  st.orientation = Eigen::Quaterniond(snap->q[0], snap->q[1], snap->q[2], snap->q[3]);
  st.angular_velocity = {snap->w[0], snap->w[1], snap->w[2]};
  st.valid = true;
  Eigen::Vector3d p;
  Eigen::Quaterniond q;
  kumite::tracking::predict(st, t, config_.filter.max_prediction_s, p, q);
  out.position = {p.x(), p.y(), p.z()};
  out.orientation = {q.w(), q.x(), q.y(), q.z()};
  out.timestamp = t;
  return out;
}

std::vector<CameraStatus> Tracker::camera_status(std::optional<Timestamp> now_s) const {
  const Timestamp now = now_s.value_or(clock_now());
  std::vector<CameraStatus> out;
  out.reserve(cameras_.size());
  for (const auto& slot : cameras_) {
    CameraStatus st = slot->value.read().value_or(CameraStatus{});
    if (st.last_frame >= 0) {
      st.since_last_s = std::max(0.0, now - st.last_frame);
      if (st.state == CameraState::ok && st.since_last_s > config_.camera_timeout_s) st.state = CameraState::no_frames;
    } else if (st.state == CameraState::ok) {
      st.state = CameraState::no_frames;
    }
    out.push_back(st);
  }
  return out;
}

}  // namespace kumite::tracking
