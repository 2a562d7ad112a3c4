// OSC in and out through liblo (Debian liblo-dev 0.31), in the layout NatNetThree2OSC's "touch"
// mode uses (tecartlab/app_NatNetThree2OSC readme: /rigidbody/<id>/transformation x y z qx qy qz
// qw, frames bracketed by /frame/start <n> and /frame/end <n>), so an OptiTrack room can feed
// Kumite through that bridge and show designers (TouchDesigner, Max) read Kumite's poses.
// Units: metres, Kumite's room (right-handed, +Y up, the visitor faces -Z).
#include <lo/lo.h>

#include <charconv>
#include <cstring>
#include <cmath>
#include <set>

#include <fmt/format.h>

#include "kumite/common/error.hpp"
#include "kumite/tracking/interop.hpp"

namespace kumite::tracking {

struct OscReceiver::State {
  OscReceiver* owner = nullptr;
  std::array<std::int32_t, 5> role_body{-1, -1, -1, -1, -1};
  RoomFrame frame;
  bool in_bundle = false;
  bool frame_open = false;       // between /frame/start and /frame/end
  bool published_in_bundle = false;
  bool packet_bad = false;       // a problem in the datagram being dispatched
  Timestamp received_at = 0;
  std::set<std::string> said;    // paths said once (at most 32)
  lo_server server = nullptr;

