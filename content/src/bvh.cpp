#include "kumite/content/bvh.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>

#include <fmt/format.h>

#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/canonical.hpp"
#include "text.hpp"

namespace kumite::content {

namespace {

// Limits that keep hostile input from exhausting memory or producing inf in FK.
constexpr int kMaxJoints = 4096;
constexpr double kMaxAbsValue = 1e7;  // file units or degrees; mocap values are far below

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }

using detail::lower;

/// Whitespace-separated tokens; '{' and '}' are tokens of their own. Tracks the line.
class Lexer {
 public:
  Lexer(std::string_view text, std::string_view source) : text_(text), source_(source) {
    if (text_.substr(0, 3) == "\xEF\xBB\xBF") pos_ = 3;  // UTF-8 byte-order mark
  }

  /// Next token, or "" at the end of the text.
  std::string_view next() {
    skip_space();
    token_line_ = line_;
    if (pos_ >= text_.size()) return {};
    const std::size_t start = pos_;
    if (text_[pos_] == '{' || text_[pos_] == '}') return text_.substr(pos_++, 1);
    while (pos_ < text_.size() && !is_space(text_[pos_]) && text_[pos_] != '{' && text_[pos_] != '}') ++pos_;
    return text_.substr(start, pos_ - start);
  }

  std::string_view expect_any(std::string_view what, std::string_view key = "") {
    const auto t = next();
    if (t.empty()) fail("truncated", key, fmt::format("unexpected end of file, expected {}", what));
    return t;
  }

  void expect(std::string_view word, std::string_view key) {
    const auto t = expect_any(fmt::format("'{}'", word), key);
    if (lower(t) != lower(word)) fail("parse", key, fmt::format("expected '{}', found '{}'", word, printable(t)));
  }

  double number(std::string_view key) {
    const auto t = expect_any("a number");
    return parse_number(t, key);
  }

  double parse_number(std::string_view t, std::string_view key) const {
    double v = 0;
    if (!to_double(t, v)) fail("parse", key, fmt::format("expected a number, found '{}'", printable(t)));
    if (!std::isfinite(v)) fail("not_finite", key, fmt::format("value '{}' is not finite", printable(t)));
    if (std::abs(v) > kMaxAbsValue) fail("range", key, fmt::format("value {} is out of range", printable(t)));
    return v;
  }

  static bool to_double(std::string_view t, double& v) {
    if (!t.empty() && t.front() == '+') t.remove_prefix(1);
    const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
    return ec == std::errc() && ptr == t.data() + t.size() && !t.empty();
  }

  [[noreturn]] void fail(std::string_view code, std::string_view key, std::string_view msg) const {
    throw file_error("bvh", code, source_, token_line_, key, msg);
  }
  [[noreturn]] void fail_at(int line, std::string_view code, std::string_view key, std::string_view msg) const {
    throw file_error("bvh", code, source_, line, key, msg);
  }

  static std::string printable(std::string_view t) {
    std::string out;
    for (char c : t.substr(0, 40)) out += (std::isprint(static_cast<unsigned char>(c)) ? c : '?');
    if (t.size() > 40) out += "...";
    return out;
  }

  /// Moves to the start of the next line (after the current token).
  void skip_rest_of_line() {
    while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
    if (pos_ < text_.size()) {
      ++pos_;
      ++line_;
    }
  }

  /// The next raw line (without its terminator); false at the end of the text.
  bool raw_line(std::string_view& out, int& line) {
    if (pos_ >= text_.size()) return false;
    const std::size_t start = pos_;
    while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
    out = text_.substr(start, pos_ - start);
    line = line_;
    if (pos_ < text_.size()) {
      ++pos_;
      ++line_;
    }
    return true;
  }

  int line() const { return line_; }
  int token_line() const { return token_line_; }
  std::string_view source() const { return source_; }

 private:
  void skip_space() {
    while (pos_ < text_.size() && is_space(text_[pos_])) {
      if (text_[pos_] == '\n') ++line_;
      ++pos_;
    }
  }

