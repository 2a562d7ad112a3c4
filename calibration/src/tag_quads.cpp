#include "kumite/calibration/tag_quads.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <unordered_map>

// Read tag_quads.hpp first: every step below reproduces the apriltag library's quad search
// exactly (integer thresholds, float angle keys, the order points are collected and sorted in,
// float square roots where it takes them), because the corners are compared with the
// library's to 1e-4 px. Where the arithmetic looks odd, that is why.

namespace kumite::calibration {
namespace {

constexpr uint8_t kBlack = 0;
constexpr uint8_t kWhite = 255;
constexpr uint8_t kNoEdge = 127;  // low-contrast pixel: neither black nor white
constexpr int kTile_px = 4;       // threshold statistics per 4x4 tile, spread over 3x3 tiles
constexpr int kMinComponent_px = 25;  // components smaller than this carry no edges

/// Black / white / no-edge image: per tile, the middle of the min and max grey over the 3x3
/// tiles around it.
cv::Mat threshold(const cv::Mat& im, int min_white_black_diff) {
  const int w = im.cols, h = im.rows;
  const int tw = w / kTile_px, th = h / kTile_px;
  cv::Mat tmax(th, tw, CV_8U), tmin(th, tw, CV_8U);
  for (int ty = 0; ty < th; ++ty) {
    for (int tx = 0; tx < tw; ++tx) {
      uint8_t hi = 0, lo = 255;
      for (int dy = 0; dy < kTile_px; ++dy) {
        const uint8_t* row = im.ptr<uint8_t>(ty * kTile_px + dy) + tx * kTile_px;
        for (int dx = 0; dx < kTile_px; ++dx) {
          hi = std::max(hi, row[dx]);
          lo = std::min(lo, row[dx]);
        }
      }
      tmax.at<uint8_t>(ty, tx) = hi;
      tmin.at<uint8_t>(ty, tx) = lo;
    }
  }
  cv::Mat smax(th, tw, CV_8U), smin(th, tw, CV_8U);
  for (int ty = 0; ty < th; ++ty) {
    for (int tx = 0; tx < tw; ++tx) {
      uint8_t hi = 0, lo = 255;
      for (int y = std::max(ty - 1, 0); y <= std::min(ty + 1, th - 1); ++y) {
        for (int x = std::max(tx - 1, 0); x <= std::min(tx + 1, tw - 1); ++x) {
          hi = std::max(hi, tmax.at<uint8_t>(y, x));
          lo = std::min(lo, tmin.at<uint8_t>(y, x));
        }
      }
      smax.at<uint8_t>(ty, tx) = hi;
      smin.at<uint8_t>(ty, tx) = lo;
    }
  }
  cv::Mat out(h, w, CV_8U);
  // Whole tiles: low contrast marks the tile as no-edge.
  for (int ty = 0; ty < th; ++ty) {
    for (int tx = 0; tx < tw; ++tx) {
      const int lo = smin.at<uint8_t>(ty, tx), hi = smax.at<uint8_t>(ty, tx);
      const bool flat = hi - lo < min_white_black_diff;
      const int thresh = lo + (hi - lo) / 2;
      for (int dy = 0; dy < kTile_px; ++dy) {
        const uint8_t* src = im.ptr<uint8_t>(ty * kTile_px + dy) + tx * kTile_px;
        uint8_t* dst = out.ptr<uint8_t>(ty * kTile_px + dy) + tx * kTile_px;
        for (int dx = 0; dx < kTile_px; ++dx) dst[dx] = flat ? kNoEdge : (src[dx] > thresh ? kWhite : kBlack);
      }
    }
  }
  // The partial tiles along the right and bottom borders take the nearest whole tile's
  // statistics and are never marked no-edge.
  for (int y = 0; y < h; ++y) {
    const int x0 = y >= th * kTile_px ? 0 : tw * kTile_px;
    const int ty = std::min(y / kTile_px, th - 1);
    const uint8_t* src = im.ptr<uint8_t>(y);
    uint8_t* dst = out.ptr<uint8_t>(y);
    for (int x = x0; x < w; ++x) {
      const int tx = std::min(x / kTile_px, tw - 1);
      const int lo = smin.at<uint8_t>(ty, tx), hi = smax.at<uint8_t>(ty, tx);
      dst[x] = src[x] > lo + (hi - lo) / 2 ? kWhite : kBlack;
    }
  }
  return out;
}

/// Union-find over pixels, union by size.
class Components {
 public:
  explicit Components(int n) : parent_(static_cast<std::size_t>(n)), size_(static_cast<std::size_t>(n), 1) {
    std::iota(parent_.begin(), parent_.end(), 0);
  }
  uint32_t find(uint32_t a) {
    uint32_t root = a;
    while (parent_[root] != root) root = parent_[root];
    while (parent_[a] != root) {
      const uint32_t next = parent_[a];
      parent_[a] = root;
      a = next;
    }
    return root;
  }
  void join(uint32_t a, uint32_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return;
    if (size_[a] < size_[b]) std::swap(a, b);
    parent_[b] = a;
    size_[a] += size_[b];
  }
  uint32_t size_of_root(uint32_t root) const { return size_[root]; }

