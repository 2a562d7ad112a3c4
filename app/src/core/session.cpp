#include "kumite/app/session.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <algorithm>
#include <cstring>
#include <ctime>
#include <sstream>
#include <thread>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "kumite/app/frame_states.hpp"
#include "kumite/app/run_control.hpp"
#include "kumite/app/tracking_input.hpp"
#include "frame_walk.hpp"
#include "json_reader.hpp"
#include "kumite/common/atomic_file.hpp"
#include "kumite/common/checksum.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/realtime.hpp"
#include "kumite/tracking/camera_frames.hpp"
#include "kumite/tracking/recording.hpp"
#include "kumite/tracking/tracker.hpp"

namespace kumite::app {

namespace {
using nlohmann::json;

/// nice added to the writer thread (the render thread itself runs at +5 by default).
constexpr int kWriterNice = 15;
/// ms the writer sleeps when it has written everything queued (the queue holds 512 frames:
/// 8.5 s at 60 Hz).
constexpr int kWriterPeriodMs = 5;
struct Fnv {
  std::uint64_t h = kFnv1a64Offset;
  void bytes(const void* p, std::size_t n) { h = fnv1a64(p, n, h); }
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

double unix_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

/// A regular file's bytes (nullopt: missing, unreadable, or not a regular file: a manifest
/// naming /dev/zero or a folder must not hang or fail the replay).
std::optional<std::string> read_bytes(const std::filesystem::path& p) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(p, ec)) return std::nullopt;
  std::ifstream in(p, std::ios::binary);
  if (!in) return std::nullopt;
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::uint64_t fnv_of(std::string_view bytes) { return fnv1a64(bytes); }

json pose_json(const BodyPose& p) {
  return {{"timestamp", p.timestamp}, {"frame", p.frame}, {"body", p.body}, {"status", static_cast<int>(p.status)},
          {"position", p.position}, {"orientation", p.orientation}, {"markers", p.markers}, {"cameras", p.cameras},
          {"ready_at", p.ready_at}};
}

json input_json(const FrameInput& in) {
  json keyed = json::array();
  for (const auto& o : in.keyed) keyed.push_back({{"time", o.time}, {"order", to_string(o)}});
  const TrackingSnapshot& s = in.tracking;
  json t = {{"measured_at", s.measured_at}, {"measured_ready_at", s.measured_ready_at},
            {"state", static_cast<int>(s.state)}, {"frame_sets", s.frame_sets}};
  t["head"] = s.head ? pose_json(*s.head) : json(nullptr);
  json cams = json::array();
  for (const CameraView& c : s.cameras) cams.push_back({static_cast<int>(c.state), c.blobs, c.since_last_ms});
  t["cameras"] = std::move(cams);
  if (s.source.recording) {
    const SourceStats& src = s.source;
    t["source"] = {{"loading", src.loading}, {"loaded", src.loaded},     {"to_load", src.to_load},
                   {"from_memory", src.from_memory}, {"decode_ms", src.decode_ms}, {"rates", src.rates},
                   {"totals", src.totals}};
  }
  if (!s.strikes.empty()) {
    json strikes = json::array();
    for (const VisitorStrike& k : s.strikes)
      strikes.push_back({{"t", k.t}, {"decided_at", k.decided_at}, {"type", recognition::to_string(k.type)},
                         {"limb", recognition::to_string(k.limb)}, {"action", recognition::to_string(k.action)},
                         {"progress", k.progress}, {"confidence", k.confidence}, {"impact", k.impact}});
    t["strikes"] = std::move(strikes);
  }
  // The visitor's bodies as measured, by role (version 5 on; always written, {} when none: its
  // absence marks an older session).
  json bodies = json::object();
  for (std::size_t r = 0; r < s.bodies.size(); ++r)
    if (s.bodies[r]) bodies[std::string(recognition::to_string(static_cast<recognition::Role>(r)))] = pose_json(*s.bodies[r]);
  t["bodies"] = std::move(bodies);
  if (s.recognition.running)
    t["recognition"] = {s.recognition.samples, s.recognition.dropped, s.recognition.events, s.recognition.events_dropped};
  return {{"now", in.now},     {"shown_at", in.shown_at}, {"keyed", keyed}, {"tracking", t}, {"clock", in.tracking_clock},
          {"latch_ms", in.latch_ms}};
}

/// manifest.json and session.jsonl lines: errors are ("replay", "session").
using LineReader = JsonLineReader;
LineReader session_reader(std::string file) { return {"replay", "session", std::move(file), 0}; }

/// A BodyPose as pose_json writes it; `key` names it in errors ("input.tracking.head").
BodyPose parse_pose(const json& h, const LineReader& r, const std::string& key) {
  const auto at = [&](const char* k) -> const json& { return r.at(h, k, key + "." + k); };
  const auto name = [&](const char* k) { return key + "." + k; };
  BodyPose p;
  p.timestamp = r.num(at("timestamp"), name("timestamp"));
  p.frame = static_cast<std::uint64_t>(r.whole(at("frame"), name("frame"), 0, 9007199254740992.0));
  p.body = static_cast<std::int32_t>(r.whole(at("body"), name("body"), -1, 1e6));
  const double st = r.num(at("status"), name("status"));
  if (st != 0 && st != 1 && st != 2) r.fail(name("status"), "expected 0, 1 or 2");
  p.status = static_cast<TrackingStatus>(static_cast<int>(st));
  p.position = r.nums<3>(at("position"), name("position"));
  p.orientation = r.nums<4>(at("orientation"), name("orientation"));
  p.markers = static_cast<std::int32_t>(r.whole(at("markers"), name("markers"), 0, 1e6));
  p.cameras = static_cast<std::int32_t>(r.whole(at("cameras"), name("cameras"), 0, 1e6));
  p.ready_at = r.num(at("ready_at"), name("ready_at"));
  return p;
}

FrameInput parse_input(const json& j, const LineReader& r) {
  FrameInput in;
  in.now = r.num(r.at(j, "now", "input.now"), "input.now");
  in.shown_at = r.num(r.at(j, "shown_at", "input.shown_at"), "input.shown_at");
  in.tracking_clock = r.num(r.at(j, "clock", "input.clock"), "input.clock");
  if (j.contains("latch_ms")) in.latch_ms = r.num(j["latch_ms"], "input.latch_ms");  // version 3 on
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
  if (t.contains("status")) {
    // Version 2: a status line, "tracked, 120 frame sets" (the cameras and source not kept).
    const json& status = t["status"];
    if (!status.is_string()) r.fail("input.tracking.status", "not a string");
    const std::string line = status.get<std::string>();
    for (const TrackerState st : {TrackerState::waiting, TrackerState::tracked, TrackerState::coasting,
                                  TrackerState::lost, TrackerState::stopped})
      if (line.starts_with(to_string(st))) in.tracking.state = st;
    if (const auto comma = line.find(", "); comma != std::string::npos)
      in.tracking.frame_sets = std::strtoull(line.c_str() + comma + 2, nullptr, 10);
    if (line.find("(tracker stopped)") != std::string::npos) in.tracking.state = TrackerState::stopped;
  } else {
    in.tracking.state = static_cast<TrackerState>(
        r.whole(r.at(t, "state", "input.tracking.state"), "input.tracking.state", 0, static_cast<int>(TrackerState::stopped)));
    in.tracking.frame_sets = static_cast<std::uint64_t>(
        r.whole(r.at(t, "frame_sets", "input.tracking.frame_sets"), "input.tracking.frame_sets", 0, 9007199254740992.0));
    for (const auto& c : r.at(t, "cameras", "input.tracking.cameras")) {
      if (!c.is_array() || c.size() != 3) r.fail("input.tracking.cameras", "expected [state, blobs, since_last_ms]");
      CameraView v;
      v.state = static_cast<CameraState>(r.whole(c[0], "input.tracking.cameras.state", 0, static_cast<int>(CameraState::blind)));
      v.blobs = static_cast<int>(r.whole(c[1], "input.tracking.cameras.blobs", 0, 1e6));
      v.since_last_ms = r.num(c[2], "input.tracking.cameras.since_last_ms");
      in.tracking.cameras.push_back(v);
    }
    if (t.contains("source")) {
      const json& src = t["source"];
      SourceStats& o = in.tracking.source;
      o.recording = true;
      const auto flag = [&](const char* key) {
        const json& b = r.at(src, key, std::string("input.tracking.source.") + key);
        if (!b.is_boolean()) r.fail(std::string("input.tracking.source.") + key, "not true or false");
        return b.get<bool>();
      };
      const auto count = [&](const json& v, const std::string& key) {
        return static_cast<std::uint64_t>(r.whole(v, key, 0, 9007199254740992.0));
      };
      o.loading = flag("loading");
      o.from_memory = flag("from_memory");
      o.loaded = count(r.at(src, "loaded", "input.tracking.source.loaded"), "input.tracking.source.loaded");
      o.to_load = count(r.at(src, "to_load", "input.tracking.source.to_load"), "input.tracking.source.to_load");
      o.decode_ms = r.num(r.at(src, "decode_ms", "input.tracking.source.decode_ms"), "input.tracking.source.decode_ms");
      o.rates = r.nums<3>(r.at(src, "rates", "input.tracking.source.rates"), "input.tracking.source.rates");
      const json& totals = r.at(src, "totals", "input.tracking.source.totals");
      if (!totals.is_array() || totals.size() != 3) r.fail("input.tracking.source.totals", "expected 3 counts");
      for (std::size_t k = 0; k < 3; ++k) o.totals[k] = count(totals[k], "input.tracking.source.totals");
    }
  }
  if (t.contains("strikes")) {  // the visitor's strikes (issue 14; any version may have them)
    const json& all = t["strikes"];
    if (!all.is_array()) r.fail("input.tracking.strikes", "not an array");
    for (const json& k : all) {
      VisitorStrike v;
      const auto text = [&](const char* key) {
        const json& x = r.at(k, key, std::string("input.tracking.strikes.") + key);
        if (!x.is_string()) r.fail(std::string("input.tracking.strikes.") + key, "not a string");
        return x.get<std::string>();
      };
      v.t = r.num(r.at(k, "t", "input.tracking.strikes.t"), "input.tracking.strikes.t");
      v.decided_at = r.num(r.at(k, "decided_at", "input.tracking.strikes.decided_at"), "input.tracking.strikes.decided_at");
      const std::string type = text("type");
      bool known = false;
      for (const auto et : {recognition::EventType::begin, recognition::EventType::switch_, recognition::EventType::end,
                            recognition::EventType::cancel})
        if (recognition::to_string(et) == type) v.type = et, known = true;
      if (!known) r.fail("input.tracking.strikes.type", fmt::format("unknown event type \"{}\"", type));
      const std::string limb = text("limb");
      const auto role = recognition::role_from_string(limb);
      if (!role || *role == recognition::Role::head) r.fail("input.tracking.strikes.limb", fmt::format("not a limb: \"{}\"", limb));
      v.limb = *role;
      v.action = recognition::action_from_string(text("action"));
      v.progress = r.num(r.at(k, "progress", "input.tracking.strikes.progress"), "input.tracking.strikes.progress");
      v.confidence = r.num(r.at(k, "confidence", "input.tracking.strikes.confidence"), "input.tracking.strikes.confidence");
      v.impact = r.nums<3>(r.at(k, "impact", "input.tracking.strikes.impact"), "input.tracking.strikes.impact");
      in.tracking.strikes.push_back(v);
    }
  }
  if (t.contains("recognition")) {
    const json& c = t["recognition"];
    if (!c.is_array() || c.size() != 4) r.fail("input.tracking.recognition", "expected [samples, dropped, events, events_dropped]");
    RecognitionStats& st = in.tracking.recognition;
    st.running = true;
    std::uint64_t* fields[4] = {&st.samples, &st.dropped, &st.events, &st.events_dropped};
    for (std::size_t k = 0; k < 4; ++k)
      *fields[k] = static_cast<std::uint64_t>(r.whole(c[k], "input.tracking.recognition", 0, 9007199254740992.0));
  }
  const json& h = r.at(t, "head", "input.tracking.head");
  if (!h.is_null()) in.tracking.head = parse_pose(h, r, "input.tracking.head");
  if (t.contains("bodies")) {  // version 5 on: the visitor's bodies as measured, by role
    const json& all = t["bodies"];
    if (!all.is_object()) r.fail("input.tracking.bodies", "not an object");
    for (const auto& [name, pose] : all.items()) {
      const auto role = recognition::role_from_string(name);
      if (!role)
        r.fail("input.tracking.bodies",
               fmt::format("not a role: \"{}\" (head, left_hand, right_hand, left_foot, right_foot)", name));
      if (!pose.is_object()) r.fail("input.tracking.bodies." + name, "not an object");
      in.tracking.bodies[static_cast<std::size_t>(*role)] = parse_pose(pose, r, "input.tracking.bodies." + name);
    }
  } else if (in.tracking.head) {
    // Before version 5 the fighter was given the head alone, as predicted to the display
    // (FighterInput::bodies): its replay gives it the same.
    in.tracking.bodies[static_cast<std::size_t>(recognition::Role::head)] = in.tracking.head;
  }
  return in;
}

/// No tracker is asked during a replay: the recorded snapshots come in through replay().
class ReplayTracking final : public TrackingInput {
 public:
  ReplayTracking(bool has_tracker, std::vector<std::string> camera_names)
      : has_tracker_(has_tracker), names_(std::move(camera_names)) {}
  void poll(Timestamp, Timestamp, TrackingSnapshot& out) override { out = {}; }
  Timestamp clock() const override { return 0; }
  std::string describe() const override { return "replay"; }
  bool has_tracker() const override { return has_tracker_; }
  const std::vector<std::string>& camera_names() const override { return names_; }

