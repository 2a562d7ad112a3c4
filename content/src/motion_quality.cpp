#include "kumite/content/motion_quality.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "kumite/common/error.hpp"
#include "kumite/content/bvh.hpp"
#include "kumite/content/mirror.hpp"

namespace kumite::content {

using CJ = CanonicalJoint;
using Eigen::Vector3d;

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double percentile_sorted(const std::vector<double>& v, double p) {
  if (v.empty()) return 0;
  const double x = std::clamp(p / 100.0, 0.0, 1.0) * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(x);
  const double t = x - static_cast<double>(i);
  return i + 1 < v.size() ? v[i] * (1 - t) + v[i + 1] * t : v[i];
}

int require(const Skeleton& s, CJ j) {
  const int i = s.index(j);
  if (i < 0)
    throw Error("content", "skeleton",
                fmt::format("motion quality: the skeleton lacks the canonical joint {}", to_string(j)));
  return i;
}

FrameRange clamp_range(const JointTrack& t, FrameRange r) {
  r.first = std::max(0, r.first);
  r.last = std::min(t.frame_count - 1, r.last);
  return r;
}

double nan_max(double a, double b) {
  if (std::isnan(a)) return b;
  if (std::isnan(b)) return a;
  return std::max(a, b);
}

struct Limb {
  CJ root, mid, end;
};
Limb limb_of(int side, bool leg) {
  if (leg) return side == kLeft ? Limb{CJ::l_hip, CJ::l_knee, CJ::l_ankle} : Limb{CJ::r_hip, CJ::r_knee, CJ::r_ankle};
  return side == kLeft ? Limb{CJ::l_shoulder, CJ::l_elbow, CJ::l_wrist} : Limb{CJ::r_shoulder, CJ::r_elbow, CJ::r_wrist};
}
}  // namespace

int speed_half_window(double frame_time_s, double window_s) {
  if (!(frame_time_s > 0)) throw Error("content", "argument", "motion quality: frame time must be > 0");
  return std::max(1, static_cast<int>(std::lround(window_s / 2 / frame_time_s)));
}

SpeedStats joint_speeds(const JointTrack& track, FrameRange range, double scale) {
  range = clamp_range(track, range);
  SpeedStats out;
  std::vector<double> v;
  const int n = track.joint_count();
  out.joint_max_mps.assign(static_cast<std::size_t>(n), 0.0);
  for (int f = range.first + 1; f <= range.last; ++f) {
    for (int j = 0; j < n; ++j) {
      if (track.skeleton->end_site[static_cast<std::size_t>(j)]) continue;
      const double s = (track.at(f, j) - track.at(f - 1, j)).norm() / track.frame_time_s * scale;
      v.push_back(s);
      out.joint_max_mps[static_cast<std::size_t>(j)] = std::max(out.joint_max_mps[static_cast<std::size_t>(j)], s);
      if (s > out.max_mps || out.max_joint < 0) {
        out.max_mps = s;
        out.max_joint = j;
        out.max_frame = f;
      }
    }
  }
  std::sort(v.begin(), v.end());
  out.p50_mps = percentile_sorted(v, 50);
  out.p99_mps = percentile_sorted(v, 99);
  out.samples = static_cast<int>(v.size());
  return out;
}

