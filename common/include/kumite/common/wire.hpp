#pragma once
// State that crosses thread boundaries now and a wire later (render cluster, record/replay):
// tracked body poses and supervisor orders. Plain, trivially copyable structs with explicit
// timestamps and units, so they serialise without touching the code that makes them.
//
// Room frame: metres, right-handed, +Y up, floor at y = 0, the visitor faces the front wall,
// which lies toward -Z.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "kumite/common/time.hpp"

namespace kumite {

enum class TrackingStatus : std::uint8_t {
  lost = 0,      ///< no pose, or the last one is older than the coasting limit
  tracked = 1,   ///< measured in this frame set
  coasting = 2,  ///< not measured now; last pose held/predicted (<= coasting limit)
};
std::string_view to_string(TrackingStatus s);

/// One camera's state as the tracker sees it (tracking::Tracker::camera_status).
enum class CameraState : std::uint8_t {
  ok = 0,            ///< frames arriving
  no_frames = 1,     ///< nothing for longer than camera_timeout_s (see since_last_s)
  reconnecting = 2,  ///< the device failed; the capture thread is trying to reopen it
  /// images arrive, but for camera_blind_s it saw none of the head's markers while >= 2
  /// other cameras tracked the head inside its view (covered, dark, moved, out of focus)
  blind = 3,
};
/// "ok", "no frames", "reconnecting", "sees no markers while others see the head".
std::string_view to_string(CameraState s);

/// One rigid body's pose at one instant.
struct BodyPose {
  Timestamp timestamp = 0;  ///< s, camera time of the frame set it was measured from
  std::uint64_t frame = 0;  ///< frame-set number
  std::int32_t body = 0;    ///< index of the body in tracking.toml ([[bodies]] order; 0 = head)
  TrackingStatus status = TrackingStatus::lost;
  std::array<double, 3> position{0, 0, 0};          ///< m, room frame (head: marker centroid)
  std::array<double, 4> orientation{1, 0, 0, 0};    ///< w,x,y,z: rotates body frame -> room
  std::int32_t markers = 0;  ///< markers of this body seen in the frame set
  std::int32_t cameras = 0;  ///< cameras that contributed
  /// s, tracker clock when the measured pose was published (-1: unknown): for a measured pose
  /// ready_at - timestamp is the tracking latency (frame set due -> pose readable), the first
  /// part of the pose age. A prediction (Tracker::predict) keeps its measurement's ready_at.
  Timestamp ready_at = -1;
};

/// A supervisor's order (keyboard, script or network).
enum class OrderKind : std::uint8_t {
  punch_left,
  punch_right,
  kick_left,
  kick_right,
  select_character,  ///< Order::character says which (0-based)
  pause,
  resume,
  recentre,
  spar,         ///< the fighter spars on its own too ([fighter.planner] mode spar)
  orders_only,  ///< the fighter does only what the supervisor orders (mode orders); text "orders"
};

struct Order {
  Timestamp time = 0;  ///< s, when it was given (same clock as the frame loop)
  OrderKind kind = OrderKind::punch_right;
  std::int32_t character = -1;  ///< 0-based character index for select_character
  bool operator==(const Order&) const = default;
};

/// "punch_left", ..., "character 2" (1-based in text, as the supervisor sees it), "pause".
std::string to_string(const Order& order);
std::string_view to_string(OrderKind kind);
/// Parses the text form above; std::nullopt when it is not an order.
std::optional<Order> parse_order(std::string_view text, Timestamp time = 0);

}  // namespace kumite
