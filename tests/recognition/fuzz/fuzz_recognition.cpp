// libFuzzer target: the model readers (.krec, .klearn) and the poses.csv reader must turn any input into a
// value or a kumite::Error, never crash or hang; poses that parse are fed to a recogniser
// (a small SYNTHETIC model), which must take any finite stream. A model that parses is
// written back and must read back identically.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "kumite/common/error.hpp"
#include "kumite/recognition/learned.hpp"
#include "kumite/recognition/recognition.hpp"
#include "offline.hpp"

using namespace kumite::recognition;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const Model synthetic = offline::synthetic_model();
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const Model m = parse_model(text, "fuzz.krec");
    const std::string again = format_model(m);
    if (format_model(parse_model(again, "fuzz-out.krec")) != again) __builtin_trap();
  } catch (const kumite::Error&) {
  }
  try {
    (void)parse_learned_model(text, "fuzz.klearn");
  } catch (const kumite::Error&) {
  }
  try {
    const auto pf = kumite::recognition::parse_poses_csv(text, "fuzz.csv");
    (void)recognise(synthetic, pf.samples);
  } catch (const kumite::Error&) {
  }
  return 0;
}
