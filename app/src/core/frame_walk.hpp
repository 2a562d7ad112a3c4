#pragma once
// The walkers of a frame's description (kumite/app/frame_fields.hpp): each goes over whatever
// describe() lists, by type, and knows no field by name. frame_states.cpp (encode, decode,
// diff), session.cpp (state hashes) and frame_log.cpp (the frames.jsonl line) call them on
// FrameData; a frame type that extends it (a test's) gets the same walk.
#include <cmath>
#include <cstring>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include <Eigen/Core>
#include <fmt/format.h>
#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>

#include "kumite/app/frame_fields.hpp"
#include "kumite/common/checksum.hpp"

namespace kumite::app {

// The last value of each enum a frame holds: a reader refuses a byte past it.
constexpr content::EventKind last_of(content::EventKind) { return content::kLastEventKind; }
constexpr content::FighterState last_of(content::FighterState) { return content::FighterState::recovering; }
constexpr content::FighterEvent::Reason last_of(content::FighterEvent::Reason) {
  return content::FighterEvent::Reason::blocking;
}
constexpr OrderKind last_of(OrderKind) { return OrderKind::orders_only; }
constexpr EventCause last_of(EventCause) { return EventCause::visitor; }
constexpr recognition::EventType last_of(recognition::EventType) { return recognition::EventType::cancel; }
constexpr recognition::Role last_of(recognition::Role) { return recognition::Role::right_foot; }
constexpr recognition::Action last_of(recognition::Action) { return recognition::Action::roundhouse_kick; }
constexpr Mesh last_of(Mesh) { return Mesh::cylinder; }
constexpr content::PlannerState last_of(content::PlannerState) { return content::PlannerState::countering; }

namespace walk {

template <class T> struct is_vector : std::false_type {};
template <class E, class A> struct is_vector<std::vector<E, A>> : std::true_type {};
template <class T> struct is_optional : std::false_type {};
template <class E> struct is_optional<std::optional<E>> : std::true_type {};
template <class T> struct is_array : std::false_type {};
template <class E, std::size_t N> struct is_array<std::array<E, N>> : std::true_type {};
template <class T> struct is_glm_vec : std::false_type {};
template <glm::length_t L, class E, glm::qualifier Q> struct is_glm_vec<glm::vec<L, E, Q>> : std::true_type {};
template <class T> struct is_glm_quat : std::false_type {};
template <class E, glm::qualifier Q> struct is_glm_quat<glm::qua<E, Q>> : std::true_type {};
template <class T> struct is_glm_mat : std::false_type {};
template <glm::length_t C, glm::length_t R, class E, glm::qualifier Q> struct is_glm_mat<glm::mat<C, R, E, Q>> : std::true_type {};

/// A number, or a fixed group of numbers: what a diff compares as one value.
template <class T>
constexpr bool is_numbers = std::is_arithmetic_v<T> || std::is_enum_v<T> || is_glm_vec<T>::value ||
                            is_glm_quat<T>::value || is_glm_mat<T>::value || std::is_same_v<T, Eigen::Vector3d> ||
                            std::is_same_v<T, std::array<double, 3>>;

/// Calls f(number&) for each number of a fixed group, in the order the formats keep them
/// (vectors x y z, quaternions w x y z, matrices column by column).
template <class T, class F>
void each_number(T& x, F&& f) {
  using U = std::remove_const_t<T>;
  if constexpr (is_glm_vec<U>::value) {
    for (glm::length_t i = 0; i < U::length(); ++i) f(x[i]);
  } else if constexpr (is_glm_quat<U>::value) {
    f(x.w), f(x.x), f(x.y), f(x.z);
  } else if constexpr (is_glm_mat<U>::value) {
    for (glm::length_t c = 0; c < U::length(); ++c)
      for (glm::length_t r = 0; r < U::col_type::length(); ++r) f(x[c][r]);
  } else if constexpr (std::is_same_v<U, Eigen::Vector3d>) {
    f(x.x()), f(x.y()), f(x.z());
  } else {
    for (auto& v : x) f(v);
  }
}

// ---- bytes: states.bin's encoding, and the state hashes over it ----------------------------

struct StringSink {
  std::string& s;
  void bytes(const void* p, std::size_t n) { s.append(static_cast<const char*>(p), n); }
};
struct FnvSink {
  std::uint64_t h = kFnv1a64Offset;
  void bytes(const void* p, std::size_t n) { h = fnv1a64(p, n, h); }
};

/// Little-endian, numbers exactly as they are: a bool or enum one byte, an int 4, a double 8;
/// a vector its u32 count, then each; an optional its u8 flag, then its value.
template <class Sink>
struct Writer {
  Sink& sink;
  int version = kFrameVersion;
  template <class T>
  void put(T v) {
    sink.bytes(&v, sizeof v);
  }
  template <class T>
  void operator()(const Field& f, const T& x) {
    if (f.present && f.since <= version) value(f, x);
  }
  template <class T>
  void value(const Field& f, const T& x) {
    if constexpr (std::is_same_v<T, bool>) {
      put<std::uint8_t>(x);
    } else if constexpr (std::is_same_v<T, content::EventKind>) {
      put<std::uint8_t>(f.fighter_byte ? content::event_info(x).fighter_byte : static_cast<std::uint8_t>(x));
    } else if constexpr (std::is_enum_v<T>) {
      put(static_cast<std::uint8_t>(x));
    } else if constexpr (std::is_arithmetic_v<T>) {
      put(x);
    } else if constexpr (is_numbers<T>) {
      each_number(x, [&](const auto& v) { put(v); });
    } else if constexpr (is_array<T>::value) {
      for (const auto& e : x) value(f, e);
    } else if constexpr (is_vector<T>::value) {
      put(static_cast<std::uint32_t>(x.size()));
      for (const auto& e : x) value(f, e);
    } else if constexpr (is_optional<T>::value) {
      put<std::uint8_t>(x.has_value());
      if (x)
        value(f, *x);
      else if (f.dense)
        value(f, typename T::value_type{});
    } else {
      describe(*this, x);
    }
  }
};

/// The bytes Writer gives a default `T`: the least an element of a vector of T takes.
template <class T>
std::size_t least_bytes() {
  static const std::size_t n = [] {
    std::string s;
    StringSink sink{s};
    Writer<StringSink> w{sink};
    w.value(Field{}, T{});
    return s.size();
  }();
  return n;
}

/// Reads what Writer wrote. `ok` false at the first thing that does not read: too few bytes,
/// a number not finite, an enum past its last value, a count larger than the bytes left hold.
struct Reader {
  std::string_view p;
  int version = kFrameVersion;
  bool ok = true;
  static constexpr std::uint32_t kMaxCount = 1u << 20;  // joints, walls, events, items: far above any real frame
  template <class T>
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
  template <class T>
  void operator()(const Field& f, T& x) {
    if (f.present && f.since <= version) value(f, x);
  }
  template <class T>
  void value(const Field& f, T& x) {
    if constexpr (std::is_same_v<T, bool>) {
      x = get<std::uint8_t>() != 0;
    } else if constexpr (std::is_enum_v<T>) {
      const auto b = get<std::uint8_t>();
      if constexpr (std::is_same_v<T, content::EventKind>)
        if (f.fighter_byte) {
          const auto kind = content::event_kind_of_fighter_byte(b);
          if (!kind) ok = false;
          x = kind.value_or(T{});
          return;
        }
      // (out of range: refused, and never stored: a later field's description reads it, e.g.
      // an event's type picks its distance's log form from the event table)
      if (b > static_cast<std::uint8_t>(last_of(T{}))) {
        ok = false;
        x = T{};
        return;
      }
      x = static_cast<T>(b);
    } else if constexpr (std::is_arithmetic_v<T>) {
      x = get<T>();
      if constexpr (std::is_floating_point_v<T>)
        if (!std::isfinite(x)) ok = false;
    } else if constexpr (is_numbers<T>) {
      each_number(x, [&](auto& v) { value(f, v); });
    } else if constexpr (is_array<T>::value) {
      for (auto& e : x) value(f, e);
    } else if constexpr (is_vector<T>::value) {
      const auto n = get<std::uint32_t>();
      if (n > kMaxCount || static_cast<std::size_t>(n) * least_bytes<typename T::value_type>() > p.size()) ok = false;
      x.resize(ok ? n : 0);
      for (auto& e : x) value(f, e);
    } else if constexpr (is_optional<T>::value) {
      const bool has = get<std::uint8_t>() != 0;
      typename T::value_type v{};
      if (has || f.dense) value(f, v);
      if (has)
        x = v;
      else
        x.reset();
    } else {
      describe(*this, x);
    }
  }
};

/// Per state hash, FNV-1a 64 of the bytes Writer gives its top-level fields.
struct Hasher {
  int version = kFrameVersion;
  std::array<FnvSink, kHashedNames.size()> groups{};
  template <class T>
  void operator()(const Field& f, const T& x) {
    if (f.hash == Hashed::none) return;
    Writer<FnvSink> w{groups[static_cast<std::size_t>(f.hash)], version};
    w(f, x);
  }
};

template <class F>
std::array<std::uint64_t, kHashedNames.size()> hash(const F& frame, int version = kFrameVersion) {
  Hasher h{version};
  describe(h, frame);
  std::array<std::uint64_t, kHashedNames.size()> out{};
  for (std::size_t k = 0; k < out.size(); ++k) out[k] = h.groups[k].h;
  return out;
}

// ---- the diff ---------------------------------------------------------------------------------

/// Bitwise: a NaN equals itself, -0 differs from 0 (what was drawn, exactly).
template <class T>
bool same(const T& a, const T& b) {
  bool equal = true;
  if constexpr (std::is_arithmetic_v<T> || std::is_enum_v<T>) {
    equal = std::memcmp(&a, &b, sizeof(T)) == 0;
  } else {
    std::vector<double> x, y;
    each_number(a, [&](const auto& v) { x.push_back(static_cast<double>(v)); });
    each_number(b, [&](const auto& v) { y.push_back(static_cast<double>(v)); });
    equal = x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) == 0;
  }
  return equal;
}

template <class T>
std::string text_of(const Field& f, const T& x) {
  if constexpr (std::is_same_v<T, bool>) {
    return x ? "true" : "false";
  } else if constexpr (std::is_enum_v<T>) {
    if constexpr (requires { to_string(x); })
      return std::string(to_string(x));
    else
      return fmt::format("{}", static_cast<int>(x));
  } else if constexpr (std::is_arithmetic_v<T>) {
    return fmt::format("{}", f.log == Log::one_based ? x + 1 : x);
  } else {
    std::string s = "(";
    each_number(x, [&](const auto& v) { s += fmt::format("{}{:.4f}", s.size() > 1 ? ", " : "", static_cast<double>(v)); });
    return s + ")";
  }
}

/// The first field where a recorded frame and the same frame made again differ, named by its
/// path ("fighter.joints[LeftHand]"), with both values.
struct Differ {
  int version = kFrameVersion;
  const FighterSkeleton* skeleton = nullptr;  ///< names the joints
  std::string path;
  std::optional<std::string> found;

