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

namespace kumite::app {

namespace {
using nlohmann::json;

json mat(const glm::dmat4& m) {
  json a = json::array();
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) a.push_back(m[c][r]);
  return a;
}
json vec(const glm::dvec3& v) { return json::array({v.x, v.y, v.z}); }
double round_to(double x, double per_unit) { return std::round(x * per_unit) / per_unit; }
json rounded(const glm::dvec3& v, double per_unit) {
  return json::array({round_to(v.x, per_unit), round_to(v.y, per_unit), round_to(v.z, per_unit)});
}
}  // namespace

std::string frame_json(const FrameData& f, const ConsoleState& c,
                       const std::vector<std::string>& wall_names, bool stereo) {
  json j;
  j["frame"] = f.frame;
  j["time_s"] = f.time_s;
  j["head"] = {{"position", vec(f.head.position)},
               {"quaternion", json::array({f.head.orientation.w, f.head.orientation.x,
                                           f.head.orientation.y, f.head.orientation.z})},
               {"live", c.head_live}};
  j["eyes"] = {{"left", vec(f.eyes.left)}, {"right", vec(f.eyes.right)}};
  json walls = json::object();
  for (std::size_t w = 0; w < f.views.size() && w < wall_names.size(); ++w) {
    json per = json::object();
    const char* names[2] = {"left", "right"};
    for (int e = 0; e < (stereo ? 2 : 1); ++e) {
      const auto& v = f.views[w][static_cast<std::size_t>(e)];
      per[stereo ? names[e] : "mono"] = {{"view", mat(v.view)}, {"projection", mat(v.projection)}};
    }
    walls[wall_names[w]] = per;
  }
  j["walls"] = walls;
  j["fighter"] = {{"present", f.fighter.present},
                  {"state", f.fighter.present ? std::string(content::to_string(f.fighter.state)) : "none"},
                  {"character", f.fighter.character + 1},
                  {"character_name", c.character_name}};
  if (f.fighter.present) {
    const FighterPose& p = f.fighter;
    json& fj = j["fighter"];
    fj["root"] = vec(p.root);
    fj["heading_rad"] = p.heading_rad;
    fj["target"] = p.target ? vec(*p.target) : json(nullptr);
    // Joints keyed by name (room frame, m, rounded to 1e-5 m), the root joint and the local
    // rotations (w, x, y, z, rounded to 1e-7): enough to rebuild the pose on the character's
    // skeleton (kumite export).
    json joints = json::object(), rotations = json::object();
    const auto* sk = p.skeleton.get();
    for (std::size_t i = 0; sk && i < p.joints.size() && i < sk->joint_names.size(); ++i) {
      joints[sk->joint_names[i]] = rounded(p.joints[i], 1e5);
      if (i < p.local_rotations.size()) {
        const glm::dquat& q = p.local_rotations[i];
        rotations[sk->joint_names[i]] = json::array({round_to(q.w, 1e7), round_to(q.x, 1e7), round_to(q.y, 1e7), round_to(q.z, 1e7)});
      }
    }
    fj["root_joint"] = rounded(p.root_joint, 1e5);
    fj["joints"] = std::move(joints);
    fj["local_rotations"] = std::move(rotations);
  }
  json events = json::array();
  for (std::size_t k = 0; k < f.events.size(); ++k) {
    const FrameEvent& e = f.events[k];
    json ev = {{"type", to_string(e.type)}, {"time_s", e.time_s}};
    if (e.order) ev["order"] = to_string(*e.order);
    if (k < c.frame_events.size() && !c.frame_events[k].empty()) ev["text"] = c.frame_events[k];
    if (is_strike_outcome(e.type) || e.type == EventType::visitor_near_wall || e.type == EventType::visitor_clear ||
        e.type == EventType::stepping_in || e.type == EventType::support_step ||
        e.type == EventType::stepping_back)
      ev["distance_m"] = e.distance_m;
    if (e.type == EventType::visitor_strike) {
      const VisitorStrike& st = e.strike;
      ev["strike"] = {{"type", recognition::to_string(st.type)}, {"limb", recognition::to_string(st.limb)},
                      {"action", recognition::to_string(st.action)}, {"progress", st.progress},
                      {"confidence", st.confidence}, {"impact", st.impact},
                      {"t", st.t - (f.now - f.time_s)},  // s since the run's start, as time_s
                      {"decided_ms", st.decided_at >= 0 ? json((st.decided_at - st.t) * 1e3) : json(nullptr)}};
    }
    events.push_back(ev);
  }
  j["events"] = events;
  if (const auto& v = f.visitor_near_wall)  // only while the visitor is near a wall (or lost near one)
    j["visitor_near_wall"] = {{"wall", v->wall < static_cast<int>(wall_names.size()) ? wall_names[static_cast<std::size_t>(v->wall)] : ""},
                              {"distance_m", v->distance_m}, {"outside", v->outside}, {"lost", v->lost}};
  j["pose_age_ms"] = f.pose_age_ms >= 0 ? json(f.pose_age_ms) : json(nullptr);
  j["tracking_latency_ms"] = f.tracking_latency_ms >= 0 ? json(f.tracking_latency_ms) : json(nullptr);
  j["latch_ms"] = f.latch_ms;
  j["predicted_ahead_ms"] = f.predicted_ahead_ms;
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
