#include "kumite/tracking/tracker.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <condition_variable>
#include <limits>
#include <map>
#include <mutex>
#include <thread>


#include <spdlog/spdlog.h>

#include "kumite/common/error.hpp"
#include "kumite/common/realtime.hpp"
#include "kumite/tracking/packed_image.hpp"
#include "kumite/tracking/pipeline.hpp"

namespace kumite::tracking {


// ---------------------------------------------------------------------------------------
// Recorded source

namespace {

std::chrono::steady_clock::time_point steady_at(Timestamp t) {
  return std::chrono::steady_clock::now() +
         std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(t - kumite::now()));
}

/// Seconds between drop reports on the log.
constexpr double kReportEvery_s = 5.0;
/// s: a worker whose buffers are full wakes this long after the first buffered set is due,
/// not at that moment, so it does not take the lock just as the tracker (higher priority)
/// comes for that set: a low-priority worker preempted while holding the lock delayed
/// hand-overs by 3-8 ms. The buffers hold 50 ms of sets, so the lag costs nothing.
constexpr double kWorkerLag_s = 0.002;

/// Images a recording's cameras could not give (a PNG cut short, the wrong size): the first
/// of each camera is said in full, the rest are counted and said in one line per camera
/// every kReportEvery_s (a camera whose every PNG is truncated would otherwise put 60
/// warnings a second on the log).
class SkippedImages {
 public:
  explicit SkippedImages(std::vector<std::string> cameras)
      : cameras_(std::move(cameras)), count_(cameras_.size(), 0), said_(cameras_.size(), false),
        last_(cameras_.size()) {}

  /// `lines` and `cameras` as Recording::load gives them; what is to be said goes to `out`.
  void add(std::vector<std::string>& lines, const std::vector<std::size_t>& cameras, Timestamp t,
           std::vector<std::string>& out) {
    if (since_ < 0) since_ = t;
    for (std::size_t k = 0; k < lines.size(); ++k) {
      const std::size_t c = k < cameras.size() && cameras[k] < cameras_.size() ? cameras[k] : cameras_.size();
      if (c == cameras_.size()) {  // not a camera's (cannot happen): said as it is
        out.push_back(std::move(lines[k]));
      } else if (!said_[c]) {
        said_[c] = true;
        out.push_back(fmt::format("{} (camera {}: more images it cannot give are counted, a line every {:.0f} s)",
                                  lines[k], cameras_[c], kReportEvery_s));
      } else {
        ++count_[c];
        last_[c] = std::move(lines[k]);
      }
    }
    lines.clear();
  }

  /// The counts, once kReportEvery_s has passed since the last ones (or now if `all`).
  void report(Timestamp t, bool all, std::vector<std::string>& out) {
    if (since_ < 0 || (!all && t - since_ < kReportEvery_s)) return;
    for (std::size_t c = 0; c < cameras_.size(); ++c) {
      if (count_[c] == 0) continue;
      out.push_back(fmt::format("recording: camera {}: {} more images skipped in the last {:.1f} s (the last: {})",
                                cameras_[c], count_[c], t - since_, last_[c]));
      count_[c] = 0;
    }
    since_ = t;
  }

 private:
  std::vector<std::string> cameras_;
  std::vector<std::uint64_t> count_;
  std::vector<bool> said_;
  std::vector<std::string> last_;
  Timestamp since_ = -1;
};

std::vector<std::string> camera_names(const RigCalibration& rig) {
  std::vector<std::string> names;
  for (const auto& c : rig.cameras) names.push_back(c.name);
  return names;
}

/// A preloaded frame set: its images packed losslessly (see packed_image.hpp), so a whole
/// recording fits in memory and a set expands far faster than its PNGs decode. Frame number
/// and times are not kept: stamp() gives every handed-over set its own.
struct PackedSet {
  PackedSet() = default;
  explicit PackedSet(const FrameSet& set) : images(set.images.begin(), set.images.end()) {}
  FrameSet unpack() const {
    FrameSet out;
    out.images.reserve(images.size());
    for (const auto& im : images) out.images.push_back(im.unpack());
    return out;
  }
  std::vector<PackedImage> images;
};

class RecordingSource final : public FrameSource {
 public:
  RecordingSource(const std::filesystem::path& dir, const RigCalibration& rig, RecordingOptions options)
      : recording_(dir, rig), options_(std::move(options)), skipped_images_(camera_names(rig)) {
    for (const auto& w : recording_.warnings()) messages_.push_back(w);
    for (const auto& s : recording_.index().skipped) messages_.push_back(s);
    if (recording_.size() == 0) {
      throw Error("recording", "empty", fmt::format("{}: frames.csv lists no frame sets", dir.string()));
    }
    if (!options_.counters) options_.counters = std::make_shared<RecordingOptions::Counters>();
    if (options_.realtime) start_realtime();
  }
  ~RecordingSource() override {
    close();
    for (auto& w : workers_)
      if (w.joinable()) w.join();
  }

