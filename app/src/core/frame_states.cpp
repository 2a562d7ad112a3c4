#include "kumite/app/frame_states.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <type_traits>

#include <fmt/format.h>
#include <zlib.h>

#include "kumite/common/checksum.hpp"
#include "kumite/common/error.hpp"

namespace kumite::app {

namespace {

constexpr std::uint32_t kMagic = 0x3154534B;  // "KST1"
constexpr std::uint32_t kMaxPayload = 64u << 20;
constexpr std::uint32_t kMaxCount = 1u << 20;  // joints, walls, events, items: far above any real frame
enum : std::uint8_t { kSkeleton = 1, kFrame = 2 };

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
  void d(double v) { put(v); }
  void v3(const glm::dvec3& v) { d(v.x), d(v.y), d(v.z); }
  void q(const glm::dquat& v) { d(v.w), d(v.x), d(v.y), d(v.z); }
  void m(const glm::dmat4& mm) {
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) d(mm[c][r]);
  }
  void str(std::string_view t) {
    u32(t.size());
    s.append(t);
  }
};

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

struct In {
  std::string_view p;
  bool ok = true;
  template <typename T>
  T get() {
    T v{};
    if (p.size() < sizeof(T)) {
      ok = false;
      return v;
    }
    std::memcpy(&v, p.data(), sizeof v);
    p.remove_prefix(sizeof v);
    return v;
  }
  std::uint8_t u8() { return get<std::uint8_t>(); }
  /// A count of things of at least `bytes_each` bytes each still to read: no more than the
  /// bytes left can hold (a damaged count must not make the reader allocate gigabytes).
  std::uint32_t count(std::size_t bytes_each = 1) {
    const auto n = get<std::uint32_t>();
    if (n > kMaxCount || static_cast<std::size_t>(n) * bytes_each > p.size()) ok = false;
    return ok ? n : 0;
  }
  /// A number that must be finite (every number of a frame is).
  double d() {
    const double v = get<double>();
    if (!std::isfinite(v)) ok = false;
    return v;
  }
  float f() {
    const float v = get<float>();
    if (!std::isfinite(v)) ok = false;
    return v;
  }
  glm::dvec3 v3() {
    glm::dvec3 v;
    v.x = d(), v.y = d(), v.z = d();
    return v;
  }
  glm::dquat q() {
    glm::dquat v;
    v.w = d(), v.x = d(), v.y = d(), v.z = d();
    return v;
  }
  glm::dmat4 m() {
    glm::dmat4 mm;
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) mm[c][r] = d();
    return mm;
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
};

}  // namespace

