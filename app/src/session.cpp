#include "kumite/app/session.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "kumite/app/run.hpp"
#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/realtime.hpp"

namespace kumite::app {

namespace {
using nlohmann::json;

/// nice added to the writer thread (the render thread itself runs at +5 by default).
constexpr int kWriterNice = 15;
/// ms the writer sleeps when it has written everything queued (the queue holds 512 frames:
/// 8.5 s at 60 Hz).
constexpr int kWriterPeriodMs = 5;
constexpr std::uint64_t kFnvOffset = 14695981039346656037ull;
constexpr std::uint64_t kFnvPrime = 1099511628211ull;

struct Fnv {
  std::uint64_t h = kFnvOffset;
  void bytes(const void* p, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ b[i]) * kFnvPrime;
  }
  void d(double v) { bytes(&v, sizeof v); }
  void i(std::int64_t v) { bytes(&v, sizeof v); }
  void v3(const glm::dvec3& v) { d(v.x); d(v.y); d(v.z); }
  void q(const glm::dquat& v) { d(v.w); d(v.x); d(v.y); d(v.z); }
  void m(const glm::dmat4& mm) {
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) d(mm[c][r]);
  }
  void s(std::string_view t) { i(static_cast<std::int64_t>(t.size())); bytes(t.data(), t.size()); }
};

std::string hex(std::uint64_t v) { return fmt::format("{:016x}", v); }

json pose_json(const BodyPose& p) {
  return {{"timestamp", p.timestamp}, {"frame", p.frame}, {"body", p.body}, {"status", static_cast<int>(p.status)},
          {"position", p.position}, {"orientation", p.orientation}, {"markers", p.markers}, {"cameras", p.cameras},
          {"ready_at", p.ready_at}};
}

json input_json(const FrameInput& in) {
  json keyed = json::array();
  for (const auto& o : in.keyed) keyed.push_back({{"time", o.time}, {"order", to_string(o)}});
  json t = {{"measured_at", in.tracking.measured_at}, {"measured_ready_at", in.tracking.measured_ready_at},
            {"status", in.tracking.status}};
  t["head"] = in.tracking.head ? pose_json(*in.tracking.head) : json(nullptr);
  return {{"now", in.now}, {"shown_at", in.shown_at}, {"keyed", keyed}, {"tracking", t}, {"clock", in.tracking_clock}};
}

struct LineReader {
  std::string file;
  int line = 0;
  [[noreturn]] void fail(std::string_view key, std::string_view msg) const {
    throw file_error("replay", "session", file, line, key, msg);
  }
  const json& at(const json& j, const char* key, std::string_view path) const {
    if (!j.is_object() || !j.contains(key)) fail(path, "missing");
    return j.at(key);
  }
  double num(const json& j, std::string_view path) const {
    if (!j.is_number()) fail(path, "not a number");
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(path, "must be a finite number");
    return v;
  }
  template <std::size_t N>
  std::array<double, N> nums(const json& j, std::string_view path) const {
    if (!j.is_array() || j.size() != N) fail(path, fmt::format("expected {} numbers", N));
    std::array<double, N> out{};
    for (std::size_t k = 0; k < N; ++k) out[k] = num(j[k], path);
    return out;
  }
};

