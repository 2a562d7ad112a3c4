#include "kumite/content/annotation.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <tuple>

#include <fmt/format.h>

#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/bvh.hpp"
#include "kumite/content/canonical.hpp"
#include "kumite/content/proportions.hpp"
#include "toml_string.hpp"

namespace kumite::content {

namespace {
constexpr std::array<std::string_view, 6> kSemantics = {"punch", "kick", "block", "walk", "rest", "other"};
constexpr std::array<std::string_view, 4> kSegments = {"left_hand", "right_hand", "left_foot", "right_foot"};
constexpr std::array<std::string_view, 3> kHeights = {"low", "mid", "high"};
constexpr std::array<std::string_view, 2> kForearms = {"left", "right"};
}  // namespace

std::string_view to_string(Forearm f) { return kForearms[static_cast<std::size_t>(f)]; }
std::optional<Forearm> forearm_from_string(std::string_view s) {
  for (std::size_t i = 0; i < kForearms.size(); ++i) {
    if (kForearms[i] == s) return static_cast<Forearm>(i);
  }
  return std::nullopt;
}

std::string_view to_string(StrikeHeight h) { return kHeights[static_cast<std::size_t>(h)]; }
std::optional<StrikeHeight> strike_height_from_string(std::string_view s) {
  for (std::size_t i = 0; i < kHeights.size(); ++i) {
    if (kHeights[i] == s) return static_cast<StrikeHeight>(i);
  }
  return std::nullopt;
}

StrikeHeight classify_strike_height(double hit_height_m, double stature_m, const StrikeHeightThresholds& t) {
  if (!(stature_m > 0)) throw Error("annotation", "stature", fmt::format("stature {} m must be > 0", stature_m));
  const double r = hit_height_m / stature_m;
  if (r < t.low_below) return StrikeHeight::low;
  if (r >= t.high_from) return StrikeHeight::high;
  return StrikeHeight::mid;
}

std::string_view to_string(Semantics s) { return kSemantics[static_cast<std::size_t>(s)]; }
std::string_view to_string(HitSegment s) { return kSegments[static_cast<std::size_t>(s)]; }

std::optional<Semantics> semantics_from_string(std::string_view s) {
  for (std::size_t i = 0; i < kSemantics.size(); ++i) {
    if (kSemantics[i] == s) return static_cast<Semantics>(i);
  }
  return std::nullopt;
}
std::optional<HitSegment> hit_segment_from_string(std::string_view s) {
  for (std::size_t i = 0; i < kSegments.size(); ++i) {
    if (kSegments[i] == s) return static_cast<HitSegment>(i);
  }
  return std::nullopt;
}

bool is_left(HitSegment s) { return s == HitSegment::left_hand || s == HitSegment::left_foot; }
bool is_hand(HitSegment s) { return s == HitSegment::left_hand || s == HitSegment::right_hand; }

CanonicalJoint hit_joint(HitSegment s) {
  using CJ = CanonicalJoint;
  switch (s) {
    case HitSegment::left_hand: return CJ::l_wrist;
    case HitSegment::right_hand: return CJ::r_wrist;
    case HitSegment::left_foot: return CJ::l_ankle;
    case HitSegment::right_foot: return CJ::r_ankle;
  }
  return CJ::r_wrist;
}

CanonicalJoint limb_root(HitSegment s) {
  using CJ = CanonicalJoint;
  switch (s) {
    case HitSegment::left_hand: return CJ::l_shoulder;
    case HitSegment::right_hand: return CJ::r_shoulder;
    case HitSegment::left_foot: return CJ::l_hip;
    case HitSegment::right_foot: return CJ::r_hip;
  }
  return CJ::r_shoulder;
}

std::filesystem::path AnnotationSet::resolve(const ClipAnnotation& clip) const {
  const std::filesystem::path p(clip.file);
  if (p.is_absolute() || source.empty()) return p;
  return source.parent_path() / p;
}

// ---- Writing -------------------------------------------------------------------------------

std::string toml_string(std::string_view s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (c == '\n') {
      out += "\\n";
    } else if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {  // TOML refuses them raw
      out += fmt::format("\\u{:04x}", static_cast<int>(c));
    } else {
      out += c;
    }
  }
  return out + "\"";
}