 private:
  std::vector<uint32_t> parent_;
  std::vector<uint32_t> size_;
};

/// Same-coloured neighbours joined: white 8-connected, black 4-connected, as the library joins
/// them: from columns 1 .. w-2 only (only leftwards on the first row), and skipping a join
/// upwards when the neighbours already imply it. The skips change nothing inside the image,
/// but the last column is never joined leftwards, so there they leave pixels apart, and the
/// component sizes at the right border depend on them: we skip the same joins.
Components connect(const cv::Mat& t) {
  const int w = t.cols, h = t.rows;
  Components uf(w * h);
  const uint8_t* first = t.ptr<uint8_t>(0);
  for (int x = 1; x < w - 1; ++x) {
    if (first[x] != kNoEdge && first[x - 1] == first[x]) uf.join(static_cast<uint32_t>(x), static_cast<uint32_t>(x - 1));
  }
  for (int y = 1; y < h; ++y) {
    const uint8_t* row = t.ptr<uint8_t>(y);
    const uint8_t* up = t.ptr<uint8_t>(y - 1);
    const auto here = static_cast<uint32_t>(y * w), above = static_cast<uint32_t>((y - 1) * w);
    for (int x = 1; x < w - 1; ++x) {
      const uint8_t v = row[x];
      if (v == kNoEdge) continue;
      const auto ux = static_cast<uint32_t>(x);
      const uint8_t left = row[x - 1], up_left = up[x - 1], up_mid = up[x], up_right = up[x + 1];
      if (left == v) uf.join(here + ux, here + ux - 1);
      if (up_mid == v && (x == 1 || !(left == up_left && up_left == up_mid))) uf.join(here + ux, above + ux);
      if (v == kWhite) {
        if (up_left == v && (x == 1 || !(left == up_left || up_mid == up_left))) uf.join(here + ux, above + ux - 1);
        if (up_right == v && up_mid != up_right) uf.join(here + ux, above + ux + 1);
      }
    }
  }
  return uf;
}

/// A point half-way between a black and a white pixel, in half pixels, with the direction
/// towards white (gx, gy: -255, 0 or 255).
struct EdgePoint {
  uint16_t x2 = 0, y2 = 0;
  int16_t gx = 0, gy = 0;
  float angle_key = 0;  // the library's "slope": sorts the points around the quad's centre
};

/// Edge points grouped by the pair of (black, white) components they separate, each group in
/// scan order (rows, then columns, then the neighbours right, down, down-left, down-right).
std::vector<std::vector<EdgePoint>> edge_clusters(const cv::Mat& t, Components& uf, bool keep_duplicates) {
  const int w = t.cols, h = t.rows;
  // Each pixel's component, or none when the component is too small to carry an edge.
  constexpr uint32_t kNone = UINT32_MAX;
  std::vector<uint32_t> comp(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), kNone);
  for (uint32_t i = 0; i < comp.size(); ++i) {
    const uint32_t r = uf.find(i);
    if (uf.size_of_root(r) >= kMinComponent_px) comp[i] = r;
  }
  std::unordered_map<uint64_t, std::size_t> index;
  std::vector<std::vector<EdgePoint>> clusters;
  uint64_t last_key = UINT64_MAX;  // neighbouring points mostly share a cluster
  std::size_t last_index = 0;
  for (int y = 1; y < h - 1; ++y) {
    // The down-right neighbour pair of pixel x and the down-left pair of pixel x + 1 cross at
    // the same half-way point (in the same cluster): the second is not added again.
    bool down_right_added = false;
    const uint8_t* row = t.ptr<uint8_t>(y);
    for (int x = 1; x < w - 1; ++x) {
      const bool skip_down_left = down_right_added && !keep_duplicates;
      down_right_added = false;
      const uint8_t v0 = row[x];
      if (v0 == kNoEdge) continue;
      const uint32_t rep0 = comp[static_cast<std::size_t>(y * w + x)];
      if (rep0 == kNone) continue;
      auto add = [&](int dx, int dy) {
        const uint8_t v1 = t.ptr<uint8_t>(y + dy)[x + dx];
        if (v0 + v1 != 255) return false;
        const uint32_t rep1 = comp[static_cast<std::size_t>((y + dy) * w + x + dx)];
        if (rep1 == kNone) return false;
        const uint64_t key = rep0 < rep1 ? (uint64_t{rep1} << 32) + rep0 : (uint64_t{rep0} << 32) + rep1;
        if (key != last_key) {
          auto [it, fresh] = index.try_emplace(key, clusters.size());
          if (fresh) clusters.emplace_back();
          last_key = key;
          last_index = it->second;
        }
        EdgePoint p;
        p.x2 = static_cast<uint16_t>(2 * x + dx);
        p.y2 = static_cast<uint16_t>(2 * y + dy);
        p.gx = static_cast<int16_t>(dx * (int{v1} - int{v0}));
        p.gy = static_cast<int16_t>(dy * (int{v1} - int{v0}));
        clusters[last_index].push_back(p);
        return true;
      };
      add(1, 0);
      add(0, 1);
      if (!skip_down_left) add(-1, 1);
      down_right_added = add(1, 1);
    }
  }
  return clusters;
}

/// Sorts by angle_key in the library's order, including the order of ties (which decides the
/// windows of the corner search): sorting networks up to 5 points, above that a merge sort
/// that takes from the second half on a tie. scratch holds n + n/2 + n/4 + ... points
/// (2n + one per level of recursion).
void sort_by_angle(EdgePoint* pts, std::size_t n, EdgePoint* scratch) {
  auto order = [pts](std::size_t a, std::size_t b) {
    if (pts[a].angle_key - pts[b].angle_key > 0) std::swap(pts[a], pts[b]);
  };
  switch (n) {
    case 0:
    case 1:
      return;
    case 2:
      order(0, 1);
      return;
    case 3:
      order(0, 1), order(1, 2), order(0, 1);
      return;
    case 4:
      order(0, 1), order(2, 3), order(0, 2), order(1, 3), order(1, 2);
      return;
    case 5:
      order(0, 1), order(3, 4), order(1, 2), order(0, 1), order(0, 3), order(2, 4), order(1, 2), order(2, 3),
          order(1, 2);
      return;
    default:
      break;
  }
  std::copy(pts, pts + n, scratch);
  const std::size_t na = n / 2, nb = n - na;
  EdgePoint* a = scratch;
  EdgePoint* b = scratch + na;
  sort_by_angle(a, na, scratch + n);
  sort_by_angle(b, nb, scratch + n);
  std::size_t i = 0, j = 0, out = 0;
  while (i < na && j < nb) pts[out++] = a[i].angle_key - b[j].angle_key < 0 ? a[i++] : b[j++];
  while (i < na) pts[out++] = a[i++];
  while (j < nb) pts[out++] = b[j++];
}

/// Cumulative weighted moments of the sorted points: a line fit over any run of them in O(1).
struct Moments {
  double mx = 0, my = 0, mxx = 0, myy = 0, mxy = 0, w = 0;
};

std::vector<Moments> cumulative_moments(const std::vector<EdgePoint>& pts, const cv::Mat& im) {
  std::vector<Moments> m(pts.size());
  Moments acc;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const double x = pts[i].x2 * .5 + 0.5;  // half pixels to apriltag's pixel convention
    const double y = pts[i].y2 * .5 + 0.5;
    const int ix = static_cast<int>(x), iy = static_cast<int>(y);
    double weight = 1;  // the image gradient's magnitude + 1: sharp edge points count more
    if (ix > 0 && ix + 1 < im.cols && iy > 0 && iy + 1 < im.rows) {
      const int gx = im.at<uint8_t>(iy, ix + 1) - im.at<uint8_t>(iy, ix - 1);
      const int gy = im.at<uint8_t>(iy + 1, ix) - im.at<uint8_t>(iy - 1, ix);
      weight = std::sqrt(static_cast<double>(gx * gx + gy * gy)) + 1;
    }
    acc.mx += weight * x;
    acc.my += weight * y;
    acc.mxx += weight * x * x;
    acc.mxy += weight * x * y;
    acc.myy += weight * y * y;
    acc.w += weight;
    m[i] = acc;
  }
  return m;
}