 private:
  bool has_tracker_;
  std::vector<std::string> names_;
};

}  // namespace

StateHashes state_hashes(const FrameData& frame, int frame_version) {
  return {walk::hash(frame, frame_version)};
}

// Sessions of versions 1 to 3, as they hashed (kept as they were: their files replay).
StateHashes state_hashes_v3(const FrameData& f, const std::function<std::string(const FrameEvent&)>& event_text) {
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
    if (event_text) {  // versions 1 and 2: events were hashed by their text
      ev.s(x.order ? to_string(*x.order) : std::string());
      ev.s(event_text(x));
    } else {
      ev.i(x.order.has_value());
      if (x.order) {
        ev.i(static_cast<int>(x.order->kind));
        ev.i(x.order->character);
      }
      ev.i(static_cast<int>(x.cause));
      const content::FighterEvent& g = x.fighter;
      ev.i(content::event_info(g.kind).fighter_byte);
      ev.i(static_cast<int>(g.reason));
      ev.i(static_cast<int>(g.order.kind));
      ev.i(g.order.character);
      ev.d(g.target.x());
      ev.d(g.target.y());
      ev.d(g.target.z());
      ev.i(g.segment);
      ev.i(g.start_frame);
      ev.i(g.contact_frame);
      ev.d(g.contact_distance_m);
      ev.i(g.out_of_reach);
      ev.i(g.character_count);
      ev.i(x.wall);
      ev.i(x.outside);
      ev.i(x.lost);
      if (x.type == EventType::visitor_strike) {
        const VisitorStrike& k = x.strike;
        ev.d(k.t);
        ev.d(k.decided_at);
        ev.i(static_cast<int>(k.type));
        ev.i(static_cast<int>(k.limb));
        ev.i(static_cast<int>(k.action));
        ev.d(k.progress);
        ev.d(k.confidence);
        for (const double c : k.impact) ev.d(c);
      }
    }
    ev.d(x.distance_m);
    ev.d(x.time_s);
  }
  out.value[5] = ev.h;
  return out;
}

