#pragma once
// The tracker (tracking/) as the installation's TrackingInput: started on its own thread
// from the config's calibration, tracking.toml and recording (or live cameras); poll()
// reads the newest head pose without waiting and predicts it to the display time.
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "kumite/app/installation.hpp"

namespace kumite::tracking {
class FrameSource;
class Tracker;
struct TrackingConfig;
}

namespace kumite::app {

struct TrackingInputOptions {
  /// The frames step on a simulated clock (`kumite --headless --simulated-time`): a poses file
  /// and a camera recording follow it (poll(now) hands over what is due by `now`, and strike
  /// recognition runs on the caller's thread), so the same inputs give the same frames on any
  /// machine under any load. Live cameras stay on the wall clock.
  bool simulated_clock = false;
};

/// Builds the tracking input the config asks for. A tracker that cannot start (missing
/// recording, calibration) throws kumite::Error naming the file.
std::unique_ptr<TrackingInput> make_tracking_input(const InstallationConfig& config,
                                                   const TrackingInputOptions& options = {});
/// The same tracker on a frame source of the caller's (benchmarks, tests, replay from memory).
std::unique_ptr<TrackingInput> make_tracking_input(const InstallationConfig& config,
                                                   std::unique_ptr<tracking::FrameSource> source);

/// The index of the glasses' body in `tracking`: `[tracking] head_body` when given, else the
/// body named `head` (its role), else body 0 (with one warning naming tracking.toml's first
/// body). Throws kumite::Error (config, range) for a head_body that does not exist.
int head_body_index(const InstallationConfig& config, const tracking::TrackingConfig& tracking);

/// What a tracker says at `now` as the frame sees it: the head predicted to `display_time`
/// (its status as of now), the measurement it comes from, the cameras' states, where the tracker stands.
/// The live input's poll() and the replay's re-tracking build their snapshots through this.
struct TrackerReading {
  Timestamp last_measured = -1;  ///< carried from call to call: the newest tracked measurement
  Timestamp last_ready = -1;
  /// The tracker's body per role (recognition::Role; -1: none): the caller's, from
  /// role_bodies(); all -1 leaves TrackingSnapshot::bodies empty.
  std::array<int, recognition::kRoleCount> role_body{-1, -1, -1, -1, -1};
  /// Carried: per role, the newest pose the tracker measured (status tracked in its frame set).
  std::array<std::optional<BodyPose>, recognition::kRoleCount> measured{};
};
/// The tracker's body of each role: `head_body` (head_body_index: the glasses) for the head, and
/// the bodies tracking.toml names left_hand, right_hand, left_foot, right_foot (-1: no such body).
std::array<int, recognition::kRoleCount> role_bodies(int head_body, const tracking::TrackingConfig& tracking);
/// Fills `out` (its vectors' room reused: nothing allocated once warm). `out.bodies`: per role
/// of `carried.role_body`, the newest pose the tracker measured (a measurement missed between
/// two calls leaves the one before: its age then errs long), its status as of `now`
/// (Tracker::predict's: tracked, coasting, or lost past the body's coasting time).
void read_tracker(const tracking::Tracker& tracker, int head_body, Timestamp now, Timestamp display_time, bool threaded,
                  TrackerReading& carried, TrackingSnapshot& out);

}  // namespace kumite::app