  template <class T>
  void operator()(const Field& f, const T& a, const T& b) {
    if (found || !f.present || f.since > version) return;
    const std::size_t at = path.size();
    if (!path.empty()) path += '.';
    path += f.name;
    value(f, a, b);
    path.resize(at);
  }
  template <class T>
  void value(const Field& f, const T& a, const T& b) {
    if constexpr (is_numbers<T>) {
      if (same(a, b)) return;
      if constexpr (is_glm_quat<T>::value) {
        const double angle = 2 * std::acos(std::min(1.0, std::abs(glm::dot(glm::dquat(a), glm::dquat(b)))));
        found = fmt::format("{}: {:.3g} degrees apart", path, angle * 180 / M_PI);
      } else if constexpr (is_glm_mat<T>::value) {
        found = fmt::format("{}: differs", path);
      } else if constexpr (std::is_arithmetic_v<T> || std::is_enum_v<T>) {
        found = fmt::format("{}: recorded {}, now {}", path, text_of(f, a), text_of(f, b));
      } else {
        double d2 = 0;
        std::vector<double> x;
        each_number(a, [&](const auto& v) { x.push_back(static_cast<double>(v)); });
        std::size_t i = 0;
        each_number(b, [&](const auto& v) { d2 += std::pow(static_cast<double>(v) - x[i++], 2); });
        found = f.unit == Unit::m ? fmt::format("{}: recorded {} m, now {} m, {:.1f} mm apart", path, text_of(f, a),
                                                text_of(f, b), std::sqrt(d2) * 1e3)
                                  : fmt::format("{}: recorded {}, now {}", path, text_of(f, a), text_of(f, b));
      }
    } else if constexpr (is_array<T>::value || is_vector<T>::value) {
      if (a.size() != b.size()) {
        found = fmt::format("{}: recorded {}, now {}", path, a.size(), b.size());
        return;
      }
      for (std::size_t k = 0; k < a.size() && !found; ++k) {
        const std::size_t at = path.size();
        path += fmt::format("[{}]", f.log == Log::per_joint && skeleton && k < skeleton->joint_names.size()
                                        ? skeleton->joint_names[k]
                                        : std::to_string(k));
        value(f, a[k], b[k]);
        path.resize(at);
      }
    } else if constexpr (is_optional<T>::value) {
      if (a.has_value() != b.has_value())
        found = fmt::format("{}: recorded {}, now {}", path, a ? "set" : "none", b ? "set" : "none");
      else if (a)
        value(f, *a, *b);
    } else {
      describe(*this, a, b);
    }
  }
};

template <class F>
std::optional<std::string> first_difference(const F& recorded, const F& now, int version = kFrameVersion) {
  Differ d{version, recorded.fighter.skeleton.get(), {}, {}};
  describe(d, recorded, now);
  return d.found;
}

// ---- the frames.jsonl line --------------------------------------------------------------------

/// The logged fields of a frame as a JSON object (frame_log.hpp says the line's keys).
struct Logger {
  const std::vector<std::string>& wall_names;
  bool stereo = true;
  const FighterSkeleton* skeleton = nullptr;  ///< names the joints
  double run_start = 0;                       ///< s on the clock: now - time_s
  nlohmann::json* object = nullptr;
  double last_clock = 0;                      ///< the last clock time logged (Log::ms_after)