std::vector<Snap> find_snaps(const JointTrack& track, FrameRange range, const SnapOptions& o) {
  range = clamp_range(track, range);
  std::vector<Snap> out;
  const int n = track.joint_count();
  // step(f) = p(f) - p(f-1): judged for f in [first+1, last]; its neighbours are the track's
  // own steps, inside the range or not (a step at the range's end is judged against the step
  // after it, where the track has one: missing, it counted as no neighbour, and a knee speeding
  // up over the last compared frame read as a one-frame jump the whole BVH does not have).
  auto step = [&](int f, int j) -> Vector3d {
    if (f < 1 || f >= track.frame_count) return Vector3d::Constant(kNaN);
    return track.at(f, j) - track.at(f - 1, j);
  };
  auto len = [](const Vector3d& v) { return v.allFinite() ? v.norm() : kNaN; };
  // A missing neighbour (NaN) never counts against the step.
  auto above = [&](double s, double neighbour) { return std::isnan(neighbour) || s > o.ratio * neighbour; };
  for (int j = 0; j < n; ++j) {
    if (track.skeleton->end_site[static_cast<std::size_t>(j)]) continue;
    for (int f = range.first + 1; f <= range.last; ++f) {
      const Vector3d d = step(f, j);
      const double s = d.norm();
      const double prev = len(step(f - 1, j)), next = len(step(f + 1, j));
      Snap snap{f, j, s, 'a'};
      if (s / track.frame_time_s > o.max_speed_mps) {
        out.push_back(snap);
        continue;
      }
      if (s > o.min_step_m && above(s, prev) && above(s, next)) {
        snap.rule = 'b';
        out.push_back(snap);
        continue;
      }
      const Vector3d dn = step(f + 1, j);
      if (s > o.min_step_m && dn.allFinite() && dn.norm() > o.min_step_m && d.dot(dn) < -0.5 * s * dn.norm()) {
        const double after = len(step(f + 2, j));
        if (above(s, prev) && above(dn.norm(), prev) && above(s, after) && above(dn.norm(), after)) {
          snap.rule = 'c';
          out.push_back(snap);
        }
      }
    }
  }
  std::sort(out.begin(), out.end(), [](const Snap& a, const Snap& b) {
    return a.frame != b.frame ? a.frame < b.frame : a.joint < b.joint;
  });
  return out;
}

Vector3d foot_point(const JointTrack& track, int side, int frame) {
  const Skeleton& s = *track.skeleton;
  const int ankle = require(s, side == kLeft ? CJ::l_ankle : CJ::r_ankle);
  const int toe = require(s, side == kLeft ? CJ::l_toe : CJ::r_toe);
  return 0.5 * (track.at(frame, ankle) + track.at(frame, toe));
}

double foot_speed(const JointTrack& track, int side, int frame, int h, bool horizontal) {
  if (frame - h < 0 || frame + h >= track.frame_count) return kNaN;
  Vector3d d = foot_point(track, side, frame + h) - foot_point(track, side, frame - h);
  if (horizontal) d.y() = 0;
  return d.norm() / (2 * h * track.frame_time_s);
}

FootContacts detect_foot_contacts(const JointTrack& track, const ContactOptions& o, FrameRange level_range) {
  if (level_range.last < level_range.first) level_range = {0, track.frame_count - 1};
  level_range = clamp_range(track, level_range);
  const Skeleton& s = *track.skeleton;
  FootContacts c;
  const int h = speed_half_window(track.frame_time_s, o.window_s);
  for (int side = 0; side < 2; ++side) {
    const int ankle = require(s, side == kLeft ? CJ::l_ankle : CJ::r_ankle);
    const int toe = require(s, side == kLeft ? CJ::l_toe : CJ::r_toe);
    const auto si = static_cast<std::size_t>(side);
    double fa = std::numeric_limits<double>::infinity(), ft = fa;
    for (int f = level_range.first; f <= level_range.last; ++f) {
      fa = std::min(fa, track.at(f, ankle).y());
      ft = std::min(ft, track.at(f, toe).y());
    }
    c.ankle_floor_m[si] = fa;
    c.toe_floor_m[si] = ft;
    c.contact[si].assign(static_cast<std::size_t>(track.frame_count), 0);
    for (int f = 0; f < track.frame_count; ++f) {
      const bool low = track.at(f, ankle).y() <= fa + o.height_tolerance_m && track.at(f, toe).y() <= ft + o.height_tolerance_m;
      if (!low) continue;
      // Near the ends the window is shortened to what exists.
      const int a = std::max(0, f - h), b = std::min(track.frame_count - 1, f + h);
      double speed = 0;
      if (b > a) {
        Vector3d d = foot_point(track, side, b) - foot_point(track, side, a);
        d.y() = 0;
        speed = d.norm() / ((b - a) * track.frame_time_s);
      }
      if (speed < o.max_speed_mps) {
        c.contact[si][static_cast<std::size_t>(f)] = 1;
      } else {
        ++c.low_fast_frames[si];
      }
    }
  }
  return c;
}

