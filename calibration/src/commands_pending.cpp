// Temporary: sub-commands not written yet (removed as each lands).
#include "kumite/calibration/commands.hpp"
#include "kumite/common/error.hpp"
namespace kumite::calibration {
void run_wand(const WandCommand&) { throw Error("calibration", "todo", "wand: not implemented yet"); }
}