  int role_of(std::int32_t id) const {
    for (std::size_t i = 0; i < role_body.size(); ++i)
      if (role_body[i] == id && id >= 0) return static_cast<int>(i);
    return -1;
  }
  RoomBody* body(std::int32_t id) {
    for (int i = 0; i < frame.body_count; ++i)
      if (frame.bodies[static_cast<std::size_t>(i)].id == id) return &frame.bodies[static_cast<std::size_t>(i)];
    if (frame.body_count >= kRoomFrameBodies) {
      ++frame.bodies_dropped;
      return nullptr;
    }
    RoomBody& b = frame.bodies[static_cast<std::size_t>(frame.body_count++)];
    b = RoomBody{};
    b.id = id;
    b.role = role_of(id);
    return &b;
  }
  void start_frame(std::uint64_t n) {
    frame.frame = n;
    frame.body_count = 0;
    frame.bodies_dropped = 0;
    frame_open = true;
  }
  void finish() {
    frame.received_at = received_at;
    owner->note_frame_number(frame.frame);
    owner->publish(frame);
    frame_open = false;
    if (in_bundle) published_in_bundle = true;
  }
  void bad(const std::string& line) {
    packet_bad = true;
    owner->problem("osc: " + line);
  }
  void bad_once(const std::string& path, const std::string& line) {
    packet_bad = true;
    if (said.size() < 32 && said.insert(path).second) owner->problem("osc: " + line + " (said once)");
  }
};

namespace {

thread_local OscReceiver::State* t_current = nullptr;  // liblo's error handler has no user data

void on_lo_error(int num, const char* msg, const char* where) {
  if (!t_current) return;
  t_current->bad(fmt::format("{} ({}{}{})", msg ? msg : "liblo error", num, where ? ", " : "", where ? where : ""));
}

/// A number argument of any OSC numeric type; nullopt when not one. Read byte-wise: OSC
/// arguments are 4-byte aligned and liblo's lo_arg union asks for 8 (UBSan: misaligned access).
std::optional<double> arg_number(char type, const lo_arg* a) {
  const auto* bytes = reinterpret_cast<const unsigned char*>(a);
  switch (type) {
    case 'f': {
      float v;
      std::memcpy(&v, bytes, sizeof v);
      return static_cast<double>(v);
    }
    case 'd': {
      double v;
      std::memcpy(&v, bytes, sizeof v);
      return v;
    }
    case 'i': {
      std::int32_t v;
      std::memcpy(&v, bytes, sizeof v);
      return static_cast<double>(v);
    }
    case 'h': {
      std::int64_t v;
      std::memcpy(&v, bytes, sizeof v);
      return static_cast<double>(v);
    }
    default: return std::nullopt;
  }
}

/// "/rigidbody/<id>/<what>" -> id and what; false when the path is not that shape.
bool rigidbody_path(std::string_view path, std::int32_t& id, std::string_view& what) {
  constexpr std::string_view prefix = "/rigidbody/";
  if (path.substr(0, prefix.size()) != prefix) return false;
  path.remove_prefix(prefix.size());
  const std::size_t slash = path.find('/');
  if (slash == std::string_view::npos || slash == 0) return false;
  const std::string_view num = path.substr(0, slash);
  const auto r = std::from_chars(num.data(), num.data() + num.size(), id);
  if (r.ec != std::errc() || r.ptr != num.data() + num.size() || id < 0) return false;
  what = path.substr(slash + 1);
  return true;
}

int on_message(const char* path_c, const char* types_c, lo_arg** argv, int argc, lo_message, void* user) {
  auto& s = *static_cast<OscReceiver::State*>(user);
  const std::string_view path(path_c ? path_c : "");
  const std::string_view types(types_c ? types_c : "");
  if (!s.in_bundle && !s.frame_open) s.received_at = now();
  if (path == "/frame/start" || path == "/frame/end") {
    std::optional<double> n;
    if (argc >= 1) n = arg_number(types[0], argv[0]);
    if (!n || !(*n >= 0 && *n <= 9007199254740992.0) || *n != std::floor(*n)) {
      s.bad(fmt::format("{}: needs the frame number (an integer >= 0), types '{}'", path, types));
      return 0;
    }
    if (path == "/frame/start") s.start_frame(static_cast<std::uint64_t>(*n));
    else if (s.frame_open) s.finish();
    return 0;
  }
  std::int32_t id = 0;
  std::string_view what;
  if (!rigidbody_path(path, id, what)) {
    s.bad_once(std::string(path), fmt::format("{}: not a path Kumite reads (/rigidbody/<id>/transformation, "
                                              "/rigidbody/<id>/tracked, /frame/start, /frame/end): ignored",
                                              path));
    return 0;
  }
  // A lone message (no bundle, no /frame/start before it) updates its body in the last frame's
  // set and is published at once as a frame of its own.
  const bool lone = !s.in_bundle && !s.frame_open;
  if (lone) {
    ++s.frame.frame;
    s.frame.bodies_dropped = 0;
  }
  if (what == "transformation") {
    if (argc != 7) {
      s.bad(fmt::format("{}: needs 7 numbers x y z qx qy qz qw, found {} (types '{}')", path, argc, types));
    } else {
      std::array<double, 7> v{};
      for (int i = 0; i < 7; ++i) {
        const auto x = arg_number(types[static_cast<std::size_t>(i)], argv[i]);
        if (!x) {
          s.bad(fmt::format("{}: argument {} is not a number (type '{}')", path, i + 1, types[static_cast<std::size_t>(i)]));
          return 0;
        }
        if (!std::isfinite(*x)) {
          s.bad(fmt::format("{}: argument {} must be a finite number, found {}", path, i + 1, *x));
          return 0;
        }
        v[static_cast<std::size_t>(i)] = *x;
      }
      for (int i = 0; i < 3; ++i)
        if (std::abs(v[static_cast<std::size_t>(i)]) > 1000) {
          s.bad(fmt::format("{}: position must be within ±1000 m, found {}", path, v[static_cast<std::size_t>(i)]));
          return 0;
        }
      const double norm = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]);
      if (norm < 0.9 || norm > 1.1) {
        s.bad(fmt::format("{}: the quaternion's norm must be 1 (±0.1), found {}", path, norm));
        return 0;
      }
      if (RoomBody* b = s.body(id)) {
        b->tracked = true;
        b->quality = 1;
        b->position_m = {v[0], v[1], v[2]};
        b->orientation = {v[6] / norm, v[3] / norm, v[4] / norm, v[5] / norm};  // w, x, y, z
      }
    }
  } else if (what == "tracked") {
    const auto t = argc == 1 ? arg_number(types[0], argv[0]) : std::nullopt;
    if (!t) {
      s.bad(fmt::format("{}: needs one number 0 or 1 (types '{}')", path, types));
    } else if (RoomBody* b = s.body(id)) {
      b->tracked = *t != 0;
      b->quality = b->tracked ? 1 : -1;
    }
  } else {
    s.bad_once(std::string(path), fmt::format("{}: not a path Kumite reads: ignored", path));
  }
  if (lone && !s.packet_bad) s.finish();
  return 0;
}

int on_bundle_start(lo_timetag, void* user) {
  auto& s = *static_cast<OscReceiver::State*>(user);
  s.in_bundle = true;
  s.published_in_bundle = false;
  s.received_at = now();
  if (!s.frame_open) s.start_frame(s.frame.frame + 1);
  return 0;
}

int on_bundle_end(void* user) {
  auto& s = *static_cast<OscReceiver::State*>(user);
  s.in_bundle = false;
  if (!s.published_in_bundle && s.frame.body_count > 0) s.finish();
  s.frame_open = false;
  return 0;
}

}  // namespace