namespace {
/// Foot speed over the frames `take(f)` selects (whole window of `h` frames either side inside
/// `range`): the fastest (and where), p50, p95 and the count.
template <typename Take>
FootFigure foot_figure(const JointTrack& track, int side, FrameRange range, int h, double scale, bool horizontal,
                       Take take) {
  range = clamp_range(track, range);
  FootFigure out{kNaN, -1, 0, kNaN, kNaN};
  std::vector<double> all_v;
  for (int f = range.first + h; f <= range.last - h; ++f) {
    if (!take(f)) continue;
    const double v = foot_speed(track, side, f, h, horizontal) * scale;
    if (std::isnan(v)) continue;
    ++out.frames;
    all_v.push_back(v);
    if (std::isnan(out.max_mps) || v > out.max_mps) {
      out.max_mps = v;
      out.frame = f;
    }
  }
  std::sort(all_v.begin(), all_v.end());
  out.p50_mps = all_v.empty() ? kNaN : percentile_sorted(all_v, 50);
  out.p95_mps = all_v.empty() ? kNaN : percentile_sorted(all_v, 95);
  return out;
}
bool in_contact(std::span<const std::uint8_t> contact, int f) {
  return f >= 0 && static_cast<std::size_t>(f) < contact.size() && contact[static_cast<std::size_t>(f)];
}
}  // namespace

FootFigure support_foot_slide(const JointTrack& track, int side, std::span<const std::uint8_t> contact,
                              FrameRange range, int h, double scale) {
  // Horizontal speed over frames whose whole window is in contact.
  return foot_figure(track, side, range, h, scale, true, [&](int f) {
    for (int k = f - h; k <= f + h; ++k)
      if (!in_contact(contact, k)) return false;
    return true;
  });
}

FootFigure stepping_foot_peak(const JointTrack& track, int side, std::span<const std::uint8_t> contact,
                              FrameRange range, int h, double scale) {
  // 3-D speed over frames not in contact.
  return foot_figure(track, side, range, h, scale, false, [&](int f) { return !in_contact(contact, f); });
}

LimbAtContact limb_at_contact(const JointTrack& track, const Effector& e, int frame, const Vector3d& target,
                              int h) {
  const Skeleton& s = *track.skeleton;
  const Limb l = limb_of(e.side, e.leg);
  const int r = require(s, l.root), m = require(s, l.mid), en = require(s, l.end);
  const Vector3d pr = track.at(frame, r), pm = track.at(frame, m), pe = track.at(frame, en);
  LimbAtContact out;
  out.extension = (pe - pr).norm() / std::max(1e-9, (pm - pr).norm() + (pe - pm).norm());
  const Vector3d to_target = target - pr;
  const Vector3d u = to_target.norm() > 1e-9 ? Vector3d(to_target.normalized()) : Vector3d::UnitZ();
  out.end_ahead_m = (pe - pm).dot(u);
  if (!e.leg) {
    const int head = require(s, CJ::head);
    out.elbow_above_head = pm.y() > track.at(frame, head).y();
  }
  out.folded = out.end_ahead_m < 0 || out.elbow_above_head;
  const int back = std::max(0, frame - h);
  if (back < frame) {
    const Vector3d v = (pe - track.at(back, en)) / ((frame - back) * track.frame_time_s);
    out.approach_elevation_deg = std::atan2(v.y(), Eigen::Vector2d(v.x(), v.z()).norm()) * 180 / std::numbers::pi;
    const Vector3d line = pe - pr;
    out.approach_above_line_deg =
        out.approach_elevation_deg - std::atan2(line.y(), Eigen::Vector2d(line.x(), line.z()).norm()) * 180 / std::numbers::pi;
  }
  const int lookback = static_cast<int>(std::lround(0.1 / track.frame_time_s));
  for (int f = std::max(1, frame - lookback); f <= frame; ++f) {
    const int b0 = std::max(0, f - h);
    const Vector3d v = (track.at(f, en) - track.at(b0, en)) / ((f - b0) * track.frame_time_s);
    if (v.norm() <= 1.0) continue;
    out.approach_max_elevation_deg = std::max(
        out.approach_max_elevation_deg, std::atan2(v.y(), Eigen::Vector2d(v.x(), v.z()).norm()) * 180 / std::numbers::pi);
  }
  out.end_to_target_m = (pe - target).norm();
  return out;
}

