// DTrack ASCII parser (issue 55). Written from the grammar as ART's DTrackSDK reads it
// (ar-tracking/DTrackSDK, src/DTrackParser.cpp and src/DTrackParse.cpp, v2.6/2.7, BSD-3: read,
// not copied), which follows "DTrack2 User Manual, Technical Appendix" / "DTRACK3 Programmer's
// Guide":
//   - one datagram = one frame; lines end in CR and/or LF; unknown line types are skipped;
//   - numbers in blocks "[...]" (whitespace between blocks allowed: DTrack1 writes "] [");
//     numbers past those a block needs are ignored (6d's location block carries 3 Euler
//     angles after the position: "[sx sy sz η θ φ]");
//   - fr <uint> | ts <s> | ts2 <s> <µs> <latency µs> | 6dcal <n>
//     6d <n> [id qu][sx sy sz (η θ φ)][b0..b8]
//     6df <n> [id qu bt][sx sy sz (η θ φ)][b0..b8]
//     6df2 <ndef> <n> [id qu nbt nct][sx sy sz][b0..b8][bt.. ct..]  (ceil(nbt/32) button words)
//     3d <n> [id qu][sx sy sz]
//   - positions in mm; b0..b8 the rotation column-wise (rot[col * 3 + row], as the SDK's
//     rot2quat reads it); quality < 0 = not tracked (the SDK stores -1 for bodies 6d omits).
// The ts2 layout is from the project's research notes (../shared/research/
// cluster-and-tracker-interop.md, section 3); the latency field is optional here.
// Where this parser is stricter than the SDK (which returns false for the whole packet, or
// reads past garbage with strtod), every problem is one line naming the line and the field.
#include <algorithm>
#include <bitset>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>

#include <fmt/format.h>

#include "kumite/common/error.hpp"
#include "kumite/tracking/interop.hpp"

namespace kumite::tracking {

void DtrackFrame::clear() {
  has_frame = false;
  frame = 0;
  timestamp_s = -1;
  ts2_s = -1;
  ts2_us = 0;
  latency_us = -1;
  calibrated_bodies = -1;
  bodies.clear();
  flysticks.clear();
  markers.clear();
  problems.clear();
  problem_count = 0;
}

const DtrackBody* DtrackFrame::body(int id) const {
  for (const auto& b : bodies)
    if (b.id == id) return &b;
  return nullptr;
}

namespace {

constexpr std::size_t kKeptProblems = 16;
constexpr double kMaxPositionMm = 1e6;  // 1 km
constexpr int kMaxBlockNumbers = 16;    // numbers kept of one block (more are checked, ignored)

/// A quoted excerpt of bad text for a message (at most 24 characters).
std::string quote(std::string_view s) {
  if (s.size() > 24) return fmt::format("'{}...'", s.substr(0, 24));
  return fmt::format("'{}'", s);
}

struct Block {
  int count = 0;  // numbers in the block (all parsed and finite)
  std::array<double, kMaxBlockNumbers> v{};
};

class Parser {
 public:
  explicit Parser(DtrackFrame& out) : f_(out) {}

  void packet(std::string_view p) {
    if (p.size() > kDtrackMaxPacketBytes) {
      fail(0, "", fmt::format("{} bytes, more than a UDP datagram can carry ({}): oversized", p.size(),
                              kDtrackMaxPacketBytes));
      return;
    }
    while (!p.empty() && p.back() == '\0') p.remove_suffix(1);
    if (p.empty()) {
      fail(0, "", "empty packet");
      return;
    }
    for (std::size_t i = 0; i < p.size(); ++i) {
      const auto c = static_cast<unsigned char>(p[i]);
      if ((c < 0x20 && c != '\r' && c != '\n' && c != '\t') || c > 0x7e) {
        const bool osc = p.front() == '/' || p.substr(0, 7) == "#bundle";
        fail(0, "", fmt::format("not DTrack ASCII: byte 0x{:02x} at offset {}{}", c, i,
                                osc ? " (an OSC packet?)" : ""));
        return;
      }
    }
    int line_no = 0;
    std::size_t i = 0;
    while (i < p.size()) {
      std::size_t e = i;
      while (e < p.size() && p[e] != '\r' && p[e] != '\n') ++e;
      ++line_no;
      line(p.substr(i, e - i), line_no);
      if (e < p.size() && p[e] == '\r' && e + 1 < p.size() && p[e + 1] == '\n') ++e;
      i = e + 1;
    }
    if (!f_.has_frame && f_.problem_count == 0) fail(0, "fr", "no frame counter line (fr) in the packet");
    if (cal_ >= 0) f_.calibrated_bodies = std::max(0, cal_ - flysticks_6df_);
  }

