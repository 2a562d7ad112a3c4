#pragma once
// Time in Kumite: every per-frame datum carries a Timestamp, seconds on the steady clock
// (std::chrono::steady_clock), as a double. Recorded data keeps the recording's own
// timestamps (seconds from its start); live data uses now().
#include <chrono>
#include <thread>

namespace kumite {

/// Seconds on the steady clock (or a recording's clock). Never wall-clock time.
using Timestamp = double;

/// The current steady-clock time in seconds.
inline Timestamp now() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}

/// Sleeps until now() >= t (at once if it is past); a sleep that ends early sleeps again.
inline void sleep_until(Timestamp t) {
  while (now() < t) std::this_thread::sleep_for(std::chrono::duration<double>(t - now()));
}

}  // namespace kumite