namespace {
// Calls visit(frame, side, leg, worst turn in the window) for every frame where the limb has
// a bend plane and an earlier frame within the window has one too.
template <class Visit>
void scan_limb_turns(const JointTrack& track, FrameRange range, const FlipOptions& o, Visit visit) {
  range = clamp_range(track, range);
  const double min_sin = std::sin(o.min_bend_deg * std::numbers::pi / 180);
  const int back = std::max(1, static_cast<int>(std::lround(o.window_s / track.frame_time_s)));
  for (int leg = 0; leg < 2; ++leg) {
    for (int side = 0; side < 2; ++side) {
      const Limb l = limb_of(side, leg != 0);
      const Skeleton& s = *track.skeleton;
      const int r = require(s, l.root), m = require(s, l.mid), e = require(s, l.end);
      // Unit bend-plane normal, or NaN when the limb is (nearly) straight.
      auto normal = [&](int f) -> Vector3d {
        const Vector3d a = track.at(f, m) - track.at(f, r), b = track.at(f, e) - track.at(f, m);
        const Vector3d n = a.cross(b);
        const double denom = a.norm() * b.norm();
        if (denom < 1e-12 || n.norm() / denom < min_sin) return Vector3d::Constant(kNaN);
        return n.normalized();
      };
      for (int f = range.first + 1; f <= range.last; ++f) {
        const Vector3d nf = normal(f);
        if (!nf.allFinite()) continue;
        double worst = -1;
        for (int k = 1; k <= back && f - k >= range.first; ++k) {
          const Vector3d nk = normal(f - k);
          if (!nk.allFinite()) continue;
          worst = std::max(worst, std::acos(std::clamp(nf.dot(nk), -1.0, 1.0)) * 180 / std::numbers::pi);
        }
        if (worst >= 0) visit(f, side, leg != 0, worst, back);
      }
    }
  }
}
}  // namespace

std::vector<LimbFlip> find_limb_flips(const JointTrack& track, FrameRange range, const FlipOptions& o) {
  std::vector<LimbFlip> out;
  scan_limb_turns(track, range, o, [&](int f, int side, bool leg, double worst, int back) {
    if (worst <= o.max_turn_deg) return;
    // One flip per event: skip when this limb was reported within the window.
    if (!out.empty() && out.back().side == side && out.back().leg == leg && out.back().frame >= f - back) return;
    out.push_back({f, side, leg, worst});
  });
  std::stable_sort(out.begin(), out.end(), [](const LimbFlip& a, const LimbFlip& b) { return a.frame < b.frame; });
  return out;
}

std::array<double, 2> max_limb_turn_deg(const JointTrack& track, FrameRange range, const FlipOptions& o) {
  std::array<double, 2> out{0, 0};
  scan_limb_turns(track, range, o, [&](int, int, bool leg, double worst, int) {
    out[leg ? 1 : 0] = std::max(out[leg ? 1 : 0], worst);
  });
  return out;
}