/// apriltag takes these square roots in float.
double sqrt_f(double v) { return static_cast<double>(std::sqrt(static_cast<float>(v))); }

struct LineFit {
  double px = 0, py = 0;  // a point on the line (weighted mean)
  double nx = 0, ny = 0;  // unit normal
  double err = 0;         // sum of squared distances (point count x mse)
  double mse = 0;         // mean squared distance, px^2
};

/// Line through points [i0, i1] (inclusive, wrapping around when i1 < i0).
LineFit fit_line(const std::vector<Moments>& m, int i0, int i1, bool want_line) {
  const int sz = static_cast<int>(m.size());
  Moments s;
  int n = 0;
  if (i0 < i1) {
    n = i1 - i0 + 1;
    s = m[static_cast<std::size_t>(i1)];
    if (i0 > 0) {
      const Moments& b = m[static_cast<std::size_t>(i0 - 1)];
      s.mx -= b.mx, s.my -= b.my, s.mxx -= b.mxx, s.mxy -= b.mxy, s.myy -= b.myy, s.w -= b.w;
    }
  } else {
    const Moments& e = m[static_cast<std::size_t>(sz - 1)];
    const Moments& b = m[static_cast<std::size_t>(i0 - 1)];
    const Moments& c = m[static_cast<std::size_t>(i1)];
    s.mx = e.mx - b.mx, s.my = e.my - b.my, s.mxx = e.mxx - b.mxx;
    s.mxy = e.mxy - b.mxy, s.myy = e.myy - b.myy, s.w = e.w - b.w;
    s.mx += c.mx, s.my += c.my, s.mxx += c.mxx, s.mxy += c.mxy, s.myy += c.myy, s.w += c.w;
    n = sz - i0 + i1 + 1;
  }
  const double ex = s.mx / s.w, ey = s.my / s.w;
  const double cxx = s.mxx / s.w - ex * ex;
  const double cxy = s.mxy / s.w - ex * ey;
  const double cyy = s.myy / s.w - ey * ey;
  // The covariance's eigenvalues: the small one is the mean squared distance to the line.
  const double root = sqrt_f((cxx - cyy) * (cxx - cyy) + 4 * cxy * cxy);
  LineFit f;
  f.mse = 0.5 * (cxx + cyy - root);
  f.err = n * f.mse;
  if (want_line) {
    f.px = ex;
    f.py = ey;
    const double big = 0.5 * (cxx + cyy + root);
    const double nx1 = cxx - big, ny1 = cxy, m1 = nx1 * nx1 + ny1 * ny1;
    const double nx2 = cxy, ny2 = cyy - big, m2 = nx2 * nx2 + ny2 * ny2;
    const bool first = m1 > m2;
    const double len = sqrt_f(first ? m1 : m2);
    f.nx = (first ? nx1 : nx2) / len;
    f.ny = (first ? ny1 : ny2) / len;
  }
  return f;
}

