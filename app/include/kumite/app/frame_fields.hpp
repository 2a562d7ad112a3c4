#pragma once
// A frame's fields, described once. Every walker of a frame goes through describe(): the
// frame states' encoder and decoder (states.bin, frame_states.cpp), the session's state hashes
// (session.jsonl), the replay's diff (first_difference), the frames.jsonl line and, through
// it, `kumite export` (app/src/core/frame_walk.hpp holds the walkers). A field is a line here:
//
//   v(Field{.name = "root", .unit = Unit::m, .log = Log::plain}, p.root...);
//
// naming it, its unit, how the log shows it, which state hash counts it and the frame states
// version that added it. describe() takes one object or several of the same type (`p...`: the
// recorded and the replayed frame for a diff) and hands the visitor each field of each, in the
// order states.bin writes them. Types a walker knows: numbers, bools, enums (one byte), glm
// vectors, quaternions and matrices, Eigen::Vector3d, std::array, std::vector (a count, then
// each), std::optional (a flag, then the value) and any struct that has a describe() here.
//
// Adding a field: its member in the struct, its line here (with `.since` the new version),
// then kFrameVersion + 1. Adding an event: content/include/kumite/content/event.hpp.
#include <array>
#include <concepts>
#include <cstdint>
#include <string_view>
#include <type_traits>

#include "kumite/app/installation.hpp"

