#pragma once
// This checkout's folders, for tests, benchmarks and kumite-recognise's defaults (never the
// installation: it is told its files). The paths are compiled into one generated source
// (build_paths.cpp.in, the library kumite_build_paths) rather than into every source that
// names them, so those sources compile to the same object in any clone and ccache serves CI,
// which builds a fresh clone in a folder of its own. Targets that link kumite_build_paths get
// this header force-included (cmake/KumiteTargets.cmake): the macros below read as the old
// string defines did, as std::string (`KUMITE_SOURCE_DIR + "/config/demo.toml"`).
#include <string>

namespace kumite::build_paths {
const std::string& source_dir();       ///< the checkout (PROJECT_SOURCE_DIR)
const std::string& binary_dir();       ///< the build folder (PROJECT_BINARY_DIR)
const std::string& shared_data_dir();  ///< ../shared/data beside the checkout (KUMITE_SHARED_DATA_DIR)
}  // namespace kumite::build_paths

#define KUMITE_SOURCE_DIR (::kumite::build_paths::source_dir())
#define KUMITE_BINARY_DIR (::kumite::build_paths::binary_dir())
#define KUMITE_SHARED_DATA_DIR (::kumite::build_paths::shared_data_dir())
