#pragma once
// Console logging for tools and the installation: spdlog, one line per message, to stderr.
#include <spdlog/spdlog.h>

namespace kumite {
/// Sets up the default logger ("[hh:mm:ss.mmm] [level] message" on stderr). verbosity:
/// 0 = warnings and errors, 1 = info (default), 2 = debug.
void init_logging(int verbosity = 1);
}  // namespace kumite