int TrackFigures::knee_flips() const {
  return static_cast<int>(std::count_if(flips.begin(), flips.end(), [](const LimbFlip& f) { return f.leg; }));
}
int TrackFigures::elbow_flips() const {
  return static_cast<int>(std::count_if(flips.begin(), flips.end(), [](const LimbFlip& f) { return !f.leg; }));
}
double TrackFigures::max_slide_mps() const { return nan_max(slide[0].max_mps, slide[1].max_mps); }
double TrackFigures::max_lifted_mps() const { return nan_max(lifted[0].max_mps, lifted[1].max_mps); }
double TrackFigures::max_slide_source_contacts_mps() const {
  return nan_max(slide_source_contacts[0].max_mps, slide_source_contacts[1].max_mps);
}
double TrackFigures::max_stepping_mps() const { return nan_max(stepping[0].max_mps, stepping[1].max_mps); }

TrackFigures track_figures(const JointTrack& track, FrameRange range, const FootContacts& contacts, double scale,
                           const FigureOptions& o) {
  TrackFigures t;
  t.speed = joint_speeds(track, range, scale);
  t.snaps = find_snaps(track, range, o.snaps);
  const int h = speed_half_window(track.frame_time_s, o.window_s);
  for (int side = 0; side < 2; ++side) {
    const auto si = static_cast<std::size_t>(side);
    t.slide[si] = support_foot_slide(track, side, contacts.contact[si], range, h, scale);
    t.stepping[si] = o.stepping_feet[si] ? stepping_foot_peak(track, side, contacts.contact[si], range, h, scale)
                                         : FootFigure{kNaN, -1, 0, kNaN, kNaN};
  }
  t.flips = find_limb_flips(track, range, o.flips);
  t.max_turn_deg = max_limb_turn_deg(track, range, o.flips);
  return t;
}

std::vector<StrikeCase> quality_grid(std::span<const Rig> characters, int targets_per_order) {
  std::vector<StrikeCase> out;
  const OrderKind orders[4] = {OrderKind::punch_left, OrderKind::punch_right, OrderKind::kick_left,
                               OrderKind::kick_right};
  const double golden = 0.6180339887498949;
  for (std::size_t c = 0; c < characters.size(); ++c) {
    const Rig& rig = characters[c];
    const double stature = rig.morphology.height_m;
    // The rest pose is decoded with the root at the origin: heights count from its lowest foot
    // joint (morphology.height_m is the head above it).
    const double head_y = rig.morphology.height_m;
    for (OrderKind order : orders) {
      const bool kick = order == OrderKind::kick_left || order == OrderKind::kick_right;
      for (int i = 0; i < targets_per_order; ++i) {
        const double u = targets_per_order > 1 ? static_cast<double>(i) / (targets_per_order - 1) : 0.5;
        const double w = std::fmod((i + 1) * golden, 1.0);  // 0..1, low discrepancy
        StrikeCase sc;
        sc.character = static_cast<int>(c);
        sc.order = order;
        sc.target_m = Vector3d((w - 0.5) * 0.20 * stature, kick ? head_y - 0.45 : head_y, (0.45 + 0.20 * u) * stature);
        out.push_back(sc);
      }
    }
  }
  return out;
}

std::vector<FrameRange> both_feet_off(const JointTrack& track, FrameRange range, const FootContacts& levels,
                                      double tolerance_m) {
  range = clamp_range(track, range);
  std::vector<FrameRange> out;
  if (range.count() <= 0) return out;
  const Skeleton& sk = *track.skeleton;
  const int joints[4] = {require(sk, CJ::l_ankle), require(sk, CJ::l_toe), require(sk, CJ::r_ankle), require(sk, CJ::r_toe)};
  const double lowest[4] = {levels.ankle_floor_m[0], levels.toe_floor_m[0], levels.ankle_floor_m[1], levels.toe_floor_m[1]};
  for (int f = range.first; f <= range.last; ++f) {
    bool off = true;
    for (int k = 0; k < 4 && off; ++k) off = track.at(f, joints[k]).y() > lowest[k] + tolerance_m;
    if (!off) continue;
    if (!out.empty() && out.back().last == f - 1) {
      out.back().last = f;
    } else {
      out.push_back({f, f});
    }
  }
  return out;
}

