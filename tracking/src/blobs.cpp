#include "kumite/tracking/blobs.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "kumite/common/error.hpp"

namespace kumite::tracking {
namespace {

constexpr std::uint64_t kOnes = 0x0101010101010101ULL;
constexpr std::uint64_t kHigh = 0x8080808080808080ULL;

/// Non-zero when any of the 8 bytes in `word` is > t (exact for every t in 0..254: the low 7
/// bits are added to a constant without carrying into the next byte).
inline std::uint64_t any_above(std::uint64_t word, int t) {
  const std::uint64_t low = word & ~kHigh;
  if (t < 128) return ((low + kOnes * static_cast<std::uint64_t>(127 - t)) | word) & kHigh;
  return (low + kOnes * static_cast<std::uint64_t>(255 - t)) & word & kHigh;
}

}  // namespace

BlobDetector::BlobDetector(BlobParams params) : params_(params) {}

const std::vector<Blob>& BlobDetector::detect(const cv::Mat& grey) {
  if (grey.type() != CV_8UC1) {
    throw Error("blobs", "format", "blob detection needs an 8-bit single-channel image");
  }
  blobs_.clear();
  stats_ = {};
  if (grey.empty()) return blobs_;
  if (grey.cols != width_ || grey.rows != height_) {
    width_ = grey.cols;
    height_ = grey.rows;
    visited_.assign(static_cast<std::size_t>(width_) * height_, 0);
  }
  const int t = std::clamp(params_.threshold, 0, 254);
  const int step = std::max(1, params_.seed_row_step);
  for (int row = step / 2; row < height_; row += step) {
    const std::uint8_t* p = grey.ptr<std::uint8_t>(row);
    int col = 0;
    for (; col + 8 <= width_; col += 8) {
      std::uint64_t w;
      std::memcpy(&w, p + col, 8);
      if (!any_above(w, t)) continue;
      for (int k = col; k < col + 8; ++k) {
        const int idx = row * width_ + k;
        if (p[k] > t && !visited_[idx]) grow(grey, idx);
      }
    }
    for (; col < width_; ++col) {
      const int idx = row * width_ + col;
      if (p[col] > t && !visited_[idx]) grow(grey, idx);
    }
  }
  for (int idx : touched_) visited_[idx] = 0;
  touched_.clear();
  return blobs_;
}

void BlobDetector::grow(const cv::Mat& grey, int seed) {
  const int t = std::clamp(params_.threshold, 0, 254);
  // Moments relative to the seed keep the sums small and exact enough in double.
  const int sx = seed % width_;
  const int sy = seed / width_;
  double w0 = 0, wx = 0, wy = 0, wxx = 0, wyy = 0, wxy = 0;
  int area = 0;
  int peak = 0;
  stack_.clear();
  stack_.push_back(seed);
  visited_[seed] = 1;
  touched_.push_back(seed);
  while (!stack_.empty()) {
    const int idx = stack_.back();
    stack_.pop_back();
    const int x = idx % width_;
    const int y = idx / width_;
    const int v = grey.ptr<std::uint8_t>(y)[x];
    const double w = v - t;
    const double dx = x - sx, dy = y - sy;
    w0 += w;
    wx += w * dx;
    wy += w * dy;
    wxx += w * dx * dx;
    wyy += w * dy * dy;
    wxy += w * dx * dy;
    ++area;
    peak = std::max(peak, v);
    // 8-connected neighbours above the threshold.
    for (int ny = std::max(0, y - 1); ny <= std::min(height_ - 1, y + 1); ++ny) {
      const std::uint8_t* row = grey.ptr<std::uint8_t>(ny);
      for (int nx = std::max(0, x - 1); nx <= std::min(width_ - 1, x + 1); ++nx) {
        const int n = ny * width_ + nx;
        if (row[nx] > t && !visited_[n]) {
          visited_[n] = 1;
          touched_.push_back(n);
          stack_.push_back(n);
        }
      }
    }
  }
  if (area < params_.min_area) {
    ++stats_.too_small;
    return;
  }
  if (area > params_.max_area) {
    ++stats_.too_large;
    return;
  }
  const double mx = wx / w0, my = wy / w0;
  // Central second moments; a single pixel has variance 1/12 along each axis.
  const double cxx = wxx / w0 - mx * mx + 1.0 / 12.0;
  const double cyy = wyy / w0 - my * my + 1.0 / 12.0;
  const double cxy = wxy / w0 - mx * my;
  const double tr = cxx + cyy;
  const double disc = std::sqrt(std::max(0.0, 0.25 * (cxx - cyy) * (cxx - cyy) + cxy * cxy));
  const double major = 0.5 * tr + disc;
  const double minor = 0.5 * tr - disc;
  const double roundness = major > 0 ? std::sqrt(std::max(0.0, minor) / major) : 0.0;
  if (roundness < params_.min_roundness) {
    ++stats_.not_round;
    return;
  }
  if (static_cast<int>(blobs_.size()) >= params_.max_blobs) {
    ++stats_.over_limit;
    return;
  }
  blobs_.push_back(Blob{sx + mx, sy + my, static_cast<double>(area), roundness, w0, peak});
}

std::vector<Blob> detect_blobs(const cv::Mat& grey, const BlobParams& params) {
  BlobDetector detector(params);
  return detector.detect(grey);
}

// ---------------------------------------------------------------------------------------
// StaticMask

void StaticMask::update(std::span<const Blob> blobs, std::span<const std::uint8_t> used,
                        Timestamp t) {
  const double still2 = params_.still_px * params_.still_px;
  for (std::size_t i = 0; i < blobs.size(); ++i) {
    if (i < used.size() && used[i]) continue;
    const Blob& b = blobs[i];
    const double radius = std::sqrt(b.area / M_PI);
    bool found = false;
    for (auto& c : candidates_) {
      const double dx = b.x - c.x, dy = b.y - c.y;
      if (dx * dx + dy * dy <= still2) {
        c.last_seen = t;
        c.radius = std::max(c.radius, radius);
        found = true;
        break;
      }
    }
    if (!found && candidates_.size() < params_.max_regions) {
      candidates_.push_back(Candidate{b.x, b.y, radius, t, t, false});
    }
  }
  // Blobs used by a body are not static: a candidate under one starts over.
  for (std::size_t i = 0; i < blobs.size() && i < used.size(); ++i) {
    if (!used[i]) continue;
    std::erase_if(candidates_, [&](const Candidate& c) {
      const double dx = blobs[i].x - c.x, dy = blobs[i].y - c.y;
      return !c.is_masked && dx * dx + dy * dy <= still2;
    });
  }
  for (auto& c : candidates_) {
    if (!c.is_masked && c.last_seen >= t && t - c.first_seen >= params_.learn_s) c.is_masked = true;
  }
  std::erase_if(candidates_, [&](const Candidate& c) {
    return !c.is_masked && t - c.last_seen > params_.forget_s;
  });
}

bool StaticMask::masked(double x, double y) const {
  for (const auto& c : candidates_) {
    if (!c.is_masked) continue;
    const double r = c.radius + params_.margin_px;
    const double dx = x - c.x, dy = y - c.y;
    if (dx * dx + dy * dy <= r * r) return true;
  }
  return false;
}

int StaticMask::apply(std::vector<Blob>& blobs) const {
  const auto before = blobs.size();
  std::erase_if(blobs, [&](const Blob& b) { return masked(b.x, b.y); });
  return static_cast<int>(before - blobs.size());
}

std::size_t StaticMask::regions() const {
  return static_cast<std::size_t>(
      std::count_if(candidates_.begin(), candidates_.end(), [](const Candidate& c) { return c.is_masked; }));
}

}  // namespace kumite::tracking
