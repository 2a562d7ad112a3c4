#pragma once
// The tracker (tracking/) as the installation's TrackingInput: started on its own thread
// from the config's calibration, tracking.toml and recording (or live cameras); poll()
// reads the newest head pose without waiting and predicts it to the display time.
#include <memory>

#include "kumite/app/installation.hpp"

namespace kumite::tracking {
class FrameSource;
}

namespace kumite::app {

/// Builds the tracking input the config asks for. A tracker that cannot start (missing
/// recording, calibration) throws kumite::Error naming the file.
std::unique_ptr<TrackingInput> make_tracking_input(const InstallationConfig& config);
/// The same tracker on a frame source of the caller's (benchmarks, tests, replay from memory).
std::unique_ptr<TrackingInput> make_tracking_input(const InstallationConfig& config,
                                                   std::unique_ptr<tracking::FrameSource> source);

}  // namespace kumite::app
