#include "kumite/content/retrieval.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <cfloat>

namespace kumite::content {

using CJ = CanonicalJoint;

namespace {

constexpr int kMaxClustersPerGroup = 512;  // bounds the stack arrays of retrieve()
constexpr double kInf = std::numeric_limits<double>::infinity();

// Partial distance search: stops (returning a value > limit) once the running sum
// exceeds limit^2, which leaves every decision of the full computation unchanged.
double feature_distance_bounded(const float* a, const float* b, double limit) {
  const double limit2 = limit * limit;
  double s = 0;
  for (int k = 0; k < kFeatureDim; k += 9) {
    for (int j = k; j < k + 9; ++j) {
      const double d = static_cast<double>(a[j]) - static_cast<double>(b[j]);
      s += d * d;
    }
    if (s > limit2) return kInf;  // cannot be within limit
  }
  return std::sqrt(s);
}

double feature_distance(const float* a, const float* b) {
  double s = 0;
  for (int k = 0; k < kFeatureDim; ++k) {
    const double d = static_cast<double>(a[k]) - static_cast<double>(b[k]);
    s += d * d;
  }
  return std::sqrt(s);
}

bool box_contains(const float* box, const Eigen::Vector3f& t, double margin) {
  for (int k = 0; k < 3; ++k) {
    if (t[k] < box[k] - margin || t[k] > box[3 + k] + margin) return false;
  }
  return true;
}

double box_distance(const float* box, const Eigen::Vector3f& t, double margin) {
  double s = 0;
  for (int k = 0; k < 3; ++k) {
    const double lo = box[k] - margin, hi = box[3 + k] + margin;
    const double d = t[k] < lo ? lo - t[k] : (t[k] > hi ? t[k] - hi : 0.0);
    s += d * d;
  }
  return std::sqrt(s);
}

// Distance from a query to a per-dimension feature range (a lower bound of the distance to
// every row of the block).
double aabb_feature_distance(const float* q, const std::array<float, kFeatureDim>& lo,
                             const std::array<float, kFeatureDim>& hi) {
  double s = 0;
  for (std::size_t k = 0; k < static_cast<std::size_t>(kFeatureDim); ++k) {
    const double d = q[k] < lo[k] ? static_cast<double>(lo[k]) - q[k] : (q[k] > hi[k] ? static_cast<double>(q[k]) - hi[k] : 0.0);
    s += d * d;
  }
  return std::sqrt(s);
}

// Full cost of one row (the one definition both searches use).
void row_cost(const RetrievalIndex& ix, int row, const RetrievalQuery& q, const RetrievalTunables& tu,
              double pose_distance, RetrievalChoice& out) {
  const float* w = ix.window.data() + static_cast<std::size_t>(row) * kWindowMax * 3;
  double best = kInf;
  int best_k = 0;
  for (int k = 0; k < ix.window_count[static_cast<std::size_t>(row)]; ++k) {
    const double dx = static_cast<double>(w[3 * k]) - q.target_m.x();
    const double dy = static_cast<double>(w[3 * k + 1]) - q.target_m.y();
    const double dz = static_cast<double>(w[3 * k + 2]) - q.target_m.z();
    const double d2 = dx * dx + dy * dy + dz * dz;
    if (d2 < best) { best = d2; best_k = k; }
  }
  best = std::sqrt(best);  // sqrt is monotonic and correctly rounded: same as the min of sqrts
  out.row = row;
  out.pose_distance = pose_distance;
  out.trajectory_distance_m = best;
  out.window_sample = best_k;
  out.cost = tu.pose_weight * pose_distance + tu.trajectory_weight_per_m * best;
}

bool better(const RetrievalChoice& c, const RetrievalChoice& best) {
  return best.row < 0 || c.cost < best.cost || (c.cost == best.cost && c.row < best.row);
}

const float* row_features(const RetrievalIndex& ix, int row) {
  return ix.features.data() + static_cast<std::size_t>(row) * kFeatureDim;
}
const float* row_box(const RetrievalIndex& ix, int row) {
  return ix.box.data() + static_cast<std::size_t>(row) * 6;
}

// Slack so that float rounding in a lower bound never prunes a cluster holding the optimum.
double slack(double v) { return 1e-6 * (1.0 + std::abs(v)); }

void grow_box(std::array<float, 6>& box, const float* b) {
  for (std::size_t a = 0; a < 3; ++a) {
    box[a] = std::min(box[a], b[a]);
    box[3 + a] = std::max(box[3 + a], b[3 + a]);
  }
}
constexpr std::array<float, 6> kEmptyBox{FLT_MAX, FLT_MAX, FLT_MAX, -FLT_MAX, -FLT_MAX, -FLT_MAX};

// The spatial index (see RetrievalIndex::SpatialBlock): per group, Morton order of the box
// centres over the group's extent, then small and large blocks with their unions of boxes.
void build_spatial_index(RetrievalIndex& ix) {
  ix.spatial_rows.clear();
  ix.spatial_box.clear();
  ix.spatial_small.clear();
  ix.spatial_large.clear();
  constexpr int B = RetrievalIndex::kBlockRows;
  std::vector<std::pair<std::uint32_t, std::int32_t>> keyed;
  for (int g = 0; g < ix.group_count; ++g) {
    ix.group_spatial_large[static_cast<std::size_t>(g)] = static_cast<std::int32_t>(ix.spatial_large.size());
    std::array<float, 6> extent = kEmptyBox;  // of the box centres
    keyed.clear();
    for (int r = 0; r < ix.size; ++r) {
      if (ix.group[static_cast<std::size_t>(r)] != g) continue;
      const float* b = ix.box.data() + static_cast<std::size_t>(r) * 6;
      const float c[6] = {0.5f * (b[0] + b[3]), 0.5f * (b[1] + b[4]), 0.5f * (b[2] + b[5]),
                          0.5f * (b[0] + b[3]), 0.5f * (b[1] + b[4]), 0.5f * (b[2] + b[5])};
      grow_box(extent, c);
      keyed.emplace_back(0u, r);
    }
    for (auto& [code, r] : keyed) {
      const float* b = ix.box.data() + static_cast<std::size_t>(r) * 6;
      code = 0;
      for (std::size_t a = 0; a < 3; ++a) {
        const float lo = extent[a], hi = extent[3 + a];
        const float mid = 0.5f * (b[a] + b[3 + a]);
        const auto qv = static_cast<std::uint32_t>(std::clamp((mid - lo) / std::max(1e-6f, hi - lo), 0.0f, 1.0f) * 1023.0f);
        for (std::uint32_t bit = 0; bit < 10; ++bit) code |= ((qv >> bit) & 1u) << (3 * bit + a);
      }
    }
    std::sort(keyed.begin(), keyed.end());
    const auto row0 = static_cast<std::int32_t>(ix.spatial_rows.size());
    for (const auto& [code, r] : keyed) {
      ix.spatial_rows.push_back(r);
      const float* b = ix.box.data() + static_cast<std::size_t>(r) * 6;
      ix.spatial_box.insert(ix.spatial_box.end(), b, b + 6);
    }
    const auto small0 = static_cast<std::int32_t>(ix.spatial_small.size());
    const auto n = static_cast<std::int32_t>(keyed.size());
    for (std::int32_t i = 0; i < n; i += B) {
      RetrievalIndex::SpatialBlock sb{kEmptyBox, row0 + i, std::min(B, n - i)};
      for (std::int32_t k = sb.first; k < sb.first + sb.count; ++k)
        grow_box(sb.box, ix.spatial_box.data() + static_cast<std::size_t>(k) * 6);
      ix.spatial_small.push_back(sb);
    }
    const auto ns = static_cast<std::int32_t>(ix.spatial_small.size()) - small0;
    for (std::int32_t i = 0; i < ns; i += B) {
      RetrievalIndex::SpatialBlock lb{kEmptyBox, small0 + i, std::min(B, ns - i)};
      for (std::int32_t k = lb.first; k < lb.first + lb.count; ++k)
        grow_box(lb.box, ix.spatial_small[static_cast<std::size_t>(k)].box.data());
      ix.spatial_large.push_back(lb);
    }
  }
  for (int g = ix.group_count; g <= kMaxGroupCount; ++g)
    ix.group_spatial_large[static_cast<std::size_t>(g)] = static_cast<std::int32_t>(ix.spatial_large.size());
}

}  // namespace

void RetrievalIndex::add(int g, std::span<const float> f, std::span<const Eigen::Vector3f> pts, int seg,
                         int start, int wfirst, int wstride) {
  features.insert(features.end(), f.begin(), f.begin() + kFeatureDim);
  const int n = std::min<int>(static_cast<int>(pts.size()), kWindowMax);
  std::array<float, 6> b{FLT_MAX, FLT_MAX, FLT_MAX, -FLT_MAX, -FLT_MAX, -FLT_MAX};
  for (int k = 0; k < kWindowMax; ++k) {
    const Eigen::Vector3f p = pts[static_cast<std::size_t>(std::min(k, n - 1))];
    window.insert(window.end(), {p.x(), p.y(), p.z()});
    if (k < n) {
      for (int a = 0; a < 3; ++a) {
        b[a] = std::min(b[a], p[a]);
        b[3 + a] = std::max(b[3 + a], p[a]);
      }
    }
  }
  window_count.push_back(static_cast<std::uint8_t>(n));
  box.insert(box.end(), b.begin(), b.end());
  segment.push_back(seg);
  start_frame.push_back(start);
  window_first.push_back(wfirst);
  window_stride.push_back(wstride);
  group.push_back(static_cast<std::uint8_t>(g));
  ++size;
}

void RetrievalIndex::build_clusters(int clusters_per_group, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<int> assignment(static_cast<std::size_t>(size), 0);
  std::vector<std::vector<std::array<float, kFeatureDim>>> centroids(static_cast<std::size_t>(group_count));
  for (int g = 0; g < group_count; ++g) {
    std::vector<int> rows;
    for (int r = 0; r < size; ++r) if (group[static_cast<std::size_t>(r)] == g) rows.push_back(r);
    const int n = static_cast<int>(rows.size());
    if (n == 0) continue;
    int k = clusters_per_group > 0 ? clusters_per_group
                                   : static_cast<int>(std::lround(std::sqrt(static_cast<double>(n))));
    k = std::clamp(k, 1, std::min(n, kMaxClustersPerGroup));
    auto& cent = centroids[static_cast<std::size_t>(g)];
    // k-means++ seeding.
    std::vector<double> d2(static_cast<std::size_t>(n), kInf);
    cent.push_back({});
    std::copy_n(row_features(*this, rows[std::uniform_int_distribution<int>(0, n - 1)(rng)]), kFeatureDim,
                cent.back().begin());
    while (static_cast<int>(cent.size()) < k) {
      double total = 0;
      for (int i = 0; i < n; ++i) {
        const double d = feature_distance(row_features(*this, rows[static_cast<std::size_t>(i)]), cent.back().data());
        d2[static_cast<std::size_t>(i)] = std::min(d2[static_cast<std::size_t>(i)], d * d);
        total += d2[static_cast<std::size_t>(i)];
      }
      if (total <= 0) break;  // fewer distinct poses than k
      double pick = std::uniform_real_distribution<double>(0, total)(rng);
      int chosen = n - 1;
      for (int i = 0; i < n; ++i) {
        pick -= d2[static_cast<std::size_t>(i)];
        if (pick <= 0) { chosen = i; break; }
      }
      cent.push_back({});
      std::copy_n(row_features(*this, rows[static_cast<std::size_t>(chosen)]), kFeatureDim, cent.back().begin());
    }
    // Lloyd iterations (a few suffice: clusters only need to be compact, not optimal).
    const int kc = static_cast<int>(cent.size());
    for (int it = 0; it < 8; ++it) {
      bool changed = false;
      for (int r : rows) {
        int best = 0;
        double bd = kInf;
        for (int c = 0; c < kc; ++c) {
          const double d = feature_distance(row_features(*this, r), cent[static_cast<std::size_t>(c)].data());
          if (d < bd) { bd = d; best = c; }
        }
        if (assignment[static_cast<std::size_t>(r)] != best) changed = true;
        assignment[static_cast<std::size_t>(r)] = best;
      }
      std::vector<std::array<double, kFeatureDim>> sum(static_cast<std::size_t>(kc));
      std::vector<int> count(static_cast<std::size_t>(kc), 0);
      for (auto& s : sum) s.fill(0);
      for (int r : rows) {
        const auto c = static_cast<std::size_t>(assignment[static_cast<std::size_t>(r)]);
        const float* f = row_features(*this, r);
        for (int a = 0; a < kFeatureDim; ++a) sum[c][static_cast<std::size_t>(a)] += f[a];
        ++count[c];
      }
      for (std::size_t c = 0; c < sum.size(); ++c) {
        if (count[c] == 0) continue;  // keep an empty cluster's centroid
        for (int a = 0; a < kFeatureDim; ++a)
          cent[c][static_cast<std::size_t>(a)] = static_cast<float>(sum[c][static_cast<std::size_t>(a)] / count[c]);
      }
      if (!changed && it > 0) break;
    }
  }
  // Reorder rows by (group, cluster), keeping the original order within a cluster.
  std::vector<int> order(static_cast<std::size_t>(size));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    const auto ua = static_cast<std::size_t>(a), ub = static_cast<std::size_t>(b);
    return std::pair(group[ua], assignment[ua]) < std::pair(group[ub], assignment[ub]);
  });
  auto permute = [&](auto& v, std::size_t width) {
    auto old = v;
    for (std::size_t i = 0; i < order.size(); ++i)
      std::copy_n(old.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(order[i]) * width), width,
                  v.begin() + static_cast<std::ptrdiff_t>(i * width));
  };
  // Every per-row array, reordered together.
  auto permute_rows = [&] {
    permute(features, kFeatureDim);
    permute(window, kWindowMax * 3);
    permute(window_count, 1);
    permute(box, 6);
    permute(segment, 1);
    permute(start_frame, 1);
    permute(window_first, 1);
    permute(window_stride, 1);
    permute(group, 1);
  };
  permute_rows();
  std::vector<int> sorted_assignment(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) sorted_assignment[i] = assignment[static_cast<std::size_t>(order[i])];

  clusters.clear();
  for (int g = 0; g < group_count; ++g) {
    group_clusters[static_cast<std::size_t>(g)] = static_cast<std::int32_t>(clusters.size());
    for (int r = 0; r < size;) {
      if (group[static_cast<std::size_t>(r)] != g) { ++r; continue; }
      const int c = sorted_assignment[static_cast<std::size_t>(r)];
      Cluster cl;
      cl.first = r;
      while (r < size && group[static_cast<std::size_t>(r)] == g && sorted_assignment[static_cast<std::size_t>(r)] == c) ++r;
      cl.count = r - cl.first;
      cl.centroid = centroids[static_cast<std::size_t>(g)][static_cast<std::size_t>(c)];
      cl.box = {FLT_MAX, FLT_MAX, FLT_MAX, -FLT_MAX, -FLT_MAX, -FLT_MAX};
      for (int m = cl.first; m < cl.first + cl.count; ++m) {
        cl.radius = std::max(cl.radius, static_cast<float>(feature_distance(row_features(*this, m), cl.centroid.data())));
        const float* b = row_box(*this, m);
        for (int a = 0; a < 3; ++a) {
          cl.box[static_cast<std::size_t>(a)] = std::min(cl.box[static_cast<std::size_t>(a)], b[a]);
          cl.box[static_cast<std::size_t>(3 + a)] = std::max(cl.box[static_cast<std::size_t>(3 + a)], b[3 + a]);
        }
      }
      // Round the radius up so float rounding never makes the bound optimistic.
      cl.radius = std::nextafter(cl.radius, FLT_MAX) * (1 + 1e-6f);
      clusters.push_back(cl);
    }
  }
  for (int g = group_count; g <= kMaxGroupCount; ++g) group_clusters[static_cast<std::size_t>(g)] = static_cast<std::int32_t>(clusters.size());

  // Within each cluster: Morton order of the box centres, so blocks are spatially tight.
  std::vector<std::uint32_t> code(static_cast<std::size_t>(size), 0);
  for (const Cluster& cl : clusters) {
    for (int r = cl.first; r < cl.first + cl.count; ++r) {
      const float* b = row_box(*this, r);
      std::uint32_t c = 0;
      for (int a = 0; a < 3; ++a) {
        const float lo = cl.box[static_cast<std::size_t>(a)], hi = cl.box[static_cast<std::size_t>(3 + a)];
        const float mid = 0.5f * (b[a] + b[3 + a]);
        const auto q = static_cast<std::uint32_t>(std::clamp((mid - lo) / std::max(1e-6f, hi - lo), 0.0f, 1.0f) * 1023.0f);
        for (int bit = 0; bit < 10; ++bit) c |= ((q >> bit) & 1u) << (3 * bit + a);
      }
      code[static_cast<std::size_t>(r)] = c;
    }
  }
  std::iota(order.begin(), order.end(), 0);
  for (const Cluster& cl : clusters) {
    std::stable_sort(order.begin() + cl.first, order.begin() + cl.first + cl.count,
                     [&](int a, int b) { return code[static_cast<std::size_t>(a)] < code[static_cast<std::size_t>(b)]; });
  }
  permute_rows();
  build_blocks();
}