  bool next(FrameSet& out, double timeout_s) override {
    return options_.realtime ? next_realtime(out, timeout_s) : next_offline(out);
  }
  bool end_of_stream() const override {
    std::lock_guard lock(mutex_);
    if (closed_) return true;
    if (!options_.realtime) return !options_.loop && next_ >= recording_.size();
    return !options_.loop && start_ >= 0 && next_decode_ >= playable_ && in_flight_ == 0 && ready_.empty();
  }
  void close() override {
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
    }
    cv_.notify_all();
  }
  std::vector<std::string> take_messages() override {
    std::lock_guard lock(mutex_);
    // At the end of a recording played once, the counts so far; else every few seconds.
    const bool finished = !options_.loop && (options_.realtime ? start_ >= 0 && next_decode_ >= end_seq_ && in_flight_ == 0
                                                               : next_ >= recording_.size());
    skipped_images_.report(kumite::now(), finished || closed_, messages_);
    return std::exchange(messages_, {});
  }

 private:
  // --- as fast as possible: every set, in order, the recording's timestamps -------------
  bool next_offline(FrameSet& out) {
    if (std::lock_guard lock(mutex_); closed_) return false;
    if (next_ >= recording_.size()) {
      if (!options_.loop) return false;
      next_ = 0;
      ++loops_;
    }
    std::vector<std::string> skipped;
    std::vector<std::size_t> skipped_cameras;
    out = recording_.load(next_, &skipped, &skipped_cameras);
    out.frame += loops_ * (recording_.index().rows.back().frame + 1);
    ++next_;
    options_.counters->delivered.fetch_add(1);
    std::lock_guard lock(mutex_);
    skipped_images_.add(skipped, skipped_cameras, kumite::now(), messages_);
    return true;
  }

  // --- real time: a clock, decode workers ahead of it, drops -----------------------------
  void start_realtime() {
    const auto& rows = recording_.index().rows;
    playable_ = options_.preload_sets > 0 ? std::min(options_.preload_sets, rows.size()) : rows.size();
    from_memory_ = options_.preload_sets > 0;
    if (from_memory_ && options_.counters) options_.counters->to_preload.store(playable_);
    rel_.resize(playable_);
    for (std::size_t i = 0; i < playable_; ++i) rel_[i] = rows[i].timestamp - rows[0].timestamp;
    const double interval = playable_ > 1 ? rel_.back() / static_cast<double>(playable_ - 1) : 1.0 / 60;
    period_ = rel_.back() + interval;
    loop_frames_ = rows[playable_ - 1].frame + 1;
    memory_.resize(from_memory_ ? playable_ : 0);
    end_seq_ = options_.loop ? std::numeric_limits<std::uint64_t>::max() : playable_;
    const int threads = std::max(1, options_.decode_threads);
    for (int k = 0; k < threads; ++k) workers_.emplace_back([this] { work(); });
  }

  Timestamp due(std::uint64_t n) const {
    return start_ + rel_[n % playable_] + static_cast<double>(n / playable_) * period_;
  }

  FrameSet load(std::size_t i, std::vector<std::string>& skipped, std::vector<std::size_t>& skipped_cameras) const {
    if (from_memory_) return memory_[i].unpack();
    return recording_.load(i, &skipped, &skipped_cameras);
  }

