#include "kumite/common/realtime.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>

#include <malloc.h>
#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace kumite {

namespace {
/// bytes: allocations below this come from the heap, not from their own mmap (glibc's
/// default starts at 128 kB, under one camera image).
constexpr int kMmapThreshold = 64 << 20;
/// bytes: free memory at the heap's top kept instead of trimmed back to the kernel.
constexpr int kTrimThreshold = 512 << 20;
/// malloc arenas at most: each keeps its own freed memory (up to kTrimThreshold), so more
/// arenas, made when threads contend under load, raise the resident high-water mark. 10-minute
/// soaks side by side under two busy loops (26 Nov): default arenas 263 -> 267 MB after
/// warm-up (+1.6 %), MALLOC_ARENA_MAX=2 270.4 MB flat to the kB.
constexpr int kArenaMax = 2;
}  // namespace

std::optional<int> lower_this_thread_priority(int by) {
  if (by <= 0) return std::nullopt;
  const auto tid = static_cast<id_t>(::syscall(SYS_gettid));
  errno = 0;
  const int now_nice = ::getpriority(PRIO_PROCESS, tid);
  if (errno != 0) return std::nullopt;
  const int nice = std::min(19, now_nice + by);
  if (::setpriority(PRIO_PROCESS, tid, nice) != 0) return std::nullopt;
  return nice;
}

std::string run_this_thread_realtime(int priority) {
  sched_param param{};
  param.sched_priority = std::clamp(priority, sched_get_priority_min(SCHED_FIFO), sched_get_priority_max(SCHED_FIFO));
  const int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
  return err == 0 ? std::string() : std::string(std::strerror(err));
}

bool keep_freed_memory() {
  const bool a = mallopt(M_MMAP_THRESHOLD, kMmapThreshold) == 1;
  const bool b = mallopt(M_TRIM_THRESHOLD, kTrimThreshold) == 1;
  const bool c = mallopt(M_ARENA_MAX, kArenaMax) == 1;
  return a && b && c;
}

MemoryFigures memory_figures() {
  const auto t0 = std::chrono::steady_clock::now();
  MemoryFigures m;
  constexpr double kMb = 1024.0 * 1024.0;
  if (std::FILE* f = std::fopen("/proc/self/statm", "r")) {
    unsigned long size = 0, resident = 0;
    if (std::fscanf(f, "%lu %lu", &size, &resident) == 2)
      m.rss_mb = static_cast<double>(resident) * static_cast<double>(::sysconf(_SC_PAGESIZE)) / kMb;
    std::fclose(f);
  }
  const struct mallinfo2 mi = ::mallinfo2();
  m.allocator_known = mi.arena != 0 || mi.hblkhd != 0 || mi.uordblks != 0;
  m.in_use_mb = static_cast<double>(mi.uordblks + mi.hblkhd) / kMb;
  m.held_mb = static_cast<double>(mi.arena + mi.hblkhd) / kMb;
  m.took_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return m;
}

}  // namespace kumite