void RetrievalIndex::build_blocks() {
  blocks.clear();
  for (Cluster& cl : clusters) {
    cl.block_first = static_cast<std::int32_t>(blocks.size());
    for (int first = cl.first; first < cl.first + cl.count; first += kBlockRows) {
      Block b;
      b.first = first;
      b.count = std::min(kBlockRows, cl.first + cl.count - first);
      b.box = {FLT_MAX, FLT_MAX, FLT_MAX, -FLT_MAX, -FLT_MAX, -FLT_MAX};
      b.fmin.fill(FLT_MAX);
      b.fmax.fill(-FLT_MAX);
      for (int r = b.first; r < b.first + b.count; ++r) {
        const float* rb = row_box(*this, r);
        const float* f = row_features(*this, r);
        for (int a = 0; a < 3; ++a) {
          b.box[static_cast<std::size_t>(a)] = std::min(b.box[static_cast<std::size_t>(a)], rb[a]);
          b.box[static_cast<std::size_t>(3 + a)] = std::max(b.box[static_cast<std::size_t>(3 + a)], rb[3 + a]);
        }
        for (int a = 0; a < kFeatureDim; ++a) {
          b.fmin[static_cast<std::size_t>(a)] = std::min(b.fmin[static_cast<std::size_t>(a)], f[a]);
          b.fmax[static_cast<std::size_t>(a)] = std::max(b.fmax[static_cast<std::size_t>(a)], f[a]);
        }
      }
      blocks.push_back(b);
    }
    cl.block_count = static_cast<std::int32_t>(blocks.size()) - cl.block_first;
  }
  build_spatial_index(*this);
}