  /// Before the clock starts: decode the preloaded sets (or only the first one, so the
  /// clock starts when set 0 can be handed over and the decode time is known).
  bool preload() {
    const std::size_t count = from_memory_ ? playable_ : 1;
    for (;;) {
      std::unique_lock lock(mutex_);
      if (closed_) return false;
      if (next_preload_ >= count) {
        cv_.wait(lock, [&] { return closed_ || start_ >= 0; });
        return !closed_;
      }
      const std::size_t i = next_preload_++;
      lock.unlock();
      std::vector<std::string> skipped;
      std::vector<std::size_t> skipped_cameras;
      const Timestamp t0 = kumite::now();
      FrameSet set = recording_.load(i, &skipped, &skipped_cameras);
      const double took = kumite::now() - t0;
      PackedSet packed = from_memory_ ? PackedSet(set) : PackedSet();
      lock.lock();
      skipped_images_.add(skipped, skipped_cameras, kumite::now(), messages_);
      if (from_memory_) memory_[i] = std::move(packed);
      else first_ = std::move(set);
      decode_s_ = decode_s_ <= 0 ? took : 0.8 * decode_s_ + 0.2 * took;
      options_.counters->decode_ms.store(decode_s_ * 1e3);
      if (from_memory_) options_.counters->preloaded.store(++preloaded_);
      if (++preloaded_done_ == count) {
        start_ = kumite::now();  // the clock starts: set 0 is due now
        last_report_ = start_;
        options_.counters->playing.store(true);
        if (!from_memory_) {
          stamp(first_, 0);
          ready_.emplace(0, std::move(first_));
          next_decode_ = 1;
        }
        cv_.notify_all();
      }
    }
  }

  void stamp(FrameSet& set, std::uint64_t n) const {
    const Timestamp t = due(n);
    set.timestamp = t;
    set.camera_times.assign(set.images.size(), t);
    set.frame = recording_.index().rows[n % playable_].frame + (n / playable_) * loop_frames_;
  }

  void work() {
    (void)lower_this_thread_priority(options_.decode_nice);
    if (!preload()) return;
    const std::size_t buffers = static_cast<std::size_t>(std::max(1, options_.buffered_sets));
    for (;;) {
      std::unique_lock lock(mutex_);
      // Like a camera, decoding goes on whether or not the tracker takes the sets: it waits
      // only while `buffers` sets lie ready for a later time (one that comes due frees one).
      for (;;) {
        if (closed_ || next_decode_ >= end_seq_) return;
        const Timestamp t = kumite::now();
        auto first_future = std::find_if(ready_.begin(), ready_.end(), [&](const auto& r) { return due(r.first) > t; });
        const auto future = static_cast<std::size_t>(std::distance(first_future, ready_.end()));
        if (future + in_flight_ < buffers) break;
        if (first_future == ready_.end()) cv_.wait(lock);
        else cv_.wait_until(lock, steady_at(due(first_future->first) + kWorkerLag_s));
      }
      // Skip what cannot be decoded before it is due (from memory: what a newer due set
      // already replaces).
      const Timestamp t = kumite::now();
      std::uint64_t n = next_decode_;
      if (from_memory_) {
        while (n + 1 < end_seq_ && due(n + 1) <= t) ++n;
      } else {
        const double lead = 1.25 * decode_s_ + 0.002;
        while (n < end_seq_ && due(n) < t + lead) ++n;
      }
      options_.counters->not_decoded.fetch_add(n - next_decode_);
      if (n >= end_seq_) {
        next_decode_ = n;
        cv_.notify_all();
        return;
      }
      next_decode_ = n + 1;
      ++in_flight_;
      lock.unlock();
      std::vector<std::string> skipped;
      std::vector<std::size_t> skipped_cameras;
      const Timestamp t0 = kumite::now();
      FrameSet set = load(static_cast<std::size_t>(n % playable_), skipped, skipped_cameras);
      const double took = kumite::now() - t0;
      lock.lock();
      --in_flight_;
      if (!from_memory_) {
        decode_s_ = 0.8 * decode_s_ + 0.2 * took;
        options_.counters->decode_ms.store(decode_s_ * 1e3);
      }
      skipped_images_.add(skipped, skipped_cameras, kumite::now(), messages_);
      if (handed_any_ && n <= last_handed_) {  // another worker's newer set went first
        options_.counters->dropped_stale.fetch_add(1);
        continue;
      }
      stamp(set, n);
      ready_.emplace(n, std::move(set));
      drop_stale(kumite::now());
      lock.unlock();  // the tracker, woken, must not find the lock held by a low-priority worker
      cv_.notify_all();
    }
  }