void encode_frame_state(const FrameData& f, bool with_skeleton, std::string& out) {
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
  record(out, raw, [&](Out& o) {
    o.u8(kFrame);
    o.put(static_cast<std::uint64_t>(f.frame));
    o.d(f.time_s);
    o.d(f.now);
    o.v3(f.head.position);
    o.q(f.head.orientation);
    o.u8(f.head_live);
    o.v3(f.eyes.left);
    o.v3(f.eyes.right);
    o.u32(f.views.size());
    for (const auto& wall : f.views)
      for (const EyeView& e : wall) {
        for (const double v : {e.frustum.left, e.frustum.right, e.frustum.bottom, e.frustum.top, e.frustum.near,
                               e.frustum.far})
          o.d(v);
        o.m(e.view);
        o.m(e.projection);
        o.u8(e.valid);
      }
    for (const double v : {f.pose_age_ms, f.pose_measured_at, f.tracking_latency_ms, f.latch_ms, f.predicted_ahead_ms})
      o.d(v);
    o.u8(p.present);
    o.u8(static_cast<std::uint8_t>(p.state));
    o.put(static_cast<std::int32_t>(p.character));
    o.u32(p.joints.size());
    for (const auto& j : p.joints) o.v3(j);
    o.u32(p.local_rotations.size());
    for (const auto& r : p.local_rotations) o.q(r);
    o.v3(p.root_joint);
    o.u8(p.target.has_value());
    if (p.target) o.v3(*p.target);
    o.v3(p.root);
    o.d(p.heading_rad);
    o.u8(f.visitor_near_wall.has_value());
    if (const auto& v = f.visitor_near_wall) {
      o.put(static_cast<std::int32_t>(v->wall));
      o.d(v->distance_m);
      o.u8(v->outside);
      o.u8(v->lost);
    }
    o.u32(f.events.size());
    for (const FrameEvent& e : f.events) {
      o.u8(static_cast<std::uint8_t>(e.type));
      o.u8(e.order.has_value());
      const Order order = e.order.value_or(Order{});
      o.d(order.time);
      o.u8(static_cast<std::uint8_t>(order.kind));
      o.put(static_cast<std::int32_t>(order.character));
      o.d(e.distance_m);
      o.d(e.time_s);
      o.u8(static_cast<std::uint8_t>(e.cause));
      const content::FighterEvent& g = e.fighter;
      o.d(g.time);
      o.u8(static_cast<std::uint8_t>(g.kind));
      o.d(g.order.time);
      o.u8(static_cast<std::uint8_t>(g.order.kind));
      o.put(static_cast<std::int32_t>(g.order.character));
      o.u8(static_cast<std::uint8_t>(g.reason));
      o.d(g.distance_m);
      o.d(g.target.x()), o.d(g.target.y()), o.d(g.target.z());
      o.put(static_cast<std::int32_t>(g.segment));
      o.put(static_cast<std::int32_t>(g.start_frame));
      o.put(static_cast<std::int32_t>(g.contact_frame));
      o.d(g.contact_distance_m);
      o.u8(g.out_of_reach);
      o.put(static_cast<std::int32_t>(g.character_count));
      o.put(static_cast<std::int32_t>(e.wall));
      o.u8(e.outside);
      o.u8(e.lost);
      if (e.type == EventType::visitor_strike) {  // version 2
        const VisitorStrike& k = e.strike;
        o.d(k.t);
        o.d(k.decided_at);
        o.u8(static_cast<std::uint8_t>(k.type));
        o.u8(static_cast<std::uint8_t>(k.limb));
        o.u8(static_cast<std::uint8_t>(k.action));
        o.d(k.progress);
        o.d(k.confidence);
        for (const double v : k.impact) o.d(v);
      }
    }
    o.u32(f.items.size());
    for (const DrawItem& it : f.items) {
      for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) o.put(it.model[c][r]);
      o.put(it.colour.r), o.put(it.colour.g), o.put(it.colour.b);
      o.u8(static_cast<std::uint8_t>(it.mesh));
    }
  });
}

