// Dynamic time warping (open-end for recognition, full with path for template averaging) and
// template building (DTW barycentre averaging from the medoid trial).
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "kumite/common/error.hpp"
#include "kumite/recognition/recognition.hpp"

namespace kumite::recognition {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

inline double cost(const Feature& a, const Feature& b) {
  double s = 0;
  for (int k = 0; k < kFeatureDim; ++k) {
    const double d = static_cast<double>(a[static_cast<std::size_t>(k)]) - b[static_cast<std::size_t>(k)];
    s += d * d;
  }
  return std::sqrt(s);
}
}  // namespace

DtwMatch dtw_open_end(std::span<const Feature> query, std::span<const Feature> templ,
                      std::vector<double>& scratch) {
  DtwMatch best;
  const auto n = static_cast<int>(query.size());
  const auto m = static_cast<int>(templ.size());
  if (n == 0 || m == 0) return best;
  // Two rows of (accumulated cost, path length).
  scratch.resize(static_cast<std::size_t>(4 * m));
  double* prev_c = scratch.data();
  double* prev_l = prev_c + m;
  double* cur_c = prev_l + m;
  double* cur_l = cur_c + m;
  for (int i = 0; i < n; ++i) {
    // Slope limit: template index within [i/2 - 1, 2i + 2] (speeds up to x2 apart).
    const int jlo = std::max(0, i / 2 - 1);
    const int jhi = std::min(m - 1, 2 * i + 2);
    for (int j = 0; j < m; ++j) {
      cur_c[j] = kInf;
      cur_l[j] = 0;
    }
    for (int j = jlo; j <= jhi; ++j) {
      const double c = cost(query[static_cast<std::size_t>(i)], templ[static_cast<std::size_t>(j)]);
      if (i == 0 && j == 0) {
        cur_c[j] = c;
        cur_l[j] = 1;
        continue;
      }
      double bc = kInf, bl = 0;
      auto consider = [&](double cc, double ll) {
        if (cc < kInf && (bc == kInf || cc / ll < bc / bl)) {
          bc = cc;
          bl = ll;
        }
      };
      if (i > 0 && j > 0) consider(prev_c[j - 1], prev_l[j - 1]);
      if (i > 0) consider(prev_c[j], prev_l[j]);
      if (j > 0) consider(cur_c[j - 1], cur_l[j - 1]);
      if (bc < kInf) {
        cur_c[j] = bc + c;
        cur_l[j] = bl + 1;
      }
    }
    std::swap(prev_c, cur_c);
    std::swap(prev_l, cur_l);
  }
  for (int j = 0; j < m; ++j) {
    if (prev_c[j] == kInf) continue;
    const double d = prev_c[j] / prev_l[j];
    if (d < best.distance) {
      best.distance = d;
      best.template_end = j;
    }
  }
  return best;
}

double dtw_full(std::span<const Feature> a, std::span<const Feature> b,
                std::vector<std::pair<int, int>>* path) {
  const auto n = static_cast<int>(a.size());
  const auto m = static_cast<int>(b.size());
  if (n == 0 || m == 0) return kInf;
  std::vector<double> D(static_cast<std::size_t>(n * m), kInf);
  auto at = [&](int i, int j) -> double& { return D[static_cast<std::size_t>(i * m + j)]; };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) {
      const double c = cost(a[static_cast<std::size_t>(i)], b[static_cast<std::size_t>(j)]);
      if (i == 0 && j == 0) {
        at(i, j) = c;
        continue;
      }
      double p = kInf;
      if (i > 0 && j > 0) p = std::min(p, at(i - 1, j - 1));
      if (i > 0) p = std::min(p, at(i - 1, j));
      if (j > 0) p = std::min(p, at(i, j - 1));
      at(i, j) = p + c;
    }
  int i = n - 1, j = m - 1, steps = 1;
  if (path) path->assign(1, {i, j});
  while (i > 0 || j > 0) {
    if (i == 0) {
      --j;
    } else if (j == 0) {
      --i;
    } else {
      const double d = at(i - 1, j - 1), u = at(i - 1, j), l = at(i, j - 1);
      if (d <= u && d <= l) {
        --i;
        --j;
      } else if (u <= l) {
        --i;
      } else {
        --j;
      }
    }
    ++steps;
    if (path) path->push_back({i, j});
  }
  if (path) std::reverse(path->begin(), path->end());
  return at(n - 1, m - 1) / steps;
}

