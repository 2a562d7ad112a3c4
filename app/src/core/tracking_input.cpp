// The tracker (kumite::tracking::Tracker) behind TrackingInput: its own thread reads the
// recording (played on a real-time clock like cameras: decoded ahead by workers, each frame
// set handed over at its due time and stamped with it, sets that cannot be decoded in time
// skipped) or the live cameras; poll() reads the newest filtered head pose and predicts it to
// the display time, never waiting.
#include "kumite/app/tracking_input.hpp"

#include "kumite/app/frame_pacer.hpp"
#include "kumite/app/session.hpp"

#include <mutex>

#include <array>
#include <condition_variable>
#include <thread>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "kumite/common/error.hpp"
#include "kumite/common/latest.hpp"
#include "kumite/recognition/poses_file.hpp"
#include "kumite/tracking/camera_frames.hpp"
#include "kumite/tracking/interop.hpp"
#include "kumite/tracking/pipeline.hpp"
#include "kumite/tracking/tracker.hpp"

namespace kumite::app {

namespace {

/// Runs `open` (reading one of the tracker's files); an error it throws comes back located
/// at the config key that named the file: "demo.toml:123: tracking.recording: ...".
template <typename F>
auto at_key(const InstallationConfig& c, const char* key, F&& open) {
  try {
    return open();
  } catch (const Error& e) {
    throw file_error(e.component(), e.code(), c.file.string(), c.line_of(key), key, e.what());
  }
}

/// The strikes the recognition thread published since the last poll, and its counters, over
/// the snapshot's (none without recognition).
void take_strikes(StrikeRecognition* recognition, TrackingSnapshot& s) {
  s.strikes.clear();
  s.recognition = {};
  if (recognition) {
    recognition->take(s.strikes);
    s.recognition = recognition->stats();
  }
}

/// Late latching's view of the newest head pose out (`newest`: none yet when nullopt).
PoseTiming timing_of(PoseClock& clock, const std::optional<BodyPose>& newest, Timestamp t) {
  PoseTiming p;
  if (newest) {
    clock.observe(newest->frame, newest->timestamp, newest->ready_at);
    p.newest = newest->frame + 1;  // 0 means none
    p.newest_at = newest->timestamp;
  }
  p.next_ready = clock.next_ready(t);
  p.period_s = clock.period_s();
  return p;
}

/// TrackingInput::faults() of an input whose one optional fault is `fault` ("": none).
std::vector<std::string> faults_of(const std::string& fault) {
  return fault.empty() ? std::vector<std::string>{} : std::vector<std::string>{fault};
}

/// Every filtered pose of the bodies `tc` names by a role goes to `recognition` as the tracker
/// finishes each frame set (on the tracker's thread, or the caller's for process(); a
/// lock-free push: never waits).
void feed_recognition(tracking::Tracker& tracker, const InstallationConfig& c, const tracking::TrackingConfig& tc,
                      StrikeRecognition* recognition) {
  std::vector<std::pair<int, recognition::Role>> roles;
  for (std::size_t b = 0; b < tc.bodies.size(); ++b)
    if (const auto r = recognition::role_from_string(tc.bodies[b].name)) roles.emplace_back(static_cast<int>(b), *r);
  if (std::none_of(roles.begin(), roles.end(), [](const auto& r) { return r.second != recognition::Role::head; }))
    spdlog::warn("recognition: {} names no glove or shoe body (left_hand, right_hand, left_foot, right_foot): "
                 "no strike can be recognised",
                 c.resolve(c.tracking.tracking).string());
  tracker.on_frame([recognition, roles](const tracking::FrameResult& r) {
    for (const auto& [b, role] : roles) {
      if (b >= static_cast<int>(r.filtered.size())) continue;
      const BodyPose& p = r.filtered[static_cast<std::size_t>(b)];
      recognition::PoseSample s;
      s.t = r.timestamp;
      s.role = role;
      s.position = p.position;
      s.orientation = p.orientation;
      s.tracked = p.status != TrackingStatus::lost;
      recognition->push(s);
    }
    recognition->end_of_set(r.timestamp);
  });
}

class TrackerInput final : public TrackingInput {
 public:
  TrackerInput(const InstallationConfig& c, tracking::RigCalibration rig,
               tracking::TrackingConfig tc, std::unique_ptr<tracking::FrameSource> source,
               std::unique_ptr<StrikeRecognition> recognition, std::string recognition_fault)
      : preload_(c.tracking.recording_preload), recognition_(std::move(recognition)),
        recognition_fault_(std::move(recognition_fault)), tracker_(rig, tc),
        head_(head_body_index(c, tc)), source_(c.tracking.source) {
    tracker_.set_realtime_priority(c.tracking.realtime_priority);
    reading_.role_body = role_bodies(head_, tc);
    if (recognition_) feed_recognition(tracker_, c, tc, recognition_.get());
    // Camera frame sets to a session recorder while one records (record_frame_sets). The
    // tracker thread takes this lock once per set; the frame loop only to swap the recorder.
    // Until the installation starts (or a recorder attaches, if earlier), the sets are kept,
    // packed (a few kB each, at most kPreroll of them: a minute at 60 Hz), so that a recording
    // made from the start holds every set the tracker's filter has seen: re-tracking it then
    // starts from the same state, however long the start-up took. Packing costs the tracker
    // thread a little only before the show starts.
    tracker_.on_frame_set([this](const tracking::FrameSet& set) {
      const std::lock_guard lock(sink_mutex_);
      if (sink_) {
        sink_->push_frame_set(set);
      } else if (preroll_open_) {
        if (preroll_.size() < kPreroll)
          preroll_.push_back(tracking::encode_frame_set(set));
        else
          preroll_overflow_ = true;
      }
    });
    for (const auto& cam : rig.cameras) names_.push_back(cam.name);  // head_: checked by head_body_index
    if (source) {
      tracker_.start(std::move(source));
      what_ = "frame source given by the caller";
    } else if (source_ == TrackingSource::recording) {
      // Looping keeps a long demo tracked; the recording plays on now()'s clock.
      counters_ = std::make_shared<tracking::RecordingOptions::Counters>();
      tracking::RecordingOptions o;
      o.realtime = true;
      o.loop = true;
      o.decode_threads = c.tracking.decode_threads;
      o.preload_sets = static_cast<std::size_t>(c.tracking.recording_preload);
      o.counters = counters_;
      tracker_.start(at_key(c, "tracking.recording", [&] {
        return tracking::open_recording_source(c.resolve(c.tracking.recording), rig, tc, o);
      }));
      what_ = "recording " + c.resolve(c.tracking.recording).string();
    } else {
      tracker_.start(at_key(c, "tracking.source", [&] { return tracking::open_live_source(rig, tc); }));
      what_ = "live cameras";
    }
  }
  ~TrackerInput() override { tracker_.stop(); }  // before recognition_: its hook pushes there