FrameStatesReader::FrameStatesReader(const std::filesystem::path& file) : path_(file), in_(file, std::ios::binary) {
  if (!in_) throw file_error("replay", "io", file.string(), 0, "", "cannot open the frame states");
  std::string first(kFrameStatesHeader.size(), '\0');
  in_.read(first.data(), static_cast<std::streamsize>(first.size()));
  if (in_.gcount() != static_cast<std::streamsize>(first.size()) ||
      (first != kFrameStatesHeader && first != kFrameStatesHeaderV1)) {
    const bool newer = first.rfind("kumite-frame-states ", 0) == 0;
    throw file_error("replay", "format", file.string(), 1, "",
                     newer ? "frame states from a newer version (this build reads versions 1 and 2)"
                           : "not a frame states file (no \"kumite-frame-states 2\" line)");
  }
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
    if (fnv1a64(buffer_) != sum) return fail("checksum does not match (damaged)");
    std::uint32_t raw_bytes = 0;
    if (bytes < 4) return fail("record too short");
    std::memcpy(&raw_bytes, buffer_.data(), 4);
    if (raw_bytes > kMaxPayload) return fail(fmt::format("record of {} bytes unpacked: too large", raw_bytes));
    raw_.resize(raw_bytes);
    uLongf unpacked = raw_bytes;
    if (uncompress(reinterpret_cast<Bytef*>(raw_.data()), &unpacked, reinterpret_cast<const Bytef*>(buffer_.data() + 4),
                   static_cast<uLong>(bytes - 4)) != Z_OK ||
        unpacked != raw_bytes)
      return fail("does not unpack (damaged)");
    In in{raw_};
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
      if (!in.ok || !in.p.empty()) return fail("a skeleton record that does not read whole");
      skeletons_[s->character] = s;
    } else if (kind == kFrame) {
      FrameData r;
      r.frame = in.get<std::uint64_t>();
      r.time_s = in.d();
      r.now = in.d();
      r.head.position = in.v3();
      r.head.orientation = in.q();
      r.head_live = in.u8() != 0;
      r.eyes.left = in.v3();
      r.eyes.right = in.v3();
      r.views.resize(in.count(2 * (38 * 8 + 1)));  // per wall: two eyes' frustum, view, projection, valid
      for (auto& wall : r.views)
        for (EyeView& e : wall) {
          e.frustum = {in.d(), in.d(), in.d(), in.d(), in.d(), in.d()};
          e.view = in.m();
          e.projection = in.m();
          e.valid = in.u8() != 0;
        }
      r.pose_age_ms = in.d();
      r.pose_measured_at = in.d();
      r.tracking_latency_ms = in.d();
      r.latch_ms = in.d();
      r.predicted_ahead_ms = in.d();
      FighterPose& p = r.fighter;
      p.present = in.u8() != 0;
      const auto state = in.u8();
      if (state > static_cast<std::uint8_t>(content::FighterState::recovering)) in.ok = false;
      p.state = static_cast<content::FighterState>(state);
      p.character = in.get<std::int32_t>();
      p.joints.resize(in.count(24));
      for (auto& j : p.joints) j = in.v3();
      p.local_rotations.resize(in.count(32));
      for (auto& q : p.local_rotations) q = in.q();
      p.root_joint = in.v3();
      if (in.u8()) p.target = in.v3();
      p.root = in.v3();
      p.heading_rad = in.d();
      if (in.u8()) {
        VisitorNearWall v;
        v.wall = in.get<std::int32_t>();
        v.distance_m = in.d();
        v.outside = in.u8() != 0;
        v.lost = in.u8() != 0;
        r.visitor_near_wall = v;
      }
      r.events.resize(in.count(100));  // an event's fields: ~120 bytes
      // An enum's byte, checked against its last value.
      const auto enum_of = [&](auto last) {
        const auto v = in.u8();
        if (v > static_cast<std::uint8_t>(last)) in.ok = false;
        return static_cast<decltype(last)>(v);
      };
      const auto order_of = [&] {
        Order o;
        o.time = in.d();
        o.kind = enum_of(OrderKind::recentre);
        o.character = in.get<std::int32_t>();
        return o;
      };
      for (FrameEvent& e : r.events) {
        e.type = enum_of(EventType::stepping_back);
        const bool has_order = in.u8() != 0;
        const Order order = order_of();
        if (has_order) e.order = order;
        e.distance_m = in.d();
        e.time_s = in.d();
        e.cause = enum_of(EventCause::visitor);
        content::FighterEvent& g = e.fighter;
        g.time = in.d();
        g.kind = enum_of(content::FighterEvent::Kind::stepping_back);
        g.order = order_of();
        g.reason = enum_of(content::FighterEvent::Reason::restance);
        g.distance_m = in.d();
        g.target.x() = in.d(), g.target.y() = in.d(), g.target.z() = in.d();
        g.segment = in.get<std::int32_t>();
        g.start_frame = in.get<std::int32_t>();
        g.contact_frame = in.get<std::int32_t>();
        g.contact_distance_m = in.d();
        g.out_of_reach = in.u8() != 0;
        g.character_count = in.get<std::int32_t>();
        e.wall = in.get<std::int32_t>();
        e.outside = in.u8() != 0;
        e.lost = in.u8() != 0;
        if (e.type == EventType::visitor_strike) {
          VisitorStrike& k = e.strike;
          k.t = in.d();
          k.decided_at = in.d();
          k.type = enum_of(recognition::EventType::cancel);
          k.limb = enum_of(recognition::Role::right_foot);
          k.action = enum_of(recognition::Action::roundhouse_kick);
          k.progress = in.d();
          k.confidence = in.d();
          for (double& v : k.impact) v = in.d();
        }
      }
      r.items.resize(in.count(77));  // 16 + 3 floats and a byte
      for (DrawItem& it : r.items) {
        for (int c = 0; c < 4; ++c)
          for (int rr = 0; rr < 4; ++rr) it.model[c][rr] = in.f();
        it.colour.r = in.f(), it.colour.g = in.f(), it.colour.b = in.f();
        const auto mesh = in.u8();
        if (mesh > static_cast<std::uint8_t>(Mesh::cylinder)) in.ok = false;
        it.mesh = static_cast<Mesh>(mesh);
      }
      if (!in.ok || !in.p.empty()) return fail("a frame record that does not read whole (or a number not finite)");
      if (p.present) {
        const auto s = skeletons_.find(p.character);
        if (s == skeletons_.end()) return fail(fmt::format("character {} drawn before its skeleton record", p.character));
        if (s->second->joint_names.size() != p.joints.size())
          return fail(fmt::format("{} joints for a skeleton of {}", p.joints.size(), s->second->joint_names.size()));
        p.skeleton = s->second;
      }
      offset_ += sizeof head + bytes;
      ++records_;
      ++frames_;
      f = std::move(r);
      return true;
    } else {
      return fail(fmt::format("unknown record kind {}", kind));
    }
    offset_ += sizeof head + bytes;
    ++records_;
  }
}

