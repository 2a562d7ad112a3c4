#pragma once
// A room's own tracker in and out (issue 55, "Tracker interop"): ART DTrack ASCII over UDP
// (in: fr, ts, ts2, 6dcal, 6d, 6df, 6df2, 3d; out: fr, ts, 6dcal, 6d with Euler angles, which
// Vrui reads) and OSC through liblo (/rigidbody/<id>/transformation x y z qx qy qz qw, metres,
// one bundle per frame). Library kumite::tracking_interop; it knows nothing of the cameras'
// pipeline, rendering or recognition (roles are names: "head", "left_hand", ...).
//
//   kumite::tracking::DtrackInput cfg = kumite::tracking::parse_dtrack_config(text, "dtrack.toml");
//   kumite::tracking::DtrackReceiver rx(cfg);       // its own thread from start()
//   rx.start();
//   // render thread, every frame, never blocks:
//   if (auto f = rx.poll()) { const RoomBody* head = find_role(*f, "head"); ... }
//   for (const std::string& line : rx.take_problems()) log(line);
//
// Frames: DtrackFrame is what one packet says, in DTrack's room and units converted (metres);
// RoomFrame is what receivers publish: bodies in Kumite's room (metres, +Y up, floor y = 0, the
// visitor faces -Z), orientation a quaternion body -> room, fixed capacity, trivially copyable.
#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "kumite/common/latest.hpp"
#include "kumite/common/time.hpp"

