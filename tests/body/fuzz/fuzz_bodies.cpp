// libFuzzer target: the bodies catalog reader (parse_bodies, bodies.toml) turns any input into
// a catalog or a kumite::Error, never crashes, hangs or exhausts memory.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "kumite/body/catalog.hpp"
#include "kumite/common/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    (void)kumite::body::parse_bodies(text, "fuzz/bodies.toml");
  } catch (const kumite::Error&) {
  }
  return 0;
}