 private:
  // --- problems -------------------------------------------------------------------------
  void fail(int line, std::string_view key, std::string_view message) {
    ++f_.problem_count;
    if (f_.problems.size() < kKeptProblems) f_.problems.push_back(format_location("packet", line, key, message));
  }

  // --- the cursor over one line ------------------------------------------------------------
  void skip_ws() {
    while (pos_ < s_.size() && (s_[pos_] == ' ' || s_[pos_] == '\t')) ++pos_;
  }
  bool at_end() {
    skip_ws();
    return pos_ >= s_.size();
  }
  std::string_view word() {
    skip_ws();
    const std::size_t b = pos_;
    while (pos_ < s_.size() && s_[pos_] != ' ' && s_[pos_] != '\t' && s_[pos_] != '[' && s_[pos_] != ']') ++pos_;
    return s_.substr(b, pos_ - b);
  }
  /// A number token as a double; nullopt (and a problem) when it is none or not finite.
  std::optional<double> number(std::string_view tok, std::string_view key) {
    double v = 0;
    const char* b = tok.data();
    const char* e = b + tok.size();
    const auto r = std::from_chars(b, e, v);
    if (tok.empty()) {
      fail(line_, key, "missing");
      return std::nullopt;
    }
    if (r.ec == std::errc::result_out_of_range) {
      fail(line_, key, fmt::format("must be a finite number, found {}", quote(tok)));
      return std::nullopt;
    }
    if (r.ec != std::errc() || r.ptr != e) {
      fail(line_, key, fmt::format("not a number: {}", quote(tok)));
      return std::nullopt;
    }
    if (!std::isfinite(v)) {
      fail(line_, key, fmt::format("must be a finite number, found {}", quote(tok)));
      return std::nullopt;
    }
    return v;
  }
  /// An integer in [lo, hi] (a double token with an integral value is accepted, e.g. "3").
  std::optional<std::int64_t> integer(std::string_view tok, std::string_view key, std::int64_t lo, std::int64_t hi) {
    std::int64_t v = 0;
    const char* b = tok.data();
    const char* e = b + tok.size();
    const auto r = std::from_chars(b, e, v);
    if (tok.empty()) {
      fail(line_, key, "missing");
      return std::nullopt;
    }
    if (r.ec != std::errc() || r.ptr != e) {
      fail(line_, key, fmt::format("must be an integer, found {}", quote(tok)));
      return std::nullopt;
    }
    if (v < lo || v > hi) {
      fail(line_, key, fmt::format("must be in [{}, {}], found {}", lo, hi, v));
      return std::nullopt;
    }
    return v;
  }
  /// The next "[...]" block. Returns false when the line's structure is broken (no '[' or
  /// no ']': the line is abandoned); `ok` false when a number in it was bad (the item is
  /// skipped, the line goes on). `need` numbers at least.
  bool block(Block& b, std::string_view key, int need, bool& ok) {
    skip_ws();
    if (pos_ >= s_.size()) {
      fail(line_, key, "cut short: the line ends where a block '[' should start");
      return false;
    }
    if (s_[pos_] != '[') {
      fail(line_, key, fmt::format("expected '[', found {}", quote(s_.substr(pos_, 8))));
      return false;
    }
    const std::size_t close = s_.find(']', pos_ + 1);
    if (close == std::string_view::npos) {
      fail(line_, key, "cut short: a block '[' without its ']'");
      return false;
    }
    const std::string_view inner = s_.substr(pos_ + 1, close - pos_ - 1);
    if (inner.find('[') != std::string_view::npos) {
      fail(line_, key, "cut short: a block '[' without its ']'");
      return false;
    }
    pos_ = close + 1;
    b.count = 0;
    std::size_t i = 0;
    int seen = 0;
    while (i < inner.size()) {
      while (i < inner.size() && (inner[i] == ' ' || inner[i] == '\t')) ++i;
      if (i >= inner.size()) break;
      std::size_t e = i;
      while (e < inner.size() && inner[e] != ' ' && inner[e] != '\t') ++e;
      const auto v = number(inner.substr(i, e - i), key);
      if (!v) ok = false;
      else if (b.count < kMaxBlockNumbers) b.v[static_cast<std::size_t>(b.count++)] = *v;
      ++seen;
      i = e;
    }
    if (ok && seen < need) {
      fail(line_, key, fmt::format("missing fields: {} number{}, needs {}", seen, seen == 1 ? "" : "s", need));
      ok = false;
    }
    return true;
  }
  bool integral(double v, std::int64_t lo, std::int64_t hi) {
    return v == std::floor(v) && v >= static_cast<double>(lo) && v <= static_cast<double>(hi);
  }
  bool check_int(double v, std::string_view key, std::int64_t lo, std::int64_t hi) {
    if (integral(v, lo, hi)) return true;
    fail(line_, key, fmt::format("must be an integer in [{}, {}], found {}", lo, hi, v));
    return false;
  }