  /// Sets older than the newest due one will never be handed over: dropped (the tracker is
  /// behind). Returns the newest due one, or ready_.end().
  std::map<std::uint64_t, FrameSet>::iterator drop_stale(Timestamp t) {
    auto pick = ready_.end();
    for (auto it = ready_.begin(); it != ready_.end() && due(it->first) <= t; ++it) pick = it;
    if (pick == ready_.end()) return pick;
    options_.counters->dropped_stale.fetch_add(static_cast<std::uint64_t>(std::distance(ready_.begin(), pick)));
    ready_.erase(ready_.begin(), pick);
    return ready_.begin();
  }

  bool next_realtime(FrameSet& out, double timeout_s) {
    std::unique_lock lock(mutex_);
    const Timestamp deadline = kumite::now() + std::max(0.0, timeout_s);
    for (;;) {
      if (closed_) return false;
      const Timestamp t = kumite::now();
      if (const auto pick = drop_stale(t); pick != ready_.end()) {
        auto& c = *options_.counters;
        const std::uint64_t n = pick->first;
        out = std::move(pick->second);
        ready_.erase(pick);
        last_handed_ = n;
        handed_any_ = true;
        const double late_ms = (t - due(n)) * 1e3;
        if (late_ms > c.max_handover_late_ms.load()) c.max_handover_late_ms.store(late_ms);
        c.delivered.fetch_add(1);
        report(t);
        lock.unlock();
        cv_.notify_all();
        return true;
      }
      if (ready_.empty() && next_decode_ >= end_seq_ && in_flight_ == 0 && start_ >= 0) return false;
      if (t >= deadline) return false;
      const Timestamp wake = ready_.empty() ? deadline : std::min(deadline, due(ready_.begin()->first));
      cv_.wait_until(lock, steady_at(wake));
    }
  }

  /// Every few seconds, a line on the log when sets were skipped or dropped.
  void report(Timestamp t) {
    if (t - last_report_ < kReportEvery_s) return;
    const auto& c = *options_.counters;
    const std::uint64_t delivered = c.delivered.load(), skipped = c.not_decoded.load(), stale = c.dropped_stale.load();
    const std::uint64_t d = delivered - reported_[0], k = skipped - reported_[1], s = stale - reported_[2];
    if (k + s > 0) {
      const std::string how = from_memory_ ? std::string("played from memory")
                                           : fmt::format("decoding takes {:.0f} ms per set on {} thread(s)",
                                                         decode_s_ * 1e3, std::max(1, options_.decode_threads));
      messages_.push_back(fmt::format("recording: in the last {:.1f} s {} frame sets handed over, {} skipped ({}), {} "
                                      "dropped (the tracker was behind)",
                                      t - last_report_, d, k, how, s));
    }
    reported_ = {delivered, skipped, stale};
    last_report_ = t;
  }

  Recording recording_;
  RecordingOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  bool closed_ = false;
  std::vector<std::string> messages_;
  SkippedImages skipped_images_;  // under mutex_
  // as fast as possible
  std::size_t next_ = 0;
  std::uint64_t loops_ = 0;
  // real time (under mutex_ unless noted)
  std::size_t playable_ = 0;        // sets played per loop (set before the workers start)
  bool from_memory_ = false;        // preload_sets > 0
  std::vector<Timestamp> rel_;      // s, set i's time after set 0
  double period_ = 0;               // s, one loop
  std::uint64_t loop_frames_ = 0;   // frame numbers per loop
  std::uint64_t end_seq_ = 0;       // sequence numbers run 0 .. end_seq_ - 1
  Timestamp start_ = -1;            // the clock's start (-1: not yet)
  std::vector<PackedSet> memory_;   // preloaded sets, packed (a few kB per image)
  FrameSet first_;                  // streaming: set 0, decoded before the clock starts
  std::size_t next_preload_ = 0, preloaded_done_ = 0;
  std::uint64_t preloaded_ = 0;
  std::uint64_t next_decode_ = 0;   // next sequence number a worker may take
  std::size_t in_flight_ = 0;
  std::uint64_t last_handed_ = 0;   // sequence number of the last set handed over
  bool handed_any_ = false;
  double decode_s_ = 0;             // s per set, smoothed
  std::map<std::uint64_t, FrameSet> ready_;  // decoded, waiting for their due time
  Timestamp last_report_ = 0;
  std::array<std::uint64_t, 3> reported_{0, 0, 0};
  std::vector<std::thread> workers_;
};

}  // namespace