/// The four corner indices: local maxima of a (smoothed) line-fit error along the sorted
/// points, the four that split the points into the best four lines.
bool corner_indices(const std::vector<Moments>& m, const QuadFitParams& prm, std::array<int, 4>& best_idx) {
  const int sz = static_cast<int>(m.size());
  const int ksz = std::min(20, sz / 12);  // half window: about half the shortest edge's points
  if (ksz < 2) return false;
  std::vector<double> errs(static_cast<std::size_t>(sz));
  for (int i = 0; i < sz; ++i) {
    errs[static_cast<std::size_t>(i)] = fit_line(m, (i + sz - ksz) % sz, (i + ksz) % sz, false).err;
  }
  // Low-pass: a Gaussian of sigma 1 point, cut at 5 %: 7 taps.
  const double sigma = 1, cutoff = 0.05;
  const int half = static_cast<int>(std::sqrt(-std::log(cutoff) * 2 * sigma * sigma) + 1);
  const int taps = 2 * half + 1;
  std::vector<float> kernel(static_cast<std::size_t>(taps));
  for (int i = 0; i < taps; ++i) {
    const int j = i - taps / 2;
    kernel[static_cast<std::size_t>(i)] = static_cast<float>(std::exp(-j * j / (2 * sigma * sigma)));
  }
  std::vector<double> smooth(static_cast<std::size_t>(sz));
  for (int k = 0; k < sz; ++k) {
    double acc = 0;
    for (int i = 0; i < taps; ++i) {
      acc += errs[static_cast<std::size_t>((k + i - taps / 2 + sz) % sz)] * kernel[static_cast<std::size_t>(i)];
    }
    smooth[static_cast<std::size_t>(k)] = acc;
  }
  std::vector<int> maxima;
  std::vector<double> maxima_errs;
  for (int i = 0; i < sz; ++i) {
    const double e = smooth[static_cast<std::size_t>(i)];
    if (e > smooth[static_cast<std::size_t>((i + 1) % sz)] && e > smooth[static_cast<std::size_t>((i + sz - 1) % sz)]) {
      maxima.push_back(i);
      maxima_errs.push_back(e);
    }
  }
  if (maxima.size() < 4) return false;
  const int keep = std::max(prm.max_nmaxima, 0);
  if (static_cast<int>(maxima.size()) > keep) {
    std::vector<double> sorted = maxima_errs;
    std::sort(sorted.begin(), sorted.end(), std::greater<>());
    const double keep_above = sorted[static_cast<std::size_t>(keep)];
    std::vector<int> kept;
    for (std::size_t i = 0; i < maxima.size(); ++i) {
      if (maxima_errs[i] > keep_above) kept.push_back(maxima[i]);
    }
    maxima = std::move(kept);
  }
  const int nm = static_cast<int>(maxima.size());
  const double max_dot = prm.cos_critical_rad;
  const double max_mse = prm.max_line_fit_mse;
  double best = static_cast<double>(HUGE_VALF);
  for (int m0 = 0; m0 < nm - 3; ++m0) {
    const int i0 = maxima[static_cast<std::size_t>(m0)];
    for (int m1 = m0 + 1; m1 < nm - 2; ++m1) {
      const int i1 = maxima[static_cast<std::size_t>(m1)];
      const LineFit l01 = fit_line(m, i0, i1, true);
      if (l01.mse > max_mse) continue;
      for (int m2 = m1 + 1; m2 < nm - 1; ++m2) {
        const int i2 = maxima[static_cast<std::size_t>(m2)];
        const LineFit l12 = fit_line(m, i1, i2, true);
        if (l12.mse > max_mse) continue;
        if (std::fabs(l01.nx * l12.nx + l01.ny * l12.ny) > max_dot) continue;
        for (int m3 = m2 + 1; m3 < nm; ++m3) {
          const int i3 = maxima[static_cast<std::size_t>(m3)];
          const LineFit l23 = fit_line(m, i2, i3, false);
          if (l23.mse > max_mse) continue;
          const LineFit l30 = fit_line(m, i3, i0, false);
          if (l30.mse > max_mse) continue;
          const double err = l01.err + l12.err + l23.err + l30.err;
          if (err < best) {
            best = err;
            best_idx = {i0, i1, i2, i3};
          }
        }
      }
    }
  }
  if (best == static_cast<double>(HUGE_VALF)) return false;
  return best / sz < max_mse;
}

