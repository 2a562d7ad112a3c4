#include "kumite/app/frame_log.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <utility>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "frame_walk.hpp"

namespace kumite::app {

using nlohmann::json;

std::string frame_json(const FrameData& f, const ConsoleState& c,
                       const std::vector<std::string>& wall_names, bool stereo) {
  // The frame's logged fields (frame_fields.hpp), then what the console adds.
  json j = walk::log_object(f, wall_names, stereo);
  j["fighter"]["character_name"] = c.character_name;
  for (std::size_t k = 0; k < f.events.size() && k < c.frame_events.size(); ++k)
    if (!c.frame_events[k].empty()) j["events"][k]["text"] = c.frame_events[k];
  json cams = json::array();
  for (const auto& cam : c.cameras)
    cams.push_back({{"name", cam.name}, {"status", cam.status}, {"blobs", cam.blobs}, {"since_last_ms", cam.since_last_ms}});
  j["console"] = {{"tracking", c.tracking},
                  {"tracking_source", c.tracking_source},
                  {"recognition", c.recognition},
                  {"markers_seen", c.markers_seen},
                  {"cameras", cams},
                  {"paused", c.paused},
                  {"last_order", c.last_order},
                  {"last_outcome", c.last_outcome},
                  {"problems", c.problems},
                  {"frame_cpu_ms", c.frame_cpu_ms},
                  {"late_latch", c.late_latch},
                  {"draw_budget_ms", c.draw_budget_ms >= 0 ? json(c.draw_budget_ms) : json(nullptr)}};
  if (!c.planner.empty()) j["console"]["planner"] = c.planner;  // absent without a fighter
  // Text from files (a problem quoting a damaged file's bytes) may not be UTF-8: such bytes
  // are written as U+FFFD rather than ending the run (nlohmann throws on them by default).
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

FrameLog::FrameLog(std::filesystem::path path, std::uint64_t budget_bytes) : path_(std::move(path)), budget_(budget_bytes) {
  fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) throw Error("io", "open", fmt::format("{}: cannot write ({})", path_.string(), std::strerror(errno)));
}

FrameLog::~FrameLog() {
  if (fd_ >= 0) ::close(fd_);
}

void FrameLog::write(const FrameData& f, const ConsoleState& c,
                     const std::vector<std::string>& wall_names, bool stereo) {
  write_line(frame_json(f, c, wall_names, stereo));
}

std::filesystem::path FrameLog::previous_path() const {
  std::filesystem::path p = path_;
  return p.replace_filename(path_.stem().string() + ".1" + path_.extension().string());
}

void FrameLog::rotate() {
  const int fd = std::exchange(fd_, -1);
  ::fsync(fd);
  ::close(fd);
  std::error_code ec;
  std::filesystem::rename(path_, previous_path(), ec);  // replaces the half before
  if (ec) throw Error("io", "write", fmt::format("{}: cannot rotate to {} ({})", path_.string(), previous_path().string(), ec.message()));
  fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) throw Error("io", "open", fmt::format("{}: cannot write ({})", path_.string(), std::strerror(errno)));
  bytes_ = 0;
  ++rotations_;
  spdlog::info("frames log: {} reached half its budget of {:.0f} MB: the frames so far are now in {}, new ones go to {}",
               path_.string(), static_cast<double>(budget_) / 1e6, previous_path().filename().string(),
               path_.filename().string());
}

void FrameLog::write_line(std::string line) {
  if (fd_ < 0) throw Error("io", "write", path_.string() + ": written after close()");
  line += '\n';
  if (budget_ > 0 && bytes_ > 0 && bytes_ + line.size() > budget_ / 2) rotate();
  bytes_ += line.size();
  // One write(2) for the whole line (a regular file takes it whole; the loop is for the
  // rare short write and EINTR): a process killed between frames leaves complete lines.
  write_all(fd_, line, path_);
}

void FrameLog::close() {
  if (fd_ < 0) return;
  const int fd = std::exchange(fd_, -1);
  const bool synced = ::fsync(fd) == 0;
  const int sync_errno = errno;
  if (::close(fd) != 0 || !synced)
    throw Error("io", "write", fmt::format("{}: cannot write ({})", path_.string(),
                                           std::strerror(synced ? errno : sync_errno)));
}

}  // namespace kumite::app
