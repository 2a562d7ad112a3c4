// libFuzzer target: the characters.toml reader (parse_characters) turns any input into a
// catalog or a kumite::Error, never crashes, hangs or exhausts memory; format_characters
// writes back what it read, and that text reads back to the same text.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "kumite/common/error.hpp"
#include "kumite/content/character.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  kumite::content::CharacterCatalog catalog;
  try {
    catalog = kumite::content::parse_characters(text, "fuzz/characters.toml");
  } catch (const kumite::Error&) {
    return 0;
  }
  const std::string out = kumite::content::format_characters(catalog);
  try {
    const auto back = kumite::content::parse_characters(out, "fuzz/characters-out.toml");
    if (kumite::content::format_characters(back) != out) std::abort();
  } catch (const kumite::Error&) {
    std::abort();  // the writer wrote what the reader refuses
  }
  return 0;
}