  void poll(Timestamp now_s, Timestamp display_time, TrackingSnapshot& s) override {
    read_tracker(tracker_, head_, now_s, display_time, true, reading_, s);
    if (counters_) describe_recording(now_s, s);
    take_strikes(recognition_.get(), s);
  }
  Timestamp clock() const override { return now(); }
  void record_frame_sets(SessionRecorder* recorder) override {
    const std::lock_guard lock(sink_mutex_);
    if (preroll_open_) {  // the first call (a recorder from the start, or the installation starting)
      if (recorder) {
        recorder->push_encoded_frame_sets(std::move(preroll_));
        preroll_ = {};
        if (preroll_overflow_)
          spdlog::warn("record: more than {} camera frame sets came before the recording began: a re-track of it "
                       "starts from a different tracker state", kPreroll);
      }
      preroll_.clear();
      preroll_.shrink_to_fit();
      preroll_open_ = false;
    }
    sink_ = recorder;
  }
  bool loading() const override { return counters_ && !counters_->playing.load(); }
  std::vector<std::string> faults() const override {
    return faults_of(recognition_fault_);
  }
  std::string describe() const override { return what_; }
  const std::vector<std::string>& camera_names() const override { return names_; }
  PoseTiming pose_timing(Timestamp t) override { return timing_of(pose_clock_, tracker_.latest(head_), t); }

 private:
  /// The recording's rates over the last second or so, and a problem when it cannot keep up.
  void describe_recording(Timestamp t, TrackingSnapshot& s) {
    const auto& c = *counters_;
    SourceStats& src = s.source;
    src.recording = true;
    src.from_memory = preload_ > 0;
    if (!c.playing.load()) {
      // The recording may hold fewer sets than the config asks to preload.
      const std::uint64_t asked = c.to_preload.load();
      src.loading = true;
      src.loaded = c.preloaded.load();
      src.to_load = asked > 0 ? asked : static_cast<std::uint64_t>(preload_);
      return;
    }
    src.loaded = c.preloaded.load();
    src.decode_ms = c.decode_ms.load();
    const std::array<std::uint64_t, 3> n{c.delivered.load(), c.not_decoded.load(), c.dropped_stale.load()};
    if (rate_t0_ < 0 || t - rate_t0_ >= 1.0) {
      if (rate_t0_ >= 0) {
        const double dt = t - rate_t0_;
        for (int k = 0; k < 3; ++k) rates_[k] = static_cast<double>(n[k] - rate_n0_[k]) / dt;
      }
      rate_t0_ = t;
      rate_n0_ = n;
    }
    src.rates = rates_;
    src.totals = n;
  }

  static constexpr std::size_t kPreroll = 3600;  // frame sets (a minute at 60 Hz, ~15 MB packed)
  std::mutex sink_mutex_;
  SessionRecorder* sink_ = nullptr;  // guarded by sink_mutex_, as the three below
  std::vector<std::string> preroll_;  // encoded records (tracking::encode_frame_set)
  bool preroll_open_ = true, preroll_overflow_ = false;
  std::shared_ptr<tracking::RecordingOptions::Counters> counters_;
  PoseClock pose_clock_;  // when the next pose should be out (late latching)
  int preload_ = 0;
  std::unique_ptr<StrikeRecognition> recognition_;  // before tracker_: destroyed after its thread stopped
  std::string recognition_fault_;  // why recognition is off ("": it is not, or was not asked for)
  TrackerReading reading_;
  Timestamp rate_t0_ = -1;
  std::array<std::uint64_t, 3> rate_n0_{0, 0, 0};
  std::array<double, 3> rates_{0, 0, 0};
  tracking::Tracker tracker_;
  int head_;
  TrackingSource source_;
  std::vector<std::string> names_;
  std::string what_;
};


/// A camera recording on the simulated clock (`--simulated-time`, TrackingInputOptions): no
/// thread; poll(now) decodes and tracks, on the caller's thread, every frame set due by `now`
/// (set i at start + (t_i - t_0), + the recording's length per loop), each stamped with its due
/// time and its pose ready then. However slowly the frames come, the tracker sees every set at
/// the time the frames do: the same inputs give the same frames on any machine, under any load.
class RecordingOnSimulatedClock final : public TrackingInput {
 public:
  RecordingOnSimulatedClock(const InstallationConfig& c, tracking::RigCalibration rig, tracking::TrackingConfig tc,
                            std::unique_ptr<StrikeRecognition> recognition, std::string recognition_fault)
      : recognition_(std::move(recognition)), recognition_fault_(std::move(recognition_fault)), rig_(rig), tc_(tc),
        tracker_(rig, tc), head_(head_body_index(c, tc)), dir_(c.resolve(c.tracking.recording)) {
    reading_.role_body = role_bodies(head_, tc);
    if (recognition_) feed_recognition(tracker_, c, tc, recognition_.get());
    for (const auto& cam : rig_.cameras) names_.push_back(cam.name);
    source_ = at_key(c, "tracking.recording", [&] { return open(); });
    what_ = "recording " + dir_.string() + ", on the simulated clock";
  }

  void poll(Timestamp now_s, Timestamp display_time, TrackingSnapshot& s) override {
    sim_now_ = now_s;
    if (!started_) {
      started_ = true;
      t0_ = now_s;
    }
    for (;;) {
      if (!next_ && !fetch()) break;
      const Timestamp due = t0_ + offset_ + (next_->timestamp - first_);
      if (due > now_s) break;
      next_->timestamp = due;
      next_->camera_times.assign(next_->images.size(), due);
      if (sink_) sink_->push_frame_set(*next_);
      tracker_.process(*next_);
      next_.reset();
    }
    read_tracker(tracker_, head_, now_s, display_time, false, reading_, s);
    take_strikes(recognition_.get(), s);
  }
  Timestamp clock() const override { return sim_now_; }
  bool follows_simulated_clock() const override { return true; }
  void record_frame_sets(SessionRecorder* recorder) override { sink_ = recorder; }
  std::string describe() const override { return what_; }
  std::vector<std::string> faults() const override {
    return faults_of(recognition_fault_);
  }
  const std::vector<std::string>& camera_names() const override { return names_; }
  PoseTiming pose_timing(Timestamp t) override { return timing_of(pose_clock_, tracker_.latest(head_), t); }

 private:
  std::unique_ptr<tracking::FrameSource> open() const {
    tracking::RecordingOptions o;
    o.realtime = false;  // every set, in order, decoded here, on the recording's own timestamps
    return tracking::open_recording_source(dir_, rig_, tc_, o);
  }
  /// The next frame set into next_ (the recording again from its start at its end: the next
  /// loop begins one frame interval after its last set); false when it holds none at all.
  bool fetch() {
    tracking::FrameSet set;
    for (int attempt = 0; attempt < 2; ++attempt) {
      const bool got = source_->next(set, 0);
      for (const auto& m : source_->take_messages()) spdlog::warn("{}", m);
      if (got) {
        if (!have_first_) {
          have_first_ = true;
          first_ = set.timestamp;
        }
        if (have_last_ && set.timestamp > last_) step_ = set.timestamp - last_;
        last_ = set.timestamp;
        have_last_ = true;
        next_ = std::move(set);
        return true;
      }
      if (!source_->end_of_stream() || !have_last_) return false;
      offset_ += last_ - first_ + step_;
      have_last_ = false;
      source_ = open();
    }
    return false;
  }