namespace kumite::tracking {

// ---------------------------------------------------------------------------------------
// DTrack ASCII (one UDP datagram = one frame; lines end in CR and/or LF)
// ---------------------------------------------------------------------------------------

/// Limits of what a packet may announce; beyond them the line is a problem, never an allocation.
inline constexpr int kDtrackMaxBodies = 256;      ///< 6d / 6df / 6df2 items per line, and ids
inline constexpr int kDtrackMaxMarkers = 1024;    ///< 3d markers per line
inline constexpr std::size_t kDtrackMaxPacketBytes = 65507;  ///< the largest UDP/IPv4 payload

/// A 6DOF body of a `6d` line (or a Flystick's pose).
struct DtrackBody {
  std::int32_t id = 0;        ///< DTrack id, 0-based
  double quality = -1;        ///< 0..1; < 0: not tracked (position and rotation then meaningless)
  std::array<double, 3> position_m{0, 0, 0};  ///< m, DTrack's room (sent in mm)
  /// body -> DTrack room, ROW-major here (R[row * 3 + col]); the wire sends it column-wise.
  std::array<double, 9> rotation{1, 0, 0, 0, 1, 0, 0, 0, 1};
  bool tracked() const { return quality >= 0; }
  bool operator==(const DtrackBody&) const = default;
};

/// A Flystick (`6df`: 8 buttons as bits; `6df2`: its own button and controller counts).
struct DtrackFlystick {
  DtrackBody pose;
  std::int32_t button_count = 0;               ///< buttons sent (6df: 8)
  std::uint64_t buttons = 0;                   ///< bit i = button i pressed (at most 64)
  std::int32_t joystick_count = 0;             ///< analog controllers sent (6df2; at most 8)
  std::array<double, 8> joysticks{};           ///< -1..1
  bool operator==(const DtrackFlystick&) const = default;
};

/// A single marker of a `3d` line.
struct DtrackMarker {
  std::int32_t id = 0;                          ///< DTrack id, 1-based
  double quality = 0;
  std::array<double, 3> position_m{0, 0, 0};    ///< m, DTrack's room
  bool operator==(const DtrackMarker&) const = default;
};

/// What one packet says. Vectors keep their capacity when a DtrackFrame is parsed into again.
struct DtrackFrame {
  bool has_frame = false;
  std::uint64_t frame = 0;        ///< `fr`: DTrack's frame counter
  double timestamp_s = -1;        ///< `ts`: s since 00:00 UTC on DTrack's clock (-1: not sent)
  std::int64_t ts2_s = -1;        ///< `ts2`: whole s (-1: not sent)
  std::int32_t ts2_us = 0;        ///< `ts2`: µs part
  std::int32_t latency_us = -1;   ///< `ts2`: DTrack's own latency, µs (-1: not sent)
  /// `6dcal`: calibrated standard bodies, as the SDK counts them (6dcal minus 6df Flysticks);
  /// -1: not sent. Ids below it that `6d` does not list are not tracked.
  std::int32_t calibrated_bodies = -1;
  std::vector<DtrackBody> bodies;          ///< `6d`, in line order (untracked ones included)
  std::vector<DtrackFlystick> flysticks;   ///< `6df` / `6df2`
  std::vector<DtrackMarker> markers;       ///< `3d`
  /// One line per problem, "packet:LINE: KEY: message" (e.g. "packet:3: 6d[1].quality: must
  /// be a finite number, found 'nan'"). A body with a problem is left out; the rest is kept.
  std::vector<std::string> problems;
  /// How many problems there were (problems keeps the first 16).
  std::int32_t problem_count = 0;
  bool ok() const { return problem_count == 0; }
  void clear();  ///< empties it, keeping the vectors' capacity
  /// The body of that id (nullptr when the packet did not list it).
  const DtrackBody* body(int id) const;
};

/// Parses one datagram. Never throws; problems are listed in `out.problems`: not ASCII (a
/// binary packet, e.g. OSC), over kDtrackMaxPacketBytes, a line cut short, missing fields, a
/// count that does not match the blocks, numbers that are not numbers or not finite (`nan`),
/// out of range (ids, quality in [-1, 1], |position| <= 1e6 mm) or not a rotation matrix.
/// Unknown line types (6dmt, gl, 6di, ...) are skipped as the SDK does. Trailing NUL bytes
/// are allowed. `out` is cleared first and keeps its capacity: parsing allocates only for
/// problems and when a frame has more bodies than any before.
void parse_dtrack(std::string_view packet, DtrackFrame& out);
DtrackFrame parse_dtrack(std::string_view packet);

/// Formats fr, ts (when >= 0), 6dcal and 6d lines of `frame`'s bodies as DTrack sends them:
/// mm with 3 decimals, the Euler angles η θ φ (degrees, 4 decimals; R = Rx(η)·Ry(θ)·Rz(φ), the
/// convention Vrui's ArtDTrack reader uses) after the position, the matrix column-wise with 6
/// decimals. Untracked bodies (quality < 0) are left out of the 6d line, as DTrack does.
/// Flysticks and markers are not written. Appends to `out` (cleared first).
void format_dtrack(const DtrackFrame& frame, std::string& out);
std::string format_dtrack(const DtrackFrame& frame);

/// The Euler angles DTrack sends for a rotation (degrees, R = Rx(η)·Ry(θ)·Rz(φ), θ in [-90, 90]).
std::array<double, 3> dtrack_euler_deg(const std::array<double, 9>& rotation_row_major);

// ---------------------------------------------------------------------------------------
// Kumite's room
// ---------------------------------------------------------------------------------------

/// The roles the installation reads (recognition's vocabulary, by name).
inline constexpr std::array<std::string_view, 5> kRoleNames{"head", "left_hand", "right_hand", "left_foot",
                                                             "right_foot"};
/// Index into kRoleNames, -1 when `name` is no role.
int role_index(std::string_view name);

/// x_kumite = R · x_dtrack + t. Orientation: R_kumite = R · R_dtrack · Rᵀ (conjugate_body,
/// the body's axes change like the room's: a body calibrated "due to room" keeps the room's
/// axes) or R · R_dtrack (not).
struct RoomTransform {
  std::array<double, 9> rotation{1, 0, 0, 0, 1, 0, 0, 0, 1};  ///< row-major, DTrack room -> Kumite room
  std::array<double, 3> translation_m{0, 0, 0};               ///< m, in Kumite's room
  bool conjugate_body = true;
  /// DTrack's default ("normal") room: Z up, the floor at z = 0, +Y toward the front wall:
  /// (x, y, z)_kumite = (x, z, -y)_dtrack, a -90° rotation about X.
  static RoomTransform z_up();
  /// A DTrack room set up as Kumite's ("powerwall": Y up, Z toward the visitor): identity.
  static RoomTransform y_up() { return {}; }
  RoomTransform inverse() const;
  std::array<double, 3> apply_position(const std::array<double, 3>& p) const;
  std::array<double, 9> apply_rotation(const std::array<double, 9>& r) const;
  bool operator==(const RoomTransform&) const = default;
};

/// [dtrack] of a TOML file: where to listen, the room transform and the body-id -> role map.
struct DtrackInput {
  int port = 5000;                      ///< UDP port DTrack sends to (0: any free one; tests)
  std::string bind_address = "0.0.0.0"; ///< IPv4 address to listen on
  std::string multicast_group;          ///< IPv4 multicast group to join ("" = unicast)
  RoomTransform room = RoomTransform::z_up();
  /// DTrack body id of each role (index as kRoleNames), -1 = none. With at least one set,
  /// bodies of other ids are counted and said once each ("not configured"), never used.
  std::array<std::int32_t, 5> role_body{-1, -1, -1, -1, -1};
  /// m, per role (index as kRoleNames): a point fixed to the body, in the body's own frame as
  /// RoomBody::orientation maps it (with conjugate_body: Kumite's axes when the body is in its
  /// calibrated pose, +X right, +Y up, +Z back), reported instead of DTrack's body origin
  /// ([<table>.offsets], each coordinate within ±1 m; default 0: the origin). Applied by
  /// to_room_frame to tracked bodies with a role; to_dtrack_frame does not take it back out.
  std::array<std::array<double, 3>, 5> role_offset_m{};
  bool has_roles() const;
  /// The role of a body id, -1 when none.
  int role_of(std::int32_t id) const;
  bool operator==(const DtrackInput&) const = default;
};

/// Reads the table at `table_path` (dotted: "dtrack", "tracking.dtrack") of a TOML document.
/// Keys (all optional): port (1..65535), bind_address, multicast_group (224.0.0.0/4),
/// room_axes ("z_up" | "y_up"), rotation ([[r00,r01,r02],[..],[..]], a rotation, det +1; over
/// room_axes), translation_m ([x,y,z], |v| <= 100 m), conjugate_body (bool), and
/// [<table>.bodies] head/left_hand/right_hand/left_foot/right_foot = id (0..255, each id once),
/// [<table>.offsets] the same roles = [x, y, z] (m, the body's frame, each within ±1 m).
/// Throws kumite::Error "file:line: key: message". No table: the defaults.
DtrackInput parse_dtrack_config(std::string_view text, std::string_view file,
                                std::string_view table_path = "dtrack");
DtrackInput read_dtrack_config(const std::string& path, std::string_view table_path = "dtrack");

// ---------------------------------------------------------------------------------------
// What receivers publish
// ---------------------------------------------------------------------------------------

inline constexpr int kRoomFrameBodies = 32;

enum class RoomBodyKind : std::uint8_t { body = 0, flystick = 1 };

struct RoomBody {
  std::int32_t id = -1;           ///< the sender's id (DTrack body / Flystick id, OSC <id>)
  std::int32_t role = -1;         ///< index into kRoleNames, -1 = none
  RoomBodyKind kind = RoomBodyKind::body;
  bool tracked = false;
  double quality = -1;            ///< DTrack's 0..1 (OSC: 1 when tracked), < 0 not tracked
  std::array<double, 3> position_m{0, 0, 0};        ///< m, Kumite's room
  std::array<double, 4> orientation{1, 0, 0, 0};    ///< w,x,y,z: body -> Kumite's room
};

/// One frame as a receiver publishes it (trivially copyable: kumite::LatestValue).
struct RoomFrame {
  std::uint64_t frame = 0;          ///< the sender's frame counter (DTrack fr, OSC /frame/start)
  double source_time_s = -1;        ///< the sender's timestamp (DTrack ts; -1 unknown)
  std::int32_t latency_us = -1;     ///< DTrack's own latency (ts2), -1 unknown
  Timestamp received_at = 0;        ///< s, kumite::now() when the datagram was read
  Timestamp published_at = 0;       ///< s, kumite::now() when it became pollable
  std::uint64_t sequence = 0;       ///< frames this receiver published, this one included
  std::int32_t body_count = 0;
  std::int32_t bodies_dropped = 0;  ///< bodies beyond kRoomFrameBodies (left out)
  std::array<RoomBody, kRoomFrameBodies> bodies{};
};

/// The body of that role, nullptr when the frame has none (or it is not tracked and
/// `tracked_only`).
const RoomBody* find_role(const RoomFrame& frame, std::string_view role, bool tracked_only = true);
const RoomBody* find_body(const RoomFrame& frame, std::int32_t id, RoomBodyKind kind = RoomBodyKind::body);

/// DTrack frame -> Kumite's room (roles from `input`; bodies of ids not in the role map are
/// left out when it has roles). Returns how many bodies were not configured.
int to_room_frame(const DtrackFrame& in, const DtrackInput& input, RoomFrame& out);
/// Kumite's room -> a DtrackFrame in DTrack's room (`room` is the DTrack -> Kumite transform;
/// its inverse is applied). Quality 1 for tracked bodies, -1 otherwise.
void to_dtrack_frame(const RoomFrame& in, const RoomTransform& room, DtrackFrame& out);

/// Rotation matrix (row-major) <-> quaternion (w,x,y,z).
std::array<double, 4> quaternion_from_rotation(const std::array<double, 9>& r);
std::array<double, 9> rotation_from_quaternion(const std::array<double, 4>& q);

// ---------------------------------------------------------------------------------------
// Receivers: their own thread; poll() never blocks
// ---------------------------------------------------------------------------------------

struct ReceiverCounters {
  std::uint64_t packets = 0;        ///< datagrams read
  std::uint64_t frames = 0;         ///< frames published
  std::uint64_t bad_packets = 0;    ///< datagrams with at least one problem (incl. oversized)
  std::uint64_t oversized = 0;      ///< datagrams longer than the receive buffer
  std::uint64_t unconfigured_bodies = 0;  ///< bodies of ids not in the role map (DTrack)
  std::uint64_t frame_gaps = 0;     ///< frames the sender's counter skipped
};

/// Shared plumbing of both receivers (thread, latest frame, counters, problem lines).
class Receiver {
 public:
  virtual ~Receiver();
  Receiver(const Receiver&) = delete;
  Receiver& operator=(const Receiver&) = delete;