std::vector<Template> build_templates(std::span<const Trial> trials, const RecogniserSettings& rs,
                                      const TrainSettings& s) {
  // (kind, action, style): the style is empty unless templates are kept per style.
  std::map<std::tuple<LimbKind, std::string, std::string>, std::vector<const Trial*>> groups;
  for (const Trial& t : trials) {
    if (t.frames.size() < 2 || t.hit < 0 || t.hit >= static_cast<int>(t.frames.size()))
      throw Error("recognition", "trial", "trial " + t.source + ": fewer than 2 frames or hit outside");
    const bool per_style = s.template_per_style && t.action != kNoneAction && t.kind == LimbKind::hand;
    groups[{t.kind, t.action, per_style ? t.style : std::string()}].push_back(&t);
  }
  std::vector<Template> out;
  std::vector<double> scratch;
  for (const auto& [key, group] : groups) {
    const auto& [kind, action, style] = key;
    if (action == kNoneAction) {
      // Kept one by one (non-strikes have no common shape), evenly thinned.
      const std::size_t keep = std::min<std::size_t>(group.size(), static_cast<std::size_t>(std::max(0, s.max_none_templates)));
      for (std::size_t i = 0; i < keep; ++i) {
        const Trial* tr = group[i * group.size() / keep];
        Template t;
        t.kind = kind;
        t.action = std::string(kNoneAction);
        t.frames.assign(tr->frames.begin(), tr->frames.begin() + std::min<std::ptrdiff_t>(static_cast<std::ptrdiff_t>(tr->frames.size()), s.none_frames));
        t.hit = static_cast<int>(t.frames.size()) - 1;
        t.threshold = 1e6;
        t.trials = 1;
        out.push_back(std::move(t));
      }
      continue;
    }
    const std::size_t k = group.size();
    // Medoid: the trial with the smallest summed DTW distance to the others.
    std::size_t medoid = 0;
    double best = kInf;
    for (std::size_t a = 0; a < k; ++a) {
      double sum = 0;
      for (std::size_t b = 0; b < k; ++b)
        if (a != b) sum += dtw_full(group[a]->frames, group[b]->frames, nullptr);
      if (sum < best) {
        best = sum;
        medoid = a;
      }
    }
    Template t;
    t.kind = kind;
    t.action = action;
    t.frames = group[medoid]->frames;
    t.hit = group[medoid]->hit;
    t.trials = static_cast<int>(k);
    // DTW barycentre averaging: every trial aligned to the current mean, frames averaged.
    std::vector<std::pair<int, int>> path;
    for (int it = 0; it < s.averaging_iterations && k > 1; ++it) {
      std::vector<std::array<double, kFeatureDim>> sum(t.frames.size());
      std::vector<int> count(t.frames.size(), 0);
      for (const Trial* tr : group) {
        dtw_full(t.frames, tr->frames, &path);
        for (auto [i, j] : path) {
          for (int d = 0; d < kFeatureDim; ++d)
            sum[static_cast<std::size_t>(i)][static_cast<std::size_t>(d)] +=
                tr->frames[static_cast<std::size_t>(j)][static_cast<std::size_t>(d)];
          ++count[static_cast<std::size_t>(i)];
        }
      }
      for (std::size_t i = 0; i < t.frames.size(); ++i)
        for (int d = 0; d < kFeatureDim; ++d)
          t.frames[i][static_cast<std::size_t>(d)] =
              static_cast<float>(sum[i][static_cast<std::size_t>(d)] / std::max(1, count[i]));
    }
    // Thresholds: the worst prefix distance of a training trial per buffer length, times the
    // factor, non-decreasing in the length (a trial shorter than n keeps its last distance).
    std::vector<double> worst(static_cast<std::size_t>(rs.max_frames), 0.0);
    for (const Trial* tr : group) {
      double last = 0;
      for (int nq = 1; nq <= rs.max_frames; ++nq) {
        if (nq <= static_cast<int>(tr->frames.size()))
          last = dtw_open_end(std::span(tr->frames).first(static_cast<std::size_t>(nq)), t.frames, scratch).distance;
        worst[static_cast<std::size_t>(nq - 1)] = std::max(worst[static_cast<std::size_t>(nq - 1)], last);
      }
    }
    double run = 1e-3;
    t.thresholds.resize(worst.size());
    for (std::size_t i = 0; i < worst.size(); ++i) {
      run = std::max(run, worst[i]);
      t.thresholds[i] = s.threshold_factor * run;
    }
    t.threshold = t.thresholds.back();
    out.push_back(std::move(t));
  }
  return out;
}