  std::unique_ptr<StrikeRecognition> recognition_;  // before tracker_: its hook pushes there
  std::string recognition_fault_;
  tracking::RigCalibration rig_;
  tracking::TrackingConfig tc_;
  tracking::Tracker tracker_;
  int head_;
  std::filesystem::path dir_;
  std::unique_ptr<tracking::FrameSource> source_;
  std::optional<tracking::FrameSet> next_;  // read, not yet due
  bool started_ = false, have_first_ = false, have_last_ = false;
  Timestamp t0_ = 0, sim_now_ = 0;
  double first_ = 0, last_ = 0, step_ = 1.0 / 60, offset_ = 0;  // s, the recording's clock
  SessionRecorder* sink_ = nullptr;
  TrackerReading reading_;
  PoseClock pose_clock_;
  std::vector<std::string> names_;
  std::string what_;
};

/// A poses.csv played on its own timestamps, as if tracked (`[tracking] source = "poses"`):
/// each row is handed over at its time (the file's first row at the input's start; looped when
/// poses_loop), the head's rows to the frame (a latest-value slot), every row to the
/// recognition thread. poll() extrapolates the newest head row to the display time (its
/// velocity from the row before, at most 0.1 s ahead), as the tracker predicts its filter.
/// On the wall clock a thread hands the rows over as they come due; on the simulated clock
/// (TrackingInputOptions::simulated_clock) poll(now) hands over every row due by `now` itself,
/// so the visitor moves with the frames' time whatever the machine's load.
class PosesInput final : public TrackingInput {
 public:
  PosesInput(const InstallationConfig& c, recognition::PosesFile file, std::unique_ptr<StrikeRecognition> rec,
             std::string recognition_fault, bool simulated_clock)
      : file_(std::move(file)), loop_(c.tracking.poses_loop), recognition_(std::move(rec)),
        recognition_fault_(std::move(recognition_fault)), simulated_(simulated_clock),
        lost_after_s_(c.tracking.lost_after_s) {
    std::size_t heads = 0;
    for (const auto& smp : file_.samples) heads += smp.role == recognition::Role::head ? 1 : 0;
    const double span = file_.samples.empty() ? 0.0 : file_.samples.back().t - file_.samples.front().t;
    what_ = fmt::format("poses file {} ({} rows, {} of the head, {:.1f} s{}{})", c.resolve(c.tracking.poses).string(),
                        file_.samples.size(), heads, span, loop_ ? ", looped" : "",
                        simulated_ ? ", on the simulated clock" : "");
    if (heads == 0)
      spdlog::warn("tracking: {} has no row of a body named head: the head stays at its default",
                   c.resolve(c.tracking.poses).string());
    if (file_.ignored_rows > 0)
      spdlog::info("tracking: {}: {} rows of bodies that are no role (head, left_hand, right_hand, left_foot, "
                   "right_foot) ignored",
                   c.resolve(c.tracking.poses).string(), file_.ignored_rows);
    const auto& rows = file_.samples;
    // One loop lasts the file's span plus one row interval (the first row again a period after the last).
    double step = 1.0 / 60;
    for (std::size_t i = 1; i < rows.size(); ++i)
      if (rows[i].t > rows[i - 1].t) {
        step = rows[i].t - rows[i - 1].t;
        break;
      }
    period_ = rows.empty() ? 0.0 : rows.back().t - rows.front().t + step;
    if (!simulated_) thread_ = std::thread([this] { run(); });
  }
  ~PosesInput() override {
    if (!thread_.joinable()) return;
    {
      const std::lock_guard lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    thread_.join();
  }

  void poll(Timestamp now_s, Timestamp display_time, TrackingSnapshot& s) override {
    if (simulated_) {
      sim_now_ = now_s;
      if (!cursor_.started) start(cursor_, now_s);
      while (!cursor_.ended && due(cursor_) <= now_s) deliver(cursor_, due(cursor_), due(cursor_));
    }
    s.head.reset();
    s.measured_at = -1;
    s.measured_ready_at = -1;
    s.cameras.clear();
    s.source = {};
    s.frame_sets = frame_sets_.load(std::memory_order_acquire);
    const auto h = head_.read();
    if (!h) {
      s.state = TrackerState::waiting;
    } else {
      BodyPose p = h->last;
      const bool seen = p.status != TrackingStatus::lost;
      const double age = now_s - h->last.timestamp;
      // Extrapolated only while fresh (a file that ended, or a gap, holds the last row).
      if (seen && age <= kMaxGap_s && h->has_prev && h->prev.status != TrackingStatus::lost) {
        const double dt = p.timestamp - h->prev.timestamp;
        if (dt > 1e-4 && dt <= kMaxGap_s) {
          const double ahead = std::clamp(display_time - p.timestamp, 0.0, kMaxGap_s);
          for (int k = 0; k < 3; ++k)
            p.position[k] += (h->last.position[k] - h->prev.position[k]) / dt * ahead;
        }
      }
      p.status = !seen ? TrackingStatus::lost : age <= kMaxGap_s ? TrackingStatus::tracked : TrackingStatus::coasting;
      s.head = p;
      if (seen) {
        s.measured_at = h->last.timestamp;
        s.measured_ready_at = h->last.ready_at;
      }
      s.state = p.status == TrackingStatus::tracked    ? TrackerState::tracked
                : p.status == TrackingStatus::coasting ? TrackerState::coasting
                                                       : TrackerState::lost;
    }
    if (ended_.load(std::memory_order_acquire)) s.state = TrackerState::stopped;
    // Every body as its newest row measured it (no extrapolation): tracked while that row is
    // fresh, coasting up to [tracking] lost_after_s, lost after that or when its newest row says lost.
    const auto m = measured_.read();
    for (std::size_t r = 0; r < s.bodies.size(); ++r) {
      auto& out = s.bodies[r];
      if (!m || m->state[r] == Measured::none) {
        out.reset();
        continue;
      }
      out = m->last[r];
      const double age = now_s - out->timestamp;
      out->status = m->state[r] == Measured::lost || age > lost_after_s_ ? TrackingStatus::lost
                    : age <= kMaxGap_s                                    ? TrackingStatus::tracked
                                                                          : TrackingStatus::coasting;
    }
    take_strikes(recognition_.get(), s);
  }
  Timestamp clock() const override { return simulated_ ? sim_now_ : now(); }
  bool follows_simulated_clock() const override { return simulated_; }
  std::string describe() const override { return what_; }
  std::vector<std::string> faults() const override {
    return faults_of(recognition_fault_);
  }
  PoseTiming pose_timing(Timestamp t) override {
    const auto h = head_.read();
    return timing_of(pose_clock_, h ? std::optional<BodyPose>(h->last) : std::nullopt, t);
  }

 private:
  static constexpr double kMaxGap_s = 0.1;  // s: a head row older than this is coasting; no extrapolation past it
  struct Head {
    BodyPose last, prev;
    bool has_prev = false;
  };
  /// Per role (recognition::Role), the newest row that measured the body, and whether the
  /// newest row of it did (`lost`: a row since says lost; `none`: no row measured it yet).
  struct Measured {
    enum State : std::uint8_t { none, tracked, lost };
    std::array<BodyPose, recognition::kRoleCount> last{};
    std::array<State, recognition::kRoleCount> state{};
  };
  /// Where the playing stands: the next row, the loop's offset, the frame count, the head.
  struct Cursor {
    bool started = false, ended = false;
    Timestamp t0 = 0;      ///< s, the clock at the input's start: the first row's due time
    std::size_t i = 0;     ///< the next row
    double offset = 0;     ///< s, the loops played so far
    std::uint64_t frame = 0;
    Head head;
    Measured measured;
  };

  void start(Cursor& c, Timestamp t0) {
    c.started = true;
    c.t0 = t0;
    if (file_.samples.empty()) finish(c);
  }
  void finish(Cursor& c) {
    c.ended = true;
    ended_.store(true, std::memory_order_release);
  }
  /// When row c.i is due (the clock's seconds).
  Timestamp due(const Cursor& c) const { return c.t0 + c.offset + (file_.samples[c.i].t - file_.samples.front().t); }

  /// Hands row c.i over at `due` (its pose published as ready at `ready`) and moves on, to the
  /// file's start again (looped) or its end.
  void deliver(Cursor& c, Timestamp due_at, Timestamp ready) {
    const auto& rows = file_.samples;
    const std::size_t i = c.i;
    if (i > 0 && rows[i].t > rows[i - 1].t) {
      ++c.frame;
      frame_sets_.store(c.frame, std::memory_order_release);
    }
    recognition::PoseSample smp = rows[i];
    smp.t = due_at;
    if (smp.role == recognition::Role::head) {
      Head& head = c.head;
      head.prev = head.last;
      head.has_prev = head.last.timestamp > 0;
      head.last = BodyPose{};
      head.last.timestamp = due_at;
      head.last.frame = c.frame;
      head.last.status = smp.tracked ? TrackingStatus::tracked : TrackingStatus::lost;
      head.last.position = smp.position;
      head.last.orientation = smp.orientation;
      head.last.markers = smp.tracked ? 4 : 0;
      head.last.ready_at = ready;
      head_.publish(head);
    }
    {
      Measured& m = c.measured;
      const auto r = static_cast<std::size_t>(smp.role);
      if (smp.tracked) {
        BodyPose& p = m.last[r];
        p = BodyPose{};
        p.timestamp = due_at;
        p.frame = c.frame;
        p.body = static_cast<std::int32_t>(r);  // the file names bodies by role
        p.status = TrackingStatus::tracked;
        p.position = smp.position;
        p.orientation = smp.orientation;
        p.markers = 4;  // as the head's (the file keeps no marker count)
        p.ready_at = ready;
        m.state[r] = Measured::tracked;
      } else if (m.state[r] != Measured::none) {
        m.state[r] = Measured::lost;
      }
      measured_.publish(m);
    }
    if (recognition_) {
      recognition_->push(smp);
      if (i + 1 == rows.size() || rows[i + 1].t != rows[i].t) recognition_->end_of_set(due_at);
    }
    if (++c.i < rows.size()) return;
    if (!loop_) {
      if (recognition_) recognition_->restart(due_at);  // the stream ended: strikes under way are cancelled
      finish(c);
      return;
    }
    c.i = 0;
    c.offset += period_;
    ++c.frame;
    c.head.last.timestamp = 0;  // the file starts again elsewhere: no velocity across the seam
    if (recognition_) recognition_->restart(c.t0 + c.offset);
  }

  /// The wall clock's thread: each row at its time.
  void run() {
    Cursor c;
    start(c, now());
    while (!c.ended) {
      const Timestamp d = due(c);
      if (!wait_until(d)) return;
      deliver(c, d, now());
    }
  }

  /// Sleeps until `due` (the clock's seconds); false when asked to stop.
  bool wait_until(Timestamp due) {
    std::unique_lock lock(mutex_);
    for (Timestamp t = now(); t < due && !stop_; t = now())
      wake_.wait_for(lock, std::chrono::duration<double>(std::min(due - t, 0.05)));
    return !stop_;
  }

  recognition::PosesFile file_;
  bool loop_ = true;
  std::unique_ptr<StrikeRecognition> recognition_;
  std::string recognition_fault_;
  bool simulated_ = false;
  double period_ = 0;     // s, one loop of the file
  Cursor cursor_;         // simulated clock: the frame thread's
  Timestamp sim_now_ = 0; // simulated clock: the last poll's time
  LatestValue<Head> head_;
  LatestValue<Measured> measured_;
  double lost_after_s_ = 0.25;  // s, [tracking] lost_after_s: a body measured longer ago is lost
  std::atomic<std::uint64_t> frame_sets_{0};
  std::atomic<bool> ended_{false};
  PoseClock pose_clock_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;  // guarded by mutex_
  std::string what_;
  std::thread thread_;  // last: started once everything above is made
};

/// A room's own tracker (`[tracking] source = "dtrack"` or "osc", issue 55): the interop
/// library's receiver (tracking::DtrackReceiver / OscReceiver) on its own thread publishes the
/// newest frame, bodies already in Kumite's room with their roles; poll() takes it without
/// waiting. Each role's body as measured, its measurement time the frame's receive time
/// (kumite::now() when the datagram was read: the same clock as clock()); tracked while in the
/// newest frame and that frame is fresh (<= kFresh_s), coasting when the newest frame lacks it
/// (or quality < 0) or the frames stop, lost once [tracking] lost_after_s passed since it was
/// last measured. The head is predicted to the display time as the poses file's is: its
/// velocity from the measurement the poll before saw, at most kFresh_s ahead, only while
/// fresh; the orientation as measured. Every published frame (not only the newest a poll
/// sees) goes to the recognition thread from the receiver's thread. Network time is wall
/// time: on the simulated clock this source stays on it (said once, as for live cameras).
class RoomTrackerInput final : public TrackingInput {
 public:
  RoomTrackerInput(const InstallationConfig& c, std::unique_ptr<StrikeRecognition> rec, std::string recognition_fault)
      : recognition_(std::move(rec)), recognition_fault_(std::move(recognition_fault)),
        lost_after_s_(c.tracking.lost_after_s), osc_(c.tracking.source == TrackingSource::osc) {
    name_ = osc_ ? "osc" : "dtrack";
    last_source_t_.fill(-1);
    prev_source_t_.fill(-1);
    const char* table = osc_ ? "tracking.osc" : "tracking.dtrack";
    tracking::DtrackInput in = osc_ ? c.tracking.osc : c.tracking.dtrack;
    if (!in.has_roles()) {  // kumite-dtrack send's ids
      in.role_body = {0, 1, 2, 3, 4};
      spdlog::info("{}: {}.bodies not given: head is body 0, left_hand 1, right_hand 2, left_foot 3, right_foot 4",
                   name_, table);
    }
    role_body_ = in.role_body;
    if (osc_) {
      tracking::OscReceiver::Options o;
      o.multicast_group = in.multicast_group;
      o.role_body = in.role_body;
      rx_ = std::make_unique<tracking::OscReceiver>(in.port, o);
    } else {
      rx_ = std::make_unique<tracking::DtrackReceiver>(in);
    }
    if (recognition_) {
      if (role_body_[static_cast<std::size_t>(recognition::Role::left_hand)] < 0 &&
          role_body_[static_cast<std::size_t>(recognition::Role::right_hand)] < 0 &&
          role_body_[static_cast<std::size_t>(recognition::Role::left_foot)] < 0 &&
          role_body_[static_cast<std::size_t>(recognition::Role::right_foot)] < 0)
        spdlog::warn("recognition: {}.bodies names no glove or shoe (left_hand, right_hand, left_foot, right_foot): "
                     "no strike can be recognised",
                     table);
      // The receiver's thread, every frame it publishes: each configured role's pose (not
      // tracked when the frame lacks it), then the set is whole. A lock-free push: never waits.
      rx_->on_publish([this](const tracking::RoomFrame& f) { feed(f); });
    }
    at_key(c, table, [&] {
      rx_->start();
      return 0;
    });
    what_ = fmt::format("{} on UDP port {}{}", osc_ ? "OSC" : "DTrack", rx_->port(),
                        in.multicast_group.empty() ? std::string() : ", multicast group " + in.multicast_group);
    spdlog::info("tracking: {}", what_);
  }
  ~RoomTrackerInput() override { rx_->stop(); }  // before recognition_: its hook pushes there