std::vector<int> both_feet_off_source_down(std::span<const FrameRange> off, int first_frame,
                                           std::span<const std::array<double, 2>> source_planted, int slack) {
  const int n = static_cast<int>(source_planted.size());
  const auto source_off = [&](int g) {
    const auto& p = source_planted[static_cast<std::size_t>(g)];
    return p[0] < 0.5 && p[1] < 0.5;
  };
  std::vector<int> out;
  for (const FrameRange& r : off)
    for (int k = r.first; k <= r.last; ++k) {
      const int g = first_frame + k;
      bool own = false;
      for (int j = std::max(0, g - slack); j <= std::min(n - 1, g + slack) && !own; ++j) own = source_off(j);
      if (!own) out.push_back(k);
    }
  return out;
}

std::vector<Vector3d> lay_on_bones(const JointTrack& source, const Skeleton& bones, double root_scale, FrameRange range) {
  const Skeleton& s = *source.skeleton;
  if (s.parents != bones.parents || s.end_site != bones.end_site ||
      bones.offsets.size() != static_cast<std::size_t>(bones.joint_count()))
    return {};
  for (int j = 0; j < s.joint_count(); ++j)
    if (s.parents[static_cast<std::size_t>(j)] >= j) return {};  // a parent after its child: not a BVH order
  range = clamp_range(source, range);
  const int n = source.joint_count();
  std::vector<Vector3d> out(static_cast<std::size_t>(source.frame_count) * static_cast<std::size_t>(n), Vector3d::Zero());
  for (int f = range.first; f <= range.last; ++f) {
    const std::size_t row = static_cast<std::size_t>(f) * static_cast<std::size_t>(n);
    for (int j = 0; j < n; ++j) {
      const int p = s.parents[static_cast<std::size_t>(j)];
      if (p < 0) {
        out[row + static_cast<std::size_t>(j)] = source.at(f, j) * root_scale;
        continue;
      }
      // Parents come before their children in a BVH's joint order.
      const Vector3d d = source.at(f, j) - source.at(f, p);
      const double len = d.norm();
      const Vector3d u = len > 1e-9 ? Vector3d(d / len) : Vector3d::Zero();
      out[row + static_cast<std::size_t>(j)] =
          out[row + static_cast<std::size_t>(p)] + u * bones.offsets[static_cast<std::size_t>(j)].norm();
    }
  }
  return out;
}

