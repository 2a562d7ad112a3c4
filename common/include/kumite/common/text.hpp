#pragma once
// Small text helpers shared by the line-oriented parsers (orders over the wire, order scripts).
#include <string_view>

namespace kumite {

/// s without leading blanks (space, tab) and trailing blanks or a carriage return (a CSV
/// saved on Windows).
inline std::string_view trim_blanks(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

/// s without a leading UTF-8 byte-order mark (EF BB BF: what a spreadsheet's "CSV UTF-8" and
/// Windows' Notepad put before the first byte; invisible, it would make the first field wrong).
inline std::string_view without_utf8_bom(std::string_view s) {
  if (s.size() >= 3 && s[0] == '\xEF' && s[1] == '\xBB' && s[2] == '\xBF') s.remove_prefix(3);
  return s;
}

}  // namespace kumite
