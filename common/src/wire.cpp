#include "kumite/common/wire.hpp"

#include <charconv>

#include <fmt/format.h>

#include "kumite/common/text.hpp"

namespace kumite {

std::string_view to_string(TrackingStatus s) {
  switch (s) {
    case TrackingStatus::tracked: return "tracked";
    case TrackingStatus::coasting: return "coasting";
    case TrackingStatus::lost: return "lost";
  }
  return "lost";
}

std::string_view to_string(CameraState s) {
  switch (s) {
    case CameraState::ok: return "ok";
    case CameraState::no_frames: return "no frames";
    case CameraState::reconnecting: return "reconnecting";
    case CameraState::blind: return "sees no markers while others see the head";
  }
  return "?";
}

std::string_view to_string(OrderKind kind) {
  switch (kind) {
    case OrderKind::punch_left: return "punch_left";
    case OrderKind::punch_right: return "punch_right";
    case OrderKind::kick_left: return "kick_left";
    case OrderKind::kick_right: return "kick_right";
    case OrderKind::select_character: return "character";
    case OrderKind::pause: return "pause";
    case OrderKind::resume: return "resume";
    case OrderKind::recentre: return "recentre";
    case OrderKind::spar: return "spar";
    case OrderKind::orders_only: return "orders";
  }
  return "?";
}

std::string to_string(const Order& order) {
  if (order.kind == OrderKind::select_character) {
    return fmt::format("character {}", order.character + 1);
  }
  return std::string(to_string(order.kind));
}


std::optional<Order> parse_order(std::string_view text, Timestamp time) {
  text = trim_blanks(text);
  Order o;
  o.time = time;
  static constexpr OrderKind kSimple[] = {OrderKind::punch_left, OrderKind::punch_right,
                                          OrderKind::kick_left,  OrderKind::kick_right,
                                          OrderKind::pause,      OrderKind::resume,
                                          OrderKind::recentre,   OrderKind::spar,
                                          OrderKind::orders_only};
  for (OrderKind k : kSimple) {
    if (text == to_string(k)) {
      o.kind = k;
      return o;
    }
  }
  constexpr std::string_view kChar = "character";
  if (text.substr(0, kChar.size()) == kChar) {
    std::string_view rest = trim_blanks(text.substr(kChar.size()));
    if (!rest.empty() && rest.front() == '_') rest = rest.substr(1);  // "character_2"
    int n = 0;
    auto [p, ec] = std::from_chars(rest.data(), rest.data() + rest.size(), n);
    if (ec == std::errc() && p == rest.data() + rest.size() && n >= 1) {
      o.kind = OrderKind::select_character;
      o.character = n - 1;
      return o;
    }
  }
  return std::nullopt;
}

}  // namespace kumite
