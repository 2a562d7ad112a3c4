#include "kumite/app/frame_states.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

#include <fmt/format.h>
#include <zlib.h>

#include "kumite/common/checksum.hpp"
#include "kumite/common/error.hpp"
#include "frame_walk.hpp"

namespace kumite::app {

namespace {

constexpr std::uint32_t kMagic = 0x3154534B;  // "KST1"
constexpr std::uint32_t kMaxPayload = 64u << 20;
constexpr std::uint32_t kMaxCount = walk::Reader::kMaxCount;
enum : std::uint8_t { kSkeleton = 1, kFrame = 2, kConsole = 3 };
/// A console record's bounds: lines in a list, bytes in a line (far above any real console).
constexpr std::uint32_t kMaxConsoleLines = 1024, kMaxConsoleText = 64u << 10;

// ---- writing -------------------------------------------------------------------------------

struct Out {
  std::string& s;
  template <typename T>
  void put(T v) {
    static_assert(std::is_arithmetic_v<T>);
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof v);
    s.append(b, sizeof b);
  }
  void u8(std::uint8_t v) { put(v); }
  void u32(std::size_t v) { put(static_cast<std::uint32_t>(v)); }
  void str(std::string_view t) {
    u32(t.size());
    s.append(t);
  }
  template <class C>
  void lines(const C& c) {
    u32(c.size());
    for (const auto& t : c) str(t);
  }
};

/// The console record's contents (frame_states.hpp), in that order.
void write_console(Out& o, const ConsoleState& c) {
  o.u8(kConsole);
  o.put(c.fps);
  o.put(c.frame_cpu_ms);
  o.str(c.tracking);
  o.str(c.tracking_source);
  o.str(c.recognition);
  o.u32(c.cameras.size());
  for (const auto& cam : c.cameras) {
    o.str(cam.name);
    o.u8(static_cast<std::uint8_t>(cam.state));
    o.str(cam.status);
    o.put(static_cast<std::int32_t>(cam.blobs));
    o.put(cam.since_last_ms);
  }
  o.put(static_cast<std::int32_t>(c.markers_seen));
  o.u8(c.head_live ? 1 : 0);
  o.put(c.pose_age_ms);
  o.put(c.tracking_latency_ms);
  o.put(c.latch_ms);
  o.put(c.draw_budget_ms);
  o.u8(c.late_latch ? 1 : 0);
  o.str(c.fighter_state);
  o.put(static_cast<std::int32_t>(c.character));
  o.str(c.character_name);
  o.u8(c.paused ? 1 : 0);
  o.str(c.last_order);
  o.str(c.last_outcome);
  o.str(c.planner);
  o.lines(c.problems);
  o.lines(c.recent);
  o.lines(c.frame_events);
}

/// A record appended to `out`: header, then the payload: u32 bytes of what `body` writes, and
/// that, zlib-compressed (level 1: a frame's ~10 kB become ~4 kB, in ~0.1 ms of the writer's
/// thread). `raw` is scratch.
template <typename F>
void record(std::string& out, std::string& raw, F&& body) {
  raw.clear();
  Out o{raw};
  body(o);
  const std::size_t at = out.size();
  uLongf packed = compressBound(static_cast<uLong>(raw.size()));
  out.resize(at + 20 + packed);
  if (compress2(reinterpret_cast<Bytef*>(out.data() + at + 20), &packed, reinterpret_cast<const Bytef*>(raw.data()),
                static_cast<uLong>(raw.size()), 1) != Z_OK)
    throw Error("io", "compress", "frame states: zlib could not compress a frame");
  out.resize(at + 20 + packed);
  const std::uint32_t magic = kMagic, bytes = static_cast<std::uint32_t>(4 + packed),
                      raw_bytes = static_cast<std::uint32_t>(raw.size());
  std::memcpy(out.data() + at + 16, &raw_bytes, 4);
  const std::uint64_t sum = fnv1a64(std::string_view(out).substr(at + 16));
  std::memcpy(out.data() + at, &magic, 4);
  std::memcpy(out.data() + at + 4, &bytes, 4);
  std::memcpy(out.data() + at + 8, &sum, 8);
}

// ---- reading -------------------------------------------------------------------------------

/// The frame fields' reader (walk::Reader: get<T>(), ok) with what the skeleton records take too.
struct In : walk::Reader {
  std::uint8_t u8() { return get<std::uint8_t>(); }
  /// A count of things of at least `bytes_each` bytes each still to read: no more than the
  /// bytes left can hold (a damaged count must not make the reader allocate gigabytes).
  std::uint32_t count(std::size_t bytes_each = 1) {
    const auto n = get<std::uint32_t>();
    if (n > kMaxCount || static_cast<std::size_t>(n) * bytes_each > p.size()) ok = false;
    return ok ? n : 0;
  }
  std::string str() {
    const auto n = count();
    if (!ok || p.size() < n) {
      ok = false;
      return {};
    }
    std::string t(p.substr(0, n));
    p.remove_prefix(n);
    return t;
  }
  /// A number that must be finite (and at least `least`).
  double f64(double least = -1e300) {
    const auto v = get<double>();
    if (!std::isfinite(v) || v < least) ok = false;
    return ok ? v : 0.0;
  }
  /// An i32 in [least, most].
  int i32(int least, int most) {
    const auto v = get<std::int32_t>();
    if (v < least || v > most) ok = false;
    return ok ? v : 0;
  }
  /// A console line: no longer than kMaxConsoleText.
  std::string line() {
    const auto n = get<std::uint32_t>();
    if (n > kMaxConsoleText || n > p.size()) ok = false;
    if (!ok) return {};
    std::string t(p.substr(0, n));
    p.remove_prefix(n);
    return t;
  }
  /// A list of console lines (each at least its 4-byte length).
  template <class C>
  void lines(C& out) {
    out.clear();
    const auto n = count(4);
    if (n > kMaxConsoleLines) ok = false;
    for (std::uint32_t k = 0; k < n && ok; ++k) out.push_back(line());
  }
};

/// A console record's contents after its kind byte into `c`; "" or what is wrong, in words.
std::string read_console(In& in, ConsoleState& c) {
  c = ConsoleState{};
  c.fps = in.f64(0);
  c.frame_cpu_ms = in.f64(0);
  c.tracking = in.line();
  c.tracking_source = in.line();
  c.recognition = in.line();
  const auto cameras = in.count(4 + 1 + 4 + 4 + 8);
  if (cameras > kMaxConsoleLines) in.ok = false;
  for (std::uint32_t k = 0; k < cameras && in.ok; ++k) {
    ConsoleCamera cam;
    cam.name = in.line();
    const auto state = in.u8();
    if (state > static_cast<std::uint8_t>(CameraState::blind)) in.ok = false;
    cam.state = static_cast<CameraState>(in.ok ? state : 0);
    cam.status = in.line();
    cam.blobs = in.i32(0, std::numeric_limits<std::int32_t>::max());
    cam.since_last_ms = in.f64(-1);
    c.cameras.push_back(std::move(cam));
  }
  c.markers_seen = in.i32(0, std::numeric_limits<std::int32_t>::max());
  c.head_live = in.u8() != 0;
  c.pose_age_ms = in.f64();
  c.tracking_latency_ms = in.f64();
  c.latch_ms = in.f64();
  c.draw_budget_ms = in.f64();
  c.late_latch = in.u8() != 0;
  c.fighter_state = in.line();
  c.character = in.i32(-1, static_cast<int>(kMaxCount));
  c.character_name = in.line();
  c.paused = in.u8() != 0;
  c.last_order = in.line();
  c.last_outcome = in.line();
  c.planner = in.line();
  in.lines(c.problems);
  in.lines(c.recent);
  in.lines(c.frame_events);
  if (!in.ok || !in.p.empty())
    return "its console record does not read whole (cut, a count or a line too long, or a number not finite or out of range)";
  return "";
}


/// One record's payload (its 16-byte header read: `sum` is the header's checksum): checked,
/// unpacked into `raw`, and read: a skeleton into `skeletons`, or a frame into `f` (then
/// `is_frame`). Returns "" or what is wrong, in words.
std::string read_record(std::string_view payload, std::uint64_t sum, int version, std::string& raw,
                        std::map<int, std::shared_ptr<const FighterSkeleton>>& skeletons, FrameData& f, bool& is_frame,
                        ConsoleState* console = nullptr, std::string* console_problem = nullptr,
                        bool* is_console = nullptr) {
  is_frame = false;
  if (fnv1a64(payload) != sum) return "checksum does not match (damaged)";
  std::uint32_t raw_bytes = 0;
  if (payload.size() < 4) return "record too short";
  std::memcpy(&raw_bytes, payload.data(), 4);
  if (raw_bytes > kMaxPayload) return fmt::format("record of {} bytes unpacked: too large", raw_bytes);
  raw.resize(raw_bytes);
  uLongf unpacked = raw_bytes;
  if (uncompress(reinterpret_cast<Bytef*>(raw.data()), &unpacked, reinterpret_cast<const Bytef*>(payload.data() + 4),
                 static_cast<uLong>(payload.size() - 4)) != Z_OK ||
      unpacked != raw_bytes)
    return "does not unpack (damaged)";
  In in;
  in.p = raw;
  in.version = version;
  const std::uint8_t kind = in.u8();
  if (kind == kSkeleton) {
    auto s = std::make_shared<FighterSkeleton>();
    s->character = in.get<std::int32_t>();
    const auto n = in.count();
    for (std::uint32_t j = 0; j < n && in.ok; ++j) {
      s->joint_names.push_back(in.str());
      s->parents.push_back(in.get<std::int32_t>());
      if (s->parents.back() < -1 || s->parents.back() >= static_cast<int>(j)) in.ok = false;
    }
    if (!in.ok || !in.p.empty()) return "a skeleton record that does not read whole";
    // The same skeleton again (a network frame carries its skeleton each time): kept as it was.
    if (const auto it = skeletons.find(s->character);
        it == skeletons.end() || it->second->joint_names != s->joint_names || it->second->parents != s->parents)
      skeletons[s->character] = s;
    return "";
  }
  if (kind == kConsole && console) {
    // A render node's STATE: the master's console. What does not read is the console's
    // problem (the frame is still drawn), never the frame's.
    *console_problem = read_console(in, *console);
    *is_console = true;
    return "";
  }
  if (kind != kFrame) return fmt::format("unknown record kind {}", kind);
  FrameData& r = f;
  walk::Reader& fields = in;
  describe(fields, r);  // the frame's fields (frame_fields.hpp)
  FighterPose& p = r.fighter;
  if (!in.ok || !in.p.empty()) return "a frame record that does not read whole (or a number not finite)";
  if (p.present) {
    const auto s = skeletons.find(p.character);
    if (s == skeletons.end()) return fmt::format("character {} drawn before its skeleton record", p.character);
    if (s->second->joint_names.size() != p.joints.size())
      return fmt::format("{} joints for a skeleton of {}", p.joints.size(), s->second->joint_names.size());
    p.skeleton = s->second;
  } else {
    p.skeleton.reset();
  }
  is_frame = true;
  return "";
}

}  // namespace