FrameInput parse_input(const json& j, const LineReader& r) {
  FrameInput in;
  in.now = r.num(r.at(j, "now", "input.now"), "input.now");
  in.shown_at = r.num(r.at(j, "shown_at", "input.shown_at"), "input.shown_at");
  in.tracking_clock = r.num(r.at(j, "clock", "input.clock"), "input.clock");
  for (const auto& o : r.at(j, "keyed", "input.keyed")) {
    const auto text = r.at(o, "order", "input.keyed.order");
    if (!text.is_string()) r.fail("input.keyed.order", "not a string");
    auto order = parse_order(text.get<std::string>(), r.num(r.at(o, "time", "input.keyed.time"), "input.keyed.time"));
    if (!order) r.fail("input.keyed.order", fmt::format("unknown order \"{}\"", text.get<std::string>()));
    in.keyed.push_back(*order);
  }
  const json& t = r.at(j, "tracking", "input.tracking");
  in.tracking.measured_at = r.num(r.at(t, "measured_at", "input.tracking.measured_at"), "input.tracking.measured_at");
  in.tracking.measured_ready_at =
      r.num(r.at(t, "measured_ready_at", "input.tracking.measured_ready_at"), "input.tracking.measured_ready_at");
  const json& status = r.at(t, "status", "input.tracking.status");
  if (!status.is_string()) r.fail("input.tracking.status", "not a string");
  in.tracking.status = status.get<std::string>();
  const json& h = r.at(t, "head", "input.tracking.head");
  if (!h.is_null()) {
    BodyPose p;
    p.timestamp = r.num(r.at(h, "timestamp", "input.tracking.head.timestamp"), "input.tracking.head.timestamp");
    p.frame = static_cast<std::uint64_t>(r.num(r.at(h, "frame", "input.tracking.head.frame"), "input.tracking.head.frame"));
    p.body = static_cast<std::int32_t>(r.num(r.at(h, "body", "input.tracking.head.body"), "input.tracking.head.body"));
    const double st = r.num(r.at(h, "status", "input.tracking.head.status"), "input.tracking.head.status");
    if (st != 0 && st != 1 && st != 2) r.fail("input.tracking.head.status", "expected 0, 1 or 2");
    p.status = static_cast<TrackingStatus>(static_cast<int>(st));
    p.position = r.nums<3>(r.at(h, "position", "input.tracking.head.position"), "input.tracking.head.position");
    p.orientation = r.nums<4>(r.at(h, "orientation", "input.tracking.head.orientation"), "input.tracking.head.orientation");
    p.markers = static_cast<std::int32_t>(r.num(r.at(h, "markers", "input.tracking.head.markers"), "input.tracking.head.markers"));
    p.cameras = static_cast<std::int32_t>(r.num(r.at(h, "cameras", "input.tracking.head.cameras"), "input.tracking.head.cameras"));
    p.ready_at = r.num(r.at(h, "ready_at", "input.tracking.head.ready_at"), "input.tracking.head.ready_at");
    in.tracking.head = p;
  }
  return in;
}

/// No tracker is asked during a replay: the recorded snapshots come in through replay().
class ReplayTracking final : public TrackingInput {
 public:
  explicit ReplayTracking(bool has_tracker) : has_tracker_(has_tracker) {}
  TrackingSnapshot poll(Timestamp, Timestamp) override { return {}; }
  Timestamp clock() const override { return 0; }
  std::string describe() const override { return "replay"; }
  bool has_tracker() const override { return has_tracker_; }

 private:
  bool has_tracker_;
};

}  // namespace

StateHashes state_hashes(const FrameData& f) {
  StateHashes out;
  Fnv t;
  t.i(static_cast<std::int64_t>(f.frame));
  t.d(f.time_s);
  t.d(f.now);
  out.value[0] = t.h;
  Fnv h;
  h.v3(f.head.position);
  h.q(f.head.orientation);
  out.value[1] = h.h;
  Fnv e;
  e.v3(f.eyes.left);
  e.v3(f.eyes.right);
  out.value[2] = e.h;
  Fnv v;
  for (const auto& wall : f.views)
    for (const auto& eye : wall) {
      v.m(eye.view);
      v.m(eye.projection);
    }
  out.value[3] = v.h;
  Fnv fi;
  const FighterPose& p = f.fighter;
  fi.i(p.present);
  fi.i(static_cast<int>(p.state));
  fi.i(p.character);
  for (const auto& j : p.joints) fi.v3(j);
  for (const auto& q : p.local_rotations) fi.q(q);
  fi.v3(p.root_joint);
  fi.i(p.target.has_value());
  if (p.target) fi.v3(*p.target);
  fi.v3(p.root);
  fi.d(p.heading_rad);
  out.value[4] = fi.h;
  Fnv ev;
  for (const auto& x : f.events) {
    ev.i(static_cast<int>(x.type));
    ev.s(x.order);
    ev.s(x.text);
    ev.d(x.distance_m);
    ev.d(x.time_s);
  }
  out.value[5] = ev.h;
  return out;
}

std::uint64_t file_checksum(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return 0;
  Fnv f;
  char buf[65536];
  while (in) {
    in.read(buf, sizeof buf);
    f.bytes(buf, static_cast<std::size_t>(in.gcount()));
  }
  return f.h;
}

SessionRecorder::SessionRecorder(std::filesystem::path dir, SessionInfo info, std::size_t queue_frames)
    : dir_(std::move(dir)), info_(std::move(info)), slots_(std::max<std::size_t>(queue_frames, 2)) {
  make_output_folder(dir_, "--record " + dir_.string());
  created_unix_s_ = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  const auto path = dir_ / "session.jsonl";
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) throw Error("io", "open", fmt::format("{}: cannot write ({})", path.string(), std::strerror(errno)));
  write_manifest(false);
  thread_ = std::thread([this] { run(); });
}

SessionRecorder::~SessionRecorder() {
  try {
    close();
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
  }
}

