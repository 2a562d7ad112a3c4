// The recorded source's real-time clock (tracking::open_recording_source with realtime): a
// tiny recording written here (1 camera, 32x24 PNGs, 60 Hz) is played as cameras would
// deliver it: every set handed over no earlier than its due time and stamped with it, on the
// 1/60 s grid; a slow consumer gets the newest due set and the older ones count as dropped;
// a preloaded recording plays only its first sets, looped, from memory. No timing figures
// here (those are in kumite_app_pose_age): only what must hold on any machine.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <thread>

#include <fmt/format.h>
#include <unistd.h>

#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>

#include "kumite/common/time.hpp"
#include "kumite/tracking/tracker.hpp"

namespace fs = std::filesystem;
using namespace kumite;
using namespace kumite::tracking;

namespace {

constexpr int kW = 32, kH = 24;
constexpr double kPeriod = 1.0 / 60;

struct TinyRecording {
  fs::path dir;
  RigCalibration rig;
  explicit TinyRecording(int sets) {
    dir = fs::temp_directory_path() / fmt::format("kumite_app_clock_{}_{}", ::getpid(), sets);
    fs::remove_all(dir);
    fs::create_directories(dir / "cam0");
    std::vector<FrameRow> rows;
    std::vector<unsigned char> px(kW * kH);
    for (int i = 0; i < sets; ++i) {
      for (int k = 0; k < kW * kH; ++k) px[static_cast<std::size_t>(k)] = static_cast<unsigned char>((k + i) % 7);
      px[static_cast<std::size_t>(i % (kW * kH))] = 255;  // each image differs
      const auto file = dir / "cam0" / frame_file_name(static_cast<std::uint64_t>(i));
      EXPECT_NE(stbi_write_png(file.c_str(), kW, kH, 1, px.data(), kW), 0);
      rows.push_back({static_cast<std::uint64_t>(i), 100.0 + i * kPeriod});  // its own clock
    }
    write_frames_csv(dir / "frames.csv", rows);
    CameraCalibration cam;
    cam.name = "cam0";
    cam.image_width = kW;
    cam.image_height = kH;
    rig.cameras.push_back(cam);
  }
  ~TinyRecording() { fs::remove_all(dir); }
};

/// Steps of the 1/60 s grid between two stamps (must be whole).
double grid_steps(Timestamp a, Timestamp b) { return (b - a) / kPeriod; }

}  // namespace

TEST(RecordingClock, HandsOverAtTheDueTimeStampedWithIt) {
  TinyRecording rec(30);
  auto counters = std::make_shared<RecordingOptions::Counters>();
  RecordingOptions o;
  o.realtime = true;
  o.counters = counters;
  auto source = open_recording_source(rec.dir, rec.rig, {}, o);
  std::vector<Timestamp> stamps;
  std::vector<std::uint64_t> frames;
  FrameSet set;
  const Timestamp deadline = now() + 10;
  while (now() < deadline) {
    if (!source->next(set, 0.1)) {
      if (source->end_of_stream()) break;
      continue;
    }
    const Timestamp handed = now();
    EXPECT_LE(set.timestamp, handed) << "set " << set.frame << " handed over before it was due";
    ASSERT_EQ(set.camera_times.size(), 1u);
    EXPECT_EQ(set.camera_times[0], set.timestamp);
    ASSERT_EQ(set.images.size(), 1u);
    EXPECT_EQ(set.images[0].cols, kW);
    EXPECT_EQ(set.images[0].at<unsigned char>(static_cast<int>(set.frame) / kW, static_cast<int>(set.frame) % kW), 255);
    EXPECT_LT(std::abs(set.timestamp - handed), 5.0) << "stamped on now()'s clock, not the recording's";
    stamps.push_back(set.timestamp);
    frames.push_back(set.frame);
  }
  EXPECT_TRUE(source->end_of_stream());
  ASSERT_GE(stamps.size(), 2u);
  for (std::size_t i = 1; i < stamps.size(); ++i) {
    EXPECT_GT(frames[i], frames[i - 1]);
    // The stamps keep the recording's spacing: whole steps of the grid, as many as frames.
    EXPECT_NEAR(grid_steps(stamps[i - 1], stamps[i]), static_cast<double>(frames[i] - frames[i - 1]), 1e-3);  // frames.csv keeps µs
  }
  // Every set is accounted for: handed over, skipped by the decoder, or dropped.
  EXPECT_EQ(counters->delivered + counters->not_decoded + counters->dropped_stale, 30u);
  EXPECT_EQ(counters->delivered.load(), stamps.size());
}