RetrievalChoice retrieve_brute_force(const RetrievalIndex& ix, const RetrievalQuery& q,
                                     const RetrievalTunables& tu) {
  bool any_inside = false;
  double min_box = kInf;
  for (int r = 0; r < ix.size; ++r) {
    if (ix.group[static_cast<std::size_t>(r)] != q.group) continue;
    if (box_contains(row_box(ix, r), q.target_m, tu.box_margin_m)) { any_inside = true; break; }
    min_box = std::min(min_box, box_distance(row_box(ix, r), q.target_m, tu.box_margin_m));
  }
  RetrievalChoice best;
  for (int r = 0; r < ix.size; ++r) {
    if (ix.group[static_cast<std::size_t>(r)] != q.group) continue;
    const bool eligible = any_inside ? box_contains(row_box(ix, r), q.target_m, tu.box_margin_m)
                                     : box_distance(row_box(ix, r), q.target_m, tu.box_margin_m) == min_box;
    if (!eligible) continue;
    RetrievalChoice c;
    row_cost(ix, r, q, tu, feature_distance(q.features.data(), row_features(ix, r)), c);
    if (better(c, best)) best = c;
  }
  best.target_in_box = any_inside && best.row >= 0;
  return best;
}

namespace {

// Up to this many eligible rows (boxes holding the target) are costed directly; more go
// through the pose clusters, whose bounds skip most of them. (rows; ~25 ns each)
constexpr std::size_t kDirectRows = 1024;

// Rows of group g whose inflated box holds the target, found through the spatial blocks.
void eligible_rows(const RetrievalIndex& ix, int g, const Eigen::Vector3f& t, double margin,
                   std::vector<std::int32_t>& out, RetrievalStats& st) {
  const auto l0 = ix.group_spatial_large[static_cast<std::size_t>(g)];
  const auto l1 = ix.group_spatial_large[static_cast<std::size_t>(g) + 1];
  for (auto li = l0; li < l1; ++li) {
    const auto& lb = ix.spatial_large[static_cast<std::size_t>(li)];
    if (!box_contains(lb.box.data(), t, margin)) continue;
    for (auto si = lb.first; si < lb.first + lb.count; ++si) {
      const auto& sb = ix.spatial_small[static_cast<std::size_t>(si)];
      if (!box_contains(sb.box.data(), t, margin)) continue;
      ++st.blocks_considered;
      for (auto k = sb.first; k < sb.first + sb.count; ++k)
        if (box_contains(ix.spatial_box.data() + static_cast<std::size_t>(k) * 6, t, margin))
          out.push_back(ix.spatial_rows[static_cast<std::size_t>(k)]);
    }
  }
}

// Rows of group g whose inflated box is nearest the target (none holds it): large blocks
// best-first, then their small blocks, stopping once a bound exceeds the nearest so far.
void nearest_box_rows(const RetrievalIndex& ix, int g, const Eigen::Vector3f& t, double margin,
                      std::vector<std::pair<double, int>>& order, std::vector<std::int32_t>& out,
                      RetrievalStats& st) {
  const auto l0 = ix.group_spatial_large[static_cast<std::size_t>(g)];
  const auto l1 = ix.group_spatial_large[static_cast<std::size_t>(g) + 1];
  order.clear();
  for (auto li = l0; li < l1; ++li) {
    const double lb = box_distance(ix.spatial_large[static_cast<std::size_t>(li)].box.data(), t, margin);
    order.emplace_back(lb - slack(lb), li);
  }
  std::sort(order.begin(), order.end());
  double min_box = kInf;
  for (const auto& [lb, li] : order) {
    if (lb > min_box) break;
    const auto& large = ix.spatial_large[static_cast<std::size_t>(li)];
    for (auto si = large.first; si < large.first + large.count; ++si) {
      const auto& sb = ix.spatial_small[static_cast<std::size_t>(si)];
      const double sd = box_distance(sb.box.data(), t, margin);
      if (sd - slack(sd) > min_box) continue;
      ++st.blocks_visited;
      for (auto k = sb.first; k < sb.first + sb.count; ++k) {
        // The same function on the same floats as the brute force: an exact comparison.
        const double d = box_distance(ix.spatial_box.data() + static_cast<std::size_t>(k) * 6, t, margin);
        if (d > min_box) continue;
        if (d < min_box) {
          min_box = d;
          out.clear();
        }
        out.push_back(ix.spatial_rows[static_cast<std::size_t>(k)]);
      }
    }
  }
}

}  // namespace

