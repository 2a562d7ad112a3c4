// Fuzzes the recording readers: frames.csv (first byte even) or truth.csv (odd). Every input
// must parse or throw kumite::Error; parsed rows must be ordered and finite.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "kumite/common/error.hpp"
#include "kumite/tracking/recording.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  try {
    if (data[0] % 2 == 0) {
      const auto idx = kumite::tracking::parse_frames_csv(text);
      for (std::size_t i = 1; i < idx.rows.size(); ++i) {
        if (idx.rows[i].frame <= idx.rows[i - 1].frame || idx.rows[i].timestamp < idx.rows[i - 1].timestamp) std::abort();
      }
      for (const auto& r : idx.rows) if (!std::isfinite(r.timestamp)) std::abort();
    } else {
      const auto t = kumite::tracking::parse_truth_csv(text);
      for (const auto& r : t.rows) {
        const double n = r.qw * r.qw + r.qx * r.qx + r.qy * r.qy + r.qz * r.qz;
        if (std::abs(n - 1) > 1e-9 || !std::isfinite(r.x + r.y + r.z)) std::abort();
        if (t.find(r.frame) == nullptr) std::abort();
      }
    }
  } catch (const kumite::Error&) {
  }
  return 0;
}