OscReceiver::OscReceiver(int port, Options options)
    : requested_port_(port), options_(std::move(options)), state_(std::make_unique<State>()) {
  state_->owner = this;
  state_->role_body = options_.role_body;
}

OscReceiver::~OscReceiver() { stop(); }

void OscReceiver::open() {
  const std::string port = std::to_string(requested_port_);
  const char* p = requested_port_ > 0 ? port.c_str() : nullptr;
  State* previous = t_current;
  t_current = state_.get();
  lo_server s = options_.multicast_group.empty()
                    ? lo_server_new_with_proto(p, LO_UDP, on_lo_error)
                    : lo_server_new_multicast(options_.multicast_group.c_str(), p, on_lo_error);
  t_current = previous;
  if (!s)
    throw Error("interop", "socket",
                fmt::format("osc: cannot listen on udp port {}{}", requested_port_,
                            options_.multicast_group.empty() ? "" : " (multicast " + options_.multicast_group + ")"));
  lo_server_add_method(s, nullptr, nullptr, on_message, state_.get());
  lo_server_add_bundle_handlers(s, on_bundle_start, on_bundle_end, state_.get());
  state_->server = s;
  bound_port_.store(lo_server_get_port(s));
}

void OscReceiver::close() {
  if (state_->server) lo_server_free(state_->server);
  state_->server = nullptr;
}

void OscReceiver::run() {
  t_current = state_.get();
  State& s = *state_;
  while (!stopping_.load(std::memory_order_relaxed)) {
    s.packet_bad = false;
    const int n = lo_server_recv_noblock(s.server, 50);
    if (n <= 0 && !s.packet_bad) continue;
    packets_.fetch_add(1, std::memory_order_relaxed);
    if (s.packet_bad) bad_packets_.fetch_add(1, std::memory_order_relaxed);
  }
  t_current = nullptr;
}

// --- OscSender -----------------------------------------------------------------------------

OscSender::OscSender(const std::string& host, int port) {
  if (port < 1 || port > 65535) throw Error("interop", "socket", fmt::format("osc: port {} out of range", port));
  address_ = lo_address_new(host.c_str(), std::to_string(port).c_str());
  if (!address_) throw Error("interop", "socket", fmt::format("osc: cannot send to '{}:{}'", host, port));
}

OscSender::~OscSender() {
  if (address_) lo_address_free(static_cast<lo_address>(address_));
}

bool OscSender::send(const RoomFrame& frame) {
  lo_timetag immediately;  // LO_TT_IMMEDIATE, spelled out: the macro is a C99 compound literal (clang warns)
  immediately.sec = 0;
  immediately.frac = 1;
  lo_bundle b = lo_bundle_new(immediately);
  const auto n = static_cast<std::int32_t>(frame.frame & 0x7fffffffU);
  auto add = [&](const std::string& path, lo_message m) { lo_bundle_add_message(b, path.c_str(), m); };
  lo_message start = lo_message_new();
  lo_message_add_int32(start, n);
  add("/frame/start", start);
  for (int i = 0; i < frame.body_count; ++i) {
    const RoomBody& r = frame.bodies[static_cast<std::size_t>(i)];
    if (r.kind != RoomBodyKind::body) continue;
    lo_message t = lo_message_new();
    lo_message_add_int32(t, r.tracked ? 1 : 0);
    add(fmt::format("/rigidbody/{}/tracked", r.id), t);
    if (!r.tracked) continue;
    lo_message m = lo_message_new();
    for (double v : r.position_m) lo_message_add_float(m, static_cast<float>(v));
    lo_message_add_float(m, static_cast<float>(r.orientation[1]));
    lo_message_add_float(m, static_cast<float>(r.orientation[2]));
    lo_message_add_float(m, static_cast<float>(r.orientation[3]));
    lo_message_add_float(m, static_cast<float>(r.orientation[0]));
    add(fmt::format("/rigidbody/{}/transformation", r.id), m);
  }
  lo_message end = lo_message_new();
  lo_message_add_int32(end, n);
  add("/frame/end", end);
  const int sent = lo_send_bundle(static_cast<lo_address>(address_), b);
  lo_bundle_free_recursive(b);
  if (sent < 0) {
    const char* e = lo_address_errstr(static_cast<lo_address>(address_));
    error_ = e ? e : "lo_send_bundle failed";
    return false;
  }
  return true;
}

}  // namespace kumite::tracking
