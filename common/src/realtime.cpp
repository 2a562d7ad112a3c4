#include "kumite/common/realtime.hpp"

#include <malloc.h>

namespace kumite {

namespace {
/// bytes: allocations below this come from the heap, not from their own mmap (glibc's
/// default starts at 128 kB, under one camera image).
constexpr int kMmapThreshold = 64 << 20;
/// bytes: free memory at the heap's top kept instead of trimmed back to the kernel.
constexpr int kTrimThreshold = 512 << 20;
}  // namespace

bool keep_freed_memory() {
  const bool a = mallopt(M_MMAP_THRESHOLD, kMmapThreshold) == 1;
  const bool b = mallopt(M_TRIM_THRESHOLD, kTrimThreshold) == 1;
  return a && b;
}

}  // namespace kumite
