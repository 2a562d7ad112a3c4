#include "kumite/common/atomic_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cctype>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <fstream>
#include <mutex>
#include <set>

#include <spdlog/spdlog.h>

#include "kumite/common/error.hpp"

namespace kumite {
namespace fs = std::filesystem;

namespace {
/// The first time a process writes into a folder, the temporaries that killed writers left
/// there go (one warning line naming them): every tool cleans up after its own kind at its next
/// start, not only kumite.
void sweep_once(const fs::path& dir) {
  static std::mutex mutex;
  static std::set<std::string> swept;
  {
    std::lock_guard lock(mutex);
    if (!swept.insert(dir.string()).second) return;
  }
  const auto removed = remove_stale_temporaries(dir);
  if (removed.empty()) return;
  std::string names;
  for (const auto& r : removed) names += (names.empty() ? "" : ", ") + r.filename().string();
  spdlog::warn("removed {} temporary file{} left by killed runs in {}: {}", removed.size(), removed.size() == 1 ? "" : "s",
               dir.string(), names);
}
}  // namespace

namespace {
std::function<void(const std::string&)>& observer() {
  static std::function<void(const std::string&)> f;
  return f;
}
}  // namespace

void observe_durable_writes(std::function<void(const std::string&)> f) { observer() = std::move(f); }

void sync_path(const fs::path& path) {
  int fd = -1;
  do fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  while (fd < 0 && errno == EINTR);
  if (fd < 0) throw Error("io", "sync", fmt::format("{}: cannot open to sync: {}", path.string(), std::strerror(errno)));
  int rc = 0;
  do rc = ::fsync(fd);
  while (rc != 0 && errno == EINTR);
  const int err = errno;
  ::close(fd);
  // A folder on a file system that cannot sync folders (EINVAL) has nothing more to do.
  if (rc != 0 && !(err == EINVAL && fs::is_directory(path)))
    throw Error("io", "sync", fmt::format("{}: cannot sync to disk: {}", path.string(), std::strerror(err)));
  if (observer()) observer()("sync " + path.string());
}

fs::path temporary_path_beside(const fs::path& path) {
  static std::atomic<unsigned> counter{0};
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  sweep_once(dir);
  return dir / fmt::format(".{}.tmp-{}-{}{}", path.stem().string(), ::getpid(), counter++,
                           path.extension().string());
}

namespace {
/// rename(tmp, path) between a sync of the file and one of its folder (see commit_temporary).
void durable_rename(const fs::path& tmp, const fs::path& path, std::string_view what) {
  std::error_code ec;
  try {
    sync_path(tmp);
  } catch (...) {
    fs::remove(tmp, ec);
    throw;
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw Error("io", "rename", fmt::format("{}: cannot {}: {}", path.string(), what, ec.message()));
  }
  if (observer()) observer()("rename " + tmp.string() + " -> " + path.string());
  sync_path(path.has_parent_path() ? path.parent_path() : fs::path("."));
}
}  // namespace

void commit_temporary(const fs::path& tmp, const fs::path& path) { durable_rename(tmp, path, "write"); }

void write_file_atomically(const fs::path& path, const std::function<void(std::ostream&)>& write) {
  const fs::path tmp = temporary_path_beside(path);
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) {
      throw Error("io", "open",
                  fmt::format("{}: cannot write: {}", path.string(), std::strerror(errno)));
    }
    try {
      write(out);
      out.flush();
      if (!out) throw Error("io", "write", fmt::format("{}: write failed", path.string()));
    } catch (...) {
      out.close();
      std::error_code ec;
      fs::remove(tmp, ec);
      throw;
    }
  }
  commit_temporary(tmp, path);
}

void write_file_atomically(const fs::path& path, std::string_view bytes) {
  write_file_atomically(path, [&](std::ostream& out) {
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  });
}

fs::path keep_previous_version(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return {};
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  localtime_r(&t, &tm);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", &tm);
  fs::path backup = path;
  backup += fmt::format(".{}.bak", stamp);
  for (int n = 1; fs::exists(backup, ec); ++n) {
    backup = path;
    backup += fmt::format(".{}-{}.bak", stamp, n);
  }
  // Copied beside it under a temporary name, then renamed: never a half (or 0-byte) backup.
  const fs::path tmp = temporary_path_beside(backup);
  fs::copy_file(path, tmp, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw Error("io", "backup",
                fmt::format("{}: cannot keep the previous version: {}", path.string(), ec.message()));
  }
  durable_rename(tmp, backup, "keep the previous version");
  return backup;
}

bool is_temporary_name(const std::string& name, long* pid) {
  // ".<stem>.tmp-<pid>-<n><ext>": the stem may itself hold dots, so look for the last ".tmp-".
  if (name.size() < 8 || name[0] != '.') return false;
  const auto at = name.rfind(".tmp-");
  if (at == std::string::npos || at == 0) return false;
  std::size_t i = at + 5, digits = 0;
  long p = 0;
  for (; i < name.size() && std::isdigit(static_cast<unsigned char>(name[i])) && digits < 10; ++i, ++digits)
    p = p * 10 + (name[i] - '0');
  if (digits == 0 || i >= name.size() || name[i] != '-') return false;
  std::size_t n = 0;
  for (++i; i < name.size() && std::isdigit(static_cast<unsigned char>(name[i])); ++i) ++n;
  if (n == 0 || (i < name.size() && name[i] != '.')) return false;
  if (pid) *pid = p;
  return p > 0;
}

std::vector<fs::path> remove_stale_temporaries(const fs::path& dir) {
  std::vector<fs::path> removed;
  std::error_code ec;
  fs::directory_iterator it(dir, ec), end;
  for (; !ec && it != end; it.increment(ec)) {
    long pid = 0;
    if (!is_temporary_name(it->path().filename().string(), &pid)) continue;
    if (!it->is_regular_file(ec)) continue;
    // Gone: no such process (EPERM means it exists under another user: leave it).
    if (pid == ::getpid() || ::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;
    std::error_code rm;
    if (fs::remove(it->path(), rm)) removed.push_back(it->path());
  }
  return removed;
}

void write_all(int fd, std::string_view bytes, const std::filesystem::path& path) {
  const char* p = bytes.data();
  std::size_t left = bytes.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0)
      throw Error("io", "write", fmt::format("{}: cannot write ({})", path.string(), n < 0 ? std::strerror(errno) : "no progress"));
    p += n;
    left -= static_cast<std::size_t>(n);
  }
}

}  // namespace kumite