  std::string_view text_;
  std::string_view source_;
  std::size_t pos_ = 0;
  int line_ = 1;
  int token_line_ = 1;
};

/// One letter per channel (see Skeleton::channels) or 0 when `t` is no channel name.
char channel_code(std::string_view t) {
  const std::string l = lower(t);
  if (l.size() != 9) return 0;
  const char axis = l[0];
  if (axis != 'x' && axis != 'y' && axis != 'z') return 0;
  if (l.substr(1) == "position") return static_cast<char>(std::toupper(axis));
  if (l.substr(1) == "rotation") return axis;
  return 0;
}

std::string_view channel_name(char code) {
  switch (code) {
    case 'X': return "Xposition";
    case 'Y': return "Yposition";
    case 'Z': return "Zposition";
    case 'x': return "Xrotation";
    case 'y': return "Yrotation";
    case 'z': return "Zrotation";
    default: return "?";
  }
}

Eigen::Vector3d axis_of(char code) {
  switch (code) {
    case 'x': case 'X': return Eigen::Vector3d::UnitX();
    case 'y': case 'Y': return Eigen::Vector3d::UnitY();
    default: return Eigen::Vector3d::UnitZ();
  }
}

int axis_index(char code) { return code == 'x' || code == 'X' ? 0 : (code == 'y' || code == 'Y' ? 1 : 2); }

struct RawSkeleton {
  Skeleton s;              // offsets in file units
  std::vector<int> first;  // index of each joint's first channel in a frame line
  int channel_total = 0;
};

void add_joint(RawSkeleton& raw, std::string name, int parent, bool end_site) {
  raw.s.names.push_back(std::move(name));
  raw.s.parents.push_back(parent);
  raw.s.offsets.emplace_back(Eigen::Vector3d::Zero());
  raw.s.end_site.push_back(end_site);
  raw.s.channels.emplace_back();
  raw.first.push_back(raw.channel_total);
}

std::string read_joint_name(Lexer& lx) {
  // Names are usually one token; tolerate names with spaces by joining up to the '{'.
  std::string name;
  for (;;) {
    const auto t = lx.expect_any("a joint name and '{'");
    if (t == "{") break;
    if (t == "}") lx.fail("parse", "JOINT", "expected a joint name, found '}'");
    if (!name.empty()) name += ' ';
    name += t;
    if (name.size() > 256) lx.fail("parse", "JOINT", "joint name too long");
  }
  if (name.empty()) lx.fail("parse", "JOINT", "missing joint name");
  return name;
}

void read_offset(Lexer& lx, RawSkeleton& raw, int joint) {
  lx.expect("OFFSET", raw.s.names[static_cast<std::size_t>(joint)]);
  Eigen::Vector3d o;
  for (int k = 0; k < 3; ++k) o[k] = lx.number("OFFSET");
  raw.s.offsets[static_cast<std::size_t>(joint)] = o;
}

void read_channels(Lexer& lx, RawSkeleton& raw, int joint) {
  const auto count_tok = lx.expect_any("the channel count");
  const double count_d = lx.parse_number(count_tok, "CHANNELS");
  if (count_d != std::floor(count_d) || count_d < 0 || count_d > 6) {
    lx.fail("channels", "CHANNELS", fmt::format("channel count must be 0..6, found '{}'", Lexer::printable(count_tok)));
  }
  const int count = static_cast<int>(count_d);
  std::string codes;
  for (int k = 0; k < count; ++k) {
    const auto t = lx.expect_any("a channel name");
    const char c = channel_code(t);
    if (c == 0) {
      lx.fail("channels", "CHANNELS",
              fmt::format("CHANNELS {} but '{}' after {} channel name(s)", count, Lexer::printable(t), k));
    }
    if (codes.find(c) != std::string::npos) {
      lx.fail("channels", "CHANNELS", fmt::format("channel '{}' appears twice", channel_name(c)));
    }
    codes += c;
  }
  raw.s.channels[static_cast<std::size_t>(joint)] = codes;
  raw.channel_total += count;
}

/// HIERARCHY ... up to (not including) MOTION. Iterative, so deep nesting cannot overflow.
RawSkeleton read_hierarchy(Lexer& lx) {
  RawSkeleton raw;
  lx.expect("HIERARCHY", "HIERARCHY");
  lx.expect("ROOT", "ROOT");
  add_joint(raw, read_joint_name(lx), -1, false);
  read_offset(lx, raw, 0);
  std::vector<int> stack{0};
  bool expect_channels = true;
  while (!stack.empty()) {
    const auto t = lx.expect_any("'JOINT', 'End Site' or '}'");
    const std::string word = lower(t);
    const int current = stack.back();
    if (word == "channels") {
      if (!expect_channels) lx.fail("parse", "CHANNELS", "CHANNELS must follow the joint's OFFSET");
      read_channels(lx, raw, current);
      expect_channels = false;
      continue;
    }
    expect_channels = false;
    if (word == "joint") {
      if (raw.s.names.size() >= static_cast<std::size_t>(kMaxJoints)) lx.fail("range", "JOINT", "too many joints");
      if (raw.s.end_site[static_cast<std::size_t>(current)]) lx.fail("parse", "JOINT", "an End Site cannot have children");
      add_joint(raw, read_joint_name(lx), current, false);
      const int j = raw.s.joint_count() - 1;
      read_offset(lx, raw, j);
      stack.push_back(j);
      expect_channels = true;
    } else if (word == "end") {
      lx.expect("Site", "End Site");
      lx.expect("{", "End Site");
      if (raw.s.names.size() >= static_cast<std::size_t>(kMaxJoints)) lx.fail("range", "End Site", "too many joints");
      add_joint(raw, raw.s.names[static_cast<std::size_t>(current)] + "_end", current, true);
      const int j = raw.s.joint_count() - 1;
      read_offset(lx, raw, j);
      lx.expect("}", "End Site");
    } else if (t == "}") {
      stack.pop_back();
    } else if (word == "root") {
      lx.fail("parse", "ROOT", "a second ROOT is not supported (one skeleton per file)");
    } else {
      lx.fail("parse", "HIERARCHY", fmt::format("unknown token '{}'", Lexer::printable(t)));
    }
  }
  return raw;
}

double rest_extent(const Skeleton& s) {
  std::vector<Eigen::Vector3d> p(s.names.size());
  Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < p.size(); ++i) {
    const int parent = s.parents[i];
    p[i] = parent < 0 ? Eigen::Vector3d::Zero() : Eigen::Vector3d(p[static_cast<std::size_t>(parent)] + s.offsets[i]);
    lo = lo.cwiseMin(p[i]);
    hi = hi.cwiseMax(p[i]);
  }
  return (hi - lo).maxCoeff();
}