std::uint64_t file_checksum(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return 0;  // a device has no end to sum
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

SessionInfo session_info(const InstallationConfig& config, const InstallationOptions& options,
                         std::optional<double> budget_mb) {
  SessionInfo info;
  info.config = config;
  if (options.orders_script) info.orders_script = std::filesystem::absolute(*options.orders_script);
  info.mono_eyes = options.mono_eyes;
  info.budget_mb = budget_mb.value_or(config.record_budget_mb);
  if (!(std::isfinite(info.budget_mb) && info.budget_mb > 0 && info.budget_mb <= 1e7))
    throw Error("cli", "range", fmt::format("--record-budget-mb: {}: must be in (0, 10000000] MB", info.budget_mb));
  return info;
}

/// One queued camera frame set (images shared with the tracker's: sources hand over fresh ones).
struct SessionRecorder::SetSlot {
  tracking::FrameSet set;
  std::size_t bytes = 0;  ///< the images' pixels, counted in queued_set_bytes_ until released
};

namespace {
std::size_t image_bytes(const tracking::FrameSet& set) {
  std::size_t n = 0;
  for (const auto& im : set.images) n += im.total() * im.elemSize();
  return n;
}
}  // namespace

// Frame sets queued for the writer (default 60: 1 s at 60 Hz). Each holds its images (4 x 1.3
// MB for the demo's cameras) until packed; the queue is bounded by their bytes too (default
// 100 MB): 60 full slots were 310 MB on a machine too loaded for the writer to keep up.
SessionRecorder::SessionRecorder(std::filesystem::path dir, SessionInfo info, std::size_t queue_frames,
                                 std::size_t queue_sets, std::size_t queue_set_bytes)
    : dir_(std::move(dir)), info_(std::move(info)), slots_(std::max<std::size_t>(queue_frames, 2)),
      set_bytes_limit_(queue_set_bytes) {
  for (std::size_t i = 0; i < std::max<std::size_t>(queue_sets, 2); ++i) set_slots_.push_back(std::make_unique<SetSlot>());
  make_output_folder(dir_, "--record " + dir_.string());
  {
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(dir_, ec)) {
      (void)e;
      throw Error("io", "folder", fmt::format("--record {}: the folder is not empty (a session is recorded into an empty "
                                              "or new folder)", dir_.string()));
    }
  }
  created_unix_s_ = unix_now();
  budget_bytes_ = static_cast<std::uint64_t>(info_.budget_mb * 1e6);
  snapshot();
  const auto path = dir_ / "session.jsonl";
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) throw Error("io", "open", fmt::format("{}: cannot write ({})", path.string(), std::strerror(errno)));
  write_manifest(false);
  thread_ = std::thread([this] { run(); });
}

void SessionRecorder::snapshot() {
  const InstallationConfig& c = info_.config;
  const auto add = [&](std::string role, int index, const std::filesystem::path& source, const std::string& name) {
    SnapshotFile f;
    f.role = std::move(role);
    f.index = index;
    f.source = std::filesystem::absolute(source).lexically_normal();
    if (const auto bytes = read_bytes(f.source)) {
      f.snapshot = "snapshot/" + name;
      f.fnv = fnv_of(*bytes);
      f.bytes = bytes->size();
      std::filesystem::create_directories((dir_ / f.snapshot).parent_path());
      write_file_atomically(dir_ / f.snapshot, *bytes);
      bytes_.fetch_add(bytes->size(), std::memory_order_relaxed);
    }
    files_.push_back(std::move(f));
  };
  if (!c.file.empty()) add("config", -1, c.file, "installation.toml");
  std::optional<std::filesystem::path> orders = info_.orders_script;
  if (!orders && c.orders_script) orders = c.resolve(*c.orders_script);
  if (orders) add("orders", -1, *orders, "orders.csv");
  if (!c.tracking.tracking.empty()) add("tracking", -1, c.resolve(c.tracking.tracking), "tracking.toml");
  if (!c.tracking.calibration.empty()) add("calibration", -1, c.resolve(c.tracking.calibration), "calibration.yaml");
  for (std::size_t i = 0; i < c.characters.size(); ++i)
    add("character", static_cast<int>(i), c.resolve(c.characters[i].bvh), fmt::format("characters/{}.bvh", i + 1));
  if (!c.fighter.database.empty()) {
    database_ = std::filesystem::absolute(c.resolve(c.fighter.database)).lexically_normal();
    // Its checksum (12 MB for the demo: ~20 ms) on the writer thread, not the frame's (the key).
    std::error_code ec;
    database_bytes_ = std::filesystem::file_size(database_, ec);
    if (ec) database_bytes_ = 0;
  }
}

SessionRecorder::~SessionRecorder() {
  try {
    close();
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
  }
}

