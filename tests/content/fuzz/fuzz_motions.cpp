// libFuzzer target: the motions.toml reader (parse_annotations) turns any input into an
// AnnotationSet or a kumite::Error, never crashes, hangs or exhausts memory. What it reads,
// format_annotations writes back, and that text reads back to the same text (a fixed point).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "kumite/common/error.hpp"
#include "kumite/content/annotation.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  kumite::content::AnnotationSet set;
  try {
    set = kumite::content::parse_annotations(text, "fuzz/motions.toml");
  } catch (const kumite::Error&) {
    return 0;
  }
  const std::string out = kumite::content::format_annotations(set);
  try {
    const auto back = kumite::content::parse_annotations(out, "fuzz/motions-out.toml");
    if (kumite::content::format_annotations(back) != out) std::abort();
  } catch (const kumite::Error&) {
    std::abort();  // the writer wrote what the reader refuses
  }
  return 0;
}