std::string stem_of(std::string_view source) {
  return std::filesystem::path(std::string(source)).stem().string();
}

}  // namespace

double guess_bvh_unit_m(double extent, bool humanoid) {
  if (!(extent > 0)) return 0.01;
  if (humanoid) {
    // The unit that makes the body closest to 1.7 m (log scale); inches and CMU ASF units
    // (the cgspeed conversions keep them: 1/0.45 inch) only when no metric unit is near.
    struct Unit { double m; double penalty; };
    constexpr Unit kUnits[] = {{0.01, 0}, {1.0, 0}, {0.001, 0}, {0.0254, 0.5}, {0.0254 / 0.45, 0.5}};
    double best = 0.01, best_cost = 1e300;
    for (const Unit& u : kUnits) {
      const double cost = std::abs(std::log(extent * u.m / 1.7)) + u.penalty;
      if (cost < best_cost) {
        best_cost = cost;
        best = u.m;
      }
    }
    return best;
  }
  if (extent < 5) return 1.0;
  if (extent < 500) return 0.01;
  return 0.001;
}

BvhUnitCheck check_bvh_unit(const Clip& clip, std::string_view source) {
  BvhUnitCheck out;
  if (clip.skeleton.dialect.empty() || !(clip.unit_m > 0)) return out;  // not a recognised humanoid
  const double extent_m = rest_extent(clip.skeleton);                // offsets are metres past the reader
  const double extent_units = extent_m / clip.unit_m;
  if (extent_m < kHumanRestExtentM[0] || extent_m > kHumanRestExtentM[1]) {
    out.plausible = false;
    out.warning = fmt::format(
        "{}: unit_m: rest height {:.4g} file units is not a human's in any unit the reader knows (cm, m, mm, inch, "
        "CMU ASF units); the guess {:.4g} m per unit gives {:.2f} m, outside {:.1f}..{:.1f} m: lengths and speeds "
        "of this clip would be distorted",
        source, extent_units, clip.unit_m, extent_m, kHumanRestExtentM[0], kHumanRestExtentM[1]);
    return out;
  }
  const bool metric = clip.unit_m == 0.01 || clip.unit_m == 1.0 || clip.unit_m == 0.001;
  if (!metric) {
    out.warning = fmt::format(
        "{}: unit_m: rest height {:.4g} file units is a human's in no metric unit; guessed {} ({:.4g} m per unit, "
        "{:.2f} m tall): check the clip is not scaled",
        source, extent_units, std::abs(clip.unit_m - 0.0254) < 1e-12 ? "inches" : "CMU ASF units", clip.unit_m,
        extent_m);
  }
  return out;
}