  void poll(Timestamp /*now_s*/, Timestamp display_time, TrackingSnapshot& s) override;
  Timestamp clock() const override { return now(); }
  std::string describe() const override { return what_; }
  std::vector<std::string> faults() const override {
    std::vector<std::string> f = faults_of(recognition_fault_);
    const double since = silent_since_.load();
    if (since >= 0) f.push_back(silence_line(now() - since + kSilence_s));
    return f;
  }
  std::string source_line() const override {
    const tracking::ReceiverCounters n = rx_->counters();
    std::string line = fmt::format("{}: port {}, {} frames, {} bad packets", name_, rx_->port(), n.frames, n.bad_packets);
    if (n.oversized > 0) line += fmt::format(" ({} oversized)", n.oversized);
    if (n.unconfigured_bodies > 0) line += fmt::format(", {} bodies of unconfigured ids", n.unconfigured_bodies);
    if (n.frame_gaps > 0) line += fmt::format(", {} frames skipped by the sender", n.frame_gaps);
    if (const auto f = rx_->poll()) {
      const std::string from = rx_->last_sender();
      line += fmt::format(", last {}{:.2f} s ago", from.empty() ? "" : "from " + from + " ", now() - f->received_at);
      if (f->latency_us >= 0) line += fmt::format(" (DTrack's latency {:.1f} ms)", f->latency_us * 1e-3);
    } else {
      line += n.packets > 0 ? ", no usable frame yet" : ", waiting for the first packet";
    }
    return line;
  }
  PoseTiming pose_timing(Timestamp t) override {
    std::optional<BodyPose> newest;
    if (const auto f = rx_->poll()) {
      BodyPose p;
      p.frame = f->sequence;
      p.timestamp = f->received_at;
      p.ready_at = f->published_at;
      newest = p;
    }
    return timing_of(pose_clock_, newest, t);
  }