namespace {

std::string v3_text(const glm::dvec3& v) { return fmt::format("({:.4f}, {:.4f}, {:.4f})", v.x, v.y, v.z); }

/// Bitwise: a NaN equals itself, -0 differs from 0 (what was drawn, exactly).
template <typename T>
bool same(const T& a, const T& b) {
  static_assert(std::is_standard_layout_v<T>);  // glm vectors and matrices: their numbers, no padding
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

}  // namespace

std::optional<std::string> first_difference(const FrameData& a, const FrameData& b) {
  const auto num = [](std::string_view field, double x, double y) -> std::optional<std::string> {
    if (same(x, y)) return std::nullopt;
    return fmt::format("{}: recorded {}, now {}", field, x, y);
  };
  const auto point = [](const std::string& field, const glm::dvec3& x, const glm::dvec3& y) -> std::optional<std::string> {
    if (same(x, y)) return std::nullopt;
    return fmt::format("{}: recorded {} m, now {} m, {:.1f} mm apart", field, v3_text(x), v3_text(y),
                       glm::length(x - y) * 1e3);
  };
  if (a.frame != b.frame) return fmt::format("frame: recorded {}, now {}", a.frame, b.frame);
  if (auto d = num("time_s", a.time_s, b.time_s)) return d;
  if (auto d = num("now", a.now, b.now)) return d;
  if (auto d = point("head.position", a.head.position, b.head.position)) return d;
  if (!same(a.head.orientation, b.head.orientation)) return std::string("head.orientation: differs");
  if (a.head_live != b.head_live) return fmt::format("head_live: recorded {}, now {}", a.head_live, b.head_live);
  if (auto d = point("eyes.left", a.eyes.left, b.eyes.left)) return d;
  if (auto d = point("eyes.right", a.eyes.right, b.eyes.right)) return d;
  if (a.views.size() != b.views.size())
    return fmt::format("views: recorded {} walls, now {}", a.views.size(), b.views.size());
  for (std::size_t w = 0; w < a.views.size(); ++w)
    for (std::size_t e = 0; e < 2; ++e) {
      const EyeView &x = a.views[w][e], &y = b.views[w][e];
      if (!same(x.view, y.view) || !same(x.projection, y.projection) || x.valid != y.valid ||
          !same(x.frustum.left, y.frustum.left) || !same(x.frustum.right, y.frustum.right) ||
          !same(x.frustum.bottom, y.frustum.bottom) || !same(x.frustum.top, y.frustum.top) ||
          !same(x.frustum.near, y.frustum.near) || !same(x.frustum.far, y.frustum.far))
        return fmt::format("views[{}][{}]: the {} eye's view of wall {} differs", w, e, e == 0 ? "left" : "right", w);
    }
  const FighterPose &p = a.fighter, &q = b.fighter;
  if (p.present != q.present) return fmt::format("fighter.present: recorded {}, now {}", p.present, q.present);
  if (p.state != q.state)
    return fmt::format("fighter.state: recorded {}, now {}", content::to_string(p.state), content::to_string(q.state));
  if (p.character != q.character)
    return fmt::format("fighter.character: recorded {}, now {}", p.character + 1, q.character + 1);
  if (p.joints.size() != q.joints.size())
    return fmt::format("fighter.joints: recorded {}, now {}", p.joints.size(), q.joints.size());
  const auto joint_name = [&](std::size_t j) {
    return p.skeleton && j < p.skeleton->joint_names.size() ? p.skeleton->joint_names[j] : fmt::format("{}", j);
  };
  if (auto d = point("fighter.root_joint", p.root_joint, q.root_joint)) return d;
  for (std::size_t j = 0; j < p.joints.size(); ++j)
    if (auto d = point(fmt::format("fighter.joints[{}]", joint_name(j)), p.joints[j], q.joints[j])) return d;
  if (p.local_rotations.size() != q.local_rotations.size())
    return fmt::format("fighter.local_rotations: recorded {}, now {}", p.local_rotations.size(), q.local_rotations.size());
  for (std::size_t j = 0; j < p.local_rotations.size(); ++j)
    if (!same(p.local_rotations[j], q.local_rotations[j])) {
      const double angle = 2 * std::acos(std::min(1.0, std::abs(glm::dot(p.local_rotations[j], q.local_rotations[j]))));
      return fmt::format("fighter.local_rotations[{}]: {:.3g} degrees apart", joint_name(j), angle * 180 / M_PI);
    }
  if (p.target.has_value() != q.target.has_value())
    return fmt::format("fighter.target: recorded {}, now {}", p.target ? "set" : "none", q.target ? "set" : "none");
  if (p.target)
    if (auto d = point("fighter.target", *p.target, *q.target)) return d;
  if (auto d = point("fighter.root", p.root, q.root)) return d;
  if (auto d = num("fighter.heading_rad", p.heading_rad, q.heading_rad)) return d;
  const auto event_name = [](const FrameEvent& e) {
    return fmt::format("{}{}", to_string(e.type), e.order ? " " + to_string(*e.order) : std::string());
  };
  if (a.events.size() != b.events.size())
    return fmt::format("events: recorded {} ({}), now {} ({})", a.events.size(),
                       a.events.empty() ? "-" : event_name(a.events.front()), b.events.size(),
                       b.events.empty() ? "-" : event_name(b.events.front()));
  for (std::size_t k = 0; k < a.events.size(); ++k) {
    const FrameEvent &x = a.events[k], &y = b.events[k];
    const bool equal = x.type == y.type && x.order.has_value() == y.order.has_value() &&
                       (!x.order || (x.order->kind == y.order->kind && x.order->character == y.order->character &&
                                     same(x.order->time, y.order->time))) &&
                       same(x.distance_m, y.distance_m) && same(x.time_s, y.time_s) && x.cause == y.cause &&
                       x.wall == y.wall && x.outside == y.outside && x.lost == y.lost;
    if (!equal || !(x.fighter == y.fighter) || !(x.strike == y.strike))
      return fmt::format("events[{}]: recorded {} ({:.3f} s, {:.4f} m), now {} ({:.3f} s, {:.4f} m)", k, event_name(x),
                         x.time_s, x.distance_m, event_name(y), y.time_s, y.distance_m);
  }
  if (a.visitor_near_wall.has_value() != b.visitor_near_wall.has_value() ||
      (a.visitor_near_wall &&
       (a.visitor_near_wall->wall != b.visitor_near_wall->wall ||
        !same(a.visitor_near_wall->distance_m, b.visitor_near_wall->distance_m) ||
        a.visitor_near_wall->outside != b.visitor_near_wall->outside ||
        a.visitor_near_wall->lost != b.visitor_near_wall->lost)))
    return std::string("visitor_near_wall: differs");
  for (const auto& [field, x, y] :
       {std::tuple{"pose_age_ms", a.pose_age_ms, b.pose_age_ms}, std::tuple{"pose_measured_at", a.pose_measured_at, b.pose_measured_at},
        std::tuple{"tracking_latency_ms", a.tracking_latency_ms, b.tracking_latency_ms},
        std::tuple{"latch_ms", a.latch_ms, b.latch_ms}, std::tuple{"predicted_ahead_ms", a.predicted_ahead_ms, b.predicted_ahead_ms}})
    if (auto d = num(field, x, y)) return d;
  if (a.items.size() != b.items.size())
    return fmt::format("items: recorded {} drawn, now {}", a.items.size(), b.items.size());
  for (std::size_t k = 0; k < a.items.size(); ++k)
    if (!same(a.items[k].model, b.items[k].model) || !same(a.items[k].colour, b.items[k].colour) ||
        a.items[k].mesh != b.items[k].mesh)
      return fmt::format("items[{}]: drawn differently", k);
  return std::nullopt;
}

}  // namespace kumite::app