RetrievalChoice retrieve(const RetrievalIndex& ix, const RetrievalQuery& q, const RetrievalTunables& tu,
                         RetrievalStats* stats) {
  RetrievalStats local_stats;
  RetrievalStats& st = stats ? *stats : local_stats;
  st = {};
  if (q.group < 0 || q.group >= ix.group_count) return {};
  const int c0 = ix.group_clusters[static_cast<std::size_t>(q.group)];
  const int c1 = ix.group_clusters[static_cast<std::size_t>(q.group) + 1];
  const int nc = c1 - c0;
  RetrievalChoice best;
  if (nc <= 0) return best;
  // (thread_local: no allocation once warmed up.)
  thread_local std::vector<std::int32_t> rows;
  thread_local std::vector<std::pair<double, int>> blocks;

  // One candidate: cheap bounds first, then the partial pose distance against the best.
  auto consider_row = [&](int r) {
    ++st.rows_visited;
    const double tlb = tu.trajectory_weight_per_m * box_distance(row_box(ix, r), q.target_m, 0);
    if (best.row >= 0 && tlb - slack(tlb) > best.cost) return;
    double pd;
    if (best.row >= 0 && tu.pose_weight > 0) {
      const double limit = (best.cost - tlb) / tu.pose_weight + slack(best.cost);
      pd = feature_distance_bounded(q.features.data(), row_features(ix, r), std::max(0.0, limit));
      if (pd > limit) return;  // cannot win or tie
      // pd completed every dimension in the same order as feature_distance(): same value.
    } else {
      pd = feature_distance(q.features.data(), row_features(ix, r));
    }
    ++st.rows_costed;
    RetrievalChoice c;
    row_cost(ix, r, q, tu, pd, c);
    if (better(c, best)) best = c;
  };

  // Which rows' inflated boxes hold the target (the spatial blocks find them)?
  rows.clear();
  eligible_rows(ix, q.group, q.target_m, tu.box_margin_m, rows, st);
  if (rows.empty()) {
    // Fallback: the nearest box(es), then the lowest cost among them.
    nearest_box_rows(ix, q.group, q.target_m, tu.box_margin_m, blocks, rows, st);
    for (int r : rows) {
      ++st.rows_visited;
      ++st.rows_costed;
      RetrievalChoice c;
      row_cost(ix, r, q, tu, feature_distance(q.features.data(), row_features(ix, r)), c);
      if (better(c, best)) best = c;
    }
    best.target_in_box = false;
    return best;
  }
  if (rows.size() <= kDirectRows) {
    // Few: cost them directly, in row order (cluster by cluster, so similar poses come
    // together and the partial distances cut off early once a good one is found).
    std::sort(rows.begin(), rows.end());
    for (int r : rows) consider_row(r);
    best.target_in_box = true;
    return best;
  }

  // Many: the blocks of the pose clusters that may hold eligible rows, best bound first, so
  // a good best cost is found early and the rest are cut off by their bounds.
  std::array<std::pair<double, int>, kMaxClustersPerGroup> order;
  int no = 0;
  for (int c = c0; c < c1; ++c) {
    const auto& cl = ix.clusters[static_cast<std::size_t>(c)];
    if (!box_contains(cl.box.data(), q.target_m, tu.box_margin_m)) continue;
    const double pose_lb = std::max(0.0, feature_distance(q.features.data(), cl.centroid.data()) - cl.radius);
    const double lb = tu.pose_weight * pose_lb + tu.trajectory_weight_per_m * box_distance(cl.box.data(), q.target_m, 0);
    order[static_cast<std::size_t>(no++)] = {lb - slack(lb), c};
  }
  std::sort(order.begin(), order.begin() + no);
  auto visit_block = [&](int bi) {
    const auto& blk = ix.blocks[static_cast<std::size_t>(bi)];
    for (int r = blk.first; r < blk.first + blk.count; ++r)
      if (box_contains(row_box(ix, r), q.target_m, tu.box_margin_m)) consider_row(r);
  };
  auto block_bound = [&](const RetrievalIndex::Block& blk) {
    const double blb = tu.pose_weight * aabb_feature_distance(q.features.data(), blk.fmin, blk.fmax) +
                       tu.trajectory_weight_per_m * box_distance(blk.box.data(), q.target_m, 0);
    return blb - slack(blb);
  };
  // The nearest cluster first, block by block, for an early best cost; then the blocks of
  // the other clusters that can still win, best bound first.
  blocks.clear();
  for (int i = 0; i < no; ++i) {
    if (best.row >= 0 && order[static_cast<std::size_t>(i)].first > best.cost) break;
    const auto& cl = ix.clusters[static_cast<std::size_t>(order[static_cast<std::size_t>(i)].second)];
    ++st.clusters_visited;
    for (int bi = cl.block_first; bi < cl.block_first + cl.block_count; ++bi) {
      const auto& blk = ix.blocks[static_cast<std::size_t>(bi)];
      if (!box_contains(blk.box.data(), q.target_m, tu.box_margin_m)) continue;
      if (i == 0) {
        visit_block(bi);
        continue;
      }
      const double blb = block_bound(blk);
      if (best.row >= 0 && blb > best.cost) continue;
      blocks.emplace_back(blb, bi);
    }
  }
  std::sort(blocks.begin(), blocks.end());
  for (const auto& [blb, bi] : blocks) {
    if (best.row >= 0 && blb > best.cost) break;
    ++st.blocks_visited;
    visit_block(bi);
  }
  best.target_in_box = true;  // rows is not empty: some row was eligible
  return best;
}