void encode_frame_state(const FrameData& f, bool with_skeleton, std::string& out, int version) {
  encode_frame_state(f, with_skeleton, nullptr, out, version);
}

void encode_frame_state(const FrameData& f, const ConsoleState& console, std::string& out) {
  encode_frame_state(f, true, &console, out, kFrameVersion);
}

void encode_frame_state(const FrameData& f, bool with_skeleton, const ConsoleState* console, std::string& out,
                        int version) {
  out.clear();
  thread_local std::string raw;  // the writer's scratch: its room kept
  const FighterPose& p = f.fighter;
  if (with_skeleton && p.present && p.skeleton)
    record(out, raw, [&](Out& o) {
      o.u8(kSkeleton);
      o.put(static_cast<std::int32_t>(p.skeleton->character));
      o.u32(p.skeleton->joint_names.size());
      for (std::size_t j = 0; j < p.skeleton->joint_names.size(); ++j) {
        o.str(p.skeleton->joint_names[j]);
        o.put(static_cast<std::int32_t>(j < p.skeleton->parents.size() ? p.skeleton->parents[j] : -1));
      }
    });
  if (console) record(out, raw, [&](Out& o) { write_console(o, *console); });
  record(out, raw, [&](Out& o) {
    o.u8(kFrame);
    walk::StringSink sink{o.s};
    walk::Writer<walk::StringSink> w{sink, version};
    describe(w, f);  // the frame's fields (frame_fields.hpp)
  });
}

