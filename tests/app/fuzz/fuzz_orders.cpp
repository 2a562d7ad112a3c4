// libFuzzer target: the supervisor's orders script reader (parse_orders_script) turns any
// input into orders or a kumite::Error, never crashes or hangs; the orders it returns have
// finite, non-negative times in order.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "kumite/app/orders.hpp"
#include "kumite/common/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const auto orders = kumite::app::parse_orders_script(text, "fuzz/orders.csv");
    double last = 0;
    for (const auto& o : orders) {
      if (!std::isfinite(o.time) || o.time < last) std::abort();
      last = o.time;
    }
  } catch (const kumite::Error&) {
  }
  return 0;
}