/// Corner b - a as the library computes it: float corners subtracted in float.
cv::Point2d float_step(const cv::Point2d& a, const cv::Point2d& b) {
  return {static_cast<double>(static_cast<float>(b.x) - static_cast<float>(a.x)),
          static_cast<double>(static_cast<float>(b.y) - static_cast<float>(a.y))};
}

/// Area of the triangle a, b, c by Heron's formula (as the library computes it).
double heron(const cv::Point2d& a, const cv::Point2d& b, const cv::Point2d& c) {
  auto length = [](const cv::Point2d& u, const cv::Point2d& v) {
    const cv::Point2d d = float_step(u, v);
    return std::sqrt(d.x * d.x + d.y * d.y);
  };
  const double la = length(a, b), lb = length(b, c), lc = length(c, a);
  const double s = (la + lb + lc) / 2;
  return std::sqrt(s * (s - la) * (s - lb) * (s - lc));
}

bool fit_quad(std::vector<EdgePoint>& pts, const cv::Mat& im, const QuadFitParams& prm, TagQuad& quad) {
  if (pts.size() < 24) return false;
  uint16_t xmin = pts[0].x2, xmax = xmin, ymin = pts[0].y2, ymax = ymin;
  for (const auto& p : pts) {
    xmin = std::min(xmin, p.x2), xmax = std::max(xmax, p.x2);
    ymin = std::min(ymin, p.y2), ymax = std::max(ymax, p.y2);
  }
  if (int64_t{xmax - xmin} * int64_t{ymax - ymin} < prm.min_tag_width) return false;
  // The centre is nudged off the half-pixel grid so that fewer points share an angle.
  const float cx = static_cast<float>((xmin + xmax) * 0.5 + 0.05118);
  const float cy = static_cast<float>((ymin + ymax) * 0.5 + -0.028581);
  // Angle key: a quadrant offset plus a slope within the quadrant; monotonic in the angle.
  const float quadrant_offset[2][2] = {{-65536.f, 0.f}, {131072.f, 65536.f}};
  float dot = 0;  // > 0 when the gradients point outwards: white outside, black inside
  for (auto& p : pts) {
    float dx = static_cast<float>(p.x2) - cx;
    float dy = static_cast<float>(p.y2) - cy;
    dot += dx * static_cast<float>(p.gx) + dy * static_cast<float>(p.gy);
    const float offset = quadrant_offset[dy > 0][dx > 0];
    if (dy < 0) {
      dy = -dy;
      dx = -dx;
    }
    if (dx < 0) {
      const float t = dx;
      dx = dy;
      dy = -t;
    }
    p.angle_key = offset + dy / dx;
  }
  if (dot < 0) return false;  // a white square on black: tag36h11 has a black border
  std::vector<EdgePoint> scratch(2 * pts.size() + 64);  // n + n/2 + n/4 + ... + one per level
  sort_by_angle(pts.data(), pts.size(), scratch.data());
  // Drop a point equal to the one sorted before it (3.3.0's duplicates that did end up
  // side by side; nothing to drop without duplicates).
  std::size_t out = 1;
  for (std::size_t i = 1; i < pts.size(); ++i) {
    if (pts[i].x2 != pts[i - 1].x2 || pts[i].y2 != pts[i - 1].y2) {
      if (i != out) pts[out] = pts[i];
      ++out;
    }
  }
  pts.resize(out);
  if (pts.size() < 24) return false;

  const auto moments = cumulative_moments(pts, im);
  std::array<int, 4> idx{};
  if (!corner_indices(moments, prm, idx)) return false;
  std::array<LineFit, 4> lines;
  for (std::size_t i = 0; i < 4; ++i) {
    lines[i] = fit_line(moments, idx[i], idx[(i + 1) & 3], true);
    if (lines[i].mse > prm.max_line_fit_mse) return false;
  }
  for (std::size_t i = 0; i < 4; ++i) {
    // Corner i: lines i and i+1 meet. Directions are the normals turned by 90 degrees.
    const LineFit& a = lines[i];
    const LineFit& b = lines[(i + 1) & 3];
    const double a00 = a.ny, a01 = -b.ny, a10 = -a.nx, a11 = b.nx;
    const double b0 = -a.px + b.px, b1 = -a.py + b.py;
    const double det = a00 * a11 - a10 * a01;
    const double w00 = a11 / det, w01 = -a01 / det;
    if (std::fabs(det) < 0.001) return false;
    const double l0 = w00 * b0 + w01 * b1;
    // The library keeps quad corners in float; its later checks and its output see those.
    quad.p[i] = {static_cast<float>(a.px + l0 * a00), static_cast<float>(a.py + l0 * a10)};
  }
  const double min_area = 0.95 * prm.min_tag_width * prm.min_tag_width;  // px^2, the library's 0.95
  if (heron(quad.p[0], quad.p[1], quad.p[2]) + heron(quad.p[2], quad.p[3], quad.p[0]) < min_area) return false;
  for (std::size_t i = 0; i < 4; ++i) {
    const cv::Point2d d1 = float_step(quad.p[i], quad.p[(i + 1) & 3]);
    const cv::Point2d d2 = float_step(quad.p[(i + 1) & 3], quad.p[(i + 2) & 3]);
    const double cos_turn = (d1.x * d2.x + d1.y * d2.y) / std::sqrt((d1.x * d1.x + d1.y * d1.y) * (d2.x * d2.x + d2.y * d2.y));
    if (cos_turn > prm.cos_critical_rad || cos_turn < -prm.cos_critical_rad || d1.x * d2.y < d1.y * d2.x) return false;
  }
  return true;
}

}  // namespace

