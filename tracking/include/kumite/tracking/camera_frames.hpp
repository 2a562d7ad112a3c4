#pragma once
// Camera frames as a session recording keeps them (`cameras.bin`): every frame set the
// tracker was handed, each image packed losslessly (PackedImage: a dark IR image with a few
// bright blobs is a few kB), so a session can be re-tracked later (`kumite --replay DIR
// --retrack`) with the tracker as it is then.
//
// File: the line "kumite-camera-frames 1\n", then one record per frame set:
//   u32 magic 0x3153464B ("KFS1"), u32 payload bytes, u64 FNV-1a 64 of the payload, payload =
//   u64 frame, f64 timestamp (s), u32 cameras, then per camera f64 capture time (s) and the
//   image (PackedImage::append_to; an empty image = no frame from that camera this time).
// Little-endian. A record is written whole with one write(2), so a recorder killed mid-write
// leaves whole records and at most one cut one, which the reader reports and stops at.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "kumite/tracking/recording.hpp"

namespace kumite::tracking {

inline constexpr std::string_view kCameraFramesHeader = "kumite-camera-frames 1\n";

/// One record (header, checksum and payload) for `set`, ready to append to the file.
std::string encode_frame_set(const FrameSet& set);

class CameraFramesReader {
 public:
  /// Opens the file and checks its first line. Throws kumite::Error ("io": cannot open;
  /// "format": not a camera frames file, or a newer version) naming the file.
  explicit CameraFramesReader(const std::filesystem::path& file);
  /// The next frame set; false at the end of the file, or at a damaged or cut record (then
  /// problem() names the file, the record and what is wrong, and nothing more is read).
  bool next(FrameSet& out);
  /// "" while all is well; one line otherwise.
  const std::string& problem() const { return problem_; }
  std::uint64_t sets_read() const { return sets_; }

 private:
  std::filesystem::path path_;
  std::ifstream in_;
  std::string buffer_;
  std::string problem_;
  std::uint64_t sets_ = 0;
  std::uint64_t offset_ = 0;
};

}  // namespace kumite::tracking