  // --- lines -------------------------------------------------------------------------------
  void line(std::string_view text, int no) {
    s_ = text;
    pos_ = 0;
    line_ = no;
    if (at_end()) return;
    const std::string_view id = word();
    if (id == "fr") return fr();
    if (id == "ts") return ts();
    if (id == "ts2") return ts2();
    if (id == "6dcal") return cal();
    if (id == "6d") return sixd();
    if (id == "6df") return flystick(false);
    if (id == "6df2") return flystick(true);
    if (id == "3d") return markers();
    // Another DTrack line (6dmt, 6dmt2, 6dmtr, gl, glcal, 6dj, 6di, 6dcov, ...): skipped, as
    // the SDK does. Anything else is not DTrack.
    const bool dtrack_like =
        !id.empty() && id.size() <= 8 &&
        std::all_of(id.begin(), id.end(), [](char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9'); });
    if (!dtrack_like) fail(line_, "", fmt::format("not a DTrack line: {}", quote(text)));
    // Every DTrack line has fields after its type; a lone word is a line cut short.
    else if (at_end()) fail(line_, id, "cut short: a line type without fields");
  }

  bool once(bool& seen, std::string_view key) {
    if (seen) {
      fail(line_, key, "a second such line in the packet (ignored)");
      return false;
    }
    seen = true;
    return true;
  }
  void trailing(std::string_view key, std::int64_t n) {
    if (!at_end())
      fail(line_, key, fmt::format("more data than its count of {} announces: {}", n, quote(s_.substr(pos_))));
  }

  void fr() {
    if (!once(seen_fr_, "fr")) return;
    const std::string_view tok = word();
    if (tok.empty()) return fail(line_, "fr", "missing the frame number");
    std::uint64_t v = 0;
    const auto r = std::from_chars(tok.data(), tok.data() + tok.size(), v);
    if (r.ec != std::errc() || r.ptr != tok.data() + tok.size())
      return fail(line_, "fr", fmt::format("must be an unsigned integer, found {}", quote(tok)));
    f_.frame = v;
    f_.has_frame = true;
    trailing("fr", 1);
  }
  void ts() {
    if (!once(seen_ts_, "ts")) return;
    const std::string_view tok = word();
    if (tok.empty()) return fail(line_, "ts", "missing the timestamp");
    const auto v = number(tok, "ts");
    if (!v) return;
    if (*v < 0) return fail(line_, "ts", fmt::format("must be >= 0 s, found {}", *v));
    f_.timestamp_s = *v;
    trailing("ts", 1);
  }
  void ts2() {
    if (!once(seen_ts2_, "ts2")) return;
    const std::string_view a = word();
    const std::string_view b = word();
    if (a.empty() || b.empty()) return fail(line_, "ts2", "missing fields: needs seconds and microseconds");
    const auto sec = integer(a, "ts2", 0, std::int64_t{1} << 40);
    const auto us = integer(b, "ts2", 0, 999999);
    if (!sec || !us) return;
    std::int64_t lat = -1;
    if (!at_end()) {
      const auto l = integer(word(), "ts2", 0, 60'000'000);
      if (!l) return;
      lat = *l;
    }
    f_.ts2_s = *sec;
    f_.ts2_us = static_cast<std::int32_t>(*us);
    f_.latency_us = static_cast<std::int32_t>(lat);
    trailing("ts2", 3);
  }
  void cal() {
    if (!once(seen_cal_, "6dcal")) return;
    const auto n = integer(word(), "6dcal", 0, kDtrackMaxBodies);
    if (!n) return;
    cal_ = static_cast<int>(*n);
    trailing("6dcal", *n);
  }

  /// A pose from a location block (3 or 6 numbers, mm [+ Euler degrees]) and a rotation block.
  bool pose(const Block& loc, const Block& rot, DtrackBody& b, std::string_view key) {
    bool ok = true;
    for (int k = 0; k < 3; ++k) {
      const double v = loc.v[static_cast<std::size_t>(k)];
      if (std::abs(v) > kMaxPositionMm) {
        fail(line_, fmt::format("{}.position", key), fmt::format("must be within ±{} mm, found {}", kMaxPositionMm, v));
        ok = false;
        break;
      }
      b.position_m[static_cast<std::size_t>(k)] = v * 1e-3;
    }
    if (loc.count >= 6) {
      for (int k = 3; k < 6; ++k)
        if (std::abs(loc.v[static_cast<std::size_t>(k)]) > 360.0) {
          fail(line_, fmt::format("{}.angles", key),
               fmt::format("Euler angles must be within ±360°, found {}", loc.v[static_cast<std::size_t>(k)]));
          ok = false;
          break;
        }
    }
    // Column-wise on the wire: b[col * 3 + row] -> R[row * 3 + col].
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r)
        b.rotation[static_cast<std::size_t>(r * 3 + c)] = rot.v[static_cast<std::size_t>(c * 3 + r)];
    if (!b.tracked()) {
      b.rotation = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // DTrack sends zeros for bodies it does not see
      return ok;
    }
    // R·Rᵀ = I within what 6 decimals allow (with margin), det +1.
    const auto& R = b.rotation;
    double worst = 0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        double d = 0;
        for (int k = 0; k < 3; ++k) d += R[static_cast<std::size_t>(i * 3 + k)] * R[static_cast<std::size_t>(j * 3 + k)];
        worst = std::max(worst, std::abs(d - (i == j ? 1.0 : 0.0)));
      }
    const double det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) +
                       R[2] * (R[3] * R[7] - R[4] * R[6]);
    if (worst > 1e-3 || det < 0) {
      fail(line_, fmt::format("{}.rotation", key),
           fmt::format("not a rotation matrix (|R·Rᵀ - I| = {:.3g}, det {:.3g})", worst, det));
      ok = false;
    }
    return ok;
  }