 private:
  static constexpr double kFresh_s = 0.1;    // s: a measurement older than this coasts; no extrapolation past it
  static constexpr double kSilence_s = 1.0;  // s without a packet: said once

  std::string silence_line(double s) const {
    const std::string from = rx_->last_sender();
    return fmt::format("{}: no {} packets for {:.1f} s{}: the head and the visitor's bodies coast, then are lost", name_,
                       osc_ ? "OSC" : "DTrack", s, from.empty() ? std::string() : " (the last from " + from + ")");
  }

  /// The receiver's thread (on_publish): the frame's role bodies to the recognition thread.
  void feed(const tracking::RoomFrame& f) {
    for (std::size_t r = 0; r < role_body_.size(); ++r) {
      if (role_body_[r] < 0) continue;
      recognition::PoseSample smp;
      smp.t = f.received_at;
      smp.role = static_cast<recognition::Role>(r);
      const tracking::RoomBody* b = body_of(f, r);
      smp.tracked = b && b->tracked;
      if (smp.tracked) {
        smp.position = {b->position_m[0], b->position_m[1], b->position_m[2]};
        smp.orientation = b->orientation;
        fed_[r] = smp;
      } else {
        smp.position = fed_[r].position;  // the last known (not used while untracked)
        smp.orientation = fed_[r].orientation;
      }
      recognition_->push(smp);
    }
    recognition_->end_of_set(f.received_at);
  }

  static const tracking::RoomBody* body_of(const tracking::RoomFrame& f, std::size_t role) {
    for (int i = 0; i < f.body_count; ++i) {
      const tracking::RoomBody& b = f.bodies[static_cast<std::size_t>(i)];
      if (b.role == static_cast<int>(role) && b.kind == tracking::RoomBodyKind::body) return &b;
    }
    return nullptr;
  }

  /// A frame the polls have not seen yet: each role measured in it becomes its newest measurement.
  void take(const tracking::RoomFrame& f) {
    for (std::size_t r = 0; r < role_body_.size(); ++r) {
      const tracking::RoomBody* b = role_body_[r] >= 0 ? body_of(f, r) : nullptr;
      in_newest_[r] = b && b->tracked;
      if (!in_newest_[r]) continue;
      prev_[r] = last_[r];
      prev_source_t_[r] = last_source_t_[r];
      last_source_t_[r] = f.source_time_s;
      BodyPose& p = last_[r].emplace();
      p.timestamp = f.received_at;
      p.frame = f.sequence;
      p.body = b->id;
      p.status = TrackingStatus::tracked;
      p.position = b->position_m;
      p.orientation = b->orientation;
      p.markers = 0;  // a room's tracker does not say
      p.cameras = 0;
      p.ready_at = f.published_at;
    }
  }

  TrackingStatus status_of(std::size_t r, Timestamp t) const {
    const double age = t - last_[r]->timestamp;
    if (age > lost_after_s_) return TrackingStatus::lost;
    return in_newest_[r] && age <= kFresh_s ? TrackingStatus::tracked : TrackingStatus::coasting;
  }

  void watch_packets(Timestamp t, std::uint64_t packets);
  void log_problems(Timestamp t);

