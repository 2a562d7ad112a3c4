#pragma once
// The one list of events, from the fighter to the log: what the fighter does or refuses
// (content::FighterEvent) and what the installation notes of the visitor (app::FrameEvent,
// whose type is this same enum) are kinds of one EventKind, named once, in kEventKinds.
//
// A new event: its enumerator at the end of EventKind and its row at the end of kEventKinds
// (the word the log and console use, whether the log shows its distance, its fighter byte),
// then the frame formats' version (app/README.md "A frame's fields").
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>

namespace kumite::content {

/// An event's kind. Its number is its byte in a frame's states and hashes: new kinds go at
/// the end.
enum class EventKind : std::uint8_t {
  order_accepted,     ///< an order taken (its outcome comes later); the log's "order"
  order_ignored,      ///< an order refused (FighterEvent::reason says why)
  hit,                ///< a strike touched the visitor
  dodged,             ///< a strike reached its target, but the visitor had moved away
  miss,               ///< a strike fell short of its target (out of reach) and did not touch the visitor
  character_changed,  ///< the fighter is another character
  warning,            ///< something the operator should know (no strike for an order, no such character, ...)
  visitor_near_wall,  ///< the tracked head came within [safety] wall_distance_m of a wall, or left the tracked area
  visitor_clear,      ///< back in the room's safe area (tracked, clear of every wall)
  visitor_strike,     ///< the recogniser's event about a strike of the visitor's
  stepping_in,        ///< an accepted strike's target is beyond its reach: the fighter steps in `distance_m` first
  support_step,       ///< a strike's support foot steps `distance_m` first, to where the strike's clip stands on it
  stepping_back,      ///< an accepted strike's target is too near for its limb to land extended: a step back first
  block,              ///< the fighter blocks a visitor's strike (seen coming or recognised): its forearm in place `margin_s` before the fist (late: < 0)
  blocked,            ///< the visitor's fist or foot met the fighter's blocking forearm
  visitor_hit,        ///< the visitor's fist or foot entered the fighter's body fast: a hit for the visitor
};

/// What is said of each kind, in one place.
struct EventKindInfo {
  EventKind kind;
  std::string_view name;       ///< its word in frames.jsonl, the console and the fighter's reports
  bool logs_distance;          ///< frames.jsonl shows its distance_m
  /// Its byte as a FighterEvent's kind in frame states (format 2 numbered the fighter's own
  /// kinds apart from the app's: 0-6, then 7-9 for stepping_in, support_step, stepping_back);
  /// a new kind takes its own number.
  std::uint8_t fighter_byte;
};

inline constexpr std::array<EventKindInfo, 16> kEventKinds = {{
    {EventKind::order_accepted, "order", false, 0},
    {EventKind::order_ignored, "order_ignored", false, 1},
    {EventKind::hit, "hit", true, 2},
    {EventKind::dodged, "dodged", true, 3},
    {EventKind::miss, "miss", true, 4},
    {EventKind::character_changed, "character_changed", false, 5},
    {EventKind::warning, "warning", false, 6},
    {EventKind::visitor_near_wall, "visitor_near_wall", true, 10},
    {EventKind::visitor_clear, "visitor_clear", true, 11},
    {EventKind::visitor_strike, "visitor_strike", false, 12},
    {EventKind::stepping_in, "stepping_in", true, 7},
    {EventKind::support_step, "support_step", true, 8},
    {EventKind::stepping_back, "stepping_back", true, 9},
    {EventKind::block, "block", false, 13},
    {EventKind::blocked, "blocked", false, 14},
    {EventKind::visitor_hit, "visitor_hit", false, 15},
}};

constexpr bool event_kinds_in_order() {
  for (std::size_t k = 0; k < kEventKinds.size(); ++k)
    if (static_cast<std::size_t>(kEventKinds[k].kind) != k) return false;
  return true;
}
static_assert(event_kinds_in_order(), "kEventKinds: one row per EventKind, in its order");

constexpr const EventKindInfo& event_info(EventKind kind) { return kEventKinds[static_cast<std::size_t>(kind)]; }
inline constexpr EventKind kLastEventKind = kEventKinds.back().kind;

/// "order", "order_ignored", "hit", ... (EventKindInfo::name).
constexpr std::string_view to_string(EventKind kind) {
  return static_cast<std::size_t>(kind) < kEventKinds.size() ? event_info(kind).name : "?";
}
/// The word back (reading logs); nullopt when it names no kind.
constexpr std::optional<EventKind> parse_event_kind(std::string_view text) {
  for (const auto& k : kEventKinds)
    if (k.name == text) return k.kind;
  return std::nullopt;
}
/// The kind whose fighter byte (EventKindInfo::fighter_byte) this is; nullopt: none.
constexpr std::optional<EventKind> event_kind_of_fighter_byte(std::uint8_t byte) {
  for (const auto& k : kEventKinds)
    if (k.fighter_byte == byte) return k.kind;
  return std::nullopt;
}
/// A strike's outcome at contact: hit, dodged or miss.
constexpr bool is_strike_outcome(EventKind kind) {
  return kind == EventKind::hit || kind == EventKind::dodged || kind == EventKind::miss;
}

}  // namespace kumite::content