std::vector<TagQuad> fit_tag_quads(const cv::Mat& grey, const QuadFitParams& params,
                                   const std::vector<cv::Rect2d>* near) {
  CV_Assert(grey.type() == CV_8U);
  // Too small for one threshold tile around another, or too large for half-pixel uint16
  // coordinates (the library's own limit): no quads.
  if (grey.cols < 2 * kTile_px || grey.rows < 2 * kTile_px || grey.cols >= 32768 || grey.rows >= 32768) return {};
  const cv::Mat t = threshold(grey, params.min_white_black_diff);
  Components uf = connect(t);
  auto clusters = edge_clusters(t, uf, params.keep_diagonal_duplicates);
  const std::size_t too_big = 3 * (2 * static_cast<std::size_t>(grey.cols) + 2 * static_cast<std::size_t>(grey.rows));
  std::vector<TagQuad> quads;
  for (auto& c : clusters) {
    if (c.size() < static_cast<std::size_t>(params.min_cluster_pixels) || c.size() > too_big) continue;
    if (near != nullptr) {
      int x0 = c[0].x2, x1 = x0, y0 = c[0].y2, y1 = y0;
      for (const auto& p : c) x0 = std::min<int>(x0, p.x2), x1 = std::max<int>(x1, p.x2), y0 = std::min<int>(y0, p.y2), y1 = std::max<int>(y1, p.y2);
      const cv::Rect2d box(x0 * 0.5, y0 * 0.5, (x1 - x0) * 0.5 + 1, (y1 - y0) * 0.5 + 1);
      if (std::none_of(near->begin(), near->end(), [&](const cv::Rect2d& r) { return (r & box).area() > 0; })) continue;
    }
    TagQuad q;
    if (fit_quad(c, grey, params, q)) quads.push_back(q);
  }
  return quads;
}

}  // namespace kumite::calibration