std::vector<Trial> none_trials(std::span<const Frame> frames, Role limb, int frames_per_trial,
                               const RecogniserSettings& s) {
  std::vector<Trial> out;
  if (limb == Role::head) return out;
  const auto l = static_cast<std::size_t>(static_cast<int>(limb) - 1);
  bool collecting = false;
  int slow = 0, nulls = 0;
  Float3 origin{};
  LimbFrame prev{};
  bool prev_valid = false;
  Trial cur;
  for (const Frame& f : frames) {
    const LimbFrame& lf = f.limbs[l];
    if (!lf.valid) {
      collecting = false;
      prev_valid = false;
      continue;
    }
    nulls = lf.speed < s.null_speed ? nulls + 1 : 0;
    slow = lf.speed < s.onset_speed ? slow + 1 : 0;
    if (!collecting) {
      if (lf.speed > s.onset_speed) {
        collecting = true;
        cur = Trial{};
        cur.action = std::string(kNoneAction);
        cur.kind = limb_kind(limb);
        const bool lead = s.lead_frames > 0 && prev_valid;
        origin = lead ? prev.pos : lf.pos;
        cur.frames.clear();
        if (lead) cur.frames.push_back(make_feature(prev, origin, s.absolute_weight));
        cur.frames.push_back(make_feature(lf, origin, s.absolute_weight));
      }
      prev = lf;
      prev_valid = true;
      continue;
    }
    prev = lf;
    prev_valid = true;
    cur.frames.push_back(make_feature(lf, origin, s.absolute_weight));
    const int n = static_cast<int>(cur.frames.size());
    const bool stop = nulls >= s.null_frames || (n > s.main_frames && slow >= s.rearm_frames);
    if (n >= frames_per_trial || stop) {
      if (n >= s.main_frames) {
        cur.hit = n - 1;
        out.push_back(cur);
      }
      collecting = false;
    }
  }
  return out;
}

std::optional<Trial> cut_trial(std::span<const Frame> frames, Role limb, Timestamp first_t,
                               Timestamp hit_t, Timestamp last_t, const RecogniserSettings& s) {
  if (frames.empty() || limb == Role::head) return std::nullopt;
  const auto l = static_cast<std::size_t>(static_cast<int>(limb) - 1);
  auto nearest = [&](Timestamp t) {
    std::size_t best = 0;
    for (std::size_t i = 0; i < frames.size(); ++i)
      if (std::abs(frames[i].t - t) < std::abs(frames[best].t - t)) best = i;
    return best;
  };
  const std::size_t first = nearest(first_t), hit = nearest(hit_t), last = nearest(last_t);
  if (!(first <= hit && hit <= last)) return std::nullopt;
  for (std::size_t i = first; i <= last; ++i)
    if (!frames[i].limbs[l].valid) return std::nullopt;
  // Back from the hit to the loop where the limb last started to move fast.
  std::size_t onset = hit;
  bool found = false;
  for (std::size_t i = hit + 1; i-- > first;) {
    if (frames[i].limbs[l].speed > s.onset_speed) {
      onset = i;
      found = true;
    } else if (found) {
      break;
    }
  }
  if (!found) return std::nullopt;
  Trial t;
  t.kind = limb_kind(limb);
  if (s.lead_frames > 0 && onset > first) onset -= 1;
  const Float3 origin = frames[onset].limbs[l].pos;
  for (std::size_t i = onset; i <= last; ++i) t.frames.push_back(make_feature(frames[i].limbs[l], origin, s.absolute_weight));
  t.hit = static_cast<int>(hit - onset);
  return t;
}

}  // namespace kumite::recognition
