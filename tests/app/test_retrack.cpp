// Issue 13: a session recorded with a tracker keeps its camera frame sets (cameras.bin), and
// `--replay --retrack` runs them through this build's tracker in step with the recorded
// frames: with the tracker unchanged, every frame comes out bit for bit as recorded. A
// camera frames file cut by a kill is re-tracked up to there and says so; a session without
// one is refused in one line. Data: a SYNTHETIC recording (tracking/synth.hpp: the scripted
// visitor's head seen by the corner rig at 320x256), played in real time.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <fstream>
#include <thread>

#include <unistd.h>

#include "kumite/app/config.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/session.hpp"
#include "kumite/app/tracking_input.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/time.hpp"
#include "kumite/content/annotation.hpp"
#include "kumite/content/database.hpp"
#include "kumite/tracking/calibration_file.hpp"
#include "kumite/tracking/config.hpp"
#include "kumite/tracking/synth.hpp"

using namespace kumite::app;
namespace fs = std::filesystem;

namespace {

const fs::path kSource = KUMITE_SOURCE_DIR;

struct Tmp {
  fs::path path = fs::temp_directory_path() / ("kumite_app_test_retrack_" + std::to_string(::getpid()));
  Tmp() {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Tmp() { fs::remove_all(path); }
};

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// The demo installation on a SYNTHETIC recording of the scripted visitor (made here).
fs::path write_setup(const fs::path& dir, int sets) {
  using namespace kumite::tracking;
  const RigCalibration rig = corner_rig(3.0, 2.6, 320, 256, 250);
  write_calibration(dir / "calibration.yaml", rig);
  const kumite::tracking::TrackingConfig tc = read_tracking_config(kSource / "config/tracking.toml");
  std::vector<TrajectoryPoint> tr;
  for (int i = 0; i < sets; ++i) tr.push_back(scripted_visitor(1.0 + i / 60.0));
  SynthOptions o;
  o.image_noise = 0;  // flat background: small PNGs, a fast test
  write_synthetic_recording(dir / "recording", rig, tc.bodies[0], tr, o, "test_retrack: scripted visitor");
  fs::copy_file(kSource / "config/tracking.toml", dir / "tracking.toml");

  const auto set = kumite::content::read_annotations(kSource / "content/motions/motions.toml");
  const auto db = kumite::content::build_database(
      kumite::content::segment_sources(set, kumite::content::load_annotated_clips(set)), {});
  kumite::content::save_database(db, dir / "fighter.kdb");

  auto cfg = parse_installation_config(read(kSource / "config/demo.toml"), (kSource / "config/demo.toml").string());
  cfg.fighter.database = dir / "fighter.kdb";
  for (auto& c : cfg.characters) c.bvh = cfg.resolve(c.bvh);
  cfg.tracking.source = TrackingSource::recording;
  cfg.tracking.calibration = dir / "calibration.yaml";
  cfg.tracking.tracking = dir / "tracking.toml";
  cfg.tracking.recording = dir / "recording";
  cfg.tracking.recording_preload = 0;
  cfg.orders_script.reset();
  const fs::path path = dir / "installation.toml";
  std::ofstream(path) << to_toml(cfg);
  return path;
}

/// Records `frames` frames in real time (the recording plays on the clock, as cameras do).
void record(const fs::path& config_path, const fs::path& out, int frames) {
  const auto cfg = load_installation_config(config_path);
  InstallationOptions io;
  auto tracking = make_tracking_input(cfg);
  // A slow start-up (a sanitizer build loading the characters): the tracker runs a second
  // before the recording begins; the sets it took meanwhile are kept for the recording.
  std::this_thread::sleep_for(std::chrono::seconds(1));
  Installation inst(cfg, std::move(tracking), io);
  // A queue for every set of the test: a slow (sanitizer) build must not drop any.
  SessionRecorder rec(out, session_info(cfg, io), 512, 1024);
  inst.record_to(&rec);
  const kumite::Timestamp t0 = kumite::now();
  inst.start(t0);
  for (int i = 0; i < frames; ++i) {
    kumite::sleep_until(t0 + i / 60.0);
    if (i == 40) inst.order(*kumite::parse_order("punch_right", kumite::now()));
    inst.step(kumite::now());
  }
  inst.record_to(nullptr);
  rec.close();
  EXPECT_EQ(rec.frame_sets_dropped(), 0u);
}

}  // namespace

TEST(Retrack, TheSessionsCameraFramesReTrackBitForBit) {
  Tmp tmp;
  const fs::path config = write_setup(tmp.path, 150);
  record(config, tmp.path / "session", 120);
  const auto manifest = read(tmp.path / "session/manifest.json");
  ASSERT_TRUE(fs::exists(tmp.path / "session/cameras.bin")) << manifest;

  // The recorded poses replay bit for bit (as always) ...
  const ReplayReport plain = replay_session(tmp.path / "session");
  EXPECT_TRUE(plain.identical) << plain.first_difference_field << ": " << plain.first_difference_detail;
  // ... and so do the camera frames through the tracker, with the recorded poses set aside.
  ReplayOptions ro;
  ro.retrack = true;
  const ReplayReport rep = replay_session(tmp.path / "session", ro);
  ASSERT_TRUE(rep.retrack);
  for (const auto& n : rep.notes) ADD_FAILURE() << n;
  EXPECT_EQ(rep.frames_replayed, 120u);
  EXPECT_GT(rep.retrack->sets, 60u) << "the head was re-tracked from the frame sets, not taken from the recording";
  EXPECT_EQ(rep.retrack->frames_identical, rep.retrack->frames_compared)
      << "first difference: frame " << rep.first_difference_frame.value_or(0) << ", " << rep.first_difference_field
      << ": " << rep.first_difference_detail;
  EXPECT_EQ(rep.retrack->head_max_m, 0.0);
  EXPECT_EQ(rep.retrack->status_differs, 0u);
  EXPECT_NE(read(tmp.path / "session/session.jsonl").find("\"status\":1,"), std::string::npos) << "the head was tracked";
  EXPECT_TRUE(rep.identical);

  // Killed mid-write: cameras.bin cut in the middle of a record ~40 sets before its end (not
  // at half its bytes: a slow sanitizer start-up fills the first half with the sets taken
  // before the recording began). The frames before the cut re-track as recorded; the note
  // names the file and where it stopped; nothing crashes.
  const auto sets = nlohmann::json::parse(manifest)["camera_frames"]["sets"].get<std::uint64_t>();
  ASSERT_GT(sets, 100u);
  const auto size = fs::file_size(tmp.path / "session/cameras.bin");
  const auto cut = size - (40 * size + size / 2) / sets;
  fs::resize_file(tmp.path / "session/cameras.bin", cut);
  const ReplayReport half = replay_session(tmp.path / "session", ro);
  ASSERT_TRUE(half.retrack);
  ASSERT_EQ(half.notes.size(), 1u);
  EXPECT_NE(half.notes[0].find("cameras.bin: frame set "), std::string::npos) << half.notes[0];
  EXPECT_NE(half.notes[0].find("cut short"), std::string::npos) << half.notes[0];
  EXPECT_GT(half.retrack->frames_identical, 10u);
  EXPECT_LT(half.retrack->frames_identical, 120u) << "frames after the cut have no new camera frames";

  // A session without camera frames cannot be re-tracked: one line naming the file.
  fs::remove(tmp.path / "session/cameras.bin");
  try {
    replay_session(tmp.path / "session", ro);
    FAIL();
  } catch (const kumite::Error& e) {
    EXPECT_EQ(std::string(e.what()), (tmp.path / "session/cameras.bin").string() +
                                         ": no camera frames in this session (recorded without a tracker, or by a "
                                         "kumite that did not keep them): it cannot be re-tracked");
  }
}