  /// The count after a line id; nullopt when missing or out of range.
  std::optional<int> count(std::string_view key, int max) {
    const std::string_view tok = word();
    if (tok.empty()) {
      fail(line_, key, "missing the count");
      return std::nullopt;
    }
    const auto n = integer(tok, key, 0, max);
    if (!n) return std::nullopt;
    return static_cast<int>(*n);
  }
  /// Items announced but not there: a cut line.
  void short_count(std::string_view key, int announced, int found) {
    fail(line_, key, fmt::format("cut short: {} announced, {} found", announced, found));
  }

  void sixd() {
    if (!once(seen_6d_, "6d")) return;
    const auto n = count("6d", kDtrackMaxBodies);
    if (!n) return;
    std::bitset<kDtrackMaxBodies> ids;
    Block head, loc, rot;
    for (int i = 0; i < *n; ++i) {
      const std::string key = fmt::format("6d[{}]", i);
      if (at_end()) return short_count("6d", *n, i);
      bool ok = true;
      if (!block(head, key, 2, ok) || !block(loc, key, 3, ok) || !block(rot, key, 9, ok)) return;
      if (!ok) continue;
      if (!check_int(head.v[0], key + ".id", 0, kDtrackMaxBodies - 1)) continue;
      DtrackBody b;
      b.id = static_cast<std::int32_t>(head.v[0]);
      b.quality = head.v[1];
      if (b.quality < -1 || b.quality > 1) {
        fail(line_, key + ".quality", fmt::format("must be in [-1, 1], found {}", b.quality));
        continue;
      }
      if (ids.test(static_cast<std::size_t>(b.id))) {
        fail(line_, key + ".id", fmt::format("body {} twice in the line", b.id));
        continue;
      }
      ids.set(static_cast<std::size_t>(b.id));
      if (!pose(loc, rot, b, key)) continue;
      f_.bodies.push_back(b);
    }
    trailing("6d", *n);
  }