Clip parse_bvh(std::string_view text, std::string_view source, const BvhReadOptions& options) {
  Lexer lx(text, source);
  RawSkeleton raw = read_hierarchy(lx);

  lx.expect("MOTION", "MOTION");
  // "Frames: N" (also tolerated: "Frames:N").
  std::string_view frames_tok = lx.expect_any("'Frames:'");
  if (lower(frames_tok).rfind("frames:", 0) != 0) {
    lx.fail("parse", "Frames", fmt::format("expected 'Frames:', found '{}'", Lexer::printable(frames_tok)));
  }
  frames_tok.remove_prefix(7);
  if (frames_tok.empty()) frames_tok = lx.expect_any("the frame count");
  const double frames_d = lx.parse_number(frames_tok, "Frames");
  if (frames_d < 0 || frames_d != std::floor(frames_d)) {
    lx.fail("parse", "Frames", fmt::format("frame count must be a whole number >= 0, found '{}'", Lexer::printable(frames_tok)));
  }
  const auto frames = static_cast<long long>(frames_d);
  lx.expect("Frame", "Frame Time");
  std::string_view time_tok = lx.expect_any("'Time:'");
  if (lower(time_tok).rfind("time:", 0) != 0) {
    lx.fail("parse", "Frame Time", fmt::format("expected 'Time:', found '{}'", Lexer::printable(time_tok)));
  }
  time_tok.remove_prefix(5);
  const double frame_time = time_tok.empty() ? lx.number("Frame Time") : lx.parse_number(time_tok, "Frame Time");
  if (!(frame_time > 0)) lx.fail("frame_time", "Frame Time", fmt::format("frame time must be > 0 s, found {}", frame_time));
  if (frame_time > 10) lx.fail("frame_time", "Frame Time", fmt::format("frame time {} s is implausible (> 10 s)", frame_time));
  lx.skip_rest_of_line();

  // Canonical joints first (names and structure only): a recognised humanoid lets the unit
  // be chosen from its body size.
  raw.s.canonical.fill(-1);
  if (options.map_canonical) {
    const auto& dialects = default_dialects();  // a broken dialect file is reported, not hidden
    try {
      raw.s.dialect = content::map_canonical(raw.s, dialects, source);
    } catch (const Error&) {
      raw.s.canonical.fill(-1);  // not a humanoid we recognise: still a valid clip
    }
  }
  Clip clip;
  clip.name = stem_of(source);
  clip.frame_time_s = frame_time;
  const double unit = options.unit_m.value_or(guess_bvh_unit_m(rest_extent(raw.s), !raw.s.dialect.empty()));
  if (!(unit > 0) || !std::isfinite(unit)) throw file_error("bvh", "unit", source, 0, "unit_m", "unit must be > 0");
  clip.unit_m = unit;

  const std::size_t n = raw.s.names.size();
  const auto channels = static_cast<std::size_t>(raw.channel_total);
  std::vector<double> values;
  values.reserve(std::min<std::size_t>(static_cast<std::size_t>(frames) * channels, text.size() / 2 + 16));
  long long read_frames = 0;
  std::string_view line_text;
  int line = 0;
  while (read_frames < frames && lx.raw_line(line_text, line)) {
    std::size_t i = 0;
    std::size_t count = 0;
    const std::size_t before = values.size();
    while (true) {
      while (i < line_text.size() && is_space(line_text[i])) ++i;
      if (i >= line_text.size()) break;
      std::size_t j = i;
      while (j < line_text.size() && !is_space(line_text[j])) ++j;
      const auto tok = line_text.substr(i, j - i);
      ++count;
      if (count > channels) {
        lx.fail_at(line, "channels", fmt::format("frame {}", read_frames),
                   fmt::format("more than the {} values the hierarchy's CHANNELS declare", channels));
      }
      double v = 0;
      if (!Lexer::to_double(tok, v)) {
        lx.fail_at(line, "parse", fmt::format("frame {}", read_frames),
                   fmt::format("expected a number, found '{}'", Lexer::printable(tok)));
      }
      if (!std::isfinite(v)) {
        lx.fail_at(line, "not_finite", fmt::format("frame {}", read_frames),
                   fmt::format("value '{}' is not finite", Lexer::printable(tok)));
      }
      if (std::abs(v) > kMaxAbsValue) {
        lx.fail_at(line, "range", fmt::format("frame {}", read_frames),
                   fmt::format("value {} is out of range", Lexer::printable(tok)));
      }
      values.push_back(v);
      i = j;
    }
    if (count == 0 && channels > 0) continue;  // blank line
    if (count != channels) {
      values.resize(before);
      lx.fail_at(line, "channels", fmt::format("frame {}", read_frames),
                 fmt::format("{} values, but the hierarchy's CHANNELS declare {}", count, channels));
    }
    ++read_frames;
    if (read_frames == frames) break;  // extra lines past Frames: N are ignored, as Blender does
  }
  if (read_frames < frames) {
    lx.fail_at(lx.line(), "truncated", "Frames",
               fmt::format("truncated: Frames: {} but {} frame line(s)", frames, read_frames));
  }

  // Convert to metres and quaternions.
  clip.frame_count = static_cast<int>(frames);
  Skeleton& s = raw.s;
  for (auto& o : s.offsets) o *= unit;
  clip.root_positions.resize(static_cast<std::size_t>(frames));
  clip.local_rotations.resize(static_cast<std::size_t>(frames) * n);
  std::vector<Eigen::Vector3d> translations;
  bool any_inner_position = false;
  for (std::size_t j = 1; j < n; ++j) {
    if (s.channels[j].find_first_of("XYZ") != std::string::npos) any_inner_position = true;
  }
  if (any_inner_position) translations.resize(static_cast<std::size_t>(frames) * n);

  for (std::size_t f = 0; f < static_cast<std::size_t>(frames); ++f) {
    const double* row = values.data() + f * channels;
    for (std::size_t j = 0; j < n; ++j) {
      const std::string& codes = s.channels[j];
      Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
      Eigen::Vector3d t = s.offsets[j];
      const double* v = row + raw.first[j];
      for (std::size_t k = 0; k < codes.size(); ++k) {
        const char c = codes[k];
        if (c >= 'a') {
          q = q * Eigen::Quaterniond(Eigen::AngleAxisd(v[k] * std::numbers::pi / 180.0, axis_of(c)));
        } else {
          t[axis_index(c)] = v[k] * unit;
        }
      }
      clip.local_rotations[f * n + j] = q.normalized();
      if (j == 0) clip.root_positions[f] = t;
      if (any_inner_position) translations[f * n + j] = t;
    }
  }
  if (any_inner_position && frames > 0) {
    // Constant position channels are just offsets; keep per-frame translations only when
    // some joint really moves.
    bool varies = false;
    for (std::size_t f = 1; f < static_cast<std::size_t>(frames) && !varies; ++f) {
      for (std::size_t j = 1; j < n; ++j) {
        if ((translations[f * n + j] - translations[j]).norm() > 1e-9) {
          varies = true;
          break;
        }
      }
    }
    for (std::size_t j = 1; j < n; ++j) s.offsets[j] = translations[j];
    if (varies) clip.local_translations = std::move(translations);
  }
  clip.skeleton = std::move(s);
  return clip;
}