std::unique_ptr<FrameSource> open_recording_source(const std::filesystem::path& dir, const RigCalibration& rig,
                                                   const TrackingConfig& /*config*/, RecordingOptions options) {
  return std::make_unique<RecordingSource>(dir, rig, std::move(options));
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

namespace {
/// SCHED_FIFO for the calling thread; one log line either way.
void use_realtime_priority(int priority) {
  if (priority <= 0) return;
  if (const std::string why = run_this_thread_realtime(priority); !why.empty()) {
    spdlog::warn("tracker: cannot run at real-time priority {} ({}); running at normal priority "
                 "(grant CAP_SYS_NICE or an rtprio limit to the installation's user)",
                 priority, why);
  } else {
    spdlog::info("tracker: thread runs at real-time priority {} (SCHED_FIFO)", priority);
  }
}
}  // namespace

namespace {
/// Per camera: how long it has seen none of the head's markers while it should have (the
/// head tracked by >= 2 other cameras, its centre inside this camera's image). Frame sets
/// where that does not hold (head lost, out of its view, no image) neither count nor reset.
class BlindWatch {
 public:
  BlindWatch(std::size_t cameras, double after_s, std::size_t head_body)
      : since_(cameras, -1), count_(cameras, 0), last_(cameras, -1), after_s_(after_s), head_(head_body) {}
  void update(const FrameResult& r) {
    const bool head = r.raw.size() > head_ && r.raw[head_].status == TrackingStatus::tracked;
    for (std::size_t c = 0; c < since_.size() && c < r.has_image.size(); ++c) {
      if (!r.has_image[c]) continue;
      if (r.head_images[c] > 0) {
        since_[c] = -1, count_[c] = 0;
      } else if (head && r.head_in_view[c] && r.raw[head_].cameras >= 2) {
        if (since_[c] < 0) since_[c] = r.timestamp;
        ++count_[c];
        last_[c] = r.timestamp;
      }
    }
  }
  /// s from the first frame set it missed the head to the last (0 while it sees it).
  double unseen_s(std::size_t c) const { return since_[c] < 0 ? 0.0 : last_[c] - since_[c]; }
  /// Blind: unseen for after_s, over at least kMinSets frame sets (not one odd frame).
  bool blind(std::size_t c) const { return since_[c] >= 0 && count_[c] >= kMinSets && unseen_s(c) >= after_s_; }

 private:
  static constexpr int kMinSets = 10;
  std::vector<Timestamp> since_;
  std::vector<int> count_;
  std::vector<Timestamp> last_;
  double after_s_;
  std::size_t head_ = 0;  // the glasses' body
};
}  // namespace

std::string describe(const CameraStatus& s) {
  switch (s.state) {
    case CameraState::ok: return "";
    case CameraState::blind: return fmt::format("{} ({:.1f} s)", to_string(s.state), s.blind_s);
    case CameraState::no_frames:
      if (s.last_frame < 0) return "no frames (never a frame)";
      return fmt::format("no frames ({:.1f} s since the last frame)", s.since_last_s);
    case CameraState::reconnecting: return "reconnecting";
  }
  return "?";
}

/// What the loop carries from one frame set to the next (the thread's, or process()'s caller's).
struct Tracker::Progress {
  Progress(std::size_t cameras, double blind_after_s, std::size_t head_body)
      : last_frame(cameras, -1), blind(cameras, blind_after_s, head_body) {}
  std::vector<Timestamp> last_frame;
  BlindWatch blind;
  bool first = true;
};

void Tracker::handle(const FrameSet& frames, Timestamp ready_override) {
  if (!progress_)
    progress_ = std::make_unique<Progress>(rig_.cameras.size(), config_.camera_blind_s,
                                           static_cast<std::size_t>(config_.head_body()));
  Progress& pr = *progress_;
  if (frame_set_hook_) frame_set_hook_(frames);
  if (pr.first) {
    // A recording played as fast as possible runs on its own clock, far from now().
    clock_is_source_.store(ready_override >= 0 || std::abs(frames.timestamp - kumite::now()) > 60.0,
                           std::memory_order_release);
    pr.first = false;
  }
  const Timestamp started = kumite::now();
  const FrameResult& r = pipeline_->process(frames);
  // On a recording's own clock (played as fast as possible) the set is handed over at
  // once: its latency is the processing time. process(): as the caller says.
  const Timestamp ready = ready_override >= 0 ? ready_override
                          : clock_is_source_.load(std::memory_order_acquire)
                              ? frames.timestamp + (kumite::now() - started)
                              : kumite::now();
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
    s.pose.ready_at = ready;
    snapshots_[b]->value.publish(s);
    poses_[b]->publish(s.pose);
  }
  pr.blind.update(r);
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    const bool has = c < frames.images.size() && !frames.images[c].empty();
    if (has) pr.last_frame[c] = c < frames.camera_times.size() ? frames.camera_times[c] : frames.timestamp;
    CameraStatus st;
    st.last_frame = pr.last_frame[c];
    st.blobs = has ? static_cast<std::int32_t>(r.blobs[c].size()) : 0;
    st.masked = has ? r.masked[c] : 0;
    st.blind_s = pr.blind.unseen_s(c);
    st.state = source_ && source_->reconnecting(c) ? CameraState::reconnecting
               : pr.blind.blind(c)                 ? CameraState::blind
                                                   : CameraState::ok;
    cameras_[c]->value.publish(st);
  }
  last_source_time_.store(frames.timestamp, std::memory_order_release);
  processed_.fetch_add(1, std::memory_order_acq_rel);
  if (hook_) hook_(r);
}

