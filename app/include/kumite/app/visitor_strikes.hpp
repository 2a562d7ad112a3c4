#pragma once
// The visitor's strikes (issue 14), as the installation sees them: every pose sample of the
// tracked bodies named by a role (head, left_hand, right_hand, left_foot, right_foot) goes, in
// order, through a lock-free queue to a recognition thread (kumite::recognition, dual-buffer
// DTW); its events come back through another queue as plain data, and a frame takes them
// (TrackingSnapshot::strikes) without waiting. A frame's strikes are part of what a session
// records, so a replay gives the same frames without the recogniser.
#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "kumite/common/time.hpp"
#include "kumite/recognition/recognition.hpp"

namespace kumite::app {

/// One recognition event (recognition::Event as plain, trivially copyable data).
struct VisitorStrike {
  /// s, tracker clock: the camera time of the pose sample whose arrival decided it.
  Timestamp t = 0;
  /// s, tracker clock: when the recognition thread published it (decided_at - t: camera frame
  /// to event, the end-to-end latency).
  Timestamp decided_at = -1;
  recognition::EventType type = recognition::EventType::begin;
  recognition::Role limb = recognition::Role::right_hand;
  recognition::Action action = recognition::Action::other;
  double progress = 0;    ///< 0..1, onset to full extension
  double confidence = 0;  ///< 0..1
  std::array<double, 3> impact{0, 0, 0};  ///< m, room frame: where the fist or foot will be at full extension
  bool operator==(const VisitorStrike&) const = default;
};

/// What the recognition thread has done so far (the console's line).
struct RecognitionStats {
  bool running = false;        ///< a recogniser is behind the tracking input
  std::uint64_t samples = 0;   ///< pose samples it has taken
  std::uint64_t dropped = 0;   ///< samples the full queue turned away (the recogniser behind)
  std::uint64_t events = 0;    ///< events it published
  std::uint64_t events_dropped = 0;  ///< events lost because no frame took them in time
  bool operator==(const RecognitionStats&) const = default;
};

/// The recognition thread. One producer thread calls push()/restart() (the tracker's, or the
/// poses file's), one consumer takes() (the frame loop); neither ever waits.
class StrikeRecognition {
 public:
  /// Starts the thread. `what` names the model in logs. `inline_on_caller` (a source on the
  /// simulated clock): no thread; each push()/end_of_set()/restart() is recognised at once on
  /// the caller's thread and its events are decided at their own time (decided_at = the
  /// sample's t), so a run's events depend on its inputs alone, never on the machine's load.
  StrikeRecognition(recognition::Model model, std::string what, bool inline_on_caller = false);
  ~StrikeRecognition();  ///< stops and joins the thread
  StrikeRecognition(const StrikeRecognition&) = delete;
  StrikeRecognition& operator=(const StrikeRecognition&) = delete;

  /// Producer: one pose sample (time order per role). A full queue drops it (counted).
  void push(const recognition::PoseSample& sample) noexcept;
  /// Producer: every sample up to `t` was pushed (the tracker's frame set is whole): the
  /// recogniser's loops up to t run now rather than at the next set's first sample.
  void end_of_set(Timestamp t) noexcept;
  /// Producer: the stream ended or jumps (a looped poses file starts again) at `t`: strikes
  /// under way are cancelled and the recogniser starts afresh.
  void restart(Timestamp t) noexcept;
  /// Consumer: appends the events published since the last call (never waits; `out` keeps its room).
  void take(std::vector<VisitorStrike>& out);
  RecognitionStats stats() const;
  /// Waits (tests, tools; never the frame loop) until every sample pushed so far was recognised.
  void drain_for_tests() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// "right_hand straight_punch begin, 40 %, confidence 0.62, impact (0.10, 1.52, -0.61) m, decided 3 ms after its frame set".
std::string describe(const VisitorStrike& s);

}  // namespace kumite::app