Clip read_bvh(const std::filesystem::path& path, const BvhReadOptions& options) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw file_error("bvh", "io", path.string(), 0, "", "is a folder, not a file: give a .bvh file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw file_error("bvh", "io", path.string(), 0, "", "cannot open file");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw file_error("bvh", "io", path.string(), 0, "", "read error");
  return parse_bvh(ss.str(), path.string(), options);
}

namespace {

std::string default_channels(const Skeleton& s, std::size_t j) {
  if (s.end_site[j]) return "";
  return s.parents[j] < 0 ? "XYZzyx" : "zyx";
}

double wrap_near(double a, double ref) {
  const double two_pi = 2 * std::numbers::pi;
  return a - two_pi * std::round((a - ref) / two_pi);
}

/// Euler angles (radians) about `axes` (three distinct rotation codes) with
/// R = R(axes[0], a0) R(axes[1], a1) R(axes[2], a2), the solution nearest to `prev`.
Eigen::Vector3d decompose(const Eigen::Quaterniond& q, const std::array<char, 3>& axes, const Eigen::Vector3d& prev) {
  const Eigen::Matrix3d m = q.toRotationMatrix();
  const Eigen::Vector3d e = m.eulerAngles(axis_index(axes[0]), axis_index(axes[1]), axis_index(axes[2]));
  const Eigen::Vector3d alt(e[0] + std::numbers::pi, std::numbers::pi - e[1], e[2] + std::numbers::pi);
  auto rebuild = [&](const Eigen::Vector3d& a) {
    return (Eigen::AngleAxisd(a[0], axis_of(axes[0])) * Eigen::AngleAxisd(a[1], axis_of(axes[1])) *
            Eigen::AngleAxisd(a[2], axis_of(axes[2]))).toRotationMatrix();
  };
  Eigen::Vector3d best = e;
  double best_d = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& cand : {e, alt}) {
    if ((rebuild(cand) - m).norm() > 1e-6) continue;
    Eigen::Vector3d w;
    for (int k = 0; k < 3; ++k) w[k] = wrap_near(cand[k], prev[k]);
    const double d = (w - prev).squaredNorm();
    if (d < best_d) {
      best_d = d;
      best = w;
    }
  }
  return best;
}

}  // namespace

