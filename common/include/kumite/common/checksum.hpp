#pragma once
// FNV-1a 64 (standard offset basis and prime): the checksum of session files, snapshots and
// camera frame records. Incremental: pass the previous value to continue over more bytes.
// (The motion database and recognition model files use their own variant, with an offset
// basis one digit short; changing it would invalidate the shipped files' checksums.)
#include <cstddef>
#include <cstdint>
#include <string_view>

namespace kumite {

inline constexpr std::uint64_t kFnv1a64Offset = 14695981039346656037ull;
inline constexpr std::uint64_t kFnv1a64Prime = 1099511628211ull;

inline std::uint64_t fnv1a64(const void* data, std::size_t n, std::uint64_t h = kFnv1a64Offset) {
  const auto* b = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < n; ++i) h = (h ^ b[i]) * kFnv1a64Prime;
  return h;
}
inline std::uint64_t fnv1a64(std::string_view s, std::uint64_t h = kFnv1a64Offset) {
  return fnv1a64(s.data(), s.size(), h);
}

}  // namespace kumite