StrikeQuality compare_strike(const StrikeComparisonInput& in, const FigureOptions& options) {
  const JointTrack& out = *in.output;
  const JointTrack& src = *in.source;
  if (std::abs(out.frame_time_s - src.frame_time_s) > 1e-6 * src.frame_time_s)
    throw Error("content", "argument",
                fmt::format("motion quality: output frame time {} s differs from the source's {} s", out.frame_time_s,
                            src.frame_time_s));
  StrikeQuality q;
  q.speed_scale = in.speed_scale;
  if (!std::isfinite(in.rate) || in.rate <= 0 || in.rate > 1)
    throw Error("content", "argument", fmt::format("motion quality: playback rate {} is not in (0, 1]", in.rate));
  const auto source_of = [&](int k) {
    const int j = k - in.output_first;
    if (j <= in.rate_lead) return in.source_first + j;
    return in.source_first + in.rate_lead + static_cast<int>(std::lround(in.rate * (j - in.rate_lead)));
  };
  q.output_range = clamp_range(out, {in.output_first, in.output_last});
  q.source_range = {in.source_first, source_of(q.output_range.last)};
  q.source_range = clamp_range(src, q.source_range);
  // Keep both ranges over the same motion (the source may end first).
  while (q.output_range.last > q.output_range.first && source_of(q.output_range.last) > q.source_range.last) --q.output_range.last;
  // Floor levels of the source over the played frames (a long clip's floor is not flat to
  // 1.5 cm everywhere).
  const FootContacts src_contacts = detect_foot_contacts(src, {}, q.source_range);
  // The source's contacts on the output's frames.
  FootContacts mapped;
  for (int side = 0; side < 2; ++side) {
    auto& m = mapped.contact[static_cast<std::size_t>(side)];
    m.assign(static_cast<std::size_t>(out.frame_count), 0);
    for (int k = q.output_range.first; k <= q.output_range.last; ++k) {
      const int sf = source_of(k);
      if (sf >= 0 && sf < src.frame_count) m[static_cast<std::size_t>(k)] = src_contacts.contact[static_cast<std::size_t>(side)][static_cast<std::size_t>(sf)];
    }
  }
  FigureOptions o = options;
  if (in.effector.leg) o.stepping_feet[static_cast<std::size_t>(in.effector.side)] = false;
  q.output = track_figures(out, q.output_range, mapped, 1, o);
  const int h = speed_half_window(out.frame_time_s, o.window_s);
  {
    // The output foot down (ankle or toe near the output's own lowest levels over the
    // compared frames): a source-contact frame with the output foot down is a skate if it
    // moves; with it off the floor, a step the source does not make (`lifted`).
    const ContactOptions co;
    const FootContacts levels = detect_foot_contacts(out, co, q.output_range);  // its floor levels
    for (int side = 0; side < 2; ++side) {
      const auto si = static_cast<std::size_t>(side);
      const int ankle = require(*out.skeleton, side == kLeft ? CJ::l_ankle : CJ::r_ankle);
      const int toe = require(*out.skeleton, side == kLeft ? CJ::l_toe : CJ::r_toe);
      const double fa = levels.ankle_floor_m[si], ft = levels.toe_floor_m[si];
      std::vector<std::uint8_t> down(mapped.contact[si]), up(mapped.contact[si]);
      for (int f = 0; f < out.frame_count; ++f) {
        // Down: heel or toes on the floor (a raised heel still stands on the ball of the foot,
        // and a foot standing on it that moves is skating); lifted: the whole foot in the air.
        const bool low = out.at(f, ankle).y() <= fa + co.down_tolerance_m || out.at(f, toe).y() <= ft + co.down_tolerance_m;
        down[static_cast<std::size_t>(f)] &= low ? 1 : 0;
        up[static_cast<std::size_t>(f)] &= low ? 0 : 1;
      }
      q.output.slide_source_contacts[si] = q.output.slide[si];
      q.output.slide[si] = support_foot_slide(out, side, down, q.output_range, h, 1);
      // Any frame of the window lifted counts (a foot that lifts for a frame or two).
      q.output.lifted[si] = foot_figure(out, side, q.output_range, h, 1, true, [&](int f) {
        bool any = false;
        for (int k = f - h; k <= f + h; ++k) {
          if (!in_contact(mapped.contact[si], k)) return false;
          any = any || in_contact(up, k);
        }
        return any;
      });
    }
  }
  const FootContacts own = detect_foot_contacts(out);
  const auto seconds_off = [](const std::vector<FrameRange>& spans, double ft) {
    int n = 0;
    for (const FrameRange& r : spans) n += r.count();
    return n * ft;
  };
  q.output_both_feet_off_s = seconds_off(both_feet_off(out, q.output_range, own), out.frame_time_s);
  q.source_both_feet_off_s = seconds_off(both_feet_off(src, q.source_range, src_contacts), src.frame_time_s);
  q.both_feet_off_excess_s = q.output_both_feet_off_s - q.source_both_feet_off_s / in.rate;
  for (int side = 0; side < 2; ++side) {
    const int toe = require(*out.skeleton, side == kLeft ? CJ::l_toe : CJ::r_toe);
    for (int f = q.output_range.first; f <= q.output_range.last; ++f)
      q.toe_below_standing_m = std::max(q.toe_below_standing_m, out.at(0, toe).y() - out.at(f, toe).y());
  }
  q.whole = track_figures(out, {0, out.frame_count - 1}, own, 1, o);
  q.tail_range = {q.output_range.last + 1, out.frame_count - 1};
  if (q.tail_range.count() > 0) q.tail = track_figures(out, q.tail_range, own, 1, o);
  q.source = track_figures(src, q.source_range, src_contacts, in.speed_scale, o);
  q.source_speed_leg_scaled = q.source.speed;
  if (const std::vector<Vector3d> laid = lay_on_bones(src, *out.skeleton, in.speed_scale, q.source_range); !laid.empty()) {
    const JointTrack on_bones{out.skeleton, laid, src.frame_count, src.frame_time_s};
    q.source.speed = joint_speeds(on_bones, q.source_range, 1);
    q.source_speed_on_output_bones = true;
  }
  q.output_contact = limb_at_contact(out, in.effector, in.contact_frame, in.target_m, h);
  const int src_contact = std::clamp(source_of(in.contact_frame), 0, src.frame_count - 1);
  const Limb l = limb_of(in.effector.side, in.effector.leg);
  const Vector3d src_end = src.at(src_contact, require(*src.skeleton, l.end));
  q.source_contact = limb_at_contact(src, in.effector, src_contact, src_end, h);
  return q;
}

