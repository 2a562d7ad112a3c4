#pragma once
// A camera image held losslessly in little memory. Tracking images are dark with a few bright
// blobs, so keeping only the runs of pixels off the background level (the image's most common
// grey: a camera's black level, 0 or a little above) shrinks a 1280x1024 frame (1.3 MB) to a
// few kB, and expanding it takes a fraction of a millisecond where decoding its PNG takes
// several. The recorded source keeps preloaded frame sets this way; a session recorder can too.
// Images that would not shrink (noisy, not 8-bit, not continuous) are kept as they are.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace kumite::tracking {

class PackedImage {
 public:
  PackedImage() = default;
  /// Packs `image` (any type; only continuous CV_8UC1 images are run-length packed, others
  /// are kept as a shared reference).
  explicit PackedImage(const cv::Mat& image);

  /// The image again, pixel for pixel: a new buffer, or for a kept image the same (shared)
  /// one, so treat it as read-only. An empty Mat for an empty image.
  cv::Mat unpack() const;

  /// Appends the image in a portable binary form (little-endian; packed runs, or a kept
  /// image's pixels with its OpenCV type) that read_from() gives back pixel for pixel.
  void append_to(std::string& out) const;
  /// Reads one image that append_to() wrote from the front of `in` and advances it. nullopt
  /// (with `why`) for a truncated or inconsistent one (runs outside the image, overlapping,
  /// sizes that do not add up): never reads past `in`.
  static std::optional<PackedImage> read_from(std::string_view& in, std::string* why = nullptr);

  bool empty() const { return rows_ == 0 && dense_.empty(); }
  bool packed() const { return dense_.empty() && rows_ > 0; }
  /// bytes held (pixels and run table; a kept image's own size)
  std::size_t bytes() const;

 private:
  int rows_ = 0, cols_ = 0;
  std::uint8_t background_ = 0;      // the grey outside the runs
  cv::Mat dense_;                    // kept as is
  std::vector<std::uint32_t> runs_;  // (offset, length) pairs in pixels, ascending
  std::vector<std::uint8_t> pixels_; // the runs' pixels, back to back
};

}  // namespace kumite::tracking
