#pragma once
// The tracker as the app uses it: a background thread pulling frame sets from a source
// (recording or live V4L2 cameras), running the Pipeline, and publishing per body
//   - the filtered pose into a kumite::LatestValue<BodyPose> (never blocks the reader),
//   - the filter state, so predict(body, t) gives the pose at a display time,
// and per camera a status (ok / no frames + time since the last / reconnecting).
//
//   kumite::tracking::Tracker tracker(rig, config);
//   tracker.start(kumite::tracking::open_recording_source(dir, rig, config, {.realtime = true}));
//   ... each display frame (render thread):
//   kumite::BodyPose head = tracker.predict(0, kumite::now() + display_latency_s);
//   if (head.status != kumite::TrackingStatus::lost) use(head);
//   for (const auto& cam : tracker.camera_status()) console(cam);
//   tracker.stop();
//
// Clock: poses carry the source's timestamps. Live sources use kumite::now() (the driver
// timestamps are CLOCK_MONOTONIC, the same clock); a real-time recording is rebased onto
// kumite::now() when it starts, so predict(kumite::now()) is right in both; a recording
// played as fast as possible keeps its own clock.
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "kumite/common/latest.hpp"
#include "kumite/common/wire.hpp"
#include "kumite/tracking/calibration_file.hpp"
#include "kumite/tracking/config.hpp"
#include "kumite/tracking/recording.hpp"

namespace kumite::tracking {

/// The camera states are common's (wire.hpp): the app's per-frame input carries them.
using kumite::CameraState;
using kumite::to_string;

/// One camera's status, trivially copyable.
struct CameraStatus {
  CameraState state = CameraState::no_frames;
  Timestamp last_frame = -1;  ///< s, time of its last image (-1 = never)
  double since_last_s = -1;   ///< s since that image, at the time asked (-1 = never)
  std::int32_t blobs = 0;     ///< blobs in its last image (after the static mask)
  std::int32_t masked = 0;    ///< blobs the static mask removed in its last image
  /// s it has seen none of the head's markers while the others saw the head in its view
  /// (0 while it sees them; state blind from camera_blind_s on)
  double blind_s = 0;
};
/// One line saying what is wrong with a camera, for consoles and logs: "" when ok, else e.g.
/// "sees no markers while others see the head (3.2 s)" or "no frames (0.6 s since the last frame)".
std::string describe(const CameraStatus& status);

/// Where frame sets come from. next() is called from the tracker thread only.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  /// Waits for the next frame set (at most ~timeout_s); false when there is none yet
  /// (end_of_stream() tells whether one will ever come).
  virtual bool next(FrameSet& out, double timeout_s) = 0;
  virtual bool end_of_stream() const = 0;
  /// Per camera (calibration order): true while the device is being reopened.
  virtual bool reconnecting(std::size_t /*camera*/) const { return false; }
  /// Interrupts a waiting next() and stops capture threads.
  virtual void close() {}
  /// Lines about what was skipped (bad files, rows, frames); drained by the tracker.
  virtual std::vector<std::string> take_messages() { return {}; }
};

/// How a recording plays. As fast as possible (realtime = false): every frame set, in order,
/// decoded on the caller's thread, with the recording's own timestamps. In real time: like
/// cameras, on a clock that does not wait for anyone: frame set i is due at
/// start + (t_i - t_0) (+ the recording's length per loop), is handed over no earlier than
/// that and stamped with that time (kumite::now()'s clock). Worker threads decode ahead of
/// the clock; a set they cannot decode before it is due is skipped (the decoder is behind),
/// and when the consumer is behind, only the newest due set is handed over and older ones
/// are dropped (a camera with `buffered_sets` driver buffers). Nothing is stamped in the past.
struct RecordingOptions {
  bool realtime = false;  ///< pace frame sets on the clock above (see there)
  bool loop = false;      ///< start again at the end
  int decode_threads = 1;  ///< realtime: threads decoding PNGs ahead of the clock
  /// realtime: nice value added to the decode threads (Linux; 0 = as the caller), so the
  /// tracker and the renderer win when the 2 cores are short.
  int decode_nice = 5;
  int buffered_sets = 3;  ///< realtime: decoded sets waiting for their time (>= 1)
  /// realtime: decode the first N frame sets into memory before the clock starts and play
  /// only those (looped if `loop`); 0 = stream every set from disk.
  std::size_t preload_sets = 0;
  /// Counts the source keeps (any thread may read them while it runs).
  struct Counters {
    std::atomic<std::uint64_t> delivered{0};      ///< frame sets handed over
    std::atomic<std::uint64_t> not_decoded{0};    ///< skipped: could not be decoded before due
    /// dropped because the consumer was behind: a newer set was due at hand-over, or the
    /// buffers were full while it came due
    std::atomic<std::uint64_t> dropped_stale{0};
    std::atomic<std::uint64_t> preloaded{0};      ///< frame sets in memory (preload_sets)
    std::atomic<std::uint64_t> to_preload{0};     ///< sets being preloaded: preload_sets or fewer
    std::atomic<bool> playing{false};             ///< the clock has started
    std::atomic<double> decode_ms{0};             ///< ms per frame set (all cameras), smoothed
    std::atomic<double> max_handover_late_ms{0};  ///< ms, worst (hand-over time - due time)
  };
  /// Optional: where the counts go (the app shows them on its console).
  std::shared_ptr<Counters> counters;
};

