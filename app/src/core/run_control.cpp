// What both runners share around their frame loop: stopping on SIGINT/SIGTERM, and output
// folders made (or refused) before a run starts.
#include <unistd.h>

#include <csignal>
#include <cerrno>
#include <cstring>
#include <system_error>

#include <fmt/format.h>

#include "kumite/app/run_control.hpp"
#include "kumite/common/error.hpp"

namespace kumite::app {

namespace {

std::atomic<int> g_stop_signal{0};
static_assert(std::atomic<int>::is_always_lock_free, "the signal handler stores into it");

extern "C" void on_stop_signal(int sig) {
  // Async-signal-safe only: a lock-free atomic, signal(), raise().
  int expected = 0;
  if (!g_stop_signal.compare_exchange_strong(expected, sig)) {
    // The second one: the run did not end (stuck in start-up or a driver): die as asked.
    std::signal(sig, SIG_DFL);
    std::raise(sig);
  }
}

}  // namespace

const std::atomic<int>& stop_on_signals() {
  static const bool installed = [] {
    struct sigaction sa {};
    sa.sa_handler = on_stop_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;  // the loop's sleeps and writes go on; the flag ends the run
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    return true;
  }();
  (void)installed;
  return g_stop_signal;
}

void make_output_folder(const std::filesystem::path& dir, std::string_view what) {
  namespace fs = std::filesystem;
  const auto fail = [&](const std::string& why) { throw Error("io", "folder", fmt::format("{}: {}", what, why)); };
  if (dir.empty()) fail("empty path");
  std::error_code ec;
  if (fs::is_directory(dir, ec)) {
    if (::access(dir.c_str(), W_OK | X_OK) != 0)
      fail(fmt::format("cannot write in the folder {} ({})", dir.string(), std::strerror(errno)));
    return;
  }
  // The deepest part of the path that exists says best why the folder cannot be made.
  for (fs::path p = dir; !p.empty() && p != p.parent_path(); p = p.parent_path()) {
    if (!fs::exists(p, ec)) continue;
    if (!fs::is_directory(p, ec))
      fail(fmt::format("cannot create the folder {}: {} is a file, not a folder", dir.string(), p.string()));
    break;
  }
  fs::create_directories(dir, ec);
  if (ec) fail(fmt::format("cannot create the folder {} ({})", dir.string(), ec.message()));
}

}  // namespace kumite::app
