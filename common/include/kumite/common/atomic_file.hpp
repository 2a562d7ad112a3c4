#pragma once
// Nothing half-written: every output file is written to a temporary file beside it and
// renamed over the destination only once complete (rename is atomic on POSIX).
#include <filesystem>
#include <functional>
#include <ostream>
#include <string_view>

namespace kumite {

/// Writes `bytes` to `path` atomically. Throws kumite::Error("io", ...) naming the path.
void write_file_atomically(const std::filesystem::path& path, std::string_view bytes);

/// Calls `write` with a stream onto a temporary file, then renames it to `path`. If `write`
/// throws, the temporary file is removed and `path` is left untouched.
void write_file_atomically(const std::filesystem::path& path,
                           const std::function<void(std::ostream&)>& write);

/// A temporary path beside `path` keeping its extension (some writers, like OpenCV's
/// FileStorage, choose the format from the extension): "dir/.name.tmp-<pid>-<n>.ext".
std::filesystem::path temporary_path_beside(const std::filesystem::path& path);

/// Atomically moves `tmp` onto `path` (same directory). Throws kumite::Error on failure.
void commit_temporary(const std::filesystem::path& tmp, const std::filesystem::path& path);

/// If `path` exists, copies it to "<path>.<YYYYmmdd-HHMMSS>.bak" (a new name each time) and
/// returns that backup path; returns an empty path when there was nothing to keep.
std::filesystem::path keep_previous_version(const std::filesystem::path& path);

/// Appends `bytes` to the open file descriptor `fd` in as few write(2) calls as it takes (one
/// for a regular file; retried on EINTR and short writes), so a process killed between two
/// calls leaves whole records. Throws kumite::Error("io", "write", "<path>: cannot write (...)").
void write_all(int fd, std::string_view bytes, const std::filesystem::path& path);

}  // namespace kumite
