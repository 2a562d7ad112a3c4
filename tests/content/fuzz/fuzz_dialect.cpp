// libFuzzer target: the skeleton dialect reader (parse_dialect_toml) turns any input into a
// Dialect or a kumite::Error, never crashes, hangs or exhausts memory.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "kumite/common/error.hpp"
#include "kumite/content/canonical.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const auto d = kumite::content::parse_dialect_toml(text, "fuzz/dialect.toml");
    if (d.name.empty()) std::abort();  // a dialect always has a name
  } catch (const kumite::Error&) {
  }
  return 0;
}