  void flystick(bool v2) {
    const std::string_view name = v2 ? "6df2" : "6df";
    if (!once(v2 ? seen_6df2_ : seen_6df_, name)) return;
    int defined = kDtrackMaxBodies;
    if (v2) {
      const auto d = count(name, kDtrackMaxBodies);
      if (!d) return;
      defined = *d;
    }
    const auto n = count(name, defined);
    if (!n) return;
    if (!v2) flysticks_6df_ = *n;
    std::bitset<kDtrackMaxBodies> ids;
    Block head, loc, rot, extra;
    for (int i = 0; i < *n; ++i) {
      const std::string key = fmt::format("{}[{}]", name, i);
      if (at_end()) return short_count(name, *n, i);
      bool ok = true;
      if (!block(head, key, v2 ? 4 : 3, ok) || !block(loc, key, 3, ok) || !block(rot, key, 9, ok)) return;
      DtrackFlystick fs;
      int words = 0;
      if (v2 && ok) {
        if (!check_int(head.v[2], key + ".buttons", 0, 64) || !check_int(head.v[3], key + ".joysticks", 0, 8)) {
          ok = false;
        } else {
          fs.button_count = static_cast<std::int32_t>(head.v[2]);
          fs.joystick_count = static_cast<std::int32_t>(head.v[3]);
          words = (fs.button_count + 31) / 32;
        }
      }
      if (v2) {
        // The buttons-and-controllers block follows even when the counts were bad: read it to
        // stay in step with the line.
        if (!block(extra, key, ok ? words + fs.joystick_count : 0, ok)) return;
      }
      if (!ok) continue;
      if (!check_int(head.v[0], key + ".id", 0, defined - 1)) continue;
      fs.pose.id = static_cast<std::int32_t>(head.v[0]);
      fs.pose.quality = head.v[1];
      if (fs.pose.quality < -1 || fs.pose.quality > 1) {
        fail(line_, key + ".quality", fmt::format("must be in [-1, 1], found {}", fs.pose.quality));
        continue;
      }
      if (ids.test(static_cast<std::size_t>(fs.pose.id))) {
        fail(line_, key + ".id", fmt::format("Flystick {} twice in the line", fs.pose.id));
        continue;
      }
      ids.set(static_cast<std::size_t>(fs.pose.id));
      if (!v2) {
        if (!check_int(head.v[2], key + ".buttons", 0, 255)) continue;
        fs.button_count = 8;
        fs.buttons = static_cast<std::uint64_t>(head.v[2]);
      } else {
        bool good = true;
        for (int w = 0; w < words && good; ++w) {
          good = check_int(extra.v[static_cast<std::size_t>(w)], key + ".buttons", 0, 0xffffffffLL);
          if (good) fs.buttons |= static_cast<std::uint64_t>(extra.v[static_cast<std::size_t>(w)]) << (32 * w);
        }
        for (int j = 0; j < fs.joystick_count && good; ++j) {
          const double v = extra.v[static_cast<std::size_t>(words + j)];
          if (std::abs(v) > 1.0 + 1e-9) {
            fail(line_, key + ".joysticks", fmt::format("must be in [-1, 1], found {}", v));
            good = false;
          }
          fs.joysticks[static_cast<std::size_t>(j)] = v;
        }
        if (!good) continue;
        if (fs.button_count < 64) fs.buttons &= (std::uint64_t{1} << fs.button_count) - 1;
      }
      if (!pose(loc, rot, fs.pose, key)) continue;
      f_.flysticks.push_back(fs);
    }
    trailing(name, *n);
  }

  void markers() {
    if (!once(seen_3d_, "3d")) return;
    const auto n = count("3d", kDtrackMaxMarkers);
    if (!n) return;
    Block head, loc;
    for (int i = 0; i < *n; ++i) {
      const std::string key = fmt::format("3d[{}]", i);
      if (at_end()) return short_count("3d", *n, i);
      bool ok = true;
      if (!block(head, key, 2, ok) || !block(loc, key, 3, ok)) return;
      if (!ok) continue;
      if (!check_int(head.v[0], key + ".id", 0, 2147483647)) continue;
      DtrackMarker m;
      m.id = static_cast<std::int32_t>(head.v[0]);
      m.quality = head.v[1];
      bool good = true;
      for (int k = 0; k < 3 && good; ++k) {
        const double v = loc.v[static_cast<std::size_t>(k)];
        if (std::abs(v) > kMaxPositionMm) {
          fail(line_, key + ".position", fmt::format("must be within ±{} mm, found {}", kMaxPositionMm, v));
          good = false;
        }
        m.position_m[static_cast<std::size_t>(k)] = v * 1e-3;
      }
      if (good) f_.markers.push_back(m);
    }
    trailing("3d", *n);
  }

  DtrackFrame& f_;
  std::string_view s_;
  std::size_t pos_ = 0;
  int line_ = 0;
  int cal_ = -1;
  int flysticks_6df_ = 0;
  bool seen_fr_ = false, seen_ts_ = false, seen_ts2_ = false, seen_cal_ = false, seen_6d_ = false,
       seen_6df_ = false, seen_6df2_ = false, seen_3d_ = false;
};

}  // namespace

void parse_dtrack(std::string_view packet, DtrackFrame& out) {
  out.clear();
  Parser(out).packet(packet);
}

DtrackFrame parse_dtrack(std::string_view packet) {
  DtrackFrame f;
  parse_dtrack(packet, f);
  return f;
}

}  // namespace kumite::tracking