TEST(RecordingClock, ASlowConsumerGetsTheNewestSetAndDropsAreCounted) {
  TinyRecording rec(60);
  auto counters = std::make_shared<RecordingOptions::Counters>();
  RecordingOptions o;
  o.realtime = true;
  o.buffered_sets = 1;
  o.counters = counters;
  auto source = open_recording_source(rec.dir, rec.rig, {}, o);
  FrameSet set;
  std::vector<std::uint64_t> frames;
  std::vector<Timestamp> stamps;
  for (int k = 0; k < 6; ++k) {
    while (!source->next(set, 0.5)) ASSERT_FALSE(source->end_of_stream());
    EXPECT_LE(set.timestamp, now());
    frames.push_back(set.frame);
    stamps.push_back(set.timestamp);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));  // six camera frames
  }
  for (std::size_t i = 1; i < frames.size(); ++i) {
    // Sets that came due while it slept are dropped for newer ones (one driver buffer: a
    // source that only kept what it had would hand over the very next set).
    EXPECT_GE(frames[i] - frames[i - 1], 2u);
    EXPECT_NEAR(grid_steps(stamps[i - 1], stamps[i]), static_cast<double>(frames[i] - frames[i - 1]), 1e-3);  // frames.csv keeps µs
  }
  // Every set that came due between the first set handed over and the last is counted: handed
  // over, dropped for a newer one (the consumer behind), or skipped undecoded (the decoder
  // behind: a loaded machine, where the decode thread yields to everything else). Which of the
  // two counts a set depends on the load; that each is counted does not.
  EXPECT_EQ(counters->delivered.load(), 6u);
  EXPECT_GE(counters->dropped_stale.load() + counters->not_decoded.load(), frames.back() - frames.front() + 1 - 6);
}

TEST(RecordingClock, PreloadedSetsLoopFromMemory) {
  TinyRecording rec(20);
  auto counters = std::make_shared<RecordingOptions::Counters>();
  RecordingOptions o;
  o.realtime = true;
  o.loop = true;
  o.preload_sets = 5;
  o.counters = counters;
  auto source = open_recording_source(rec.dir, rec.rig, {}, o);
  FrameSet set;
  std::vector<std::uint64_t> frames;
  const Timestamp deadline = now() + 10;
  while (frames.size() < 12 && now() < deadline)
    if (source->next(set, 0.1)) {
      // Only the first 5 rows play; frame numbers go on across loops (row + 5 x loop).
      const auto row = static_cast<int>(set.frame % 5);
      EXPECT_EQ(set.images[0].at<unsigned char>(row / kW, row % kW), 255) << set.frame;
      frames.push_back(set.frame);
    }
  EXPECT_EQ(counters->preloaded.load(), 5u);
  EXPECT_EQ(counters->to_preload.load(), 5u);
  EXPECT_TRUE(counters->playing.load());
  ASSERT_EQ(frames.size(), 12u);
  EXPECT_GT(frames.back(), 5u);  // it looped
  source->close();
  EXPECT_FALSE(source->next(set, 0.1));
  EXPECT_TRUE(source->end_of_stream());
}

TEST(RecordingClock, PreloadCountsNoMoreSetsThanTheRecordingHas) {
  // The console says "loading N of M": M is what will be loaded, not what the config asked.
  TinyRecording rec(6);
  auto counters = std::make_shared<RecordingOptions::Counters>();
  RecordingOptions o;
  o.realtime = true;
  o.preload_sets = 480;
  o.counters = counters;
  auto source = open_recording_source(rec.dir, rec.rig, {}, o);
  FrameSet set;
  const Timestamp deadline = now() + 10;
  while (!source->next(set, 0.1) && now() < deadline) {
  }
  EXPECT_EQ(counters->to_preload.load(), 6u);
  EXPECT_EQ(counters->preloaded.load(), 6u);
  source->close();
}