std::string toml_number(double v) {
  std::string s = fmt::format("{}", v);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

std::string format_annotations(const AnnotationSet& set) {
  std::string out;
  out += "# Kumite motion annotations (see content/include/kumite/content/annotation.hpp).\n";
  out += "# frames = [first, last]: 0-based BVH motion frames, inclusive. hit_frame: contact frame.\n";
  out += "# semantics: punch | kick | block | walk | rest | other; hit_segment (strikes only):\n";
  out += "# left_hand | right_hand | left_foot | right_foot (hit point = wrist / ankle joint).\n";
  out += "# height (strikes, optional): low | mid | high, the hit point above the floor at hit_frame\n";
  out += "# relative to the actor's stature (low < 0.55, high >= 0.81; content/README.md); blocks: what it guards.\n";
  out += "# forearm (blocks): left | right; intercept_frames = [a, b] (blocks): the forearm in place.\n";
  out += "# A block with forearm, intercept_frames and height goes into the database; one with none is left out.\n";
  out += "# peak_speed_mps (m/s) and extension (1 = limb straight) are informational.\n";
  out += "# repair_frames = [a, b] (optional): frames where the capture glitched, rebuilt at build time by\n";
  out += "# interpolating each joint between frames a - 1 and b + 1 (inside the segment, at most 8 frames).\n";
  out += "# unit_m (clips, optional): metres per file unit, instead of the guess from the rest pose.\n";
  out += fmt::format("version = {}\n", set.version);
  for (const ClipAnnotation& c : set.clips) {
    out += "\n[[clip]]\n";
    out += fmt::format("file = {}\n", toml_string(c.file));
    out += fmt::format("name = {}\n", toml_string(c.name));
    out += fmt::format("mirror = {}\n", c.mirror ? "true" : "false");
    if (c.unit_m) out += fmt::format("unit_m = {}\n", toml_number(*c.unit_m));
    for (const MotionAnnotation& m : c.motions) {
      out += "\n[[clip.motion]]\n";
      out += fmt::format("name = {}\n", toml_string(m.name));
      out += fmt::format("semantics = \"{}\"\n", to_string(m.semantics));
      out += fmt::format("frames = [{}, {}]\n", m.first_frame, m.last_frame);
      if (m.hit_segment) out += fmt::format("hit_segment = \"{}\"\n", to_string(*m.hit_segment));
      if (m.hit_frame) out += fmt::format("hit_frame = {}\n", *m.hit_frame);
      if (m.height) out += fmt::format("height = \"{}\"\n", to_string(*m.height));
      if (m.forearm) out += fmt::format("forearm = \"{}\"\n", to_string(*m.forearm));
      if (m.intercept_frames) out += fmt::format("intercept_frames = [{}, {}]\n", (*m.intercept_frames)[0], (*m.intercept_frames)[1]);
      if (m.repair_frames) out += fmt::format("repair_frames = [{}, {}]\n", (*m.repair_frames)[0], (*m.repair_frames)[1]);
      if (!m.note.empty()) out += fmt::format("note = {}\n", toml_string(m.note));
      // Informational, so rounded for people; a value that rounds to zero is left out as a zero
      // is (found by fuzz_motions: 0.004 m/s was written "0.00", which reads back as none, so a
      // second write differed from the first).
      if (const std::string v = fmt::format("{:.2f}", m.peak_speed_mps); m.peak_speed_mps > 0 && v != "0.00")
        out += "peak_speed_mps = " + v + "\n";
      if (const std::string v = fmt::format("{:.3f}", m.extension); m.extension > 0 && v != "0.000")
        out += "extension = " + v + "\n";
    }
  }
  return out;
}

void write_annotations(const std::filesystem::path& path, const AnnotationSet& set) {
  write_file_atomically(path, format_annotations(set));
}

// ---- Validation against clips ---------------------------------------------------------------

void validate_annotations(const AnnotationSet& set, std::size_t clip_index, const Clip& clip) {
  const ClipAnnotation& c = set.clips.at(clip_index);
  const std::string file = set.source.empty() ? std::string("<annotations>") : set.source.string();
  const int last = clip.frame_count - 1;
  for (std::size_t i = 0; i < c.motions.size(); ++i) {
    const MotionAnnotation& m = c.motions[i];
    const std::string key = fmt::format("clip[{}].motion[{}]", clip_index, i);
    auto fail = [&](std::string_view field, std::string_view msg) {
      throw file_error("annotation", "range", file, m.line, key + "." + std::string(field), msg);
    };
    if (m.first_frame < 0 || m.last_frame > last) {
      fail("frames", fmt::format("[{}, {}] is outside the clip '{}' (frames 0..{})", m.first_frame, m.last_frame,
                                 c.name, last));
    }
    if (m.hit_frame && (*m.hit_frame < 0 || *m.hit_frame > last)) {
      fail("hit_frame", fmt::format("{} is outside the clip '{}' (frames 0..{})", *m.hit_frame, c.name, last));
    }
    if (m.forearm) {
      const bool left = *m.forearm == Forearm::left;
      for (CanonicalJoint j : {left ? CanonicalJoint::l_elbow : CanonicalJoint::r_elbow,
                               left ? CanonicalJoint::l_wrist : CanonicalJoint::r_wrist}) {
        if (clip.skeleton.index(j) < 0) {
          fail("forearm", fmt::format("{} needs joint {} which the clip '{}' does not map", to_string(*m.forearm),
                                      to_string(j), c.name));
        }
      }
    }
    if (m.hit_segment) {
      const HitSegment h = *m.hit_segment;
      for (CanonicalJoint j : {hit_joint(h), limb_root(h)}) {
        if (clip.skeleton.index(j) < 0) {
          fail("hit_segment", fmt::format("{} needs joint {} which the clip '{}' does not map", to_string(h),
                                          to_string(j), c.name));
        }
      }
    }
  }
}

std::vector<Clip> load_annotated_clips(const AnnotationSet& set) {
  std::vector<Clip> clips;
  clips.reserve(set.clips.size());
  for (std::size_t i = 0; i < set.clips.size(); ++i) {
    const std::filesystem::path path = set.resolve(set.clips[i]);
    if (!std::filesystem::exists(path)) {
      throw file_error("annotation", "missing_file", set.source.string(), set.clips[i].line,
                       fmt::format("clip[{}].file", i), fmt::format("'{}' not found", path.string()));
    }
    BvhReadOptions read_options;
    read_options.unit_m = set.clips[i].unit_m;  // stated: no guess, nothing to check it against
    Clip clip = read_bvh(path, read_options);
    clip.name = set.clips[i].name;
    if (clip.skeleton.dialect.empty()) map_canonical(clip.skeleton, path.string());
    if (const BvhUnitCheck u = check_bvh_unit(clip, path.string()); !set.clips[i].unit_m && !u.plausible) {
      // The database needs true metres: a clip at the wrong scale would retrieve wrong reaches.
      throw file_error("annotation", "unit", set.source.string(), set.clips[i].line, fmt::format("clip[{}].file", i),
                       "refused: " + u.warning + "; if its unit is known, state it in the clip's unit_m (metres per file unit)");
    }
    validate_annotations(set, i, clip);
    clips.push_back(std::move(clip));
  }
  return clips;
}

// ---- The proposer --------------------------------------------------------------------------

namespace {

using CJ = CanonicalJoint;

struct Track {
  std::vector<Eigen::Vector3d> p;  // m, smoothed positions [frame]
  std::vector<double> speed;       // m/s [frame]
};

Track track_of(const std::vector<Eigen::Vector3d>& all, std::size_t n, int joint, int frames, int half, double dt) {
  Track t;
  t.p.resize(static_cast<std::size_t>(frames));
  for (int f = 0; f < frames; ++f) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int count = 0;
    for (int k = std::max(0, f - half); k <= std::min(frames - 1, f + half); ++k) {
      sum += all[static_cast<std::size_t>(k) * n + static_cast<std::size_t>(joint)];
      ++count;
    }
    t.p[static_cast<std::size_t>(f)] = sum / count;
  }
  t.speed.resize(static_cast<std::size_t>(frames));
  for (int f = 0; f < frames; ++f) {
    const int a = std::max(0, f - 1), b = std::min(frames - 1, f + 1);
    t.speed[static_cast<std::size_t>(f)] =
        b > a ? (t.p[static_cast<std::size_t>(b)] - t.p[static_cast<std::size_t>(a)]).norm() / ((b - a) * dt) : 0.0;
  }
  return t;
}

/// Frames f where v[f] >= min and v[f] is the largest value within +-w (first of equal ones).
std::vector<int> peaks(const std::vector<double>& v, double min, int w) {
  std::vector<int> out;
  const int n = static_cast<int>(v.size());
  for (int f = 0; f < n; ++f) {
    if (v[static_cast<std::size_t>(f)] < min) continue;
    bool is_peak = true;
    for (int k = std::max(0, f - w); k <= std::min(n - 1, f + w) && is_peak; ++k) {
      const double o = v[static_cast<std::size_t>(k)], x = v[static_cast<std::size_t>(f)];
      if (o > x || (o == x && k < f)) is_peak = false;
    }
    if (is_peak) out.push_back(f);
  }
  return out;
}

double max_in(const std::vector<double>& v, int a, int b, int* at = nullptr) {
  a = std::max(a, 0);
  b = std::min(b, static_cast<int>(v.size()) - 1);
  double m = -1e300;
  for (int f = a; f <= b; ++f) {
    if (v[static_cast<std::size_t>(f)] > m) {
      m = v[static_cast<std::size_t>(f)];
      if (at) *at = f;
    }
  }
  return m;
}

/// [first, last] around `hit`: from where the hit point's speed rises above `frac` of its
/// approach peak to where the return motion has slowed below it again.
std::pair<int, int> bounds(const std::vector<double>& speed, int hit, int approach, int max_half, double frac) {
  const int n = static_cast<int>(speed.size());
  int at = hit;
  const double vp = max_in(speed, hit - approach, hit, &at);
  const double low = frac * vp;
  int first = at;
  while (first > 0 && first > hit - max_half && speed[static_cast<std::size_t>(first - 1)] >= low) --first;
  int ret = hit;
  max_in(speed, hit, hit + approach, &ret);
  int last = std::max(ret, hit);
  while (last < n - 1 && last < hit + max_half && speed[static_cast<std::size_t>(last + 1)] >= low) ++last;
  return {first, std::max(last, hit)};
}

struct Found {
  MotionAnnotation m;
  std::string kind;  // for naming: "punch_left", "kick_right", "rest", ...
};

bool overlaps(const MotionAnnotation& a, int first, int last) { return a.first_frame <= last && first <= a.last_frame; }

/// Runs of consecutive true frames at least `min_len` long, as [first, last].
std::vector<std::pair<int, int>> runs(const std::vector<bool>& ok, int min_len) {
  std::vector<std::pair<int, int>> out;
  const int n = static_cast<int>(ok.size());
  for (int f = 0; f < n;) {
    if (!ok[static_cast<std::size_t>(f)]) {
      ++f;
      continue;
    }
    int g = f;
    while (g + 1 < n && ok[static_cast<std::size_t>(g + 1)]) ++g;
    if (g - f + 1 >= min_len) out.emplace_back(f, g);
    f = g + 1;
  }
  return out;
}

}  // namespace