FrameStatesReader::FrameStatesReader(const std::filesystem::path& file) : path_(file), in_(file, std::ios::binary) {
  if (!in_) throw file_error("replay", "io", file.string(), 0, "", "cannot open the frame states");
  // "kumite-frame-states N\n", N a version this build reads (1 to kFrameVersion).
  std::string first;
  std::getline(in_, first);
  int version = 0;
  const bool ours = first.rfind("kumite-frame-states ", 0) == 0;
  if (ours) version = std::atoi(first.c_str() + 20);
  if (!in_ || version < 1 || version > kFrameVersion) {
    throw file_error("replay", "format", file.string(), 1, "",
                     ours ? fmt::format("frame states from a newer version (this build reads versions 1 to {})", kFrameVersion)
                          : fmt::format("not a frame states file (no \"{}\" line)", kFrameStatesHeader.substr(0, kFrameStatesHeader.size() - 1)));
  }
  version_ = version;
  first += '\n';
  offset_ = first.size();
}

bool FrameStatesReader::fail(std::string what) {
  problem_ = fmt::format("{}: record {} (byte {}): {}; {} frames before it read", path_.string(), records_, offset_,
                         what, frames_);
  return false;
}

bool FrameStatesReader::next(FrameData& f) {
  for (;;) {
    if (!problem_.empty()) return false;
    char head[16];
    in_.read(head, sizeof head);
    if (in_.gcount() == 0) return false;  // the end
    if (in_.gcount() != sizeof head) return fail("cut short (a recorder killed mid-write)");
    std::uint32_t magic = 0, bytes = 0;
    std::uint64_t sum = 0;
    std::memcpy(&magic, head, 4);
    std::memcpy(&bytes, head + 4, 4);
    std::memcpy(&sum, head + 8, 8);
    if (magic != kMagic) return fail("not a frame state record");
    if (bytes > kMaxPayload) return fail(fmt::format("record of {} bytes: too large", bytes));
    buffer_.resize(bytes);
    in_.read(buffer_.data(), bytes);
    if (in_.gcount() != static_cast<std::streamsize>(bytes)) return fail("cut short (a recorder killed mid-write)");
    // A fresh frame: the fields a file of an older version lacks take their defaults.
    bool is_frame = false;
    FrameData r;
    if (auto why = read_record(buffer_, sum, version_, raw_, skeletons_, r, is_frame); !why.empty()) return fail(why);
    offset_ += sizeof head + bytes;
    ++records_;
    if (is_frame) {
      ++frames_;
      f = std::move(r);
      return true;
    }
  }
}