void Tracker::process(const FrameSet& frames) {
  if (thread_.joinable()) throw Error("tracking", "state", "Tracker::process while its thread runs");
  handle(frames, frames.timestamp);
}

void Tracker::run() {
  use_realtime_priority(realtime_priority_);
  progress_.reset();
  try {
    while (!stop_.load()) {
      FrameSet frames;
      const bool got = source_->next(frames, 0.1);
      for (const auto& m : source_->take_messages()) spdlog::warn("{}", m);
      if (!got) {
        if (source_->end_of_stream()) break;
        continue;
      }
      handle(frames, -1);
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
  const BodyConfig& bc = config_.bodies[static_cast<std::size_t>(body)];
  if (!snap->valid || t - snap->last_measured > bc.coasting_or(config_.coasting_s)) {
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
  kumite::tracking::predict(st, t, bc.filter_or(config_.filter).max_prediction_s, p, q);
  out.position = {p.x(), p.y(), p.z()};
  out.orientation = {q.w(), q.x(), q.y(), q.z()};
  out.timestamp = t;
  return out;
}

std::vector<CameraStatus> Tracker::camera_status(std::optional<Timestamp> now_s) const {
  const Timestamp now = now_s.value_or(clock_now());
  std::vector<CameraStatus> out;
  out.reserve(cameras_.size());
  for (std::size_t i = 0; i < cameras_.size(); ++i) out.push_back(camera_status(i, now));
  return out;
}

CameraStatus Tracker::camera_status(std::size_t camera, Timestamp now) const {
  CameraStatus st = cameras_.at(camera)->value.read().value_or(CameraStatus{});
  if (st.last_frame >= 0) {
    st.since_last_s = std::max(0.0, now - st.last_frame);
    if (st.state != CameraState::reconnecting && st.since_last_s > config_.camera_timeout_s) {
      st.state = CameraState::no_frames;
    }
  } else if (st.state == CameraState::ok) {
    st.state = CameraState::no_frames;
  }
  return st;
}

}  // namespace kumite::tracking
