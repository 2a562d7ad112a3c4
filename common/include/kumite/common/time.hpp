#pragma once
// Time in Kumite: every per-frame datum carries a Timestamp, seconds on the steady clock
// (std::chrono::steady_clock), as a double. Recorded data keeps the recording's own
// timestamps (seconds from its start); live data uses now().
#include <chrono>
#include <ctime>
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

/// Seconds of CPU the calling thread has run (POSIX CLOCK_THREAD_CPUTIME_ID). Beside now(),
/// it tells working from waiting: on a virtual machine, time the hypervisor gives to others
/// passes on now() but not here.
inline double thread_cpu_time() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

}  // namespace kumite
