#include "kumite/common/log.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>

namespace kumite {
void init_logging(int verbosity) {
  spdlog::drop("kumite");
  auto logger = spdlog::stderr_color_mt("kumite");
  logger->set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
  logger->set_level(verbosity <= 0 ? spdlog::level::warn
                    : verbosity == 1 ? spdlog::level::info
                                     : spdlog::level::debug);
  spdlog::set_default_logger(logger);
}
}  // namespace kumite