RetrievalIndex replicated_index(const RetrievalIndex& base, int copies, double feature_noise,
                                double window_noise_m, std::uint32_t seed, int clusters_per_group) {
  RetrievalIndex out;
  out.group_count = base.group_count;
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0, 1);
  std::array<float, kFeatureDim> f{};
  std::vector<Eigen::Vector3f> pts;
  for (int c = 0; c < copies; ++c) {
    for (int r = 0; r < base.size; ++r) {
      const float* bf = row_features(base, r);
      for (int a = 0; a < kFeatureDim; ++a) f[static_cast<std::size_t>(a)] = bf[a] + static_cast<float>(feature_noise * n01(rng));
      // A different performance of the same strike: the hit window turned about the
      // vertical, scaled and shifted a little.
      const Eigen::Vector3f shift = Eigen::Vector3d(n01(rng), n01(rng), n01(rng)).cast<float>() * static_cast<float>(window_noise_m);
      const float yaw = static_cast<float>(0.17 * n01(rng));  // ~10 degrees
      const float scale = static_cast<float>(1.0 + 0.05 * n01(rng));
      const Eigen::Matrix3f rot = Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitY()).toRotationMatrix();
      pts.clear();
      const float* w = base.window.data() + static_cast<std::size_t>(r) * kWindowMax * 3;
      for (int k = 0; k < base.window_count[static_cast<std::size_t>(r)]; ++k)
        pts.emplace_back(rot * Eigen::Vector3f(w[3 * k], w[3 * k + 1], w[3 * k + 2]) * scale + shift);
      const auto ur = static_cast<std::size_t>(r);
      out.add(base.group[ur], f, pts, base.segment[ur], base.start_frame[ur], base.window_first[ur], base.window_stride[ur]);
    }
  }
  out.build_clusters(clusters_per_group, seed);
  return out;
}

