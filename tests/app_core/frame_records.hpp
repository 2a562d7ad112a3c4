#pragma once
// The records of a frame states stream (app/src/core/frame_states.cpp: u32 magic "KST1", u32
// payload bytes, u64 FNV-1a of the payload; the payload a u32 raw size and the raw bytes
// deflated), packed and unpacked by hand for tests that pin or damage them: shared by
// tests/app_core and tests/app.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "kumite/common/checksum.hpp"

namespace kumite::app::test {

/// A record around `raw` (what a record holds before it is packed), as frame_states.cpp writes it.
inline std::string pack_record(std::string_view raw) {
  uLongf packed = compressBound(static_cast<uLong>(raw.size()));
  std::string z(packed, '\0');
  EXPECT_EQ(compress2(reinterpret_cast<Bytef*>(z.data()), &packed, reinterpret_cast<const Bytef*>(raw.data()),
                      static_cast<uLong>(raw.size()), 1),
            Z_OK);
  z.resize(packed);
  std::string payload(4, '\0');
  const auto n = static_cast<std::uint32_t>(raw.size());
  std::memcpy(payload.data(), &n, 4);
  payload += z;
  std::string out(16, '\0');
  const std::uint32_t magic = 0x3154534B, bytes = static_cast<std::uint32_t>(payload.size());
  const std::uint64_t sum = kumite::fnv1a64(payload);
  std::memcpy(out.data(), &magic, 4);
  std::memcpy(out.data() + 4, &bytes, 4);
  std::memcpy(out.data() + 8, &sum, 8);
  return out + payload;
}

/// The records of a stream of them, unpacked (each: its kind byte, then its contents).
inline std::vector<std::string> unpack_records(std::string_view s) {
  std::vector<std::string> out;
  while (s.size() >= 20) {
    std::uint32_t bytes = 0, raw = 0;
    std::memcpy(&bytes, s.data() + 4, 4);
    std::memcpy(&raw, s.data() + 16, 4);
    std::string p(raw, '\0');
    uLongf n = raw;
    EXPECT_EQ(uncompress(reinterpret_cast<Bytef*>(p.data()), &n, reinterpret_cast<const Bytef*>(s.data() + 20), bytes - 4),
              Z_OK);
    out.push_back(std::move(p));
    s.remove_prefix(16 + bytes);
  }
  EXPECT_TRUE(s.empty());
  return out;
}

}  // namespace kumite::app::test