  template <class T>
  void operator()(const Field& f, const T& x) {
    if (f.log == Log::no || !f.present) return;
    auto v = value(f, x);
    if (!v) return;
    const std::string_view key = f.log_name();
    if (const auto slash = key.find('/'); slash != std::string_view::npos)
      (*object)[std::string(key.substr(0, slash))][std::string(key.substr(slash + 1))] = std::move(*v);
    else
      (*object)[std::string(key)] = std::move(*v);
  }

  template <class T>
  std::optional<nlohmann::json> value(const Field& f, const T& x) {
    using nlohmann::json;
    switch (f.log) {
      case Log::none_word: return json("none");
      case Log::wall_name:
        if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>)
          return json(x >= 0 && static_cast<std::size_t>(x) < wall_names.size() ? wall_names[static_cast<std::size_t>(x)]
                                                                                 : std::string());
        break;
      case Log::one_based:
        if constexpr (std::is_integral_v<T>) return json(x + 1);
        break;
      case Log::run_time:
        if constexpr (std::is_floating_point_v<T>) {
          last_clock = x;
          return json(x - run_start);
        }
        break;
      case Log::ms_after:
        if constexpr (std::is_floating_point_v<T>) return x >= 0 ? json((x - last_clock) * 1e3) : json(nullptr);
        break;
      case Log::per_joint:
        if constexpr (is_vector<T>::value) {
          json o = json::object();
          for (std::size_t i = 0; skeleton && i < x.size() && i < skeleton->joint_names.size(); ++i)
            o[skeleton->joint_names[i]] = plain(f, x[i]);
          return o;
        }
        break;
      case Log::per_wall:
        if constexpr (std::is_same_v<T, WallViews>) {
          json walls = json::object();
          const char* names[2] = {"left", "right"};
          for (std::size_t w = 0; w < x.size() && w < wall_names.size(); ++w) {
            json per = json::object();
            for (std::size_t e = 0; e < (stereo ? 2u : 1u); ++e) per[stereo ? names[e] : "mono"] = plain(f, x[w][e]);
            walls[wall_names[w]] = std::move(per);
          }
          return walls;
        }
        break;
      case Log::or_null:
        if constexpr (is_optional<T>::value) {
          return x ? plain(f, *x) : json(nullptr);
        } else if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
          return x >= 0 ? json(x) : json(nullptr);
        }
        break;
      case Log::plain:
        if constexpr (is_optional<T>::value) {
          if (!x) return std::nullopt;
          return plain(f, *x);
        } else {
          return plain(f, x);
        }
      case Log::no: return std::nullopt;
    }
    return plain(f, x);
  }

  template <class T>
  nlohmann::json plain(const Field& f, const T& x) {
    using nlohmann::json;
    const auto rounded = [&](double v) { return f.round > 0 ? std::round(v * f.round) / f.round : v; };
    if constexpr (std::is_same_v<T, bool>) {
      return json(x);
    } else if constexpr (std::is_floating_point_v<T>) {
      return json(rounded(x));
    } else if constexpr (std::is_arithmetic_v<T>) {
      return json(x);
    } else if constexpr (std::is_enum_v<T>) {  // by its word
      if constexpr (requires { to_string(x); })
        return json(std::string(to_string(x)));
      else
        return json(static_cast<int>(x));
    } else if constexpr (is_numbers<T>) {
      json a = json::array();
      each_number(x, [&](const auto& v) { a.push_back(rounded(static_cast<double>(v))); });
      return a;
    } else if constexpr (requires { to_string(x); }) {  // an order by its text
      return json(to_string(x));
    } else if constexpr (is_optional<T>::value) {
      return x ? plain(f, *x) : json(nullptr);
    } else if constexpr (is_vector<T>::value || is_array<T>::value) {
      json a = json::array();
      for (const auto& e : x) a.push_back(plain(f, e));
      return a;
    } else {
      json o = json::object();
      nlohmann::json* outer = std::exchange(object, &o);
      describe(*this, x);
      object = outer;
      return o;
    }
  }
};

template <class F>
nlohmann::json log_object(const F& frame, const std::vector<std::string>& wall_names, bool stereo) {
  nlohmann::json j = nlohmann::json::object();
  Logger l{wall_names, stereo, frame.fighter.skeleton.get(), frame.now - frame.time_s, &j};
  describe(l, frame);
  return j;
}

}  // namespace walk
}  // namespace kumite::app