bool FrameStateDecoder::decode(std::string_view bytes, FrameData& out, ConsoleState* console) {
  problem_.clear();
  console_problem_.clear();
  has_console_ = false;
  bool got = false, got_console = false;
  ConsoleState* const console_out = console ? console : &scratch_;  // read (and checked) either way
  while (!bytes.empty()) {
    if (bytes.size() < 16) return fail("a record cut short");
    std::uint32_t magic = 0, n = 0;
    std::uint64_t sum = 0;
    std::memcpy(&magic, bytes.data(), 4);
    std::memcpy(&n, bytes.data() + 4, 4);
    std::memcpy(&sum, bytes.data() + 8, 8);
    if (magic != kMagic) return fail("not a frame state record");
    if (n > kMaxPayload || n > bytes.size() - 16) return fail(fmt::format("a record of {} bytes in {}: cut short", n, bytes.size() - 16));
    bool is_frame = false, is_console = false;
    if (auto why = read_record(bytes.substr(16, n), sum, kFrameVersion, raw_, skeletons_, out, is_frame,
                               got_console ? nullptr : console_out, &console_problem_, &is_console);
        !why.empty())
      return fail(got_console && why == fmt::format("unknown record kind {}", kConsole) ? "a second console record" : why);
    bytes.remove_prefix(16 + n);
    got_console = got_console || is_console;
    if (is_frame) {
      if (!bytes.empty()) return fail("bytes after the frame record");
      got = true;
    }
  }
  if (!got) return fail("no frame record");
  if (got_console && console_problem_.empty() && console_out->frame_events.size() != out.events.size())
    console_problem_ = fmt::format("its console has {} event texts for the frame's {} events",
                                   console_out->frame_events.size(), out.events.size());
  has_console_ = got_console && console_problem_.empty();
  return true;
}

bool FrameStateDecoder::fail(std::string what) {
  problem_ = std::move(what);
  return false;
}

std::optional<std::string> first_difference(const FrameData& recorded, const FrameData& now) {
  return walk::first_difference(recorded, now);
}

}  // namespace kumite::app