ClipAnnotation propose_annotations(const Clip& clip, std::string file, const ProposerSettings& cfg) {
  const Skeleton& s = clip.skeleton;
  for (CJ c : {CJ::pelvis, CJ::l_wrist, CJ::r_wrist, CJ::l_ankle, CJ::r_ankle, CJ::l_shoulder, CJ::r_shoulder,
               CJ::l_hip, CJ::r_hip}) {
    if (s.index(c) < 0) {
      throw Error("annotation", "canonical",
                  fmt::format("{}: canonical joint {} not mapped; cannot propose annotations", clip.name, to_string(c)));
    }
  }
  ClipAnnotation out;
  out.file = std::move(file);
  out.name = clip.name;
  const int frames = clip.frame_count;
  if (frames < 3) return out;
  const double dt = clip.frame_time_s;
  const auto n = static_cast<std::size_t>(s.joint_count());
  const auto all = all_joint_positions(clip);
  const int half = std::max(0, static_cast<int>(std::lround(cfg.smoothing_s / dt / 2)));
  auto track = [&](CJ c) { return track_of(all, n, s.index(c), frames, half, dt); };
  auto frames_of = [&](double seconds) { return std::max(1, static_cast<int>(std::lround(seconds / dt))); };
  const int W = frames_of(cfg.peak_window_s), A = frames_of(cfg.approach_s), H = frames_of(cfg.max_half_window_s);

  const Proportions body = measure_proportions(s);
  const Track pelvis = track(CJ::pelvis);
  double floor_y = 1e300;
  for (CJ c : {CJ::l_toe, CJ::r_toe, CJ::l_ankle, CJ::r_ankle}) {
    if (s.index(c) < 0) continue;
    for (int f = 0; f < frames; ++f) {
      floor_y = std::min(floor_y, all[static_cast<std::size_t>(f) * n + static_cast<std::size_t>(s.index(c))].y());
    }
  }
  std::vector<Found> strikes;

  // Kicks: the ankle high above the floor at a local maximum, reached fast, the leg extended.
  for (HitSegment seg : {HitSegment::left_foot, HitSegment::right_foot}) {
    const Track ankle = track(hit_joint(seg));
    const Track hip = track(limb_root(seg));
    std::vector<double> height(static_cast<std::size_t>(frames)), ext(static_cast<std::size_t>(frames));
    for (int f = 0; f < frames; ++f) {
      const auto fi = static_cast<std::size_t>(f);
      height[fi] = ankle.p[fi].y() - floor_y;
      ext[fi] = (ankle.p[fi] - hip.p[fi]).norm() / body.leg_m;
    }
    std::vector<int> kick_frames;
    auto consider = [&](int f, bool arrival) {
      const auto fi = static_cast<std::size_t>(f);
      const double vmax = max_in(ankle.speed, f - A, f);
      if (vmax < cfg.kick_min_speed || ext[fi] < cfg.kick_min_extension) return;
      if (height[fi] < cfg.kick_min_height * body.stature_m) return;
      const auto span = bounds(ankle.speed, f, A, H, cfg.bound_speed_fraction);
      Found k;
      k.kind = is_left(seg) ? "kick_left" : "kick_right";
      k.m.semantics = Semantics::kick;
      k.m.hit_segment = seg;
      k.m.hit_frame = f;
      k.m.first_frame = span.first;
      k.m.last_frame = span.second;
      k.m.peak_speed_mps = vmax;
      k.m.extension = ext[fi];
      k.m.height = classify_strike_height(height[fi], body.stature_m, cfg.height);
      k.m.note = fmt::format("proposed: {}ankle {:.0f} cm above the floor at the hit ({:.2f} of stature)",
                             arrival ? "chambered kick (knee raised first, leg straight below the knee's apex): " : "",
                             100 * height[fi], height[fi] / body.stature_m);
      strikes.push_back(k);
      kick_frames.push_back(f);
    };
    for (int f : peaks(height, cfg.kick_min_height * body.stature_m, W)) consider(f, false);
    // Extension-driven candidates: a chambered kick raises the knee first (the ankle's
    // highest point has a bent leg) and hits lower, where the leg arrives straight.
    for (int f = 1; f < frames; ++f) {
      if (!(ext[static_cast<std::size_t>(f - 1)] < cfg.kick_arrival_extension &&
            ext[static_cast<std::size_t>(f)] >= cfg.kick_arrival_extension)) {
        continue;
      }
      int top = f;
      const double e = max_in(ext, f, f + W, &top);
      int hit = top;
      while (hit > f && ext[static_cast<std::size_t>(hit - 1)] >= e - 0.01) --hit;
      const bool near_kick = std::any_of(kick_frames.begin(), kick_frames.end(), [&](int k) { return std::abs(k - hit) <= W; });
      if (!near_kick) consider(hit, true);
    }
  }
  const std::vector<Found> kicks = strikes;
  auto inside_kick = [&](int first, int last) {
    return std::any_of(kicks.begin(), kicks.end(), [&](const Found& k) { return overlaps(k.m, first, last); });
  };

  // Punches: the arm nearly straight at a local maximum of extension, straightened fast and
  // not pointing at the floor (low blocks sweep the arm down). No "forward" test: a boxer's
  // bladed stance and a cross turn hips and shoulders too much to define forward reliably.
  std::vector<Found> fast_non_punches;
  for (HitSegment seg : {HitSegment::left_hand, HitSegment::right_hand}) {
    const Track wrist = track(hit_joint(seg));
    const Track shoulder = track(limb_root(seg));
    std::vector<double> ext(static_cast<std::size_t>(frames)), radial(static_cast<std::size_t>(frames));
    for (int f = 0; f < frames; ++f) {
      ext[static_cast<std::size_t>(f)] =
          (wrist.p[static_cast<std::size_t>(f)] - shoulder.p[static_cast<std::size_t>(f)]).norm() / body.arm_m;
    }
    for (int f = 0; f < frames; ++f) {
      const int a = std::max(0, f - 1), b = std::min(frames - 1, f + 1);
      radial[static_cast<std::size_t>(f)] =
          b > a ? (ext[static_cast<std::size_t>(b)] - ext[static_cast<std::size_t>(a)]) * body.arm_m / ((b - a) * dt) : 0;
    }
    std::vector<int> punch_frames;
    // A candidate at frame f: a punch straightens the arm fast (punch_min_*); a jab or a punch
    // without a lunge may move the wrist slower but ends with the arm fully straight, reached
    // as fast (jab_min_*). Returns whether it was taken.
    auto consider = [&](int f, bool only_jab) {
      const std::size_t fi = static_cast<std::size_t>(f);
      const double vmax = max_in(wrist.speed, f - A, f);
      const double rmax = max_in(radial, f - A, f);
      const Eigen::Vector3d d = wrist.p[fi] - shoulder.p[fi];
      const double drop_deg = -std::asin(std::clamp(d.y() / d.norm(), -1.0, 1.0)) * 180 / std::numbers::pi;
      const bool punch = !only_jab && vmax >= cfg.punch_min_speed && rmax >= cfg.punch_min_radial_speed;
      const bool jab = ext[fi] >= cfg.jab_min_extension && vmax >= cfg.jab_min_speed && rmax >= cfg.jab_min_radial_speed;
      if (!(punch || jab) || drop_deg > cfg.punch_max_drop_deg) return false;
      if (inside_kick(f, f)) return false;  // arms swing for balance during kicks
      if (!punch) {
        // The arm may stay out (and creep straighter) after a jab: the hit is where it
        // arrived, the first frame within 0.01 of the held extension.
        while (f > 0 && f > static_cast<int>(fi) - W && ext[static_cast<std::size_t>(f - 1)] >= ext[fi] - 0.01) --f;
      }
      const std::size_t hi = static_cast<std::size_t>(f);
      const auto span = bounds(wrist.speed, f, A, H, cfg.bound_speed_fraction);
      Found p;
      p.kind = is_left(seg) ? "punch_left" : "punch_right";
      p.m.semantics = Semantics::punch;
      p.m.hit_segment = seg;
      p.m.hit_frame = f;
      p.m.first_frame = span.first;
      p.m.last_frame = span.second;
      p.m.peak_speed_mps = vmax;
      p.m.extension = ext[hi];
      const double h = wrist.p[hi].y() - floor_y;
      p.m.height = classify_strike_height(h, body.stature_m, cfg.height);
      p.m.note = fmt::format("proposed: {}wrist {:.0f} cm above the floor at the hit ({:.2f} of stature)",
                             punch ? "" : "jab (slower wrist, arm fully straight): ", 100 * h, h / body.stature_m);
      strikes.push_back(p);
      punch_frames.push_back(f);
      return true;
    };
    for (int f : peaks(ext, cfg.punch_min_extension, W)) consider(f, false);
    // Extension-driven candidates: where the arm arrives at full extension. A held arm that
    // creeps straighter has its extension peak later, away from the speeds of the jab.
    for (int f = 1; f < frames; ++f) {
      if (!(ext[static_cast<std::size_t>(f - 1)] < cfg.jab_min_extension && ext[static_cast<std::size_t>(f)] >= cfg.jab_min_extension)) continue;
      int top = f;
      max_in(ext, f, f + W, &top);
      const bool near_punch = std::any_of(punch_frames.begin(), punch_frames.end(), [&](int p) { return std::abs(p - top) <= W; });
      if (!near_punch) consider(top, true);
    }
    // Blocks: fast hands that are no punch (and not balance swings during kicks).
    for (int f : peaks(wrist.speed, cfg.block_min_speed, W)) {
      const auto span = bounds(wrist.speed, f, A / 2, H / 2, cfg.bound_speed_fraction);
      const int first = span.first, last = span.second;
      const bool near_punch = std::any_of(punch_frames.begin(), punch_frames.end(),
                                          [&](int p) { return p >= first - A && p <= last + A; });
      if (near_punch || inside_kick(first, last)) continue;
      Found b;
      b.kind = is_left(seg) ? "block_left" : "block_right";
      b.m.semantics = Semantics::block;
      b.m.first_frame = first;
      b.m.last_frame = last;
      b.m.peak_speed_mps = wrist.speed[static_cast<std::size_t>(f)];
      b.m.note = fmt::format("proposed: fast {} hand (peak f{}) that is not a punch: block? check", is_left(seg) ? "left" : "right", f);
      fast_non_punches.push_back(b);
    }
  }

  // Rest and walk, outside every strike.
  std::vector<bool> busy(static_cast<std::size_t>(frames), false);
  for (const auto& f : strikes) {
    for (int k = f.m.first_frame; k <= f.m.last_frame; ++k) busy[static_cast<std::size_t>(k)] = true;
  }
  std::vector<Track> ends;
  for (CJ c : {CJ::l_wrist, CJ::r_wrist, CJ::l_ankle, CJ::r_ankle}) ends.push_back(track(c));
  std::vector<bool> still(static_cast<std::size_t>(frames)), walking(static_cast<std::size_t>(frames));
  for (int f = 0; f < frames; ++f) {
    const std::size_t fi = static_cast<std::size_t>(f);
    double v = pelvis.speed[fi];
    for (const auto& t : ends) v = std::max(v, t.speed[fi]);
    still[fi] = !busy[fi] && v < cfg.rest_max_speed;
    const int a = std::max(0, f - 1), b = std::min(frames - 1, f + 1);
    Eigen::Vector3d dp = pelvis.p[static_cast<std::size_t>(b)] - pelvis.p[static_cast<std::size_t>(a)];
    dp.y() = 0;
    walking[fi] = !busy[fi] && b > a && dp.norm() / ((b - a) * dt) >= cfg.walk_min_speed;
  }
  std::vector<Found> others;
  for (auto [a, b] : runs(still, frames_of(cfg.rest_min_s))) {
    Found r;
    r.kind = "rest";
    r.m.semantics = Semantics::rest;
    r.m.first_frame = a;
    r.m.last_frame = b;
    r.m.note = fmt::format("proposed: everything slower than {:.2f} m/s", cfg.rest_max_speed);
    others.push_back(r);
  }
  for (auto [a, b] : runs(walking, frames_of(cfg.walk_min_s))) {
    Found w;
    w.kind = "walk";
    w.m.semantics = Semantics::walk;
    w.m.first_frame = a;
    w.m.last_frame = b;
    w.m.note = fmt::format("proposed: pelvis moving faster than {:.2f} m/s", cfg.walk_min_speed);
    others.push_back(w);
  }
  for (auto& b : fast_non_punches) {
    const bool in_walk = std::any_of(others.begin(), others.end(), [&](const Found& o) {
      return o.m.semantics == Semantics::walk && overlaps(o.m, b.m.first_frame, b.m.last_frame);
    });
    if (!in_walk) others.push_back(b);  // arms swing while walking
  }

  std::vector<Found> found = strikes;
  found.insert(found.end(), others.begin(), others.end());
  std::sort(found.begin(), found.end(), [](const Found& a, const Found& b) {
    return std::tie(a.m.first_frame, a.kind) < std::tie(b.m.first_frame, b.kind);
  });
  std::map<std::string, int> counts;
  for (auto& f : found) {
    f.m.name = fmt::format("{}_{}_{}", clip.name, f.kind, ++counts[f.kind]);
    out.motions.push_back(f.m);
  }
  return out;
}

}  // namespace kumite::content
