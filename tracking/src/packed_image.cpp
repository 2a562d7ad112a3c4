#include "kumite/tracking/packed_image.hpp"

#include "binary_io.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <type_traits>

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
  // Estimated from every 61st pixel (a prime stride: no alignment with rows): the blobs cover
  // a few percent of an IR image, so the most common grey is found as well, in a fraction of
  // the time (a session recorder packs 240 images a second). Any value would still be exact:
  // the runs keep every pixel that differs from it.
  {
    std::array<std::size_t, 256> hist{};
    for (std::size_t k = 0; k < n; k += 61) ++hist[p[k]];
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

namespace {
using binary::get;
using binary::put;
constexpr std::uint8_t kEmpty = 0, kPacked = 1, kDense = 2;
constexpr std::int64_t kMaxPixels = 1LL << 26;  // 64 Mpx: no camera image is larger
}  // namespace

void PackedImage::append_to(std::string& out) const {
  if (empty()) {
    put<std::uint8_t>(out, kEmpty);
    return;
  }
  if (!dense_.empty()) {
    const cv::Mat m = dense_.isContinuous() ? dense_ : dense_.clone();
    put<std::uint8_t>(out, kDense);
    put<std::int32_t>(out, m.rows);
    put<std::int32_t>(out, m.cols);
    put<std::int32_t>(out, m.type());
    const std::uint64_t bytes = m.total() * m.elemSize();
    put<std::uint64_t>(out, bytes);
    out.append(reinterpret_cast<const char*>(m.data), bytes);
    return;
  }
  put<std::uint8_t>(out, kPacked);
  put<std::int32_t>(out, rows_);
  put<std::int32_t>(out, cols_);
  put<std::uint8_t>(out, background_);
  put<std::uint32_t>(out, static_cast<std::uint32_t>(runs_.size() / 2));
  out.append(reinterpret_cast<const char*>(runs_.data()), runs_.size() * sizeof(std::uint32_t));
  put<std::uint32_t>(out, static_cast<std::uint32_t>(pixels_.size()));
  out.append(reinterpret_cast<const char*>(pixels_.data()), pixels_.size());
}

std::optional<PackedImage> PackedImage::read_from(std::string_view& in, std::string* why) {
  const auto bad = [&](const char* what) -> std::optional<PackedImage> {
    if (why) *why = what;
    return std::nullopt;
  };
  std::uint8_t kind = 0;
  if (!get(in, kind)) return bad("truncated (no image kind)");
  PackedImage img;
  if (kind == kEmpty) return img;
  std::int32_t rows = 0, cols = 0;
  if (!get(in, rows) || !get(in, cols)) return bad("truncated (no image size)");
  if (rows <= 0 || cols <= 0 || static_cast<std::int64_t>(rows) * cols > kMaxPixels) return bad("image size out of range");
  if (kind == kDense) {
    std::int32_t type = 0;
    std::uint64_t bytes = 0;
    if (!get(in, type) || !get(in, bytes)) return bad("truncated (no pixel type)");
    const int depth = CV_MAT_DEPTH(type), channels = CV_MAT_CN(type);
    if (type < 0 || depth > CV_16F || channels < 1 || channels > 4) return bad("unknown pixel type");
    cv::Mat m(rows, cols, type);
    if (bytes != m.total() * m.elemSize()) return bad("pixel bytes do not match the image size");
    if (in.size() < bytes) return bad("truncated (pixels)");
    std::memcpy(m.data, in.data(), bytes);
    in.remove_prefix(bytes);
    img.dense_ = m;
    return img;
  }
  if (kind != kPacked) return bad("unknown image kind");
  std::uint8_t bg = 0;
  std::uint32_t pairs = 0;
  if (!get(in, bg) || !get(in, pairs)) return bad("truncated (no run table)");
  const std::uint64_t n = static_cast<std::uint64_t>(rows) * static_cast<std::uint64_t>(cols);
  if (pairs > n || in.size() < static_cast<std::size_t>(pairs) * 8) return bad("truncated (runs)");
  img.runs_.resize(static_cast<std::size_t>(pairs) * 2);
  std::memcpy(img.runs_.data(), in.data(), img.runs_.size() * sizeof(std::uint32_t));
  in.remove_prefix(img.runs_.size() * sizeof(std::uint32_t));
  std::uint64_t end = 0, total = 0;
  for (std::size_t r = 0; r < img.runs_.size(); r += 2) {
    const std::uint64_t at = img.runs_[r], len = img.runs_[r + 1];
    if (at < end || len == 0 || at + len > n) return bad("runs outside the image or overlapping");
    end = at + len;
    total += len;
  }
  std::uint32_t pixel_bytes = 0;
  if (!get(in, pixel_bytes)) return bad("truncated (no pixel count)");
  if (pixel_bytes != total) return bad("pixel bytes do not match the runs");
  if (in.size() < pixel_bytes) return bad("truncated (pixels)");
  img.pixels_.assign(in.data(), in.data() + pixel_bytes);
  in.remove_prefix(pixel_bytes);
  img.rows_ = rows;
  img.cols_ = cols;
  img.background_ = bg;
  return img;
}

}  // namespace kumite::tracking