  std::unique_ptr<StrikeRecognition> recognition_;  // before rx_: its hook pushes there
  std::string recognition_fault_;
  double lost_after_s_ = 0.25;
  bool osc_ = false;
  std::string name_, what_;
  std::array<std::int32_t, 5> role_body_{-1, -1, -1, -1, -1};
  std::array<recognition::PoseSample, recognition::kRoleCount> fed_{};  // the receiver thread's
  // The frame thread's: per role the newest measurement and the one before, and whether the newest frame had it.
  std::array<std::optional<BodyPose>, recognition::kRoleCount> last_{}, prev_{};
  std::array<bool, recognition::kRoleCount> in_newest_{};
  std::array<double, recognition::kRoleCount> last_source_t_{}, prev_source_t_{};  // the sender's time (-1: none)
  std::uint64_t seen_ = 0;        // the newest frame's sequence taken
  std::uint64_t packets_ = 0;     // packets at the last poll
  Timestamp started_ = -1, last_packet_at_ = -1;
  bool said_none_ = false;
  std::atomic<double> silent_since_{-1};  // s, when the silence was said (-1: packets flow)
  Timestamp problems_window_ = -1;
  int problems_in_window_ = 0, problems_held_ = 0;
  PoseClock pose_clock_;
  std::unique_ptr<tracking::Receiver> rx_;  // last: its thread stops first
};

void RoomTrackerInput::watch_packets(Timestamp t, std::uint64_t packets) {
  if (started_ < 0) started_ = t;
  if (packets != packets_) {
    packets_ = packets;
    if (const double since = silent_since_.load(); since >= 0) {
      spdlog::info("{}: packets again from {} after {:.1f} s without", name_, rx_->last_sender(),
                   t - last_packet_at_);
      silent_since_.store(-1);
    }
    last_packet_at_ = t;
    return;
  }
  if (last_packet_at_ < 0) {
    if (!said_none_ && t - started_ > kSilence_s) {
      said_none_ = true;
      spdlog::warn("{}: no {} packets on UDP port {} in {:.1f} s since the start: is the tracker sending to this "
                   "machine and port?",
                   name_, osc_ ? "OSC" : "DTrack", rx_->port(), t - started_);
    }
    return;
  }
  if (silent_since_.load() < 0 && t - last_packet_at_ > kSilence_s) {
    silent_since_.store(t);
    spdlog::warn("{}", silence_line(t - last_packet_at_));
  }
}

void RoomTrackerInput::log_problems(Timestamp t) {
  // One line each, as the receiver words them (bad packets, bodies of unconfigured ids said
  // once each), at most kPerSecond a second: a flood of bad packets is counted, not printed.
  constexpr int kPerSecond = 10;
  if (problems_window_ < 0 || t - problems_window_ >= 1.0) {
    if (problems_held_ > 0)
      spdlog::warn("{}: {} more problem lines in the last second not shown ({} bad packets in all)", name_,
                   problems_held_, rx_->counters().bad_packets);
    problems_window_ = t;
    problems_in_window_ = problems_held_ = 0;
  }
  for (const std::string& line : rx_->take_problems()) {
    if (problems_in_window_++ < kPerSecond) spdlog::warn("{}", line);
    else ++problems_held_;
  }
}

void RoomTrackerInput::poll(Timestamp /*now_s*/, Timestamp display_time, TrackingSnapshot& s) {
  // Ages on the receive clock (kumite::now()); the display time relative to the frame's own now.
  const Timestamp t = now();
  s.head.reset();
  s.measured_at = -1;
  s.measured_ready_at = -1;
  s.cameras.clear();
  s.source = {};
  const tracking::ReceiverCounters n = rx_->counters();
  s.frame_sets = n.frames;
  watch_packets(t, n.packets);
  log_problems(t);
  if (rx_->version() != seen_) {
    if (const auto f = rx_->poll(); f && f->sequence != seen_) {
      seen_ = f->sequence;
      take(*f);
    }
  }
  for (std::size_t r = 0; r < s.bodies.size(); ++r) {
    auto& out = s.bodies[r];
    out = last_[r];
    if (out) out->status = status_of(r, t);
  }
  const auto h = static_cast<std::size_t>(recognition::Role::head);
  if (!last_[h]) {
    s.state = TrackerState::waiting;
  } else {
    BodyPose p = *last_[h];
    p.status = status_of(h, t);
    // Extrapolated to the display time while fresh, from the measurement before (as the poses file's head).
    if (p.status == TrackingStatus::tracked && prev_[h]) {
      // The interval on the sender's clock when it sends one (DTrack's ts: packets that
      // arrive in a burst would make a velocity of the receive times jump), else on ours.
      const double src_dt = last_source_t_[h] - prev_source_t_[h];
      const double dt = last_source_t_[h] >= 0 && prev_source_t_[h] >= 0 && src_dt > 0
                            ? src_dt
                            : p.timestamp - prev_[h]->timestamp;
      if (dt > 1e-4 && dt <= kFresh_s) {
        const double ahead = std::clamp(display_time - p.timestamp, 0.0, kFresh_s);
        for (std::size_t k = 0; k < 3; ++k) p.position[k] += (last_[h]->position[k] - prev_[h]->position[k]) / dt * ahead;
      }
    }
    s.head = p;
    s.measured_at = last_[h]->timestamp;
    s.measured_ready_at = last_[h]->ready_at;
    s.state = p.status == TrackingStatus::tracked    ? TrackerState::tracked
              : p.status == TrackingStatus::coasting ? TrackerState::coasting
                                                     : TrackerState::lost;
  }
  if (!rx_->running()) s.state = TrackerState::stopped;
  take_strikes(recognition_.get(), s);
}

/// The recognition thread [recognition] asks for (nullptr: none). A model that cannot be read
/// (missing, cut, damaged) takes out recognition alone: one error line, and `fault` says so
/// for the console and the health report; the tracker starts as ever.
std::unique_ptr<StrikeRecognition> make_recognition(const InstallationConfig& c, std::string& fault,
                                                    bool inline_on_caller = false) {
  if (c.recognition.model.empty()) return nullptr;
  if (c.tracking.source == TrackingSource::none) {
    spdlog::warn("recognition: {}: recognition.model is set but tracking.source = \"none\": no pose to recognise",
                 c.file.string());
    return nullptr;
  }
  const auto path = c.resolve(c.recognition.model);
  try {
    auto model = at_key(c, "recognition.model", [&] { return recognition::read_model(path); });
    return std::make_unique<StrikeRecognition>(std::move(model), path.string(), inline_on_caller);
  } catch (const Error& e) {
    fault = std::string("strike recognition off: ") + e.what();
    spdlog::error("{}", fault);
    return nullptr;
  }
}

}  // namespace

int head_body_index(const InstallationConfig& c, const tracking::TrackingConfig& tc) {
  if (c.tracking.head_body) {
    if (*c.tracking.head_body >= static_cast<int>(tc.bodies.size()))
      throw file_error("config", "range", c.file.string(), c.line_of("tracking.head_body"), "tracking.head_body",
                       fmt::format("body {} does not exist ({} bodies in {})", *c.tracking.head_body, tc.bodies.size(),
                                   c.resolve(c.tracking.tracking).string()));
    return *c.tracking.head_body;
  }
  if (tc.find_body("head") >= 0 || tc.bodies.empty()) return tc.head_body();
  spdlog::warn("tracking: {} names no body \"head\": body 0 (\"{}\") is taken as the glasses; name it head (its "
               "role) or set [tracking] head_body",
               c.resolve(c.tracking.tracking).string(), tc.bodies[0].name);
  return tc.head_body();
}

std::array<int, recognition::kRoleCount> role_bodies(int head, const tracking::TrackingConfig& tc) {
  std::array<int, recognition::kRoleCount> out;
  out.fill(-1);
  out[static_cast<std::size_t>(recognition::Role::head)] = head;
  for (std::size_t b = 0; b < tc.bodies.size(); ++b)
    if (const auto r = recognition::role_from_string(tc.bodies[b].name); r && *r != recognition::Role::head)
      if (out[static_cast<std::size_t>(*r)] < 0) out[static_cast<std::size_t>(*r)] = static_cast<int>(b);
  return out;
}

void read_tracker(const tracking::Tracker& tracker, int head, Timestamp now_s, Timestamp display_time, bool threaded,
                  TrackerReading& carried, TrackingSnapshot& s) {
  s.head.reset();
  s.measured_at = -1;
  s.measured_ready_at = -1;
  s.source = {};
  const auto latest = tracker.latest(head);
  if (latest) {
    // A coasting pose is a prediction: its age counts from the last frame set that saw the
    // head (if that one came and went between two polls, an older one: the age errs long).
    if (latest->status == TrackingStatus::tracked) {
      carried.last_measured = latest->timestamp;
      carried.last_ready = latest->ready_at;
    }
    // Tracked, coasting or lost as of now: the time to the display (vsync, projector lag)
    // must not age a fresh pose into "lost". Extrapolated to the display time, unless that
    // lies past the tracker's coasting time: then the pose as of now.
    const BodyPose at_now = tracker.predict(head, now_s);
    s.head = tracker.predict(head, display_time);
    if (s.head->status == TrackingStatus::lost) s.head = at_now;
    s.head->status = at_now.status;
    s.measured_at = carried.last_measured;
    s.measured_ready_at = carried.last_ready;
    s.state = s.head->status == TrackingStatus::tracked    ? TrackerState::tracked
              : s.head->status == TrackingStatus::coasting ? TrackerState::coasting
                                                           : TrackerState::lost;
  } else {
    s.state = TrackerState::waiting;
  }
  // A tracker whose thread ended says so, whatever its last pose was.
  if (threaded && !tracker.running()) s.state = TrackerState::stopped;
  // The visitor's bodies as measured (not predicted), each with its status as of now.
  for (std::size_t r = 0; r < s.bodies.size(); ++r) {
    auto& out = s.bodies[r];
    const int b = carried.role_body[r];
    if (b < 0) {
      out.reset();
      continue;
    }
    auto& measured = carried.measured[r];
    const auto newest = tracker.latest(b);
    if (newest && newest->status == TrackingStatus::tracked) measured = *newest;
    out = measured;
    if (out) out->status = tracker.predict(b, now_s).status;
  }
  s.frame_sets = tracker.frames_processed();
  s.cameras.resize(tracker.camera_count());  // its room kept from frame to frame
  for (std::size_t i = 0; i < s.cameras.size(); ++i) {
    const tracking::CameraStatus c = tracker.camera_status(i, now_s);
    s.cameras[i] = {c.state, c.blobs, c.since_last_s >= 0 ? c.since_last_s * 1e3 : -1};
  }
}

std::string_view to_string(TrackerState state) {
  switch (state) {
    case TrackerState::none: return "no tracking";
    case TrackerState::waiting: return "waiting for the first frame set";
    case TrackerState::tracked: return "tracked";
    case TrackerState::coasting: return "coasting";
    case TrackerState::lost: return "lost";
    case TrackerState::stopped: return "tracker stopped";
  }
  return "?";
}

std::string describe(const TrackingSnapshot& s, std::string_view none_why) {
  if (s.state == TrackerState::none) return std::string(none_why);
  return fmt::format("{}, {} frame sets", to_string(s.state), s.frame_sets);
}

std::string describe(const SourceStats& src) {
  if (src.retracked) return "re-tracked from the session's camera frames (cameras.bin)";
  if (!src.recording) return {};
  if (src.loading)
    return src.to_load > 0 ? fmt::format("recording: loading {} of {} frame sets into memory", src.loaded, src.to_load)
                           : std::string("recording: decoding the first frame set");
  return fmt::format(
      "recording ({}): {:.1f} frame sets/s tracked, {:.1f}/s skipped (decoder behind), {:.1f}/s dropped "
      "(tracker behind); totals {} / {} / {}",
      src.from_memory ? fmt::format("{} sets looped from memory", src.loaded)
                      : fmt::format("from disk, decode {:.0f} ms/set", src.decode_ms),
      src.rates[0], src.rates[1], src.rates[2], src.totals[0], src.totals[1], src.totals[2]);
}

std::optional<std::string> source_problem(const SourceStats& src) {
  if (!src.recording || src.loading) return std::nullopt;
  const double all = src.rates[0] + src.rates[1] + src.rates[2];
  if (!(all > 0 && src.rates[0] < 0.9 * all)) return std::nullopt;
  // Which side is behind: the decoder (sets skipped: reading PNGs from disk is too slow) or the
  // tracker (sets dropped: the machine too loaded for the cameras' rate; a preload does not help).
  if (src.rates[1] >= src.rates[2] && !src.from_memory)
    return fmt::format(
        "recording: only {:.0f}% of frame sets reach the tracker (PNG decoding {:.0f} ms per set): "
        "pose age grows; set tracking.recording_preload to play from memory",
        100 * src.rates[0] / all, src.decode_ms);
  return fmt::format(
      "recording: only {:.0f}% of frame sets reach the tracker ({:.1f}/s dropped: the tracker is behind, "
      "{:.1f}/s skipped by the decoder): pose age grows; the machine is too busy for the cameras' rate",
      100 * src.rates[0] / all, src.rates[2], src.rates[1]);
}

namespace {

/// "host:port" (checked by the config reader) split.
std::pair<std::string, int> host_port(const std::string& s) {
  const auto colon = s.rfind(':');
  return {s.substr(0, colon), std::stoi(s.substr(colon + 1))};
}

/// A sender that cannot be made (a host that does not resolve) is the file's mistake: one line
/// at its key, and the run does not start.
template <typename F>
auto checked(const InstallationConfig& c, const char* key, F&& make) {
  try {
    return make();
  } catch (const Error& e) {
    throw file_error("config", "tracking_out", c.file.string(), c.line_of(key), key, e.what());
  }
}

/// [tracking.out]: another input's visitor bodies sent on, each time the source has measured
/// something new (the newest measurement's time advances), as DTrack ASCII and/or OSC. Sent on
/// the thread that polls (the frame's): a sendto of a few hundred bytes; OSC through liblo,
/// which allocates its bundle. Everything else is the inner input's.
class TrackerOutput final : public TrackingInput {
 public:
  TrackerOutput(const InstallationConfig& c, std::unique_ptr<TrackingInput> inner)
      : inner_(std::move(inner)), dtrack_in_(c.tracking.dtrack) {
    if (!c.tracking.out_dtrack.empty()) {
      // Not a structured binding: clang 14 (the fuzz build's) cannot capture one in a lambda.
      const auto hp = host_port(c.tracking.out_dtrack);
      dtrack_ = checked(c, "tracking.out.dtrack", [&] { return std::make_unique<tracking::DtrackSender>(hp.first, hp.second); });
      dtrack_to_ = c.tracking.out_dtrack;
    }
    if (!c.tracking.out_osc.empty()) {
      const auto hp = host_port(c.tracking.out_osc);
      osc_ = checked(c, "tracking.out.osc", [&] { return std::make_unique<tracking::OscSender>(hp.first, hp.second); });
      osc_to_ = c.tracking.out_osc;
    }
    spdlog::info("tracking out: the visitor's bodies{}{} (ids: {})",
                 dtrack_ ? " as DTrack ASCII to " + dtrack_to_ : "", osc_ ? " as OSC to " + osc_to_ : "",
                 dtrack_in_.has_roles() ? "[tracking.dtrack.bodies]" : "head 0, left_hand 1, right_hand 2, left_foot 3, right_foot 4");
  }
  ~TrackerOutput() override {
    spdlog::info("tracking out: {} measurements sent{}{}", sent_,
                 dtrack_ ? fmt::format(", DTrack {} failed", dtrack_failed_) : "",
                 osc_ ? fmt::format(", OSC {} failed", osc_failed_) : "");
  }