  /// Opens the socket and starts the thread; Error("interop", "socket") when it cannot
  /// (port in use, a bad address), naming it.
  void start();
  void stop();
  bool running() const { return thread_.joinable(); }
  /// The UDP port it listens on (the one chosen when configured 0), after start().
  int port() const { return bound_port_.load(); }

  /// The newest frame (nullopt before the first); never blocks.
  std::optional<RoomFrame> poll() const { return latest_.read(); }
  /// How many frames were published so far (cheap: compare to see a new one).
  std::uint64_t version() const { return latest_.version(); }
  ReceiverCounters counters() const;
  /// Problem lines since the last call, each prefixed by where the packet came from
  /// ("dtrack 127.0.0.1:40123: packet:2: 6d: ..."); at most 100 are kept between calls (the
  /// rest only counted: a last line says how many were left out).
  std::vector<std::string> take_problems();
  /// Where the newest datagram came from ("127.0.0.1:40123"; "" before the first, or when the
  /// receiver does not know: OSC).
  std::string last_sender() const;
  /// Called on the receiver's thread with each frame as it is published (after poll() can see
  /// it): every frame, where poll() gives the newest only. Set it before start(); keep it short
  /// and without waiting (the installation pushes the roles' poses to its recognition thread).
  void on_publish(std::function<void(const RoomFrame&)> hook) { on_publish_ = std::move(hook); }

