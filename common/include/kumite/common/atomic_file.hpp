#pragma once
// Nothing half-written: every output file is written to a temporary file beside it and
// renamed over the destination only once complete (rename is atomic on POSIX). Durable too:
// the temporary file is fsync'ed before the rename and its folder after it, so after a power
// cut the path holds the old content or the new, whole (a kill alone never needed the syncs).
#include <filesystem>
#include <functional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

namespace kumite {

/// Writes `bytes` to `path` atomically. Throws kumite::Error("io", ...) naming the path.
void write_file_atomically(const std::filesystem::path& path, std::string_view bytes);

/// Calls `write` with a stream onto a temporary file, then renames it to `path`. If `write`
/// throws, the temporary file is removed and `path` is left untouched.
void write_file_atomically(const std::filesystem::path& path,
                           const std::function<void(std::ostream&)>& write);

/// A temporary path beside `path` keeping its extension (some writers, like OpenCV's
/// FileStorage, choose the format from the extension): "dir/.name.tmp-<pid>-<n>.ext". The first
/// call for a folder in a process also removes the temporaries of writers that are gone
/// (remove_stale_temporaries), with one warning line when there were any.
std::filesystem::path temporary_path_beside(const std::filesystem::path& path);

/// Atomically and durably moves `tmp` onto `path` (same directory): fsync(tmp), rename,
/// fsync(the folder). Throws kumite::Error on failure (tmp removed, `path` untouched).
void commit_temporary(const std::filesystem::path& tmp, const std::filesystem::path& path);

/// fsync(2) on `path` (a file or a folder), so what was written to it survives a power cut.
/// Throws kumite::Error("io", "sync") naming it.
void sync_path(const std::filesystem::path& path);

/// What the durable writes do, in order ("sync <path>", "rename <from> -> <to>"), handed to
/// `observer` as they happen (tests; nullptr: none). Not thread-safe to set while writing.
void observe_durable_writes(std::function<void(const std::string&)> observer);

/// If `path` exists, copies it to "<path>.<YYYYmmdd-HHMMSS>.bak" (a new name each time) and
/// returns that backup path; returns an empty path when there was nothing to keep. The copy
/// goes through a temporary file renamed into place: a backup is complete or absent (a
/// process killed mid-copy leaves a temporary that remove_stale_temporaries() clears).
std::filesystem::path keep_previous_version(const std::filesystem::path& path);

/// Whether `name` is a temporary file name temporary_path_beside() makes
/// (".<stem>.tmp-<pid>-<n><ext>"); its pid is stored in `pid` when given.
bool is_temporary_name(const std::string& name, long* pid = nullptr);

/// Removes the temporary files (temporary_path_beside's names) in `dir` whose writing process
/// is gone: leftovers of runs killed with SIGKILL or by a power cut. A temporary of a live
/// process (another run writing now) is left alone. Returns the removed paths; a folder that
/// does not exist or cannot be read gives none. Never throws.
std::vector<std::filesystem::path> remove_stale_temporaries(const std::filesystem::path& dir);

/// Appends `bytes` to the open file descriptor `fd` in as few write(2) calls as it takes (one
/// for a regular file; retried on EINTR and short writes), so a process killed between two
/// calls leaves whole records. Throws kumite::Error("io", "write", "<path>: cannot write (...)").
void write_all(int fd, std::string_view bytes, const std::filesystem::path& path);

}  // namespace kumite
