// libFuzzer target: a recorded session's manifest.json and session.jsonl (replay_session). The
// input is the manifest, optionally followed by a line "=====" and session.jsonl; the
// session folder also holds a valid snapshot/installation.toml (below). Any input gives a
// report or a kumite::Error naming the file, never a crash, a hang or another exception; a
// manifest cannot point the replay outside its folder or at a device.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include <spdlog/spdlog.h>

#include "kumite/app/session.hpp"
#include "kumite/common/error.hpp"

namespace fs = std::filesystem;

namespace {

// The snapshot's installation file (the seeds' manifests carry its size and FNV-1a 64).
constexpr std::string_view kInstallation = R"(display_rate_hz = 60.0

[[windows]]
name = "main"
size = [320, 180]

[[walls]]
name = "front"
lower_left = [-1.5, 0.0, -1.5]
lower_right = [1.5, 0.0, -1.5]
upper_left = [-1.5, 2.4, -1.5]
resolution = [64, 36]
window = "main"
)";

const fs::path& session_dir() {
  static const fs::path dir = [] {
    spdlog::set_level(spdlog::level::off);  // an installation per input: its log lines are noise here
    const fs::path d = fs::temp_directory_path() / ("kumite_fuzz_session_" + std::to_string(::getpid()));
    fs::create_directories(d / "snapshot");
    std::ofstream(d / "snapshot/installation.toml", std::ios::binary) << kInstallation;
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto cut = text.find("\n=====\n");
  const fs::path& dir = session_dir();
  std::ofstream(dir / "manifest.json", std::ios::binary | std::ios::trunc) << text.substr(0, cut);
  std::ofstream(dir / "session.jsonl", std::ios::binary | std::ios::trunc)
      << (cut == std::string_view::npos ? std::string_view() : text.substr(cut + 7));
  try {
    const kumite::app::ReplayReport rep = kumite::app::replay_session(dir);
    if (rep.frames_replayed > rep.frames_recorded) std::abort();
  } catch (const kumite::Error&) {
  }
  return 0;
}
