// The tracker behind TrackingInput. TEMPORARY until branch tracking is merged: no tracker
// in this build, so the head stays at the configured default and the console says why.
#include "kumite/app/tracking_input.hpp"

namespace kumite::app {

std::unique_ptr<TrackingInput> make_tracking_input(const InstallationConfig& config) {
  if (config.tracking.source == TrackingSource::none)
    return make_fixed_head_input("tracking.source = \"none\"");
  return make_fixed_head_input("no tracker in this build");
}

}  // namespace kumite::app
