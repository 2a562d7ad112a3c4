#pragma once
// A TOML basic string ("...") for any text: quotes, backslashes, newlines and other control
// characters escaped, so what a content writer writes reads back to the same text (shared by
// format_annotations and format_characters; fuzz_characters found notes with a newline written
// raw, which the reader then refused).
#include <string>
#include <string_view>

namespace kumite::content {
std::string toml_string(std::string_view s);
/// A TOML float that reads back to the same double (shortest round-trip digits, always with a
/// decimal point: 1.84, 1.0001, 2.0); fuzz_characters found scales written with 3 decimals
/// (1.0001 -> "1.000"), which then read back as another value.
std::string toml_number(double v);
}  // namespace kumite::content
