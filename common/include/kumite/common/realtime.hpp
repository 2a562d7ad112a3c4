#pragma once
// Scheduling and memory settings for the programs that run the tracker in real time
// (kumite, kumite-track, the pose-age bench). Linux.
#include <optional>
#include <string>

namespace kumite {

/// Lowers the calling thread's priority by `by` nice steps (per-thread nice values; at most
/// 19). Returns the new nice value, or nullopt when `by` <= 0 or the system refused.
std::optional<int> lower_this_thread_priority(int by);

/// Runs the calling thread under SCHED_FIFO at `priority` (clamped to the system's range).
/// Returns "" on success, else why not (e.g. "Operation not permitted": needs root,
/// CAP_SYS_NICE or an rtprio limit).
std::string run_this_thread_realtime(int priority);

/// Tells the allocator to keep freed memory instead of returning it to the kernel, so the
/// camera-sized buffers a frame set allocates and frees (4 x 1.3 MB, 60 times a second) come
/// from memory already mapped. Without it each set cost mmap/munmap calls and fresh page
/// faults, which the tracker thread, even at real-time priority, can stall behind: in a
/// kumite_app_pose_age run without it two frame sets took 22 and 31 ms to process (1-2 ms
/// as a rule); in the same run with it, none took over 5 ms. It also bounds the allocator to a
/// few arenas, each of which would keep its own freed memory (realtime.cpp: kArenaMax).
/// Returns false if the allocator refused (the program runs on, just with those stalls).
bool keep_freed_memory();

/// This process's memory as the allocator sees it beside the kernel's count: with
/// keep_freed_memory() the resident set is the high-water mark of what was ever in use (freed
/// memory is kept for reuse), so a growing RSS alone does not tell a leak from a rarer
/// transient peak; `in_use_mb` is what is allocated now. mallinfo2() walks every arena under its
/// lock: call it about once a second at most, off the frame thread (~`took_ms`).
struct MemoryFigures {
  double rss_mb = 0;      ///< MB (2^20 B), resident set (/proc/self/statm); 0 when unreadable
  double in_use_mb = 0;   ///< MB, allocated and not freed (mallinfo2: uordblks + hblkhd)
  double held_mb = 0;     ///< MB, the allocator's arenas and mmapped blocks (arena + hblkhd)
  /// false: the allocator does not say (mallinfo2 all zero: a sanitizer's allocator replaces
  /// glibc's); in_use_mb and held_mb are then 0 and mean nothing.
  bool allocator_known = false;
  double took_ms = 0;     ///< ms, the time these took
};
MemoryFigures memory_figures();

}  // namespace kumite