void SessionRecorder::started(Timestamp start, bool has_tracker) {
  const std::uint64_t h = head_.load(std::memory_order_relaxed);
  if (h - tail_.load(std::memory_order_acquire) >= slots_.size()) {  // cannot happen before the first frame
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  Item& item = slots_[h % slots_.size()];
  item.start = std::pair{start, has_tracker};
  head_.store(h + 1, std::memory_order_release);
}

void SessionRecorder::push(std::uint64_t frame, const FrameInput& input, const StateHashes& hashes) {
  pushed_.fetch_add(1, std::memory_order_relaxed);
  const std::uint64_t h = head_.load(std::memory_order_relaxed);
  if (h - tail_.load(std::memory_order_acquire) >= slots_.size()) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  Item& item = slots_[h % slots_.size()];
  item.frame = frame;
  item.input.now = input.now;
  item.input.shown_at = input.shown_at;
  item.input.keyed.assign(input.keyed.begin(), input.keyed.end());
  item.input.tracking.head = input.tracking.head;
  item.input.tracking.measured_at = input.tracking.measured_at;
  item.input.tracking.measured_ready_at = input.tracking.measured_ready_at;
  item.input.tracking.status.assign(input.tracking.status);
  item.input.tracking_clock = input.tracking_clock;
  item.hashes = hashes;
  item.start.reset();
  head_.store(h + 1, std::memory_order_release);
}

void SessionRecorder::run() {
  // Below the frame loop and the tracker: the disk can wait, a frame cannot.
  lower_this_thread_priority(kWriterNice);
  std::string text;
  for (;;) {
    const bool stopping = stop_.load(std::memory_order_acquire);
    const std::uint64_t h = head_.load(std::memory_order_acquire);
    std::uint64_t t = tail_.load(std::memory_order_relaxed);
    for (; t < h; ++t) {
      const Item& item = slots_[t % slots_.size()];
      json j;
      if (item.start) {
        j = {{"start", item.start->first}, {"has_tracker", item.start->second}};
      } else {
        json hashes = json::object();
        for (std::size_t k = 0; k < StateHashes::kFields.size(); ++k)
          hashes[std::string(StateHashes::kFields[k])] = hex(item.hashes.value[k]);
        j = {{"frame", item.frame}, {"input", input_json(item.input)}, {"hash", hashes}};
      }
      tail_.store(t + 1, std::memory_order_release);  // the slot is read: the frame loop may reuse it
      text = j.dump();
      text += '\n';
      try {
        if (error_.empty()) write_line(text);
      } catch (const std::exception& e) {
        error_ = e.what();  // said at close(); later frames are not written (the file would have a hole)
      }
    }
    if (stopping) return;  // everything pushed before stop was written
    std::this_thread::sleep_for(std::chrono::milliseconds(kWriterPeriodMs));
  }
}

void SessionRecorder::write_line(const std::string& line) {
  write_all(fd_, line, dir_ / "session.jsonl");
  Fnv f{checksum_};
  f.bytes(line.data(), line.size());
  checksum_ = f.h;
  if (line.rfind("{\"frame\"", 0) == 0) written_.fetch_add(1, std::memory_order_relaxed);
}

void SessionRecorder::write_manifest(bool complete) {
  json m;
  m["format"] = "kumite-session";
  m["version"] = kSessionVersion;
  m["complete"] = complete;
  m["created_unix_s"] = created_unix_s_;
  m["config"] = info_.config.string();
  m["config_fnv"] = hex(file_checksum(info_.config));
  m["orders_script"] = info_.orders_script ? json(info_.orders_script->string()) : json(nullptr);
  m["orders_fnv"] = info_.orders_script ? json(hex(file_checksum(*info_.orders_script))) : json(nullptr);
  m["mono_eyes"] = info_.mono_eyes;
  m["state_fields"] = StateHashes::kFields;
  if (complete) {
    m["closed_unix_s"] = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    m["frames"] = written_.load();
    m["frames_offered"] = pushed_.load();
    m["dropped"] = dropped_.load();
    m["session_fnv"] = hex(checksum_);
  }
  write_file_atomically(dir_ / "manifest.json", m.dump(2) + "\n");
}

void SessionRecorder::close() {
  if (fd_ < 0) return;
  stop_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
  const int fd = std::exchange(fd_, -1);
  const bool synced = ::fsync(fd) == 0;
  ::close(fd);
  write_manifest(true);
  if (!error_.empty()) throw Error("io", "write", error_);
  if (!synced) throw Error("io", "write", fmt::format("{}: cannot sync", (dir_ / "session.jsonl").string()));
  if (dropped_ > 0)
    spdlog::warn("record: {} frame(s) dropped (the writer was behind): a replay stops at the first", dropped_.load());
  spdlog::info("record: {} frames -> {}", written_.load(), dir_.string());
}

std::uint64_t SessionRecorder::frames_written() const { return written_.load(); }
std::uint64_t SessionRecorder::dropped() const { return dropped_.load(); }

ReplayReport replay_session(const std::filesystem::path& dir, const std::optional<std::filesystem::path>& config_override,
                            const std::optional<std::filesystem::path>& data_dir) {
  ReplayReport rep;
  const auto manifest_path = dir / "manifest.json";
  std::ifstream mf(manifest_path);
  if (!mf) throw Error("replay", "missing", fmt::format("{}: cannot read (not a recorded session)", manifest_path.string()));
  const json m = json::parse(mf, nullptr, false);
  LineReader mr{manifest_path.string(), 0};
  if (m.is_discarded() || !m.is_object()) mr.fail("", "not valid JSON (or not an object)");
  const double version = mr.num(mr.at(m, "version", "version"), "version");
  if (version > kSessionVersion)
    mr.fail("version", fmt::format("session version {} is newer than this kumite reads ({})", version, kSessionVersion));
  if (!m.value("complete", false))
    rep.notes.push_back(fmt::format("{}: complete: false: the recording did not end cleanly (killed?): replaying its "
                                    "complete frames", manifest_path.string()));
  const std::filesystem::path recorded_config = m.value("config", "");
  const std::filesystem::path config_path = config_override.value_or(recorded_config);
  if (hex(file_checksum(config_path)) != m.value("config_fnv", ""))
    rep.notes.push_back(fmt::format("{}: differs from the recorded config's checksum: frames may differ", config_path.string()));
  auto config = load_installation_config(config_path, data_dir);
  InstallationOptions io;
  io.mono_eyes = m.value("mono_eyes", false);
  if (m.contains("orders_script") && m["orders_script"].is_string()) {
    io.orders_script = m["orders_script"].get<std::string>();
    if (hex(file_checksum(*io.orders_script)) != m.value("orders_fnv", ""))
      rep.notes.push_back(fmt::format("{}: differs from the recorded orders script: frames may differ", io.orders_script->string()));
  }

  const auto session_path = dir / "session.jsonl";
  std::ifstream in(session_path, std::ios::binary);
  if (!in) throw Error("replay", "missing", fmt::format("{}: cannot read", session_path.string()));
  std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  LineReader r{session_path.string(), 0};
  std::size_t pos = 0;
  std::unique_ptr<Installation> inst;
  std::optional<std::uint64_t> expected;
  const auto t0 = std::chrono::steady_clock::now();
  Timestamp first_now = 0, last_now = 0;
  while (pos < all.size()) {
    const auto end = all.find('\n', pos);
    ++r.line;
    if (end == std::string::npos) {
      rep.notes.push_back(fmt::format("{}:{}: the last line is cut short (the recorder was killed): left out", r.file, r.line));
      break;
    }
    const json j = json::parse(std::string_view(all).substr(pos, end - pos), nullptr, false);
    pos = end + 1;
    if (j.is_discarded() || !j.is_object()) r.fail("", "not valid JSON (or not an object)");
    if (!inst) {
      const double start = r.num(r.at(j, "start", "start"), "start");
      inst = std::make_unique<Installation>(config, std::make_unique<ReplayTracking>(j.value("has_tracker", false)), io);
      inst->start(start);
      continue;
    }
    const auto frame = static_cast<std::uint64_t>(r.num(r.at(j, "frame", "frame"), "frame"));
    ++rep.frames_recorded;
    if (expected && frame != *expected) {
      rep.notes.push_back(fmt::format("{}:{}: frame {} follows frame {}: frames {}..{} were dropped while recording; the "
                                      "replay stops there", r.file, r.line, frame, *expected - 1, *expected, frame - 1));
      break;
    }
    expected = frame + 1;
    const FrameInput input = parse_input(r.at(j, "input", "input"), r);
    const FrameData& f = inst->replay(input);
    if (rep.frames_replayed == 0) first_now = input.now;
    last_now = input.now;
    ++rep.frames_replayed;
    const StateHashes got = state_hashes(f);
    const json& want = r.at(j, "hash", "hash");
    for (std::size_t k = 0; k < StateHashes::kFields.size(); ++k) {
      const std::string field(StateHashes::kFields[k]);
      if (want.value(field, "") != hex(got.value[k])) {
        rep.identical = false;
        rep.first_difference_frame = frame;
        rep.first_difference_field = field;
        break;
      }
    }
    if (!rep.identical) break;
  }
  if (!inst) throw file_error("replay", "session", session_path.string(), 1, "start", "no start line: nothing recorded");
  rep.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  rep.session_s = last_now - first_now;
  return rep;
}

}  // namespace kumite::app