  void poll(Timestamp now_s, Timestamp display_time, TrackingSnapshot& s) override {
    inner_->poll(now_s, display_time, s);
    Timestamp newest = -1;
    for (const auto& b : s.bodies)
      if (b && b->status == TrackingStatus::tracked) newest = std::max(newest, b->timestamp);
    if (newest <= last_) return;  // nothing measured since the last send
    last_ = newest;
    room_.frame = ++sent_;
    room_.source_time_s = newest;
    room_.body_count = 0;
    for (std::size_t r = 0; r < s.bodies.size(); ++r) {
      if (!s.bodies[r]) continue;
      const BodyPose& p = *s.bodies[r];
      auto& b = room_.bodies[static_cast<std::size_t>(room_.body_count++)];
      b.role = static_cast<std::int32_t>(r);
      b.id = dtrack_in_.role_body[r] >= 0 ? dtrack_in_.role_body[r] : static_cast<std::int32_t>(r);
      // Measured in this set: tracked; coasting or lost: not (DTrack leaves it out of 6d).
      b.tracked = p.status == TrackingStatus::tracked && p.timestamp == newest;
      b.quality = b.tracked ? 1.0 : -1.0;
      b.position_m = p.position;
      b.orientation = p.orientation;
    }
    if (dtrack_) {
      tracking::to_dtrack_frame(room_, dtrack_in_.room, dtrack_frame_);
      dtrack_frame_.timestamp_s = newest;
      if (!dtrack_->send(dtrack_frame_) && dtrack_failed_++ == 0)
        spdlog::warn("tracking out: DTrack to {}: {} (said once; counted)", dtrack_to_, dtrack_->last_error());
    }
    if (osc_ && !osc_->send(room_) && osc_failed_++ == 0)
      spdlog::warn("tracking out: OSC to {}: {} (said once; counted)", osc_to_, osc_->last_error());
  }
  Timestamp clock() const override { return inner_->clock(); }
  std::string describe() const override { return inner_->describe(); }
  std::string none_why() const override { return inner_->none_why(); }
  std::string source_line() const override { return inner_->source_line(); }
  const std::vector<std::string>& camera_names() const override { return inner_->camera_names(); }
  PoseTiming pose_timing(Timestamp t) override { return inner_->pose_timing(t); }
  bool has_tracker() const override { return inner_->has_tracker(); }
  bool follows_simulated_clock() const override { return inner_->follows_simulated_clock(); }
  bool loading() const override { return inner_->loading(); }
  std::vector<std::string> faults() const override { return inner_->faults(); }
  void record_frame_sets(SessionRecorder* recorder) override { inner_->record_frame_sets(recorder); }

