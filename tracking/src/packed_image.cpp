#include "kumite/tracking/packed_image.hpp"

#include <algorithm>
#include <array>
#include <cstring>

namespace kumite::tracking {

namespace {
/// Zero gaps shorter than this (pixels) stay inside a run: a run costs 8 bytes of table.
constexpr std::size_t kMinGap = 8;
/// Pack only when the result is at most this fraction of the raw image.
constexpr double kWorthIt = 0.5;
}  // namespace

PackedImage::PackedImage(const cv::Mat& image) {
  if (image.empty()) return;
  if (image.type() != CV_8UC1 || !image.isContinuous()) {
    dense_ = image;
    return;
  }
  const std::size_t n = image.total();
  const std::uint8_t* p = image.ptr<std::uint8_t>();
  // The background level: cameras (and the synthetic recordings) have a black level above 0,
  // so the runs kept are the pixels that differ from the image's most common value.
  {
    std::array<std::size_t, 256> hist{};
    for (std::size_t k = 0; k < n; ++k) ++hist[p[k]];
    background_ = static_cast<std::uint8_t>(std::max_element(hist.begin(), hist.end()) - hist.begin());
  }
  const std::uint8_t bg = background_;
  const std::size_t budget = static_cast<std::size_t>(kWorthIt * static_cast<double>(n));
  std::size_t i = 0;
  while (i < n) {
    while (i < n && p[i] == bg) ++i;
    if (i == n) break;
    const std::size_t begin = i;
    std::size_t end = i;  // one past the last non-zero pixel of the run
    while (i < n) {
      if (p[i] != bg) {
        end = ++i;
        continue;
      }
      std::size_t gap = i;
      while (gap < n && p[gap] == bg && gap - end < kMinGap) ++gap;
      if (gap < n && p[gap] != bg && gap - end < kMinGap) {
        i = gap;  // a short gap: the run goes on
      } else {
        break;
      }
    }
    runs_.push_back(static_cast<std::uint32_t>(begin));
    runs_.push_back(static_cast<std::uint32_t>(end - begin));
    pixels_.insert(pixels_.end(), p + begin, p + end);
    if (pixels_.size() + 4 * runs_.size() > budget) {  // would not pay: keep it as it is
      runs_.clear();
      pixels_.clear();
      dense_ = image;
      return;
    }
    i = end;
  }
  rows_ = image.rows;
  cols_ = image.cols;
  runs_.shrink_to_fit();
  pixels_.shrink_to_fit();
}

cv::Mat PackedImage::unpack() const {
  if (!dense_.empty()) return dense_;
  if (rows_ == 0) return {};
  cv::Mat out(rows_, cols_, CV_8UC1, cv::Scalar(background_));
  std::uint8_t* p = out.ptr<std::uint8_t>();
  const std::uint8_t* src = pixels_.data();
  for (std::size_t r = 0; r + 1 < runs_.size(); r += 2) {
    std::memcpy(p + runs_[r], src, runs_[r + 1]);
    src += runs_[r + 1];
  }
  return out;
}

std::size_t PackedImage::bytes() const {
  if (!dense_.empty()) return dense_.total() * dense_.elemSize();
  return pixels_.size() + runs_.size() * sizeof(std::uint32_t);
}

}  // namespace kumite::tracking
