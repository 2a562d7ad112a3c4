#include "kumite/common/atomic_file.hpp"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <fstream>

#include "kumite/common/error.hpp"

namespace kumite {
namespace fs = std::filesystem;

fs::path temporary_path_beside(const fs::path& path) {
  static std::atomic<unsigned> counter{0};
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  return dir / fmt::format(".{}.tmp-{}-{}{}", path.stem().string(), ::getpid(), counter++,
                           path.extension().string());
}

void commit_temporary(const fs::path& tmp, const fs::path& path) {
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw Error("io", "rename", fmt::format("{}: cannot write: {}", path.string(), ec.message()));
  }
}

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
  fs::copy_file(path, backup, ec);
  if (ec) {
    throw Error("io", "backup",
                fmt::format("{}: cannot keep the previous version: {}", path.string(), ec.message()));
  }
  return backup;
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