void SessionRecorder::started(Timestamp start, bool has_tracker, std::uint64_t first_frame,
                              std::vector<std::string> camera_names) {
  const std::uint64_t h = head_.load(std::memory_order_relaxed);
  if (h - tail_.load(std::memory_order_acquire) >= slots_.size()) {  // cannot happen before the first frame
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  Item& item = slots_[h % slots_.size()];
  item.start = Item::Start{start, has_tracker, first_frame, unix_now(), std::move(camera_names)};
  head_.store(h + 1, std::memory_order_release);
}

void SessionRecorder::push(std::uint64_t frame, const FrameInput& input, const StateHashes& hashes,
                           const FrameData& state) {
  if (budget_reached_.load(std::memory_order_relaxed)) return;  // stopped: said once by the writer
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
  item.input.tracking.state = input.tracking.state;
  item.input.tracking.frame_sets = input.tracking.frame_sets;
  item.input.tracking.cameras.assign(input.tracking.cameras.begin(), input.tracking.cameras.end());
  item.input.tracking.source = input.tracking.source;
  item.input.tracking.strikes.assign(input.tracking.strikes.begin(), input.tracking.strikes.end());
  item.input.tracking.recognition = input.tracking.recognition;
  item.input.tracking.bodies = input.tracking.bodies;
  item.input.tracking_clock = input.tracking_clock;
  item.input.latch_ms = input.latch_ms;
  item.hashes = hashes;
  item.state = state;  // copy-assigned: the slot's vectors keep their room
  item.start.reset();
  head_.store(h + 1, std::memory_order_release);
}

void SessionRecorder::reserve(const FrameCapacity& c) {
  // The slots from head to tail + size are the frame loop's (the others wait for the writer).
  const std::uint64_t h = head_.load(std::memory_order_relaxed);
  const std::uint64_t t = tail_.load(std::memory_order_acquire);
  for (std::uint64_t k = h; k < t + slots_.size(); ++k) {
    Item& item = slots_[k % slots_.size()];
    item.input.keyed.reserve(c.keyed);
    item.input.tracking.cameras.reserve(c.cameras);
    item.input.tracking.strikes.reserve(c.strikes);
    item.state.views.reserve(c.walls);
    item.state.items.reserve(c.items);
    item.state.events.reserve(c.events);
    item.state.fighter.joints.reserve(c.joints);
    item.state.fighter.local_rotations.reserve(c.joints);
  }
}

void SessionRecorder::push_frame_set(const tracking::FrameSet& set) {
  if (budget_reached_.load(std::memory_order_relaxed) || stop_.load(std::memory_order_relaxed)) return;
  const std::uint64_t h = set_head_.load(std::memory_order_relaxed);
  const std::uint64_t queued = h - set_tail_.load(std::memory_order_acquire);
  const std::size_t bytes = image_bytes(set);
  // (the writer subtracts a set's bytes as it releases its images, before it frees the slot)
  const std::uint64_t held = queued_set_bytes_.load(std::memory_order_acquire);
  if (queued >= set_slots_.size() || (queued > 0 && held + bytes > set_bytes_limit_)) {
    sets_dropped_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  SetSlot& s = *set_slots_[h % set_slots_.size()];
  s.bytes = bytes;
  const std::uint64_t now_held = queued_set_bytes_.fetch_add(bytes, std::memory_order_acq_rel) + bytes;
  if (now_held > peak_queued_set_bytes_.load(std::memory_order_relaxed))
    peak_queued_set_bytes_.store(now_held, std::memory_order_relaxed);  // the one producer writes it
  tracking::FrameSet& slot = s.set;
  slot.frame = set.frame;
  slot.timestamp = set.timestamp;
  slot.images.assign(set.images.begin(), set.images.end());  // headers: the pixels are shared
  slot.camera_times.assign(set.camera_times.begin(), set.camera_times.end());
  set_head_.store(h + 1, std::memory_order_release);
}

void SessionRecorder::push_encoded_frame_sets(std::vector<std::string> records) {
  const std::lock_guard lock(encoded_mutex_);
  for (auto& r : records) encoded_.push_back(std::move(r));
}

void SessionRecorder::write_frame_set(const tracking::FrameSet& set) { write_frame_record(tracking::encode_frame_set(set)); }

void SessionRecorder::write_frame_record(const std::string& record) {
  const auto path = dir_ / "cameras.bin";
  const std::size_t header = frames_fd_ < 0 ? tracking::kCameraFramesHeader.size() : 0;
  if (bytes_.load(std::memory_order_relaxed) + record.size() + header > budget_bytes_) {
    budget_reached_.store(true, std::memory_order_relaxed);
    spdlog::warn("record: {}: the disk budget of {:g} MB is spent: recording stopped after {} frames and {} camera "
                 "frame sets (the session replays up to there; --record-budget-mb or [record] budget_mb for more)",
                 dir_.string(), info_.budget_mb, written_.load(), sets_written_.load());
    return;
  }
  if (frames_fd_ < 0) {
    frames_fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (frames_fd_ < 0) throw Error("io", "open", fmt::format("{}: cannot write ({})", path.string(), std::strerror(errno)));
    write_all(frames_fd_, tracking::kCameraFramesHeader, path);
    bytes_.fetch_add(header, std::memory_order_relaxed);
  }
  write_all(frames_fd_, record, path);  // one write: a kill leaves whole records
  bytes_.fetch_add(record.size(), std::memory_order_relaxed);
  set_bytes_.fetch_add(record.size() + header, std::memory_order_relaxed);
  sets_written_.fetch_add(1, std::memory_order_relaxed);
}

void SessionRecorder::write_state_record() {
  const auto path = dir_ / "states.bin";
  if (states_fd_ < 0) {
    states_fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (states_fd_ < 0) throw Error("io", "open", fmt::format("{}: cannot write ({})", path.string(), std::strerror(errno)));
    write_all(states_fd_, kFrameStatesHeader, path);
    bytes_.fetch_add(kFrameStatesHeader.size(), std::memory_order_relaxed);
    state_bytes_.fetch_add(kFrameStatesHeader.size(), std::memory_order_relaxed);
  }
  write_all(states_fd_, state_record_, path);  // one write: a kill leaves whole records
  bytes_.fetch_add(state_record_.size(), std::memory_order_relaxed);
  state_bytes_.fetch_add(state_record_.size(), std::memory_order_relaxed);
}

void SessionRecorder::run() {
  // Below the frame loop and the tracker: the disk can wait, a frame cannot.
  lower_this_thread_priority(kWriterNice);
  if (!database_.empty()) {
    database_fnv_ = file_checksum(database_);
    try {
      write_manifest(false);
    } catch (const std::exception& e) {
      error_ = e.what();
    }
  }
  std::string text;
  for (;;) {
    const bool stopping = stop_.load(std::memory_order_acquire);
    const std::uint64_t h = head_.load(std::memory_order_acquire);
    std::uint64_t t = tail_.load(std::memory_order_relaxed);
    for (; t < h; ++t) {
      const Item& item = slots_[t % slots_.size()];
      json j;
      if (item.start) {
        start_ = item.start;
        j = {{"start", item.start->start}, {"unix_s", item.start->unix_s}, {"has_tracker", item.start->has_tracker},
             {"first_frame", item.start->first_frame}, {"cameras", item.start->camera_names}};
      } else {
        json hashes = json::object();
        for (std::size_t k = 0; k < StateHashes::kFields.size(); ++k)
          hashes[std::string(StateHashes::kFields[k])] = hex(item.hashes.value[k]);
        j = {{"frame", item.frame}, {"input", input_json(item.input)}, {"hash", hashes}};
        const FighterPose& p = item.state.fighter;
        const bool first_of_character =
            p.present && std::find(skeletons_written_.begin(), skeletons_written_.end(), p.character) == skeletons_written_.end();
        encode_frame_state(item.state, first_of_character, state_record_);
        if (first_of_character) skeletons_written_.push_back(p.character);
      }
      const bool is_start = item.start.has_value();  // read before the slot is given back
      tail_.store(t + 1, std::memory_order_release);  // the slot is read: the frame loop may reuse it
      text = j.dump(-1, ' ', false, json::error_handler_t::replace);
      text += '\n';
      if (!error_.empty() || budget_reached_.load(std::memory_order_relaxed)) continue;
      const std::size_t state_bytes = is_start ? 0 : state_record_.size() + (states_fd_ < 0 ? kFrameStatesHeader.size() : 0);
      if (bytes_.load(std::memory_order_relaxed) + text.size() + state_bytes > budget_bytes_) {
        budget_reached_.store(true, std::memory_order_relaxed);
        spdlog::warn("record: {}: the disk budget of {:g} MB is spent: recording stopped after {} frames (the session "
                     "replays up to there; --record-budget-mb or [record] budget_mb for more)",
                     dir_.string(), info_.budget_mb, written_.load());
        continue;
      }
      try {
        // The state first: a frame whose line is in session.jsonl has its state in states.bin
        // (a kill between the two leaves one state more, which the replay does not reach).
        if (!is_start) write_state_record();
        write_line(text);
      } catch (const std::exception& e) {
        error_ = e.what();  // said at close(); later frames are not written (the file would have a hole)
      }
    }
    // Camera frame sets: first the tracker's pre-roll (already encoded), then the queue (a few
    // ms each to pack). The queue's head is read first: a set queued after it waits for the
    // next round, so a pre-roll handed over meanwhile is still written before it.
    const std::uint64_t sh = set_head_.load(std::memory_order_acquire);
    {
      std::vector<std::string> pre;
      {
        const std::lock_guard lock(encoded_mutex_);
        pre.swap(encoded_);
      }
      for (const auto& r : pre) {
        if (!error_.empty() || budget_reached_.load(std::memory_order_relaxed)) break;
        try {
          write_frame_record(r);
        } catch (const std::exception& e) {
          error_ = e.what();
        }
      }
    }
    for (std::uint64_t st = set_tail_.load(std::memory_order_relaxed); st < sh; ++st) {
      tracking::FrameSet& set = set_slots_[st % set_slots_.size()]->set;
      if (error_.empty() && !budget_reached_.load(std::memory_order_relaxed)) {
        try {
          write_frame_set(set);
        } catch (const std::exception& e) {
          error_ = e.what();
        }
      }
      for (auto& im : set.images) im.release();  // the tracker's pixels are not held longer than needed
      queued_set_bytes_.fetch_sub(set_slots_[st % set_slots_.size()]->bytes, std::memory_order_acq_rel);
      set_tail_.store(st + 1, std::memory_order_release);
    }
    if (stopping) return;  // everything pushed before stop was written
    std::this_thread::sleep_for(std::chrono::milliseconds(kWriterPeriodMs));
  }
}

void SessionRecorder::write_line(const std::string& line) {
  write_all(fd_, line, dir_ / "session.jsonl");
  bytes_.fetch_add(line.size(), std::memory_order_relaxed);
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
  json files = json::array();
  for (const auto& f : files_) {
    json e = {{"role", f.role}, {"source", f.source.string()}};
    if (f.index >= 0) e["index"] = f.index;
    if (f.snapshot.empty()) {
      e["snapshot"] = nullptr;  // not there when recording started
    } else {
      e["snapshot"] = f.snapshot;
      e["fnv"] = hex(f.fnv);
      e["bytes"] = f.bytes;
    }
    files.push_back(std::move(e));
  }
  m["files"] = std::move(files);
  if (!database_.empty())  // fnv null until the writer has read it
    m["database"] = {{"source", database_.string()},
                     {"fnv", database_fnv_ != 0 ? json(hex(database_fnv_)) : json(nullptr)},
                     {"bytes", database_bytes_}};
  const auto root = info_.config.data_root();
  m["data_dir"] = root.empty() ? json(nullptr) : json(std::filesystem::absolute(root).lexically_normal().string());
  m["recording"] = info_.config.tracking.recording.empty()
                       ? json(nullptr)
                       : json(std::filesystem::absolute(info_.config.resolve(info_.config.tracking.recording)).string());
  m["mono_eyes"] = info_.mono_eyes;
  m["state_fields"] = StateHashes::kFields;
  m["frame_version"] = kFrameVersion;
  if (frames_fd_ >= 0 || sets_written_.load() > 0 || sets_dropped_.load() > 0)
    m["camera_frames"] = {{"file", "cameras.bin"}, {"sets", sets_written_.load()}, {"dropped", sets_dropped_.load()},
                          {"bytes", set_bytes_.load()}};
  m["budget_mb"] = info_.budget_mb;
  if (complete) {
    m["closed_unix_s"] = unix_now();
    if (start_) {
      m["start_unix_s"] = start_->unix_s;
      m["first_frame"] = start_->first_frame;
    }
    m["frames"] = written_.load();
    m["frames_offered"] = pushed_.load();
    m["dropped"] = dropped_.load();
    m["stopped"] = budget_reached_.load() ? json("budget") : json(nullptr);
    m["bytes"] = bytes_.load();
    m["session_fnv"] = hex(checksum_);
    if (state_bytes_.load() > 0) m["frame_states"] = {{"file", "states.bin"}, {"bytes", state_bytes_.load()}};
  }
  write_file_atomically(dir_ / "manifest.json", m.dump(2, ' ', false, json::error_handler_t::replace) + "\n");
}

void SessionRecorder::close() {
  if (fd_ < 0) return;
  stop_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
  const int fd = std::exchange(fd_, -1);
  bool synced = ::fsync(fd) == 0;
  ::close(fd);
  if (frames_fd_ >= 0) {
    synced = ::fsync(frames_fd_) == 0 && synced;
    ::close(std::exchange(frames_fd_, -1));
  }
  if (states_fd_ >= 0) {
    synced = ::fsync(states_fd_) == 0 && synced;
    ::close(std::exchange(states_fd_, -1));
  }
  write_manifest(true);
  if (!error_.empty()) throw Error("io", "write", error_);
  if (!synced) throw Error("io", "write", fmt::format("{}: cannot sync", (dir_ / "session.jsonl").string()));
  if (dropped_ > 0)
    spdlog::warn("record: {} frame(s) dropped (the writer was behind): a replay stops at the first", dropped_.load());
  if (sets_dropped_ > 0)
    spdlog::warn("record: {} camera frame set(s) dropped (the writer was behind; its queue held at most {:.0f} MB of "
                 "images, bounded at {:.0f} MB): a re-track misses them",
                 sets_dropped_.load(), peak_queued_set_bytes_.load() / 1e6, set_bytes_limit_ / 1e6);
  spdlog::info("record: {} frames, {} camera frame sets, {:.2f} MB -> {}", written_.load(), sets_written_.load(),
               bytes_.load() / 1e6, dir_.string());
}

std::uint64_t SessionRecorder::frames_written() const { return written_.load(); }
std::uint64_t SessionRecorder::dropped() const { return dropped_.load(); }

std::string SessionRecorder::status_line() const {
  std::string s = fmt::format("recording {}: {} frames, {:.1f} of {:g} MB", dir_.string(), written_.load(),
                              bytes_.load(std::memory_order_relaxed) / 1e6, info_.budget_mb);
  if (const auto d = dropped_.load(std::memory_order_relaxed); d > 0) s += fmt::format(", {} dropped", d);
  if (const auto n = sets_written_.load(std::memory_order_relaxed); n > 0) s += fmt::format(", {} camera frame sets", n);
  if (const auto d = sets_dropped_.load(std::memory_order_relaxed); d > 0) s += fmt::format(" ({} dropped)", d);
  if (budget_reached()) s += ": STOPPED, disk budget spent";
  return s;
}

// ---------------------------------------------------------------------------------------------

RecordSwitch::RecordSwitch(Installation& installation, SessionInfo info, std::filesystem::path folder)
    : inst_(installation), info_(std::move(info)), folder_(std::move(folder)) {}

RecordSwitch::~RecordSwitch() {
  try {
    finish();
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
  }
}

void RecordSwitch::start() {
  if (recorder_) return;
  std::filesystem::path dir = folder_;
  for (int n = 2; std::filesystem::exists(dir) && !std::filesystem::is_empty(dir); ++n)
    dir = folder_.string() + fmt::format("-{}", n);
  recorder_ = std::make_unique<SessionRecorder>(dir, info_);
  inst_.record_to(recorder_.get());
  spdlog::info("record: every frame's inputs and state hashes -> {}", dir.string());
}

void RecordSwitch::stop() {
  if (!recorder_) return;
  inst_.record_to(nullptr);
  closing_.emplace_back([r = std::shared_ptr<SessionRecorder>(std::move(recorder_))] {
    try {
      r->close();
    } catch (const std::exception& e) {
      spdlog::error("record: {}", e.what());
    }
  });
}

void RecordSwitch::toggle() {
  try {
    if (recorder_)
      stop();
    else
      start();
  } catch (const std::exception& e) {
    spdlog::error("record: {}", e.what());
  }
}

void RecordSwitch::finish() {
  if (recorder_) {
    inst_.record_to(nullptr);
    auto r = std::move(recorder_);
    r->close();  // throws its error here
  }
  for (auto& t : closing_)
    if (t.joinable()) t.join();
  closing_.clear();
}

// ---------------------------------------------------------------------------------------------

std::optional<double> parse_replay_from(std::string_view text, double start_unix_s) {
  const std::string s(text);
  int hh = 0, mm = 0, ss = 0;
  char c1 = 0, c2 = 0;
  std::istringstream in(s);
  if (s.find(':') != std::string::npos) {
    if (!(in >> hh >> c1 >> mm >> c2 >> ss) || c1 != ':' || c2 != ':' || !in.eof() || hh < 0 || hh > 23 || mm < 0 ||
        mm > 59 || ss < 0 || ss > 59)
      return std::nullopt;
    const auto t = static_cast<std::time_t>(std::floor(start_unix_s));
    std::tm local{};
    if (!localtime_r(&t, &local)) return std::nullopt;
    local.tm_hour = hh;
    local.tm_min = mm;
    local.tm_sec = ss;
    local.tm_isdst = -1;
    double at = static_cast<double>(std::mktime(&local));
    if (at < std::floor(start_unix_s)) at += 86400;  // past midnight
    return at - start_unix_s;
  }
  double v = 0;
  if (!(in >> v) || !in.eof() || !std::isfinite(v) || v < 0) return std::nullopt;
  return v;
}

namespace {

struct LoadedConfig {
  InstallationConfig config;
  std::optional<std::filesystem::path> orders;
};

/// The session's installation from its snapshot (or what it falls back to), notes for every
/// file that is not as recorded.
LoadedConfig session_config(const std::filesystem::path& dir, const json& m, const LineReader& mr,
                            const ReplayOptions& options, std::vector<std::string>& notes) {
  // ${data_dir}: --data-dir, else $KUMITE_DATA_DIR, else the folder it was when recorded.
  std::optional<std::filesystem::path> data_dir = options.data_dir;
  if (const char* env = std::getenv(kDataDirEnv); !data_dir && env && *env) data_dir = std::filesystem::path(env);
  if (!data_dir && m.contains("data_dir") && m["data_dir"].is_string()) data_dir = m["data_dir"].get<std::string>();
  LoadedConfig out;
  if (!m.contains("files")) {  // version 1: the config and orders script by path
    const std::filesystem::path recorded = m.value("config", "");
    const std::filesystem::path path = options.config_override.value_or(recorded);
    if (hex(file_checksum(path)) != m.value("config_fnv", ""))
      notes.push_back(fmt::format("{}: differs from the recorded config's checksum: frames may differ", path.string()));
    out.config = load_installation_config(path, options.data_dir);
    if (m.contains("orders_script") && m["orders_script"].is_string()) {
      out.orders = m["orders_script"].get<std::string>();
      if (hex(file_checksum(*out.orders)) != m.value("orders_fnv", ""))
        notes.push_back(fmt::format("{}: differs from the recorded orders script: frames may differ", out.orders->string()));
    }
    return out;
  }
  // Each snapshot file: there, whole and unchanged, else its source as it is now (said).
  struct Usable {
    std::string role;
    int index = -1;
    std::optional<std::filesystem::path> path;  // none: missing when recorded, or now
  };
  std::vector<Usable> usable;
  const json& files = mr.at(m, "files", "files");
  if (!files.is_array()) mr.fail("files", "expected an array");
  for (const json& f : files) {
    Usable u;
    const json& role = mr.at(f, "role", "files.role");
    if (!role.is_string()) mr.fail("files.role", "not a string");
    u.role = role.get<std::string>();
    u.index = f.contains("index") ? static_cast<int>(mr.whole(f["index"], "files.index", 0, 1e6)) : -1;
    const std::filesystem::path source = f.value("source", "");
    if (!f.contains("snapshot") || f["snapshot"].is_null()) {
      // Missing when recorded (a character left out): missing for the replay too.
      usable.push_back(u);
      continue;
    }
    const json& rel = f["snapshot"];
    if (!rel.is_string()) mr.fail("files.snapshot", "not a string");
    const std::filesystem::path rel_path(rel.get<std::string>());
    // Inside the session folder only (a damaged manifest cannot point the replay elsewhere).
    if (rel_path.is_absolute() || rel_path.lexically_normal().string().rfind("..", 0) == 0 || rel_path.empty())
      mr.fail("files.snapshot", fmt::format("\"{}\" is not a path inside the session folder", rel_path.string()));
    const std::filesystem::path snap = dir / rel_path;
    const auto bytes = read_bytes(snap);
    const auto want_bytes = static_cast<std::uint64_t>(mr.whole(mr.at(f, "bytes", "files.bytes"), "files.bytes", 0, 9007199254740992.0));
    std::string problem;
    if (!bytes)
      problem = "missing";
    else if (bytes->size() < want_bytes)
      problem = fmt::format("cut short ({} of {} bytes)", bytes->size(), want_bytes);
    else if (bytes->size() != want_bytes || hex(fnv_of(*bytes)) != f.value("fnv", ""))
      problem = "changed since it was recorded (checksum)";
    if (problem.empty()) {
      u.path = snap;
    } else if (std::error_code ec; std::filesystem::is_regular_file(source, ec)) {
      u.path = source;
      notes.push_back(fmt::format("{}: {}: replaying with {} as it is now: frames may differ", snap.string(), problem,
                                  source.string()));
    } else {
      notes.push_back(fmt::format("{}: {}, and {} is gone: replaying without it: frames may differ", snap.string(),
                                  problem, source.string()));
    }
    usable.push_back(u);
  }
  const auto find = [&](std::string_view role, int index = -1) -> const Usable* {
    for (const auto& u : usable)
      if (u.role == role && u.index == index) return &u;
    return nullptr;
  };
  // The config: --config, else the snapshot, else (it no longer validates) the source.
  const Usable* cfg = find("config");
  if (options.config_override) {
    notes.push_back(fmt::format("{}: replaying with --config instead of the recorded snapshot: frames may differ",
                                options.config_override->string()));
    out.config = load_installation_config(*options.config_override, data_dir);
  } else {
    if (!cfg || !cfg->path) throw Error("replay", "missing", fmt::format("{}: no installation file to replay with (the "
                                                                         "snapshot and its source are gone)",
                                                                         (dir / "manifest.json").string()));
    try {
      out.config = load_installation_config(*cfg->path, data_dir);
    } catch (const Error& e) {
      std::filesystem::path source;
      for (const json& f : files)
        if (f.value("role", "") == "config") source = f.value("source", "");
      if (source.empty() || source == *cfg->path || !std::filesystem::exists(source)) throw;
      notes.push_back(fmt::format("{}: the snapshot no longer validates: replaying with {} as it is now: frames may differ",
                                  e.what(), source.string()));
      out.config = load_installation_config(source, data_dir);
    }
  }
  // The snapshot's paths are relative to the original file's folder: point them at the
  // snapshot's copies (or what stands in for them). --config keeps its own characters and
  // tracking files; the orders are the session's.
  InstallationConfig& c = out.config;
  if (const Usable* u = find("orders")) {
    if (u->path) out.orders = std::filesystem::absolute(*u->path);
  }
  c.orders_script.reset();  // none recorded: none replayed
  if (options.config_override) return out;
  for (std::size_t i = 0; i < c.characters.size(); ++i) {
    const Usable* u = find("character", static_cast<int>(i));
    c.characters[i].bvh = u && u->path ? std::filesystem::absolute(*u->path)
                                       : std::filesystem::absolute(dir / fmt::format("snapshot/missing-{}.bvh", i + 1));
  }
  if (const Usable* u = find("tracking"); u && u->path) c.tracking.tracking = std::filesystem::absolute(*u->path);
  if (const Usable* u = find("calibration"); u && u->path) c.tracking.calibration = std::filesystem::absolute(*u->path);
  if (m.contains("recording") && m["recording"].is_string()) c.tracking.recording = m["recording"].get<std::string>();
  if (m.contains("database") && m["database"].is_object()) {
    const json& d = m["database"];
    const std::filesystem::path recorded = d.value("source", "");
    // A "${data_dir}/..." database moves with the data folder; else the path recorded.
    const std::filesystem::path now =
        c.fighter.database.string().rfind(kDataDirPlaceholder, 0) == 0 ? c.resolve(c.fighter.database) : recorded;
    c.fighter.database = std::filesystem::absolute(now);
    if (!std::filesystem::exists(now))
      notes.push_back(fmt::format("{}: the fighter database is gone: replaying without a fighter: frames differ",
                                  now.string()));
    else if (!d.contains("fnv") || !d["fnv"].is_string() || hex(file_checksum(now)) != d["fnv"].get<std::string>())
      notes.push_back(fmt::format("{}: the fighter database differs from the one recorded (checksum): frames may differ",
                                  now.string()));
  }
  return out;
}

}  // namespace

namespace {
ReplayReport replay(const std::filesystem::path& dir, const ReplayOptions& options, std::string& where);
}  // namespace

ReplayReport replay_session(const std::filesystem::path& dir, const ReplayOptions& options) {
  // A value of the wrong JSON type (a hand-edited or damaged session) throws from the JSON
  // library: said in one line naming the file (and line) being read.
  std::string where = (dir / "manifest.json").string();
  try {
    return replay(dir, options, where);
  } catch (const json::exception& e) {
    throw Error("replay", "json", fmt::format("{}: {}", where, e.what()));
  }
}

namespace {

ReplayReport replay(const std::filesystem::path& dir, const ReplayOptions& options, std::string& where) {
  ReplayReport rep;
  const auto manifest_path = dir / "manifest.json";
  std::ifstream mf(manifest_path);
  if (!mf) throw Error("replay", "missing", fmt::format("{}: cannot read (not a recorded session)", manifest_path.string()));
  const json m = json::parse(mf, nullptr, false);
  LineReader mr = session_reader(manifest_path.string());
  if (m.is_discarded() || !m.is_object()) mr.fail("", "not valid JSON (or not an object)");
  const double version = mr.num(mr.at(m, "version", "version"), "version");
  if (version > kSessionVersion)
    rep.notes.push_back(fmt::format("{}: version: session version {} is newer than this kumite reads ({}): replayed as "
                                    "version {}; a difference may be the format's",
                                    manifest_path.string(), version, kSessionVersion, kSessionVersion));
  if (!m.value("complete", false))
    rep.notes.push_back(fmt::format("{}: complete: false: the recording did not end cleanly (killed?): replaying its "
                                    "complete frames", manifest_path.string()));
  if (m.value("stopped", json(nullptr)) == "budget")
    rep.notes.push_back(fmt::format("{}: stopped: the disk budget ({} MB) was spent: the session ends there",
                                    manifest_path.string(), m.value("budget_mb", 0.0)));
  if (const double dropped = m.contains("dropped") ? mr.whole(m["dropped"], "dropped", 0, 9007199254740992.0) : 0; dropped > 0)
    rep.notes.push_back(fmt::format("{}: dropped: {} frame(s) were dropped while recording: the replay stops at the first",
                                    manifest_path.string(), dropped));
  LoadedConfig loaded = session_config(dir, m, mr, options, rep.notes);
  InstallationOptions io;
  io.mono_eyes = m.value("mono_eyes", false);
  io.orders_script = loaded.orders;

  // --retrack: the session's camera frames through this build's tracker, in step with the
  // recorded frames (each frame set processed before the first frame at or after its time).
  struct Retracking {
    tracking::Tracker tracker;
    tracking::CameraFramesReader frames;
    int head = 0;
    std::vector<std::string> names;
    TrackerReading reading;
    std::optional<tracking::FrameSet> next;
    bool more = true;
    std::vector<double> head_m;
  };
  std::unique_ptr<Retracking> rt;
  if (options.retrack) {
    const auto cameras = dir / "cameras.bin";
    if (!std::filesystem::exists(cameras))
      throw Error("replay", "missing", fmt::format("{}: no camera frames in this session (recorded without a tracker, or "
                                                   "by a kumite that did not keep them): it cannot be re-tracked",
                                                   cameras.string()));
    const InstallationConfig& c = loaded.config;
    auto rig = tracking::read_calibration(c.resolve(c.tracking.calibration));
    auto tc = tracking::read_tracking_config(c.resolve(c.tracking.tracking));
    std::vector<std::string> names;
    for (const auto& cam : rig.cameras) names.push_back(cam.name);
    const int head = head_body_index(c, tc);  // throws, naming the key, for a body that does not exist
    TrackerReading reading;
    reading.role_body = role_bodies(head, tc);  // the gloves and shoes re-tracked too
    rt.reset(new Retracking{tracking::Tracker(std::move(rig), std::move(tc)), tracking::CameraFramesReader(cameras),
                            head, std::move(names), reading, std::nullopt, true, {}});
    rep.retrack = ReplayReport::Retrack{};
  }

  // The frames as recorded, whole (version 3 on): each replayed frame is checked against its
  // recorded state too, and a difference is said by value.
  std::unique_ptr<FrameStatesReader> states;
  FrameData recorded;
  if (const auto path = dir / "states.bin"; std::filesystem::exists(path)) {
    try {
      states = std::make_unique<FrameStatesReader>(path);
    } catch (const std::exception& e) {
      rep.notes.push_back(fmt::format("{}: the frames are checked by their hashes alone", e.what()));
    }
  } else if (m.contains("frame_states")) {
    // Recorded, then lost (deleted, not copied with the rest): said, never taken for a match.
    rep.notes.push_back(fmt::format("{}: missing (manifest.json says the session recorded it): the frames are checked "
                                    "by their hashes alone",
                                    path.string()));
  }
  rep.states_compared = states != nullptr;
  // The recorded state of `frame` (nullptr: none, said once).
  const auto recorded_state = [&](std::uint64_t frame) -> FrameData* {
    if (!states) return nullptr;
    const bool read = states->next(recorded);
    if (read && recorded.frame == frame) return &recorded;
    rep.notes.push_back(
        read ? fmt::format("{}: holds frame {} where frame {} was due: later frames are checked by their hashes alone",
                           (dir / "states.bin").string(), recorded.frame, frame)
        : !states->problem().empty()
            ? states->problem() + ": later frames are checked by their hashes alone"
            : fmt::format("{}: ends before frame {}: later frames are checked by their hashes alone",
                          (dir / "states.bin").string(), frame));
    states.reset();
    rep.states_compared = false;
    return nullptr;
  };

  const auto session_path = dir / "session.jsonl";
  std::ifstream in(session_path, std::ios::binary);
  if (!in) throw Error("replay", "missing", fmt::format("{}: cannot read", session_path.string()));
  std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  LineReader r = session_reader(session_path.string());
  std::size_t pos = 0;
  std::unique_ptr<Installation> inst;
  std::optional<std::uint64_t> expected;
  std::optional<double> from_s;
  double start = 0;
  auto t0 = std::chrono::steady_clock::now();
  std::chrono::steady_clock::time_point pace0;
  Timestamp first_now = 0, last_now = 0, pace_now0 = 0;
  std::optional<std::uint64_t> stop_after;  // the viewer ended the replay after this frame
  // Sessions before version 3 hashed events by their text: the same text, made again.
  std::function<std::string(const FrameEvent&)> text_hash;
  if (version < 3) text_hash = [&](const FrameEvent& e) { return inst->event_text(e); };
  // Version 4 on: the hashes walk the frame's description, up to the frame version recorded.
  const int frame_version = m.contains("frame_version")
                                ? static_cast<int>(mr.whole(m["frame_version"], "frame_version", 1, kFrameVersion))
                                : kFrameVersion;
  const auto hashes_of = [&](const FrameData& f) {
    return version >= 4 ? state_hashes(f, frame_version) : state_hashes_v3(f, text_hash);
  };
  while (pos < all.size()) {
    if (stop_after) {
      rep.stopped_after_frame = stop_after;
      break;
    }
    const auto end = all.find('\n', pos);
    ++r.line;
    if (end == std::string::npos) {
      rep.notes.push_back(fmt::format("{}:{}: the last line is cut short (the recorder was killed): left out", r.file, r.line));
      break;
    }
    const json j = json::parse(std::string_view(all).substr(pos, end - pos), nullptr, false);
    pos = end + 1;
    where = fmt::format("{}:{}", r.file, r.line);
    if (j.is_discarded() || !j.is_object()) {
      rep.notes.push_back(fmt::format("{}:{}: not valid JSON: the replay stops there", r.file, r.line));
      break;
    }
    if (!inst) {
      start = r.num(r.at(j, "start", "start"), "start");
      std::vector<std::string> names;  // version 3 on; before, the console says cam0, cam1, ...
      if (j.contains("cameras") && j["cameras"].is_array())
        for (const auto& n : j["cameras"]) names.push_back(n.is_string() ? n.get<std::string>() : "?");
      if (rt) names = rt->names;
      const bool has_tracker = j.contains("has_tracker") && j["has_tracker"].is_boolean() && j["has_tracker"].get<bool>();
      inst = std::make_unique<Installation>(loaded.config, std::make_unique<ReplayTracking>(has_tracker, std::move(names)), io);
      inst->start(start);
      if (options.on_start) options.on_start(*inst);
      const auto first =
          j.contains("first_frame") ? static_cast<std::uint64_t>(r.whole(j["first_frame"], "first_frame", 0, 9007199254740992.0)) : 0;
      if (first > 0) {
        rep.compared = false;
        rep.notes.push_back(fmt::format("{}:{}: first_frame: the recording started at frame {} of the run (the record "
                                        "key): the state before it was not recorded, so its frames are re-run from a "
                                        "fresh start and not compared", r.file, r.line, first));
      }
      if (options.from) {
        from_s = parse_replay_from(*options.from, j.value("unix_s", m.value("created_unix_s", 0.0)));
        if (!from_s) throw Error("cli", "from", fmt::format("--from {}: expected seconds (12.5) or a time of day (21:14:05)", *options.from));
      }
      continue;
    }
    const auto frame = static_cast<std::uint64_t>(r.whole(r.at(j, "frame", "frame"), "frame", 0, 9007199254740992.0));
    if (rep.frames_recorded == 0) t0 = std::chrono::steady_clock::now();  // the frames' time, not the start-up's
    ++rep.frames_recorded;
    if (expected && frame != *expected) {
      rep.notes.push_back(fmt::format("{}:{}: frame {} follows frame {}: frames {}..{} were dropped while recording; the "
                                      "replay stops there", r.file, r.line, frame, *expected - 1, *expected, frame - 1));
      break;
    }
    expected = frame + 1;
    FrameInput input = parse_input(r.at(j, "input", "input"), r);
    std::optional<BodyPose> recorded_head;
    if (rt) {
      recorded_head = input.tracking.head;
      for (;;) {
        if (!rt->next && rt->more) {
          tracking::FrameSet set;
          rt->more = rt->frames.next(set);
          if (rt->more) rt->next = std::move(set);
        }
        // The sets the live tracker had published when this frame took its pose: up to the one
        // its newest pose came from (recorded), else (no pose yet) those due by the frame's time.
        if (!rt->next) break;
        const bool due = recorded_head ? rt->next->frame <= recorded_head->frame : rt->next->timestamp <= input.now;
        if (!due) break;
        rt->tracker.process(*rt->next);
        rt->next.reset();
        ++rep.retrack->sets;
      }
      // The time the frame predicts the head to, as Installation::update_head does.
      const Timestamp seen_at = std::max(input.now, input.shown_at) + loaded.config.display_latency_ms * 1e-3;
      read_tracker(rt->tracker, rt->head, input.now, seen_at, false, rt->reading, input.tracking);
      input.tracking.source.retracked = true;
    }
    const bool shown = !from_s || input.now - start >= *from_s;
    if (shown && !rep.from_frame) {
      rep.from_frame = frame;
      rep.from_s = input.now - start;
      pace0 = std::chrono::steady_clock::now();
      pace_now0 = input.now;
    }
    if (shown && options.real_time)
      std::this_thread::sleep_until(pace0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                std::chrono::duration<double>(input.now - pace_now0)));
    const FrameData& f = inst->replay(input);
    // The frame as recorded (states.bin; nullptr: none), read once for the presenter and the check.
    FrameData* was = recorded_state(frame);
    if (shown && options.on_frame) options.on_frame(options.show_recorded && was ? *was : f);
    if (shown && options.stop_requested && options.stop_requested()) stop_after = frame;
    if (rep.frames_replayed == 0) first_now = input.now;
    last_now = input.now;
    ++rep.frames_replayed;
    if (rt) {
      // Re-tracked: compared with the recording, not required to match it.
      const auto& h = input.tracking.head;
      const bool a = recorded_head && recorded_head->status == TrackingStatus::tracked;
      const bool b = h && h->status == TrackingStatus::tracked;
      if (a && b) {
        const double dx = h->position[0] - recorded_head->position[0], dy = h->position[1] - recorded_head->position[1],
                     dz = h->position[2] - recorded_head->position[2];
        rt->head_m.push_back(std::sqrt(dx * dx + dy * dy + dz * dz));
      } else if (a != b) {
        ++rep.retrack->status_differs;
      }
      const StateHashes got = hashes_of(f);
      const json& want = r.at(j, "hash", "hash");
      bool same = true;
      for (std::size_t k = 0; k < StateHashes::kFields.size(); ++k)
        same = same && want.value(std::string(StateHashes::kFields[k]), "") == hex(got.value[k]);
      // The live tracker's timing is a measurement of that run which re-tracking offline cannot
      // make again: its latency (when its poses were published), and which measurement the
      // frame's newest pose counted as its age's start (the live input reads the newest pose
      // and the filter a moment apart; a pose published between the two moves it by a set,
      // seen once in CI: 118 of 120 frames). Not compared; the head, eyes, views, fighter and
      // events are.
      if (was) {
        was->tracking_latency_ms = f.tracking_latency_ms;
        was->pose_age_ms = f.pose_age_ms;
        was->pose_measured_at = f.pose_measured_at;
      }
      const auto detail = was ? first_difference(*was, f) : std::nullopt;
      same = same && !detail;
      ++rep.retrack->frames_compared;
      if (same) ++rep.retrack->frames_identical;
      if (!same && !rep.first_difference_frame) {
        if (detail) rep.first_difference_detail = *detail;
        rep.first_difference_frame = frame;
        for (std::size_t k = 0; k < StateHashes::kFields.size(); ++k)
          if (want.value(std::string(StateHashes::kFields[k]), "") != hex(got.value[k])) {
            rep.first_difference_field = std::string(StateHashes::kFields[k]);
            break;
          }
      }
      continue;
    }
    if (!rep.compared) continue;
    if (rep.first_difference_frame) continue;  // show_recorded goes on past the first difference
    const StateHashes got = hashes_of(f);
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
    // The whole state as recorded: every field (what was drawn included), by value.
    if (was)
      if (auto detail = first_difference(*was, f)) {
        if (rep.identical) rep.first_difference_field = detail->substr(0, detail->find(':'));
        rep.identical = false;
        rep.first_difference_frame = frame;
        rep.first_difference_detail = std::move(*detail);
      }
    if (!rep.identical && !options.show_recorded) break;
  }
  if (!inst) throw file_error("replay", "session", session_path.string(), 1, "start", "no start line: nothing recorded");
  if (options.on_end) options.on_end(*inst);
  if (from_s && !rep.from_frame && rep.identical)
    rep.notes.push_back(fmt::format("--from {}: {:.3f} s is past the last frame replayed ({:.3f} s)", *options.from,
                                    *from_s, last_now - start));
  if (rt) {
    if (!rt->frames.problem().empty()) rep.notes.push_back(rt->frames.problem() + ": the re-track has no frames after it");
    auto& v = rt->head_m;
    std::sort(v.begin(), v.end());
    const auto pct = [&](double q) { return v.empty() ? 0.0 : v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))]; };
    rep.retrack->head_p50_m = pct(0.5);
    rep.retrack->head_p95_m = pct(0.95);
    rep.retrack->head_max_m = v.empty() ? 0.0 : v.back();
    rep.identical = rep.retrack->frames_identical == rep.retrack->frames_compared;
  }
  rep.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  rep.session_s = last_now - first_now;
  return rep;
}

}  // namespace

}  // namespace kumite::app