void pose_features(const CanonicalPose& now, const CanonicalPose& before, double dt_s,
                   const GroundFrame& ground, double leg_length_m, double velocity_weight_s,
                   std::span<float> out) {
  static constexpr std::array<CJ, 10> kPos{CJ::chest,  CJ::head,   CJ::l_elbow, CJ::r_elbow, CJ::l_wrist,
                                           CJ::r_wrist, CJ::l_knee, CJ::r_knee,  CJ::l_ankle, CJ::r_ankle};
  static constexpr std::array<CJ, 5> kVel{CJ::pelvis, CJ::l_wrist, CJ::r_wrist, CJ::l_ankle, CJ::r_ankle};
  const double inv_l = 1.0 / leg_length_m;
  std::size_t k = 0;
  for (CJ j : kPos) {
    const Eigen::Vector3d p = ground.to_local(at(now, j)) * inv_l;
    for (int a = 0; a < 3; ++a) out[k++] = static_cast<float>(p[a]);
  }
  const double vscale = dt_s > 0 ? velocity_weight_s / dt_s * inv_l : 0.0;
  for (CJ j : kVel) {
    const Eigen::Vector3d v = (ground.to_local(at(now, j)) - ground.to_local(at(before, j))) * vscale;
    for (int a = 0; a < 3; ++a) out[k++] = static_cast<float>(v[a]);
  }
}

}  // namespace kumite::content