 private:
  std::unique_ptr<TrackingInput> inner_;
  tracking::DtrackInput dtrack_in_;
  std::unique_ptr<tracking::DtrackSender> dtrack_;
  std::unique_ptr<tracking::OscSender> osc_;
  std::string dtrack_to_, osc_to_;
  tracking::RoomFrame room_;
  tracking::DtrackFrame dtrack_frame_;
  Timestamp last_ = -1;
  std::uint64_t sent_ = 0, dtrack_failed_ = 0, osc_failed_ = 0;
};

std::unique_ptr<TrackingInput> make_source(const InstallationConfig& config, const TrackingInputOptions& options);

}  // namespace

std::unique_ptr<TrackingInput> make_tracking_input(const InstallationConfig& config, const TrackingInputOptions& options) {
  auto in = make_source(config, options);
  if (config.tracking.out_dtrack.empty() && config.tracking.out_osc.empty()) return in;
  return std::make_unique<TrackerOutput>(config, std::move(in));
}

namespace {
std::unique_ptr<TrackingInput> make_source(const InstallationConfig& config, const TrackingInputOptions& options) {
  if (config.tracking.source == TrackingSource::none)
    return make_fixed_head_input("tracking.source = \"none\"");
  // On the simulated clock a source with a clock of its own (a file) follows the frames'
  // time; live cameras cannot, and stay on the wall clock (said once).
  const bool network = config.tracking.source == TrackingSource::dtrack || config.tracking.source == TrackingSource::osc;
  const bool simulated = options.simulated_clock && config.tracking.source != TrackingSource::live && !network;
  if (options.simulated_clock && !simulated)
    spdlog::warn("tracking: {} run on the wall clock: under simulated time the frames and the visitor drift "
                 "apart as the machine's load decides",
                 network ? "a room's tracker's packets" : "live cameras");
  if (network) {
    std::string fault;
    auto rec = make_recognition(config, fault);
    return std::make_unique<RoomTrackerInput>(config, std::move(rec), std::move(fault));
  }
  if (config.tracking.source == TrackingSource::poses) {
    auto file = at_key(config, "tracking.poses",
                       [&] { return recognition::read_poses_csv(config.resolve(config.tracking.poses)); });
    std::string fault;
    auto rec = make_recognition(config, fault, simulated);
    return std::make_unique<PosesInput>(config, std::move(file), std::move(rec), std::move(fault), simulated);
  }
  auto rig = at_key(config, "tracking.calibration",
                    [&] { return tracking::read_calibration(config.resolve(config.tracking.calibration)); });
  auto tc = at_key(config, "tracking.tracking",
                   [&] { return tracking::read_tracking_config(config.resolve(config.tracking.tracking)); });
  std::string fault;
  auto rec = make_recognition(config, fault, simulated);
  if (simulated)
    return std::make_unique<RecordingOnSimulatedClock>(config, std::move(rig), std::move(tc), std::move(rec),
                                                       std::move(fault));
  return std::make_unique<TrackerInput>(config, std::move(rig), std::move(tc), nullptr, std::move(rec), std::move(fault));
}
}  // namespace

std::unique_ptr<TrackingInput> make_tracking_input(const InstallationConfig& config,
                                                   std::unique_ptr<tracking::FrameSource> source) {
  auto rig = tracking::read_calibration(config.resolve(config.tracking.calibration));
  auto tc = tracking::read_tracking_config(config.resolve(config.tracking.tracking));
  std::string fault;
  auto rec = make_recognition(config, fault);
  return std::make_unique<TrackerInput>(config, std::move(rig), std::move(tc), std::move(source), std::move(rec),
                                        std::move(fault));
}

}  // namespace kumite::app