 protected:
  Receiver() = default;
  virtual void open() = 0;             ///< sets bound_port_; throws on failure
  virtual void run() = 0;              ///< the thread; returns when stopping_ is set
  virtual void close() = 0;
  void publish(RoomFrame& frame);      ///< stamps published_at and sequence
  void problem(std::string line);
  void note_frame_number(std::uint64_t frame);
  /// Notes a datagram's sender (IPv4 address in network order, port in host order).
  void note_sender(std::uint32_t address_be, std::uint16_t port) {
    last_sender_.store((std::uint64_t{1} << 48) | (std::uint64_t{address_be} << 16) | port, std::memory_order_relaxed);
  }

  std::atomic<bool> stopping_{false};
  std::atomic<int> bound_port_{0};
  std::atomic<std::uint64_t> packets_{0}, frames_{0}, bad_packets_{0}, oversized_{0}, unconfigured_{0},
      frame_gaps_{0};
  std::atomic<std::uint64_t> last_sender_{0};  ///< bit 48 set: known; address << 16 | port

 private:
  LatestValue<RoomFrame> latest_;
  std::function<void(const RoomFrame&)> on_publish_;
  std::thread thread_;
  std::uint64_t sequence_ = 0;
  bool have_frame_number_ = false;
  std::uint64_t last_frame_number_ = 0;
  struct Problems;
  std::shared_ptr<Problems> problems_;
};

struct DtrackReceiverOptions {
  std::size_t buffer_bytes = 16384;  ///< longer datagrams are "oversized" (bad)
  /// Called on the receiver thread after each datagram was parsed (kumite-dtrack listen prints
  /// from it); keep it short.
  std::function<void(const DtrackFrame&, const RoomFrame&)> on_packet;
};

/// DTrack ASCII over UDP (unicast, or a multicast group).
class DtrackReceiver : public Receiver {
 public:
  using Options = DtrackReceiverOptions;
  explicit DtrackReceiver(DtrackInput input);
  DtrackReceiver(DtrackInput input, Options options);
  ~DtrackReceiver() override;

