#include "kumite/tracking/camera_frames.hpp"

#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "binary_io.hpp"
#include "kumite/common/checksum.hpp"
#include "kumite/common/error.hpp"
#include "kumite/tracking/packed_image.hpp"

namespace kumite::tracking {

namespace {
constexpr std::uint32_t kMagic = 0x3153464B;  // "KFS1" little-endian
constexpr std::uint32_t kMaxPayload = 1u << 30;
constexpr std::uint32_t kMaxCameras = 64;

using binary::get;
using binary::put;
}  // namespace

std::string encode_frame_set(const FrameSet& set) {
  std::string payload;
  put<std::uint64_t>(payload, set.frame);
  put<double>(payload, set.timestamp);
  put<std::uint32_t>(payload, static_cast<std::uint32_t>(set.images.size()));
  for (std::size_t c = 0; c < set.images.size(); ++c) {
    put<double>(payload, c < set.camera_times.size() ? set.camera_times[c] : set.timestamp);
    PackedImage(set.images[c]).append_to(payload);
  }
  std::string out;
  out.reserve(payload.size() + 16);
  put<std::uint32_t>(out, kMagic);
  put<std::uint32_t>(out, static_cast<std::uint32_t>(payload.size()));
  put<std::uint64_t>(out, fnv1a64(payload));
  out += payload;
  return out;
}

CameraFramesReader::CameraFramesReader(const std::filesystem::path& file) : path_(file), in_(file, std::ios::binary) {
  if (!in_) throw file_error("replay", "io", file.string(), 0, "", "cannot open the camera frames");
  std::string first(kCameraFramesHeader.size(), '\0');
  in_.read(first.data(), static_cast<std::streamsize>(first.size()));
  if (in_.gcount() != static_cast<std::streamsize>(first.size()) || first != kCameraFramesHeader) {
    const bool newer = first.rfind("kumite-camera-frames ", 0) == 0;
    throw file_error("replay", "format", file.string(), 1, "",
                     newer ? "camera frames from a newer version (this build reads version 1)"
                           : "not a camera frames file (no \"kumite-camera-frames 1\" line)");
  }
  offset_ = first.size();
}

bool CameraFramesReader::next(FrameSet& out) {
  if (!problem_.empty()) return false;
  const auto fail = [&](const std::string& what) {
    problem_ = fmt::format("{}: frame set {} (byte {}): {}; {} sets before it read", path_.string(), sets_, offset_, what,
                           sets_);
    return false;
  };
  char head[16];
  in_.read(head, sizeof head);
  if (in_.gcount() == 0) return false;  // the end
  if (in_.gcount() != sizeof head) return fail("cut short (a recorder killed mid-write)");
  std::string_view h(head, sizeof head);
  std::uint32_t magic = 0, bytes = 0;
  std::uint64_t sum = 0;
  get(h, magic);
  get(h, bytes);
  get(h, sum);
  if (magic != kMagic) return fail("not a frame set record");
  if (bytes > kMaxPayload) return fail(fmt::format("record of {} bytes: too large", bytes));
  buffer_.resize(bytes);
  in_.read(buffer_.data(), bytes);
  if (in_.gcount() != static_cast<std::streamsize>(bytes)) return fail("cut short (a recorder killed mid-write)");
  if (fnv1a64(buffer_) != sum) return fail("checksum does not match (damaged)");
  std::string_view p(buffer_);
  FrameSet set;
  std::uint32_t cameras = 0;
  if (!get(p, set.frame) || !get(p, set.timestamp) || !get(p, cameras)) return fail("truncated header");
  if (!std::isfinite(set.timestamp)) return fail("timestamp is not a finite number");
  if (cameras > kMaxCameras) return fail(fmt::format("{} cameras: too many", cameras));
  for (std::uint32_t c = 0; c < cameras; ++c) {
    double t = 0;
    if (!get(p, t) || !std::isfinite(t)) return fail(fmt::format("camera {}: bad capture time", c));
    std::string why;
    auto img = PackedImage::read_from(p, &why);
    if (!img) return fail(fmt::format("camera {}: {}", c, why));
    set.camera_times.push_back(t);
    set.images.push_back(img->unpack());
  }
  if (!p.empty()) return fail("bytes left over after the last camera");
  offset_ += sizeof head + bytes;
  ++sets_;
  out = std::move(set);
  return true;
}

}  // namespace kumite::tracking
