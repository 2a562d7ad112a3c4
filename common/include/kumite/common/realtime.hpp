#pragma once
// Process-wide settings for the programs that run the tracker in real time (kumite,
// kumite-track): call once at the start of main, before threads start.

namespace kumite {

/// Tells the allocator to keep freed memory instead of returning it to the kernel, so the
/// camera-sized buffers a frame set allocates and frees (4 x 1.3 MB, 60 times a second) come
/// from memory already mapped. Without it each set cost mmap/munmap calls and fresh page
/// faults, which the tracker thread, even at real-time priority, can stall behind: in a
/// kumite_app_pose_age run without it two frame sets took 22 and 31 ms to process (1-2 ms
/// as a rule); in the same run with it, none took over 5 ms.
/// Returns false if the allocator refused (the program runs on, just with those stalls).
bool keep_freed_memory();

}  // namespace kumite