 private:
  void open() override;
  void run() override;
  void close() override;
  DtrackInput input_;
  Options options_;
  int fd_ = -1;
};

struct OscReceiverOptions {
  std::string multicast_group;  ///< "" = unicast
  /// Body id -> role, as DtrackInput::role_body (-1 = none).
  std::array<std::int32_t, 5> role_body{-1, -1, -1, -1, -1};
};

/// OSC over UDP via liblo: /rigidbody/<id>/transformation x y z qx qy qz qw (Kumite's room,
/// m), inside a bundle per frame or bracketed by /frame/start <n> ... /frame/end <n>; also
/// /rigidbody/<id>/tracked 0|1. A frame is published at a bundle's end, at /frame/end, or,
/// for a lone message outside both, at once.
class OscReceiver : public Receiver {
 public:
  using Options = OscReceiverOptions;
  explicit OscReceiver(int port, Options options = {});
  ~OscReceiver() override;

  struct State;  ///< liblo's callbacks' view (defined in osc.cpp)

 private:
  void open() override;
  void run() override;
  void close() override;
  int requested_port_;
  Options options_;
  std::unique_ptr<State> state_;
};

// ---------------------------------------------------------------------------------------
// Senders (the caller's thread; one datagram per frame)
// ---------------------------------------------------------------------------------------

/// DTrack ASCII to host:port (a multicast group address works as host).
class DtrackSender {
 public:
  DtrackSender(const std::string& host, int port);  ///< Error("interop", "socket") on a bad host
  ~DtrackSender();
  DtrackSender(const DtrackSender&) = delete;
  DtrackSender& operator=(const DtrackSender&) = delete;
  /// Formats and sends; false (and errno's text in last_error()) when sendto failed.
  bool send(const DtrackFrame& frame);
  bool send_raw(std::string_view bytes);
  const std::string& last_error() const { return error_; }

 private:
  int fd_ = -1;
  std::array<unsigned char, 16> addr_{};  // sockaddr_in
  std::string buffer_, error_;
};

/// OSC to host:port, one bundle per frame: /frame/start n, per body /rigidbody/<id>/tracked
/// 0|1 and, when tracked, /rigidbody/<id>/transformation x y z qx qy qz qw (float32), /frame/end n.
class OscSender {
 public:
  OscSender(const std::string& host, int port);
  ~OscSender();
  OscSender(const OscSender&) = delete;
  OscSender& operator=(const OscSender&) = delete;
  bool send(const RoomFrame& frame);
  const std::string& last_error() const { return error_; }

 private:
  void* address_ = nullptr;  // lo_address
  std::string error_;
};

}  // namespace kumite::tracking
