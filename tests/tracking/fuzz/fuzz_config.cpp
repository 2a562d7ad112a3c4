// Fuzzes the tracking.toml reader: parse or throw kumite::Error, never crash; a parsed config
// always has a body with >= 3 markers.
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "kumite/common/error.hpp"
#include "kumite/tracking/config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const auto c = kumite::tracking::parse_tracking_config(text, "fuzz.toml");
    if (c.bodies.empty() || c.bodies[0].markers.size() < 3) std::abort();
  } catch (const kumite::Error&) {
  }
  return 0;
}