namespace kumite::app {

/// The frame description's version: states.bin's header says it, a session's manifest keeps it
/// ("frame_version"). A file of an older version lacks the fields added since (`Field::since`):
/// they read as their defaults and are neither hashed nor compared. 2: a visitor_strike event
/// carries its recognition event. 3: the fighter's events carry the visitor's limb, the
/// forearm, a margin and a speed (block, blocked, visitor_hit). 4: the spar bout's planner
/// state and score (FrameData::spar).
inline constexpr int kFrameVersion = 4;

/// What a number measures.
enum class Unit : std::uint8_t {
  none,
  m,        ///< metres, room frame (a diff says how far apart)
  s,        ///< seconds since the run's start
  ms,       ///< milliseconds
  rad,      ///< radians
  clock_s,  ///< seconds on the frame loop's (or the tracker's) clock
  rotation, ///< a unit quaternion, w x y z (a diff says the angle between)
};

/// Which of the session's state hashes a top-level field counts in (StateHashes::kFields).
enum class Hashed : std::uint8_t { time, head, eyes, views, fighter, events, none };
inline constexpr std::array<std::string_view, 6> kHashedNames = {"time", "head", "eyes", "views", "fighter", "events"};

/// How frames.jsonl shows a field.
enum class Log : std::uint8_t {
  no,         ///< not logged
  plain,      ///< as it is: a number, true/false, an enum or an order by its word, a struct as an
              ///< object of its logged fields, a vector as an array; an empty optional left out
  or_null,    ///< plain, but null when it has no value: an empty optional, a -1 (none) age
  one_based,  ///< an index counted from 1, as the operator counts characters
  none_word,  ///< the word "none" (the fighter's state when there is no fighter)
  per_joint,  ///< an object keyed by the skeleton's joint names, one entry per joint
  per_wall,   ///< "walls": an object keyed by the walls' names, per eye "left"/"right" (or "mono")
  wall_name,  ///< a wall's index as its name
  run_time,   ///< a clock time as s since the run's start
  ms_after,   ///< a clock time as ms after the clock time logged before it (null when negative: unknown)
};

/// One field as the walkers see it. Designated initialisers name what differs from the default
/// (in this order).
struct Field {
  std::string_view name;         ///< its name in diffs ("fighter.joints[Head]") and its key in the log
  Unit unit = Unit::none;
  Log log = Log::no;
  std::string_view key = {};     ///< its key in the log when not `name` ("a/b": b inside a's object)
  double round = 0;              ///< log: rounded to 1/round of its unit (0: as it is)
  Hashed hash = Hashed::none;    ///< top-level fields: the state hash it counts in
  int since = 1;                 ///< the kFrameVersion that added it
  bool dense = false;            ///< an optional written as its flag and its value (the default when empty)
  bool present = true;           ///< false: this object has no such field (a strike's details on another event)
  bool fighter_byte = false;     ///< an EventKind written as its fighter byte (content::EventKindInfo)
  std::string_view log_name() const { return key.empty() ? name : key; }
};

/// All of `T...` are `X` (const or not): describe()'s overloads pick by this.
template <class X, class... T>
concept AllOf = sizeof...(T) > 0 && (std::same_as<std::remove_const_t<T>, X> && ...);

template <class T, class... R>
T& first_of(T& t, R&...) {
  return t;
}

// ---- the descriptions --------------------------------------------------------------------

template <class V, class... T> requires AllOf<Frustum, T...>
void describe(V& v, T&... x) {
  v(Field{.name = "left", .unit = Unit::m}, x.left...);
  v(Field{.name = "right", .unit = Unit::m}, x.right...);
  v(Field{.name = "bottom", .unit = Unit::m}, x.bottom...);
  v(Field{.name = "top", .unit = Unit::m}, x.top...);
  v(Field{.name = "near", .unit = Unit::m}, x.near...);
  v(Field{.name = "far", .unit = Unit::m}, x.far...);
}

template <class V, class... T> requires AllOf<EyeView, T...>
void describe(V& v, T&... x) {
  v(Field{.name = "frustum"}, x.frustum...);
  v(Field{.name = "view", .log = Log::plain}, x.view...);
  v(Field{.name = "projection", .log = Log::plain}, x.projection...);
  v(Field{.name = "valid"}, x.valid...);
}

template <class V, class... T> requires AllOf<HeadPose, T...>
void describe(V& v, T&... x) {
  v(Field{.name = "position", .unit = Unit::m, .log = Log::plain}, x.position...);
  v(Field{.name = "orientation", .unit = Unit::rotation, .log = Log::plain, .key = "quaternion"}, x.orientation...);
}

template <class V, class... T> requires AllOf<Eyes, T...>
void describe(V& v, T&... x) {
  v(Field{.name = "left", .unit = Unit::m, .log = Log::plain}, x.left...);
  v(Field{.name = "right", .unit = Unit::m, .log = Log::plain}, x.right...);
}

template <class V, class... T> requires AllOf<Order, T...>
void describe(V& v, T&... x) {
  v(Field{.name = "time", .unit = Unit::clock_s}, x.time...);
  v(Field{.name = "kind"}, x.kind...);
  v(Field{.name = "character"}, x.character...);
}

template <class V, class... T> requires AllOf<FighterPose, T...>
void describe(V& v, T&... x) {
  // The log shows the pose only while there is a fighter.
  const auto shown = [&](Log log) { return first_of(x...).present ? log : Log::no; };
  v(Field{.name = "present", .log = Log::plain}, x.present...);
  v(Field{.name = "state", .log = first_of(x...).present ? Log::plain : Log::none_word}, x.state...);
  v(Field{.name = "character", .log = Log::one_based}, x.character...);
  v(Field{.name = "joints", .unit = Unit::m, .log = shown(Log::per_joint), .round = 1e5}, x.joints...);
  v(Field{.name = "local_rotations", .unit = Unit::rotation, .log = shown(Log::per_joint), .round = 1e7},
    x.local_rotations...);
  v(Field{.name = "root_joint", .unit = Unit::m, .log = shown(Log::plain), .round = 1e5}, x.root_joint...);
  v(Field{.name = "target", .unit = Unit::m, .log = shown(Log::or_null)}, x.target...);
  v(Field{.name = "root", .unit = Unit::m, .log = shown(Log::plain)}, x.root...);
  v(Field{.name = "heading_rad", .unit = Unit::rad, .log = shown(Log::plain)}, x.heading_rad...);
}

template <class V, class... T> requires AllOf<VisitorNearWall, T...>
void describe(V& v, T&... x) {
  v(Field{.name = "wall", .log = Log::wall_name}, x.wall...);
  v(Field{.name = "distance_m", .unit = Unit::m, .log = Log::plain}, x.distance_m...);
  v(Field{.name = "outside", .log = Log::plain}, x.outside...);
  v(Field{.name = "lost", .log = Log::plain}, x.lost...);
}

template <class V, class... T> requires AllOf<SparFrame, T...>
void describe(V& v, T&... x) {
  v(Field{.name = "state", .log = Log::plain}, x.state...);
  v(Field{.name = "visitor_hits", .log = Log::plain}, x.visitor_hits...);
  v(Field{.name = "visitor_dodges", .log = Log::plain}, x.visitor_dodges...);
  v(Field{.name = "fighter_hits", .log = Log::plain}, x.fighter_hits...);
  v(Field{.name = "blocks", .log = Log::plain}, x.blocks...);
  v(Field{.name = "blocks_late", .log = Log::plain}, x.blocks_late...);
  v(Field{.name = "blocked", .log = Log::plain}, x.blocked...);
  v(Field{.name = "unanswered", .log = Log::plain}, x.unanswered...);
}

template <class V, class... T> requires AllOf<content::FighterEvent, T...>
void describe(V& v, T&... x) {
  v(Field{.name = "time", .unit = Unit::clock_s}, x.time...);
  v(Field{.name = "kind", .fighter_byte = true}, x.kind...);
  v(Field{.name = "order"}, x.order...);
  v(Field{.name = "reason"}, x.reason...);
  v(Field{.name = "distance_m", .unit = Unit::m}, x.distance_m...);
  v(Field{.name = "target", .unit = Unit::m}, x.target...);
  v(Field{.name = "segment"}, x.segment...);
  v(Field{.name = "start_frame"}, x.start_frame...);
  v(Field{.name = "contact_frame"}, x.contact_frame...);
  v(Field{.name = "contact_distance_m", .unit = Unit::m}, x.contact_distance_m...);
  v(Field{.name = "out_of_reach"}, x.out_of_reach...);
  v(Field{.name = "character_count"}, x.character_count...);
  v(Field{.name = "limb", .since = 3}, x.limb...);
  v(Field{.name = "side", .since = 3}, x.side...);
  v(Field{.name = "margin_s", .since = 3}, x.margin_s...);
  v(Field{.name = "speed_mps", .since = 3}, x.speed_mps...);
  v(Field{.name = "recognised", .since = 3}, x.recognised...);
}

template <class V, class... T> requires AllOf<VisitorStrike, T...>
void describe(V& v, T&... x) {
  v(Field{.name = "t", .unit = Unit::clock_s, .log = Log::run_time}, x.t...);
  v(Field{.name = "decided_at", .unit = Unit::clock_s, .log = Log::ms_after, .key = "decided_ms"}, x.decided_at...);
  v(Field{.name = "type", .log = Log::plain}, x.type...);
  v(Field{.name = "limb", .log = Log::plain}, x.limb...);
  v(Field{.name = "action", .log = Log::plain}, x.action...);
  v(Field{.name = "progress", .log = Log::plain}, x.progress...);
  v(Field{.name = "confidence", .log = Log::plain}, x.confidence...);
  v(Field{.name = "impact", .unit = Unit::m, .log = Log::plain}, x.impact...);
}

template <class V, class... T> requires AllOf<FrameEvent, T...>
void describe(V& v, T&... x) {
  v(Field{.name = "type", .log = Log::plain}, x.type...);
  v(Field{.name = "order", .log = Log::plain, .dense = true}, x.order...);
  v(Field{.name = "distance_m", .unit = Unit::m,
          .log = content::event_info(first_of(x...).type).logs_distance ? Log::plain : Log::no},
    x.distance_m...);
  v(Field{.name = "time_s", .unit = Unit::s, .log = Log::plain}, x.time_s...);
  v(Field{.name = "cause"}, x.cause...);
  v(Field{.name = "fighter"}, x.fighter...);
  v(Field{.name = "wall"}, x.wall...);
  v(Field{.name = "outside"}, x.outside...);
  v(Field{.name = "lost"}, x.lost...);
  v(Field{.name = "strike", .log = Log::plain, .since = 2, .present = first_of(x...).type == EventType::visitor_strike},
    x.strike...);
}

template <class V, class... T> requires AllOf<DrawItem, T...>
void describe(V& v, T&... x) {
  v(Field{.name = "model"}, x.model...);
  v(Field{.name = "colour"}, x.colour...);
  v(Field{.name = "mesh"}, x.mesh...);
}

/// The frame. The fighter's skeleton (names and parents of its joints) is not a field: it is
/// made once per character, written once per character (states.bin's skeleton record) and
/// names the joints in the log and in diffs.
template <class V, class... T> requires AllOf<FrameData, T...>
void describe(V& v, T&... x) {
  v(Field{.name = "frame", .log = Log::plain, .hash = Hashed::time}, x.frame...);
  v(Field{.name = "time_s", .unit = Unit::s, .log = Log::plain, .hash = Hashed::time}, x.time_s...);
  v(Field{.name = "now", .unit = Unit::clock_s, .hash = Hashed::time}, x.now...);
  v(Field{.name = "head", .log = Log::plain, .hash = Hashed::head}, x.head...);
  v(Field{.name = "head_live", .log = Log::plain, .key = "head/live", .hash = Hashed::head}, x.head_live...);
  v(Field{.name = "eyes", .log = Log::plain, .hash = Hashed::eyes}, x.eyes...);
  v(Field{.name = "views", .log = Log::per_wall, .key = "walls", .hash = Hashed::views}, x.views...);
  // The tracker's timing: a measurement of the run (a re-track cannot make it again), not hashed.
  v(Field{.name = "pose_age_ms", .unit = Unit::ms, .log = Log::or_null}, x.pose_age_ms...);
  v(Field{.name = "pose_measured_at", .unit = Unit::clock_s}, x.pose_measured_at...);
  v(Field{.name = "tracking_latency_ms", .unit = Unit::ms, .log = Log::or_null}, x.tracking_latency_ms...);
  v(Field{.name = "latch_ms", .unit = Unit::ms, .log = Log::plain, .hash = Hashed::time}, x.latch_ms...);
  v(Field{.name = "predicted_ahead_ms", .unit = Unit::ms, .log = Log::plain, .hash = Hashed::time}, x.predicted_ahead_ms...);
  v(Field{.name = "fighter", .log = Log::plain, .hash = Hashed::fighter}, x.fighter...);
  v(Field{.name = "visitor_near_wall", .log = Log::plain, .hash = Hashed::head}, x.visitor_near_wall...);
  v(Field{.name = "events", .log = Log::plain, .hash = Hashed::events}, x.events...);
  v(Field{.name = "items", .hash = Hashed::fighter}, x.items...);  // what was drawn: the fighter, its target, a wall's glow
  v(Field{.name = "spar", .log = Log::plain, .hash = Hashed::fighter, .since = 4}, x.spar...);
}

/// `t` as its base `B`, keeping its constness: a frame type that extends FrameData describes
/// FrameData's fields with describe(v, as_base<FrameData>(x)...), then its own.
template <class B, class T>
auto& as_base(T& t) {
  if constexpr (std::is_const_v<T>)
    return static_cast<const B&>(t);
  else
    return static_cast<B&>(t);
}

}  // namespace kumite::app