/// A source reading a recording (see recording.hpp). Throws kumite::Error as Recording does.
std::unique_ptr<FrameSource> open_recording_source(const std::filesystem::path& dir,
                                                   const RigCalibration& rig,
                                                   const TrackingConfig& config,
                                                   RecordingOptions options = {});

/// A source capturing from the V4L2 cameras in config.cameras (one thread per camera, frame
/// sets assembled from driver timestamps within config.frame_tolerance_s). Throws
/// kumite::Error for unknown camera names; cameras that cannot be opened are reported and
/// retried ("reconnecting") while the others run. Throws when none can be opened.
std::unique_ptr<FrameSource> open_live_source(const RigCalibration& rig, const TrackingConfig& config);

class Pipeline;
struct FrameResult;

class Tracker {
 public:
  /// Throws kumite::Error for an invalid config (no bodies, ...).
  Tracker(RigCalibration rig, TrackingConfig config);
  ~Tracker();  ///< stops the thread
  Tracker(const Tracker&) = delete;
  Tracker& operator=(const Tracker&) = delete;

  /// Starts the tracker thread on `source` (stops a previous one first).
  void start(std::unique_ptr<FrameSource> source);
  /// Stops and joins the thread; the last poses stay readable.
  void stop();
  /// True while the thread runs (false once a recording has ended).
  bool running() const { return running_.load(std::memory_order_acquire); }

  std::size_t body_count() const;
  /// Index of the body called `name` ([[bodies]] order), or -1.
  int find_body(std::string_view name) const;
  std::size_t camera_count() const { return rig_.cameras.size(); }
  /// The calibration (camera names, in camera_status() order) and the config it runs with.
  const RigCalibration& rig() const { return rig_; }
  const TrackingConfig& config() const { return config_; }

  /// The newest filtered pose of `body` (nullopt before the first frame set). Never blocks.
  std::optional<BodyPose> latest(int body) const;
  /// The slot itself, for readers that poll version().
  const LatestValue<BodyPose>& slot(int body) const;
  /// The pose of `body` predicted to time `t` (s, the poses' clock): the filtered pose
  /// extrapolated with the filter's velocities, at most filter.max_prediction_s ahead; its
  /// status becomes coasting/lost by age (coasting_s). Never blocks.
  BodyPose predict(int body, Timestamp t) const;
  /// Per camera (calibration order), as of time `now_s` (default: the tracker's clock now).
  std::vector<CameraStatus> camera_status(std::optional<Timestamp> now_s = std::nullopt) const;
  /// One camera's (index in camera_status() order; < camera_count()), at `now_s`: allocates nothing.
  CameraStatus camera_status(std::size_t camera, Timestamp now_s) const;
  /// Frame sets processed so far.
  std::uint64_t frames_processed() const { return processed_.load(std::memory_order_acquire); }
  /// Optional per-frame hook, called on the tracker thread after publishing (the tool writes
  /// poses.csv rows with it). Set before start().
  void on_frame(std::function<void(const FrameResult&)> hook) { hook_ = std::move(hook); }
  /// Optional raw hook, called on the tracker thread with every frame set as the source
  /// handed it over, before it is processed (a session recorder copies the images). It must
  /// not block. Set before start().
  void on_frame_set(std::function<void(const FrameSet&)> hook) { frame_set_hook_ = std::move(hook); }
  /// Processes one frame set on the caller's thread, as the tracker thread would (the thread
  /// must not run): replaying recorded camera frames in step with recorded display frames.
  /// The pose is published as ready at the set's own timestamp, on the recording's clock.
  void process(const FrameSet& frames);
  /// Runs the tracker thread under SCHED_FIFO at `priority` (1..99; 0 = the normal
  /// scheduler, the default), so rendering and decoding never hold a frame set back: its
  /// pose is ready about a millisecond after the set is due. Needs root, CAP_SYS_NICE or an
  /// rtprio limit (limits.conf); without them the tracker logs once why and runs normally.
  /// The thread sleeps between sets, so it cannot starve the machine. Set before start().
  void set_realtime_priority(int priority) { realtime_priority_ = priority; }

 private:
  struct Snapshot;  // filter state, trivially copyable
  struct Progress;  // what the loop carries from set to set
  void run();
  /// One frame set: process, publish poses and camera states. ready_override >= 0: the
  /// poses' ready_at (process()); < 0: measured (the thread).
  void handle(const FrameSet& frames, Timestamp ready_override);
  Timestamp clock_now() const;

  RigCalibration rig_;
  TrackingConfig config_;
  std::unique_ptr<Pipeline> pipeline_;
  std::unique_ptr<FrameSource> source_;
  std::vector<std::unique_ptr<LatestValue<BodyPose>>> poses_;
  struct SnapshotSlot;
  std::vector<std::unique_ptr<SnapshotSlot>> snapshots_;
  struct CameraSlot;
  std::vector<std::unique_ptr<CameraSlot>> cameras_;
  std::atomic<double> clock_offset_{0};  // tracker clock = now() + offset (recordings)
  std::atomic<bool> clock_is_source_{false};
  std::atomic<double> last_source_time_{0};
  std::function<void(const FrameResult&)> hook_;
  std::function<void(const FrameSet&)> frame_set_hook_;
  std::unique_ptr<Progress> progress_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> running_{false};
  std::atomic<std::uint64_t> processed_{0};
  int realtime_priority_ = 0;
};

}  // namespace kumite::tracking
