#pragma once
// A TOML basic string ("...") for any text: quotes, backslashes, newlines and other control
// characters escaped, so what a content writer writes reads back to the same text (shared by
// format_annotations and format_characters; fuzz_characters found notes with a newline written
// raw, which the reader then refused).
#include <string>
#include <string_view>

namespace kumite::content {
std::string toml_string(std::string_view s);
}  // namespace kumite::content
