// cameras.bin: frame sets written as a session recording keeps them read back pixel for pixel,
// whatever the images hold; a file cut by a killed recorder or damaged is read up to its last
// whole record and says where it stopped.
#include <gtest/gtest.h>

#include <filesystem>
#include <cstring>
#include <fstream>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <unistd.h>

#include "kumite/common/error.hpp"
#include "kumite/tracking/camera_frames.hpp"
#include "kumite/tracking/packed_image.hpp"

using namespace kumite::tracking;
namespace fs = std::filesystem;

namespace {

/// SYNTHETIC frame sets: a dark image with two bright blobs (packs), sensor noise (kept as
/// it is), a 16-bit image, and no image from one camera.
FrameSet make_set(std::uint64_t frame) {
  FrameSet s;
  s.frame = frame;
  s.timestamp = 100.0 + static_cast<double>(frame) / 60;
  cv::Mat blobs(240, 320, CV_8UC1, cv::Scalar(3));
  cv::circle(blobs, {40 + static_cast<int>(frame), 60}, 4, cv::Scalar(250), -1);
  cv::circle(blobs, {200, 100 + static_cast<int>(frame)}, 3, cv::Scalar(180), -1);
  cv::RNG rng(frame + 1);  // the same set for the same frame
  cv::Mat noise(120, 160, CV_8UC1);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 255);
  cv::Mat deep(60, 80, CV_16UC1);
  rng.fill(deep, cv::RNG::UNIFORM, 0, 65535);
  s.images = {blobs, noise, deep, cv::Mat()};
  s.camera_times = {s.timestamp, s.timestamp - 0.001, s.timestamp, -1};
  return s;
}

bool same(const cv::Mat& a, const cv::Mat& b) {
  if (a.empty() || b.empty()) return a.empty() && b.empty();
  return a.type() == b.type() && a.size() == b.size() && cv::norm(a, b, cv::NORM_INF) == 0;
}

struct TmpFile {
  fs::path path = fs::temp_directory_path() / ("kumite_camera_frames_" + std::to_string(::getpid()) + ".bin");
  ~TmpFile() { fs::remove(path); }
};

}  // namespace

TEST(CameraFrames, SetsReadBackPixelForPixel) {
  TmpFile f;
  std::string file(kCameraFramesHeader);
  for (std::uint64_t i = 0; i < 5; ++i) file += encode_frame_set(make_set(i));
  std::ofstream(f.path, std::ios::binary) << file;
  // The blob image packs: a few hundred bytes against 76.8 kB raw.
  std::string one;
  PackedImage(make_set(0).images[0]).append_to(one);
  EXPECT_LT(one.size(), 2000u);

  CameraFramesReader r(f.path);
  FrameSet got;
  for (std::uint64_t i = 0; i < 5; ++i) {
    ASSERT_TRUE(r.next(got)) << r.problem();
    const FrameSet want = make_set(i);
    EXPECT_EQ(got.frame, want.frame);
    EXPECT_EQ(got.timestamp, want.timestamp);
    EXPECT_EQ(got.camera_times, want.camera_times);
    ASSERT_EQ(got.images.size(), 4u);
    for (std::size_t c = 0; c < 4; ++c) EXPECT_TRUE(same(got.images[c], want.images[c])) << "set " << i << " camera " << c;
  }
  EXPECT_FALSE(r.next(got));
  EXPECT_EQ(r.problem(), "");
  EXPECT_EQ(r.sets_read(), 5u);
}

TEST(CameraFrames, ACutOrDamagedFileIsReadUpToItsLastWholeSet) {
  TmpFile f;
  std::string file(kCameraFramesHeader);
  for (std::uint64_t i = 0; i < 3; ++i) file += encode_frame_set(make_set(i));
  const std::size_t third = file.size() - encode_frame_set(make_set(2)).size();
  // Killed mid-write: the third record cut in its middle.
  std::ofstream(f.path, std::ios::binary | std::ios::trunc) << file.substr(0, third + 100);
  {
    CameraFramesReader r(f.path);
    FrameSet got;
    EXPECT_TRUE(r.next(got));
    EXPECT_TRUE(r.next(got));
    EXPECT_FALSE(r.next(got));
    EXPECT_NE(r.problem().find("frame set 2 (byte " + std::to_string(third) + "): cut short"), std::string::npos)
        << r.problem();
  }
  // One byte of the second record's pixels changed: the checksum catches it.
  std::string damaged = file;
  damaged[third - 50] ^= 0x20;
  std::ofstream(f.path, std::ios::binary | std::ios::trunc) << damaged;
  {
    CameraFramesReader r(f.path);
    FrameSet got;
    EXPECT_TRUE(r.next(got));
    EXPECT_FALSE(r.next(got));
    EXPECT_NE(r.problem().find("frame set 1"), std::string::npos) << r.problem();
    EXPECT_NE(r.problem().find("checksum"), std::string::npos) << r.problem();
  }
  // Not a camera frames file, or a newer one: refused at open, naming the file.
  std::ofstream(f.path, std::ios::binary | std::ios::trunc) << "kumite-camera-frames 2\n";
  try {
    CameraFramesReader r(f.path);
    FAIL();
  } catch (const kumite::Error& e) {
    EXPECT_EQ(std::string(e.what()), f.path.string() + ":1: camera frames from a newer version (this build reads version 1)");
  }
}

TEST(CameraFrames, AnInconsistentImageIsRefusedNotReadOutOfBounds) {
  std::string img;
  PackedImage(make_set(0).images[0]).append_to(img);
  // Every prefix of a valid image is refused as truncated, never read past its end.
  for (std::size_t n = 0; n < img.size(); n += 7) {
    std::string_view v(img.data(), n);
    std::string why;
    EXPECT_FALSE(PackedImage::read_from(v, &why)) << n;
    EXPECT_FALSE(why.empty());
  }
  std::string_view whole(img);
  EXPECT_TRUE(PackedImage::read_from(whole));
  EXPECT_TRUE(whole.empty());
  // A run moved past the image's end.
  std::string bad = img;
  const std::size_t first_run = 1 + 4 + 4 + 1 + 4;
  const std::uint32_t far = 240 * 320;
  std::memcpy(bad.data() + first_run, &far, 4);
  std::string_view b(bad);
  std::string why;
  EXPECT_FALSE(PackedImage::read_from(b, &why));
  EXPECT_EQ(why, "runs outside the image or overlapping");
}