std::string format_bvh(const Clip& clip) {
  const Skeleton& s = clip.skeleton;
  const std::size_t n = s.names.size();
  if (n == 0) throw Error("bvh", "empty", "format_bvh: clip '" + clip.name + "' has no joints");
  const double unit = clip.unit_m > 0 ? clip.unit_m : 0.01;
  std::vector<std::string> chans(n);
  for (std::size_t j = 0; j < n; ++j) {
    chans[j] = j < s.channels.size() ? s.channels[j] : default_channels(s, j);
    if (s.end_site[j]) chans[j].clear();
  }
  // The root must carry its motion: add position channels when it moves and has none.
  if (chans[0].find_first_of("XYZ") == std::string::npos) {
    bool moves = false;
    for (const auto& p : clip.root_positions) moves = moves || (p - s.offsets[0]).norm() > 1e-12;
    if (moves) chans[0] = "XYZ" + chans[0];
  }
  // Joints with per-frame translations need position channels too.
  if (!clip.local_translations.empty()) {
    for (std::size_t j = 1; j < n; ++j) {
      if (s.end_site[j] || chans[j].find_first_of("XYZ") != std::string::npos) continue;
      for (int f = 0; f < clip.frame_count; ++f) {
        if ((clip.local_translations[static_cast<std::size_t>(f) * n + j] - s.offsets[j]).norm() > 1e-12) {
          chans[j] = "XYZ" + chans[j];
          break;
        }
      }
    }
  }

  std::string out;
  out.reserve(4096 + static_cast<std::size_t>(clip.frame_count) * n * 30);
  auto indent = [&](int depth) { out.append(static_cast<std::size_t>(depth), '\t'); };
  // Children lists (parents-first order means a DFS in index order reproduces the file).
  std::vector<std::vector<std::size_t>> children(n);
  for (std::size_t j = 1; j < n; ++j) children[static_cast<std::size_t>(s.parents[j])].push_back(j);

  out += "HIERARCHY\n";
  struct Item { std::size_t joint; int depth; bool close; };
  std::vector<Item> stack{{0, 0, false}};
  std::vector<std::size_t> order;  // joints with channels, in file order
  while (!stack.empty()) {
    const Item it = stack.back();
    stack.pop_back();
    if (it.close) {
      indent(it.depth);
      out += "}\n";
      continue;
    }
    const std::size_t j = it.joint;
    const Eigen::Vector3d o = s.offsets[j] / unit;
    indent(it.depth);
    if (s.end_site[j]) {
      out += "End Site\n";
    } else {
      out += (s.parents[j] < 0 ? "ROOT " : "JOINT ") + s.names[j] + "\n";
    }
    indent(it.depth);
    out += "{\n";
    indent(it.depth + 1);
    out += fmt::format("OFFSET {:.6f} {:.6f} {:.6f}\n", o.x() + 0.0, o.y() + 0.0, o.z() + 0.0);
    if (!s.end_site[j]) {
      indent(it.depth + 1);
      out += fmt::format("CHANNELS {}", chans[j].size());
      for (char c : chans[j]) out += fmt::format(" {}", channel_name(c));
      out += "\n";
      order.push_back(j);
    }
    stack.push_back({j, it.depth, true});
    for (auto c = children[j].rbegin(); c != children[j].rend(); ++c) stack.push_back({*c, it.depth + 1, false});
  }
  out += "MOTION\n";
  out += fmt::format("Frames: {}\n", clip.frame_count);
  out += fmt::format("Frame Time: {:.9g}\n", clip.frame_time_s);

  std::vector<Eigen::Vector3d> prev(n, Eigen::Vector3d::Zero());  // radians, per joint
  for (int f = 0; f < clip.frame_count; ++f) {
    const auto rot = clip.rotations(f);
    bool first_value = true;
    for (const std::size_t j : order) {
      const std::string& codes = chans[j];
      Eigen::Vector3d t = s.offsets[j];
      if (j == 0) t = clip.root_positions[static_cast<std::size_t>(f)];
      else if (!clip.local_translations.empty()) t = clip.local_translations[static_cast<std::size_t>(f) * n + j];
      // Rotation axes in file order, completed with the missing ones (whose angles are ~0
      // when the rotation came from those channels).
      std::array<char, 3> axes{};
      int na = 0;
      for (char c : codes) if (c >= 'a') axes[static_cast<std::size_t>(na++)] = c;
      const int given = na;
      for (char c : {'x', 'y', 'z'}) {
        if (std::find(axes.begin(), axes.begin() + na, c) == axes.begin() + na) axes[static_cast<std::size_t>(na++)] = c;
      }
      Eigen::Vector3d angles = Eigen::Vector3d::Zero();
      if (given > 0) {
        angles = decompose(rot[j], axes, prev[j]);
        prev[j] = angles;
      }
      for (char c : codes) {
        double v = 0;
        if (c >= 'a') {
          const auto k = static_cast<int>(std::find(axes.begin(), axes.end(), c) - axes.begin());
          v = angles[k] * 180.0 / std::numbers::pi;
        } else {
          v = t[axis_index(c)] / unit;
        }
        if (!first_value) out += ' ';
        first_value = false;
        fmt::format_to(std::back_inserter(out), "{:.6f}", v + 0.0);  // + 0.0: no "-0"
      }
    }
    out += '\n';
  }
  return out;
}

void write_bvh(const std::filesystem::path& path, const Clip& clip) {
  write_file_atomically(path, format_bvh(clip));
}

}  // namespace kumite::content
