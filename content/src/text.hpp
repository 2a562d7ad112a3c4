// Small text helpers shared by the content library's sources (not a public header).
#pragma once

#include <cctype>
#include <string>
#include <string_view>

namespace kumite::content::detail {

/// `s` in ASCII lower case (joint names, BVH keywords).
inline std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

}  // namespace kumite::content::detail
