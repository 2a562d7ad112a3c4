#include "kumite/app/run.hpp"
#include "kumite/common/error.hpp"
namespace kumite::app {
int run_windows(Installation&, const WindowOptions&) { throw Error("app", "todo", "windows not yet"); }
}
