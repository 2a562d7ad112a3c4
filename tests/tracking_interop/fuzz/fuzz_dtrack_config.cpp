// Fuzzes the [dtrack] table reader: parse or throw kumite::Error, never crash; a parsed room
// rotation is a rotation and no two roles share a body id.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "kumite/common/error.hpp"
#include "kumite/tracking/interop.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const auto c = kumite::tracking::parse_dtrack_config(text, "fuzz.toml");
    const auto& r = c.room.rotation;
    const double det = r[0] * (r[4] * r[8] - r[5] * r[7]) - r[1] * (r[3] * r[8] - r[5] * r[6]) +
                       r[2] * (r[3] * r[7] - r[4] * r[6]);
    if (!(std::abs(det - 1) < 1e-9)) std::abort();
    for (std::size_t i = 0; i < c.role_body.size(); ++i)
      for (std::size_t j = i + 1; j < c.role_body.size(); ++j)
        if (c.role_body[i] >= 0 && c.role_body[i] == c.role_body[j]) std::abort();
  } catch (const kumite::Error&) {
  }
  return 0;
}
