#include "kumite/content/database.hpp"

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <type_traits>

#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/annotation.hpp"
#include "kumite/content/proportions.hpp"

namespace kumite::content {

using CJ = CanonicalJoint;
using Eigen::Vector3d;

std::string_view to_string(SegmentKind k) {
  switch (k) {
    case SegmentKind::rest: return "rest";
    case SegmentKind::walk: return "walk";
    case SegmentKind::strike: return "strike";
    case SegmentKind::other: return "other";
    case SegmentKind::block: return "block";
  }
  return "?";
}

std::optional<Effector> MotionSegment::effector() const {
  if (effector_group < 0) return std::nullopt;
  return Effector{effector_group % 2, effector_group >= 2};
}

std::optional<int> find_segment(const Database& db, SegmentKind kind) {
  for (std::size_t i = 0; i < db.segments.size(); ++i)
    if (db.segments[i].kind == kind) return static_cast<int>(i);
  return std::nullopt;
}

namespace {

constexpr char kMagic[8] = {'K', 'U', 'M', 'I', 'T', 'E', 'D', 'B'};

Error segment_error(const SegmentSource& s, std::string_view msg) {
  return Error("database", "annotation", fmt::format("segment '{}': {}", s.name, msg));
}

void validate_source(const SegmentSource& s) {
  if (!s.clip) throw segment_error(s, "no clip");
  const int n = s.clip->frame_count;
  if (s.first_frame < 0 || s.last_frame >= n || s.first_frame > s.last_frame) {
    throw segment_error(s, fmt::format("frames {}..{} lie outside clip '{}' (0..{})", s.first_frame,
                                       s.last_frame, s.clip->name, n - 1));
  }
  if (s.last_frame - s.first_frame < 1) throw segment_error(s, "needs at least 2 frames");
  if (s.kind == SegmentKind::strike) {
    if (!s.effector) throw segment_error(s, "a strike needs a hit segment (hand or foot)");
    if (s.hit_frame < s.first_frame || s.hit_frame > s.last_frame) {
      throw segment_error(s, fmt::format("hit frame {} lies outside the segment {}..{}", s.hit_frame,
                                         s.first_frame, s.last_frame));
    }
  }
  if (s.kind == SegmentKind::block) {
    if (!s.effector || s.effector->leg) throw segment_error(s, "a block needs a forearm (left or right)");
    if (!s.height) throw segment_error(s, "a block needs a height (low, mid or high: what it guards)");
    if (!s.intercept_frames || (*s.intercept_frames)[0] < s.first_frame || (*s.intercept_frames)[1] > s.last_frame ||
        (*s.intercept_frames)[0] > (*s.intercept_frames)[1]) {
      throw segment_error(s, s.intercept_frames ? fmt::format("intercept frames {}..{} lie outside the segment {}..{}",
                                                              (*s.intercept_frames)[0], (*s.intercept_frames)[1],
                                                              s.first_frame, s.last_frame)
                                                : std::string("a block needs its intercept frames"));
    }
  }
}

std::vector<CanonicalPose> clip_poses(const Clip& clip, int first, int last) {
  const auto n = static_cast<std::size_t>(clip.skeleton.joint_count());
  std::vector<Vector3d> gp(n);
  std::vector<Eigen::Quaterniond> gr(n);
  std::vector<CanonicalPose> out;
  out.reserve(static_cast<std::size_t>(last - first + 1));
  for (int f = first; f <= last; ++f) {
    forward_kinematics(clip, f, gp, gr);
    out.emplace_back();
    canonical_positions(clip.skeleton, gp, out.back());
  }
  return out;
}

Morphology skeleton_morphology(const Skeleton& sk, std::string_view what) {
  require_canonical_joints(sk, what);
  const auto n = static_cast<std::size_t>(sk.joint_count());
  std::vector<Eigen::Quaterniond> id(n, Eigen::Quaterniond::Identity()), gr(n);
  std::vector<Vector3d> gp(n);
  forward_kinematics(sk, Vector3d::Zero(), id, gp, gr);
  CanonicalPose rest;
  canonical_positions(sk, gp, rest);
  return measure_morphology(rest, what);
}

// Whether a canonical pose stands: the head above the pelvis above both ankles.
bool standing(const CanonicalPose& p) {
  constexpr double kMost_m = 0.1;  // m: each at least this far above the next
  return at(p, CJ::head).y() > at(p, CJ::pelvis).y() + kMost_m &&
         at(p, CJ::pelvis).y() > std::max(at(p, CJ::l_ankle).y(), at(p, CJ::r_ankle).y()) + kMost_m;
}

// A clip's body, measured on its rest pose; where that is no standing body (a studio's export
// with every bone along its joint's local X puts every joint at one height, and the pelvis's
// drop to the hips, measured along the pelvis's up, came out 10 cm short) on its first frame.
// Bone lengths are the same in any pose; the rest pose's standing references are measured again
// on each segment (add_segment).
Morphology clip_morphology(const Clip& clip) {
  const Skeleton& sk = clip.skeleton;
  require_canonical_joints(sk, clip.name);
  const auto n = static_cast<std::size_t>(sk.joint_count());
  std::vector<Eigen::Quaterniond> id(n, Eigen::Quaterniond::Identity()), gr(n);
  std::vector<Vector3d> gp(n);
  forward_kinematics(sk, Vector3d::Zero(), id, gp, gr);
  CanonicalPose pose;
  canonical_positions(sk, gp, pose);
  if (!standing(pose) && clip.frame_count > 0) {
    forward_kinematics(clip, 0, gp, gr);
    canonical_positions(sk, gp, pose);
  }
  return measure_morphology(pose, clip.name);
}

double lowest_foot(const std::vector<CanonicalPose>& poses) {
  double lo = std::numeric_limits<double>::infinity();
  for (const auto& p : poses) {
    for (CJ j : {CJ::l_ankle, CJ::r_ankle, CJ::l_toe, CJ::r_toe})
      if (at(p, j).allFinite()) lo = std::min(lo, at(p, j).y());
  }
  return lo;
}

// A capture glitch (SegmentSource::repair_frames): each joint's position over the frames
// interpolated between the good frames either side of them.
void repair_glitch(const SegmentSource& src, std::vector<CanonicalPose>& poses) {
  if (!src.repair_frames) return;
  const int a = (*src.repair_frames)[0] - src.first_frame, b = (*src.repair_frames)[1] - src.first_frame;
  if (a < 1 || b < a || b + 1 >= static_cast<int>(poses.size()) || b - a + 1 > kMaxRepairFrames) {
    throw Error("database", "annotation",
                fmt::format("{}: repair_frames [{}, {}] must lie inside frames [{}, {}], not on their first or last", src.name,
                            (*src.repair_frames)[0], (*src.repair_frames)[1], src.first_frame, src.last_frame));
  }
  const CanonicalPose& before = poses[static_cast<std::size_t>(a - 1)];
  const CanonicalPose& after = poses[static_cast<std::size_t>(b + 1)];
  for (int f = a; f <= b; ++f) {
    const double u = static_cast<double>(f - a + 1) / (b - a + 2);
    CanonicalPose& p = poses[static_cast<std::size_t>(f)];
    for (std::size_t j = 0; j < p.size(); ++j) p[j] = (1 - u) * before[j] + u * after[j];
  }
}

void add_segment(Database& db, const SegmentSource& src, std::vector<CanonicalPose> poses,
                 const Morphology& m, bool mirrored, const BuildOptions& o) {
  const Clip& clip = *src.clip;
  const double scale = db.actor.leg_length_m / m.leg_length_m;
  // Put the floor at y = 0: features, hit paths and targets all measure height from it.
  const double floor_y_raw = lowest_foot(poses);
  for (auto& p : poses)
    for (auto& j : p) j.y() -= floor_y_raw;
  const double floor_y = 0;
  // Root heights count from the ankle standing on this floor: the lowest the segment has an
  // ankle (the skeleton's rest pose is no stance: HDM05's stands its ankles 5 cm above the toe
  // joint, its actors 9 cm).
  // Foot directions count from the foot standing flat: the median pitch over the frames its
  // ankle is within 1 cm of its lowest (the heel down). Not the frame the ankle and toe are
  // lowest together: HDM05's toe joint dips 3 cm with the ankle level (44 deg against 27).
  // (Each ankle's lowest also sets its planted level and heel lift, below.)
  std::array<double, 2> low_ankle{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  for (const auto& p : poses)
    for (int s = 0; s < 2; ++s) low_ankle[static_cast<std::size_t>(s)] = std::min(low_ankle[static_cast<std::size_t>(s)], at(p, s == kLeft ? CJ::l_ankle : CJ::r_ankle).y());
  Morphology me = m;
  me.standing_ankle_m = std::min(low_ankle[0], low_ankle[1]);
  std::vector<double> pitches;
  pitches.reserve(poses.size());
  for (int s = 0; s < 2; ++s) {
    const CJ ankle = s == kLeft ? CJ::l_ankle : CJ::r_ankle;
    pitches.clear();
    for (const auto& p : poses)
      if (at(p, ankle).y() <= low_ankle[static_cast<std::size_t>(s)] + 0.01) pitches.push_back(standing_foot_pitch(p, s));
    std::nth_element(pitches.begin(), pitches.begin() + static_cast<std::ptrdiff_t>(pitches.size() / 2), pitches.end());
    me.standing_foot_pitch_rad[static_cast<std::size_t>(s)] = pitches[pitches.size() / 2];
  }
  MotionSegment seg;
  seg.name = mirrored ? src.name + ":mirror" : src.name;
  seg.source_clip = clip.name;
  seg.kind = src.kind;
  seg.mirrored = mirrored;
  seg.source_first_frame = src.first_frame;
  seg.frame_time_s = clip.frame_time_s;
  if (src.height) seg.height = static_cast<std::int8_t>(*src.height);
  const int n = static_cast<int>(poses.size());
  seg.frames.resize(static_cast<std::size_t>(n));
  for (int f = 0; f < n; ++f) {
    MkmFrame& fr = seg.frames[static_cast<std::size_t>(f)];
    encode_mkm(poses[static_cast<std::size_t>(f)], me, floor_y, f > 0 ? &seg.frames[static_cast<std::size_t>(f - 1)] : nullptr, fr);
    fr.root_xz_m *= scale;
  }
  if (o.steady_straight_poles) steady_straight_limb_poles(seg.frames, clip.frame_time_s);
  // Planted feet: the ankle low (relative to its lowest point in the segment) and slow, or the
  // toes low and slow (the heel raised onto the ball of the foot, as the back foot of a lunge
  // before it steps: the foot is still down, turning about its toes).
  for (int s = 0; s < 2; ++s) {
    const CJ ankle = s == kLeft ? CJ::l_ankle : CJ::r_ankle;
    const CJ toe = s == kLeft ? CJ::l_toe : CJ::r_toe;
    const double lowest_ankle = low_ankle[static_cast<std::size_t>(s)];
    double low_toe = std::numeric_limits<double>::infinity();
    for (const auto& p : poses) low_toe = std::min(low_toe, at(p, toe).y());
    const auto low_and_slow = [&](CJ j, double low, int f) {
      const int a = std::max(0, f - 1), b = std::min(n - 1, f + 1);
      const double speed = b > a ? (at(poses[static_cast<std::size_t>(b)], j) - at(poses[static_cast<std::size_t>(a)], j)).norm() /
                                       ((b - a) * clip.frame_time_s)
                                 : 0.0;
      return at(poses[static_cast<std::size_t>(f)], j).y() - low < o.plant_height_m && speed < o.plant_speed_mps;
    };
    for (int f = 0; f < n; ++f) {
      MkmFrame& fr = seg.frames[static_cast<std::size_t>(f)];
      fr.planted[static_cast<std::size_t>(s)] = low_and_slow(ankle, lowest_ankle, f) || low_and_slow(toe, low_toe, f) ? 1.0 : 0.0;
      fr.ankle_lift_n[static_cast<std::size_t>(s)] = (at(poses[static_cast<std::size_t>(f)], ankle).y() - lowest_ankle) / m.leg_length_m;
    }
  }
  const int seg_index = static_cast<int>(db.segments.size());
  const double ft = clip.frame_time_s;
  const int stride = std::max(1, static_cast<int>(std::lround(o.start_stride_s / ft)));
  // A retrieval candidate at every `stride`-th start frame up to last_start: its pose features
  // and the window's points (`point(pose)`, m, room, sampled from wfirst to wlast) in its
  // ground frame, at the actor's scale.
  const auto add_candidates = [&](RetrievalIndex& index, int group, int last_start, int wfirst, int wlast,
                                  const auto& point) {
    const int wstride = std::max(1, (wlast - wfirst + kWindowMax - 1) / (kWindowMax - 1));
    std::array<float, kFeatureDim> feat{};
    std::vector<Eigen::Vector3f> pts;
    for (int f = 0; f <= std::max(0, last_start); f += stride) {
      const CanonicalPose& now = poses[static_cast<std::size_t>(f)];
      const CanonicalPose& before = poses[static_cast<std::size_t>(std::max(0, f - 1))];
      const GroundFrame g = ground_frame_of(now);
      pose_features(now, before, f > 0 ? ft : 0.0, g, m.leg_length_m, o.velocity_weight_s, feat);
      pts.clear();
      for (int k = wfirst; k <= wlast && static_cast<int>(pts.size()) < kWindowMax; k += wstride) {
        const Vector3d q = point(poses[static_cast<std::size_t>(k)]);
        pts.push_back((g.to_local(q) * scale).cast<float>());
      }
      index.add(group, feat, pts, seg_index, f, wfirst, wstride);
    }
  };
  if (src.kind == SegmentKind::strike) {
    Effector e = *src.effector;
    if (mirrored) e.side = 1 - e.side;
    seg.effector_group = static_cast<std::int8_t>(e.side + 2 * (e.leg ? 1 : 0));
    seg.hit_frame = src.hit_frame - src.first_frame;
    const CJ ej = e.joint();
    seg.hit_path_m.resize(static_cast<std::size_t>(n));
    for (int f = 0; f < n; ++f)
      seg.hit_path_m[static_cast<std::size_t>(f)] = (at(poses[static_cast<std::size_t>(f)], ej) * scale).cast<float>();
    // Candidates: start frames before the hit; the hit window around it.
    const int last_start = std::min(static_cast<int>(o.start_window_s / ft), seg.hit_frame - static_cast<int>(std::lround(o.min_lead_s / ft)));
    const int wfirst = std::max(0, seg.hit_frame - static_cast<int>(std::lround(o.window_before_s / ft)));
    const int wlast = std::min(n - 1, seg.hit_frame + static_cast<int>(std::lround(o.window_after_s / ft)));
    add_candidates(db.index, seg.effector_group, last_start, wfirst, wlast, [&](const CanonicalPose& p) { return at(p, ej); });
  } else if (src.kind == SegmentKind::block) {
    // The forearm (elbow -> wrist) per frame; candidates: start frames before the intercept,
    // the window the forearm's contact point over the frames it is in place.
    Effector e = *src.effector;
    if (mirrored) e.side = 1 - e.side;
    seg.effector_group = static_cast<std::int8_t>(e.side);
    seg.intercept_first = (*src.intercept_frames)[0] - src.first_frame;
    seg.intercept_last = (*src.intercept_frames)[1] - src.first_frame;
    const CJ elbow = e.side == kLeft ? CJ::l_elbow : CJ::r_elbow;
    const CJ wrist = e.side == kLeft ? CJ::l_wrist : CJ::r_wrist;
    seg.hit_path_m.resize(static_cast<std::size_t>(n));
    seg.elbow_path_m.resize(static_cast<std::size_t>(n));
    for (int f = 0; f < n; ++f) {
      seg.hit_path_m[static_cast<std::size_t>(f)] = (at(poses[static_cast<std::size_t>(f)], wrist) * scale).cast<float>();
      seg.elbow_path_m[static_cast<std::size_t>(f)] = (at(poses[static_cast<std::size_t>(f)], elbow) * scale).cast<float>();
    }
    const int last_start = std::min(static_cast<int>(o.start_window_s / ft),
                                    seg.intercept_first - static_cast<int>(std::lround(o.block_min_lead_s / ft)));
    add_candidates(db.block_index, e.side + 2 * seg.height, last_start, seg.intercept_first, seg.intercept_last,
                   [&](const CanonicalPose& p) -> Vector3d {
                     return at(p, elbow) + kForearmContactFraction * (at(p, wrist) - at(p, elbow));
                   });
  }
  db.segments.push_back(std::move(seg));
}

// ---- binary I/O -------------------------------------------------------------------------

std::uint64_t fnv1a(std::string_view bytes) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : bytes) { h ^= c; h *= 1099511628211ull; }
  return h;
}

class Writer {
 public:
  template <typename T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  void str(const std::string& s) { put<std::uint64_t>(s.size()); out += s; }
  template <typename T>
  void vec(const std::vector<T>& v) {
    put<std::uint64_t>(v.size());
    if (!v.empty()) out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  void v3(const Vector3d& v) { put(v.x()); put(v.y()); put(v.z()); }
  void q(const Eigen::Quaterniond& v) { put(v.w()); put(v.x()); put(v.y()); put(v.z()); }
  std::string out;
};

class Reader {
 public:
  Reader(std::string_view bytes, std::string_view name) : b_(bytes), name_(name) {}
  template <typename T>
  T get(std::string_view what) {
    need(sizeof(T), what);
    T v;
    std::memcpy(&v, b_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::uint64_t count(std::string_view what, std::size_t element_size) {
    const auto n = get<std::uint64_t>(what);
    if (element_size > 0 && n > (b_.size() - pos_) / element_size) fail("corrupt", fmt::format("{}: count {} exceeds the file", what, n));
    return n;
  }
  std::string str(std::string_view what) {
    const auto n = count(what, 1);
    std::string s(b_.substr(pos_, n));
    pos_ += n;
    return s;
  }
  template <typename T>
  std::vector<T> vec(std::string_view what) {
    const auto n = count(what, sizeof(T));
    std::vector<T> v(n);
    if (n) std::memcpy(v.data(), b_.data() + pos_, n * sizeof(T));
    pos_ += n * sizeof(T);
    return v;
  }
  double f(std::string_view what) {
    const double v = get<double>(what);
    if (!std::isfinite(v)) fail("corrupt", fmt::format("{}: not a finite number", what));
    return v;
  }
  Vector3d v3(std::string_view what) { const double x = f(what), y = f(what), z = f(what); return {x, y, z}; }
  Eigen::Quaterniond q(std::string_view what) {
    const double w = f(what), x = f(what), y = f(what), z = f(what);
    return Eigen::Quaterniond(w, x, y, z);
  }
  [[noreturn]] void fail(std::string_view code, std::string_view msg) const {
    throw Error("database", std::string(code), fmt::format("{}: {}", name_, msg));
  }
  std::size_t pos() const { return pos_; }
  std::size_t size() const { return b_.size(); }

 private:
  void need(std::size_t n, std::string_view what) const {
    if (b_.size() - pos_ < n) fail("truncated", fmt::format("truncated at byte {} while reading {}", pos_, what));
  }
  std::string_view b_;
  std::string_view name_;
  std::size_t pos_ = 0;
};

void put_frame(Writer& w, const MkmFrame& f) {
  w.put(f.root_xz_m.x()); w.put(f.root_xz_m.y()); w.put(f.root_height_n);
  w.q(f.pelvis); w.q(f.chest); w.v3(f.spine_dir); w.v3(f.head_dir);
  for (int s = 0; s < 2; ++s) {
    w.v3(f.clavicle_dir[s]); w.v3(f.arm_n[s]); w.v3(f.arm_pole[s]);
    w.v3(f.leg_n[s]); w.v3(f.leg_pole[s]); w.v3(f.foot_dir[s]); w.put(f.planted[s]);
    w.put(f.ankle_lift_n[s]);
  }
}
MkmFrame get_frame(Reader& r) {
  MkmFrame f;
  f.root_xz_m.x() = r.f("frame"); f.root_xz_m.y() = r.f("frame"); f.root_height_n = r.f("frame");
  f.pelvis = r.q("frame"); f.chest = r.q("frame"); f.spine_dir = r.v3("frame"); f.head_dir = r.v3("frame");
  for (int s = 0; s < 2; ++s) {
    f.clavicle_dir[s] = r.v3("frame"); f.arm_n[s] = r.v3("frame"); f.arm_pole[s] = r.v3("frame");
    f.leg_n[s] = r.v3("frame"); f.leg_pole[s] = r.v3("frame"); f.foot_dir[s] = r.v3("frame");
    for (const Vector3d* pole : {&f.arm_pole[s], &f.leg_pole[s]})
      if (std::abs(pole->norm() - 1) > 1e-6) r.fail("corrupt", fmt::format("frame: a limb pole of length {} (unit)", pole->norm()));
    f.planted[s] = r.f("frame");
    f.ankle_lift_n[s] = r.f("frame");
    if (f.ankle_lift_n[s] < 0 || f.ankle_lift_n[s] > 2) r.fail("corrupt", fmt::format("frame: ankle lift {} leg lengths (0..2)", f.ankle_lift_n[s]));
  }
  return f;
}

void put_skeleton(Writer& w, const Skeleton& s) {
  w.put<std::uint64_t>(s.names.size());
  for (std::size_t i = 0; i < s.names.size(); ++i) {
    w.str(s.names[i]);
    w.put<std::int32_t>(s.parents[i]);
    w.v3(s.offsets[i]);
    w.put<std::uint8_t>(s.end_site[i] ? 1 : 0);
  }
  for (int c : s.canonical) w.put<std::int32_t>(c);
}
Skeleton get_skeleton(Reader& r) {
  Skeleton s;
  const auto n = r.count("skeleton", 8 + 4 + 24 + 1);
  for (std::uint64_t i = 0; i < n; ++i) {
    s.names.push_back(r.str("joint name"));
    const auto p = r.get<std::int32_t>("joint parent");
    if (p >= static_cast<std::int64_t>(i) || (i == 0 && p != -1) || (i > 0 && p < 0)) r.fail("corrupt", fmt::format("joint {}: bad parent {}", i, p));
    s.parents.push_back(p);
    s.offsets.push_back(r.v3("joint offset"));
    s.end_site.push_back(r.get<std::uint8_t>("end site") != 0);
  }
  for (auto& c : s.canonical) {
    c = r.get<std::int32_t>("canonical joint");
    if (c < -1 || c >= static_cast<int>(n)) r.fail("corrupt", fmt::format("canonical joint index {} out of range", c));
  }
  return s;
}

double median_block_reach(const RetrievalIndex& ix) {
  std::vector<double> r;
  for (int row = 0; row < ix.size; ++row) {
    const float* w = ix.window.data() + static_cast<std::size_t>(row) * kWindowMax * 3;
    for (int k = 0; k < ix.window_count[static_cast<std::size_t>(row)]; ++k)
      r.push_back(std::hypot(static_cast<double>(w[3 * k]), static_cast<double>(w[3 * k + 2])));
  }
  if (r.empty()) return 0;
  std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
  return r[r.size() / 2];
}

void put_index(Writer& w, const RetrievalIndex& ix) {
  w.put<std::int32_t>(ix.size);
  w.vec(ix.features); w.vec(ix.window); w.vec(ix.window_count); w.vec(ix.box);
  w.vec(ix.segment); w.vec(ix.start_frame); w.vec(ix.window_first); w.vec(ix.window_stride); w.vec(ix.group);
  w.put<std::uint64_t>(ix.clusters.size());
  for (const auto& c : ix.clusters) {
    w.put(c.first); w.put(c.count); w.put(c.centroid); w.put(c.radius); w.put(c.box);
  }
  for (int g = 0; g <= ix.group_count; ++g) w.put<std::int32_t>(ix.group_clusters[static_cast<std::size_t>(g)]);
}

// A retrieval index of `group_count` groups over db.segments: every row's segment of `kind`,
// its group the segment's (strikes: the effector group; blocks: forearm + 2 * height).
void get_index(Reader& body, Database& db, RetrievalIndex& ix, int group_count, SegmentKind kind) {
  const std::string_view what = kind == SegmentKind::block ? "block index" : "retrieval index";
  ix.group_count = group_count;
  ix.size = body.get<std::int32_t>("index size");
  ix.features = body.vec<float>("features");
  ix.window = body.vec<float>("window");
  ix.window_count = body.vec<std::uint8_t>("window count");
  ix.box = body.vec<float>("boxes");
  ix.segment = body.vec<std::int32_t>("row segment");
  ix.start_frame = body.vec<std::int32_t>("row start");
  ix.window_first = body.vec<std::int32_t>("row window");
  ix.window_stride = body.vec<std::int32_t>("row window stride");
  ix.group = body.vec<std::uint8_t>("row group");
  const auto n = static_cast<std::size_t>(std::max(0, ix.size));
  if (ix.size < 0 || ix.features.size() != n * kFeatureDim || ix.window.size() != n * kWindowMax * 3 ||
      ix.window_count.size() != n || ix.box.size() != n * 6 || ix.segment.size() != n || ix.start_frame.size() != n ||
      ix.window_first.size() != n || ix.window_stride.size() != n || ix.group.size() != n)
    body.fail("corrupt", fmt::format("{} arrays disagree in size", what));
  for (std::size_t row = 0; row < n; ++row) {
    const int s = ix.segment[row];
    if (s < 0 || s >= static_cast<int>(db.segments.size())) body.fail("corrupt", fmt::format("{} row {}: segment {} out of range", what, row, s));
    const MotionSegment& seg = db.segments[static_cast<std::size_t>(s)];
    const int group = kind == SegmentKind::block ? seg.effector_group + 2 * seg.height : seg.effector_group;
    const int last_window = ix.window_first[row] + ix.window_stride[row] * (ix.window_count[row] - 1);
    if (seg.kind != kind || ix.window_count[row] < 1 || ix.window_count[row] > kWindowMax || ix.group[row] != group ||
        ix.start_frame[row] < 0 || ix.start_frame[row] >= seg.frame_count() || ix.window_first[row] < 0 ||
        ix.window_stride[row] < 1 || last_window >= seg.frame_count())
      body.fail("corrupt", fmt::format("{} row {}: inconsistent with segment '{}'", what, row, seg.name));
  }
  const auto nc = body.count("clusters", 8);
  for (std::uint64_t c = 0; c < nc; ++c) {
    RetrievalIndex::Cluster cl;
    cl.first = body.get<std::int32_t>("cluster");
    cl.count = body.get<std::int32_t>("cluster");
    cl.centroid = body.get<std::array<float, kFeatureDim>>("cluster");
    cl.radius = body.get<float>("cluster");
    cl.box = body.get<std::array<float, 6>>("cluster");
    if (cl.first < 0 || cl.count < 1 || cl.first + cl.count > ix.size) body.fail("corrupt", fmt::format("{} cluster {}: rows out of range", what, c));
    ix.clusters.push_back(cl);
  }
  for (int g = 0; g <= group_count; ++g) {
    auto& gc = ix.group_clusters[static_cast<std::size_t>(g)];
    gc = body.get<std::int32_t>("group clusters");
    if (gc < 0 || gc > static_cast<int>(nc)) body.fail("corrupt", fmt::format("{}: group cluster range out of range", what));
  }
  for (int g = group_count + 1; g <= kMaxGroupCount; ++g) ix.group_clusters[static_cast<std::size_t>(g)] = ix.group_clusters[static_cast<std::size_t>(group_count)];
  for (int g = 0; g < group_count; ++g)
    if (ix.group_clusters[static_cast<std::size_t>(g)] > ix.group_clusters[static_cast<std::size_t>(g) + 1])
      body.fail("corrupt", fmt::format("{}: group cluster ranges out of order", what));
}

}  // namespace

std::vector<SegmentSource> segment_sources(const AnnotationSet& set, const std::vector<Clip>& clips) {
  std::vector<SegmentSource> out;
  for (std::size_t c = 0; c < set.clips.size() && c < clips.size(); ++c) {
    for (const MotionAnnotation& m : set.clips[c].motions) {
      SegmentSource s;
      s.clip = &clips[c];
      s.name = m.name;
      s.first_frame = m.first_frame;
      s.last_frame = m.last_frame;
      s.mirror = set.clips[c].mirror;
      s.repair_frames = m.repair_frames;
      switch (m.semantics) {
        case Semantics::block:
          if (!is_reviewed_block(m)) continue;  // unreviewed (as proposed): left out
          s.kind = SegmentKind::block;
          s.effector = Effector{*m.forearm == Forearm::left ? kLeft : kRight, false};
          s.height = m.height;
          s.intercept_frames = m.intercept_frames;
          break;
        case Semantics::punch:
        case Semantics::kick:
          s.kind = SegmentKind::strike;
          if (m.hit_segment) s.effector = Effector{is_left(*m.hit_segment) ? kLeft : kRight, !is_hand(*m.hit_segment)};
          s.hit_frame = m.hit_frame.value_or(-1);
          s.height = m.height;
          break;
        case Semantics::rest: s.kind = SegmentKind::rest; break;
        case Semantics::walk: s.kind = SegmentKind::walk; break;
        default: continue;
      }
      out.push_back(std::move(s));
    }
  }
  return out;
}

Database build_database(std::span<const SegmentSource> sources, const BuildOptions& o) {
  Database db;
  db.velocity_weight_s = o.velocity_weight_s;
  if (sources.empty()) throw Error("database", "annotation", "no segments to build a database from");
  for (const auto& s : sources) validate_source(s);
  db.actor_name = sources.front().clip->name;
  db.actor_skeleton = sources.front().clip->skeleton;
  db.actor = skeleton_morphology(db.actor_skeleton, db.actor_name);
  {
    // The actor is measured on its rest pose here and again when the database is loaded.
    const auto n = static_cast<std::size_t>(db.actor_skeleton.joint_count());
    std::vector<Eigen::Quaterniond> id(n, Eigen::Quaterniond::Identity()), gr(n);
    std::vector<Vector3d> gp(n);
    forward_kinematics(db.actor_skeleton, Vector3d::Zero(), id, gp, gr);
    CanonicalPose rest;
    canonical_positions(db.actor_skeleton, gp, rest);
    if (!standing(rest)) {
      throw Error("database", "actor", fmt::format("{}: the first clip is the database's actor and its rest pose is no standing "
                                                   "body (head above pelvis above ankles): put a clip with one first",
                                                   db.actor_name));
    }
  }
  db.actor_stature_m = measure_proportions(db.actor_skeleton).stature_m;
  db.block_index.group_count = kBlockGroupCount;
  // Blocks after every other segment (strike, rest and walk segments keep their indices).
  std::vector<std::size_t> order;
  for (int blocks = 0; blocks < 2; ++blocks)
    for (std::size_t i = 0; i < sources.size(); ++i)
      if ((sources[i].kind == SegmentKind::block) == (blocks == 1)) order.push_back(i);
  for (std::size_t k = 0; k < order.size(); ++k) {
    const std::size_t i = order[k];
    const SegmentSource& src = sources[i];
    if (o.progress) o.progress(src.name, static_cast<double>(k) / static_cast<double>(sources.size()));
    const Morphology m = clip_morphology(*src.clip);
    auto poses = clip_poses(*src.clip, src.first_frame, src.last_frame);
    repair_glitch(src, poses);
    add_segment(db, src, poses, m, false, o);
    if (o.mirror && src.mirror) {
      std::vector<CanonicalPose> mirrored(poses.size());
      const GroundFrame g = ground_frame_of(poses.front());
      for (std::size_t f = 0; f < poses.size(); ++f) mirror_pose(poses[f], g, mirrored[f]);
      add_segment(db, src, mirrored, m, true, o);
    }
  }
  if (o.progress) o.progress("clustering", 0.99);
  db.index.build_clusters(o.clusters_per_group);
  db.block_index.build_clusters(o.clusters_per_group);
  db.block_reach_m = median_block_reach(db.block_index);
  if (o.progress) o.progress("done", 1.0);
  return db;
}

std::string serialize_database(const Database& db) {
  Writer w;
  w.out.append(kMagic, sizeof(kMagic));
  w.put<std::uint32_t>(kDatabaseVersion);
  w.str(db.actor_name);
  put_skeleton(w, db.actor_skeleton);
  w.put(db.velocity_weight_s);
  w.put<std::uint64_t>(db.segments.size());
  for (const MotionSegment& s : db.segments) {
    w.str(s.name); w.str(s.source_clip);
    w.put<std::uint8_t>(static_cast<std::uint8_t>(s.kind));
    w.put<std::int8_t>(s.effector_group);
    w.put<std::uint8_t>(s.mirrored ? 1 : 0);
    w.put<std::int32_t>(s.source_first_frame);
    w.put(s.frame_time_s);
    w.put<std::int32_t>(s.hit_frame);
    w.put<std::int8_t>(s.height);
    w.put<std::int32_t>(s.intercept_first);
    w.put<std::int32_t>(s.intercept_last);
    w.put<std::uint64_t>(s.frames.size());
    for (const auto& f : s.frames) put_frame(w, f);
    for (const auto* path : {&s.hit_path_m, &s.elbow_path_m}) {
      w.put<std::uint64_t>(path->size());
      for (const auto& p : *path) { w.put(p.x()); w.put(p.y()); w.put(p.z()); }
    }
  }
  put_index(w, db.index);
  put_index(w, db.block_index);
  w.put(db.block_reach_m);
  w.put<std::uint64_t>(fnv1a(w.out));
  return std::move(w.out);
}

Database parse_database(std::string_view bytes, std::string_view name) {
  Reader r(bytes, name);
  if (bytes.size() < sizeof(kMagic) + 4 + 8 || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0)
    r.fail("magic", "not a Kumite motion database (bad magic; build one with kumite-motion build)");
  for (std::size_t i = 0; i < sizeof(kMagic); ++i) r.get<char>("magic");
  const auto version = r.get<std::uint32_t>("version");
  if (version != kDatabaseVersion)
    r.fail("version", fmt::format("format version {}, this program reads version {}: rebuild it with kumite-motion build",
                                  version, kDatabaseVersion));
  std::uint64_t stored;
  std::memcpy(&stored, bytes.data() + bytes.size() - 8, 8);
  if (stored != fnv1a(bytes.substr(0, bytes.size() - 8))) r.fail("checksum", "checksum mismatch (file corrupt or truncated)");
  Reader body(bytes.substr(0, bytes.size() - 8), name);
  for (std::size_t i = 0; i < sizeof(kMagic) + 4; ++i) body.get<char>("header");

  Database db;
  db.actor_name = body.str("actor name");
  db.actor_skeleton = get_skeleton(body);
  try {
    db.actor = skeleton_morphology(db.actor_skeleton, db.actor_name);
    db.actor_stature_m = measure_proportions(db.actor_skeleton).stature_m;
  } catch (const Error& e) {
    body.fail("corrupt", e.what());
  }
  db.velocity_weight_s = body.f("velocity weight");
  const auto nseg = body.count("segments", 8);
  for (std::uint64_t i = 0; i < nseg; ++i) {
    MotionSegment s;
    s.name = body.str("segment name");
    s.source_clip = body.str("segment clip");
    const auto kind = body.get<std::uint8_t>("segment kind");
    if (kind > 4) body.fail("corrupt", fmt::format("segment {}: bad kind {}", i, kind));
    s.kind = static_cast<SegmentKind>(kind);
    s.effector_group = body.get<std::int8_t>("effector");
    if (s.effector_group < -1 || s.effector_group >= kGroupCount) body.fail("corrupt", fmt::format("segment {}: bad effector", i));
    s.mirrored = body.get<std::uint8_t>("mirrored") != 0;
    s.source_first_frame = body.get<std::int32_t>("first frame");
    s.frame_time_s = body.f("frame time");
    if (!(s.frame_time_s > 0)) body.fail("corrupt", fmt::format("segment {}: frame time {} is not positive", i, s.frame_time_s));
    s.hit_frame = body.get<std::int32_t>("hit frame");
    s.height = body.get<std::int8_t>("height");
    if (s.height < -1 || s.height > 2) body.fail("corrupt", fmt::format("segment {}: bad height {}", i, s.height));
    s.intercept_first = body.get<std::int32_t>("intercept first");
    s.intercept_last = body.get<std::int32_t>("intercept last");
    const auto nf = body.count("frames", 47 * 8);
    if (nf < 2) body.fail("corrupt", fmt::format("segment {}: {} frames", i, nf));
    for (std::uint64_t f = 0; f < nf; ++f) s.frames.push_back(get_frame(body));
    for (auto* path : {&s.hit_path_m, &s.elbow_path_m}) {
      const auto np = body.count("path", 12);
      if (np != 0 && np != nf) body.fail("corrupt", fmt::format("segment {}: a path of {} for {} frames", i, np, nf));
      for (std::uint64_t f = 0; f < np; ++f) {
        const float x = body.get<float>("path"), y = body.get<float>("path"), z = body.get<float>("path");
        if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) body.fail("corrupt", fmt::format("segment {}: a path point is not finite", i));
        path->emplace_back(x, y, z);
      }
    }
    if (s.kind == SegmentKind::strike && (s.effector_group < 0 || s.hit_frame < 0 || s.hit_frame >= static_cast<int>(nf) || s.hit_path_m.empty()))
      body.fail("corrupt", fmt::format("segment {} ('{}'): strike without a valid hit", i, s.name));
    if (s.kind == SegmentKind::block &&
        (s.effector_group < 0 || s.effector_group > 1 || s.height < 0 || s.intercept_first < 0 ||
         s.intercept_last < s.intercept_first || s.intercept_last >= static_cast<int>(nf) || s.hit_path_m.empty() ||
         s.elbow_path_m.empty()))
      body.fail("corrupt", fmt::format("segment {} ('{}'): block without a valid forearm, height or intercept", i, s.name));
    db.segments.push_back(std::move(s));
  }
  get_index(body, db, db.index, kGroupCount, SegmentKind::strike);
  get_index(body, db, db.block_index, kBlockGroupCount, SegmentKind::block);
  db.block_reach_m = body.f("block reach");
  if (db.block_reach_m < 0 || db.block_reach_m > 10) body.fail("corrupt", fmt::format("block reach {} m (0..10)", db.block_reach_m));
  if (body.pos() != body.size()) body.fail("corrupt", fmt::format("{} unexpected bytes after the index", body.size() - body.pos()));
  db.index.build_blocks();
  db.block_index.build_blocks();
  return db;
}

void save_database(const Database& db, const std::filesystem::path& path) {
  write_file_atomically(path, serialize_database(db));
}

Database load_database(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec))
    throw Error("database", "io", fmt::format("{}: is not a file (a folder?): not a motion database", path.string()));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("database", "io", fmt::format("{}: cannot open the motion database", path.string()));
  std::string bytes;
  try {
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  } catch (const std::exception& e) {
    throw Error("database", "io", fmt::format("{}: cannot read the motion database ({})", path.string(), e.what()));
  }
  return parse_database(bytes, path.string());
}

}  // namespace kumite::content
