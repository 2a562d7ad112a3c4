// libFuzzer target: the installation file reader (parse_installation_config, which also
// validates) turns any input into a config or a kumite::Error, never crashes, hangs or
// exhausts memory. A config it accepts is written back with to_toml, and that text reads
// back to the same text (a fixed point).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "kumite/app/config.hpp"
#include "kumite/common/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  kumite::app::InstallationConfig config;
  try {
    config = kumite::app::parse_installation_config(text, "/fuzz/installation.toml");
  } catch (const kumite::Error&) {
    return 0;
  }
  const std::string out = kumite::app::to_toml(config);
  try {
    const auto back = kumite::app::parse_installation_config(out, "/fuzz/installation.toml");
    if (kumite::app::to_toml(back) != out) std::abort();
  } catch (const kumite::Error&) {
    std::abort();  // the writer wrote what the reader refuses
  }
  return 0;
}