Clip load_source_clip(const std::string& clip_name, bool mirrored, const std::filesystem::path& motions_dir) {
  const std::filesystem::path path = motions_dir / (clip_name + ".bvh");
  if (!std::filesystem::exists(path))
    throw Error("content", "source",
                fmt::format("{}: no such file (the source clip of database clip '{}')", path.string(), clip_name));
  Clip c = read_bvh(path);
  return mirrored ? mirror_clip(c) : c;
}

Effector effector_of_order(OrderKind order) {
  switch (order) {
    case OrderKind::punch_left: return {kLeft, false};
    case OrderKind::kick_left: return {kLeft, true};
    case OrderKind::kick_right: return {kRight, true};
    default: return {kRight, false};
  }
}

StrikeComparisonInput strike_comparison_input(const Database& db, const StrikeRecording& rec, OrderKind order,
                                              const JointTrack& output, const JointTrack& source,
                                              double output_leg_m, double source_leg_m) {
  if (rec.contact_frame < 0 || rec.strike.plan.segment < 0 ||
      rec.strike.plan.segment >= static_cast<int>(db.segments.size()))
    throw Error("content", "argument", "motion quality: the recording holds no strike");
  const MotionSegment& seg = db.segments[static_cast<std::size_t>(rec.strike.plan.segment)];
  // Played at rate r after `lead` frames at the clip's own rate, the contact comes on the first
  // frame at or past the contact time.
  const double r = rec.strike.rate;
  const int lead = r != 1 ? std::max(0, rec.strike.rate_lead_updates) : 0;
  const auto frames_to = [&](int source_frames) {  // output frames to show that many source frames
    if (source_frames <= lead) return source_frames;
    return lead + static_cast<int>(std::ceil((source_frames - lead) / r - 1e-9));
  };
  const int first = rec.contact_frame - frames_to(rec.strike.plan.contact_frame - rec.strike.plan.start_frame);
  const int seg_last = seg.source_first_frame + seg.frame_count() - 1;
  const int to_last = seg_last - rec.source_start_frame;  // source frames from the start to the segment's end
  const int last_j = to_last <= lead ? to_last : lead + static_cast<int>(std::floor((to_last - lead) / r));
  StrikeComparisonInput in;
  in.output = &output;
  in.source = &source;
  in.output_first = first;
  in.output_last = std::min(output.frame_count - 1, first + last_j);
  in.source_first = rec.source_start_frame;
  in.rate = r;
  in.rate_lead = lead;
  in.contact_frame = rec.contact_frame;
  in.effector = effector_of_order(order);
  in.target_m = rec.strike.target_room_m;
  in.speed_scale = output_leg_m / std::max(1e-9, source_leg_m);
  return in;
}

}  // namespace kumite::content
