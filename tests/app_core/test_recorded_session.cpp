// Issue 13: the short session in the repository (tests/app/data/session-demo, 200 frames of the
// shipped demo with its tracker, recorded by scripts/record-test-session.sh) replays bit for
// bit with this build; and the same replay catches a changed step.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "kumite/app/session.hpp"
#include "kumite/content/annotation.hpp"
#include "kumite/content/database.hpp"

using namespace kumite::app;
namespace fs = std::filesystem;

namespace {

const fs::path kSource = KUMITE_SOURCE_DIR;
const fs::path kSession = kSource / "tests/app/data/session-demo";

constexpr const char* kReRecord =
    "\nIf a change to the fighter (content/: behaviour, foot planting, adaptation, the motion database) or to the "
    "frame (app/) is MEANT to change what the installation does, re-record the session and commit it:\n"
    "    scripts/record-test-session.sh [BUILD_DIR]\n"
    "Otherwise the change altered the installation's frames by accident.";

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct Tmp {
  fs::path path = fs::temp_directory_path() / ("kumite_app_test_recorded_" + std::to_string(::getpid()));
  Tmp() {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Tmp() { fs::remove_all(path); }
};

/// The database as set-up makes it (kumite-motion build), from the motions in the repository:
/// what ${data_dir}/fighter.kdb is for the replay.
void build_database(const fs::path& dir) {
  const auto set = kumite::content::read_annotations(kSource / "content/motions/motions.toml");
  const auto clips = kumite::content::load_annotated_clips(set);
  const auto db = kumite::content::build_database(kumite::content::segment_sources(set, clips), {});
  kumite::content::save_database(db, dir / "fighter.kdb");
}

}  // namespace

TEST(RecordedSession, TheRepositorysSessionReplaysBitForBit) {
  ASSERT_TRUE(fs::exists(kSession / "manifest.json")) << kSession << " is missing" << kReRecord;
  const auto manifest = nlohmann::json::parse(read(kSession / "manifest.json"));
  ASSERT_TRUE(manifest.value("complete", false));
  const auto frames = manifest.at("frames").get<std::uint64_t>();
  // What makes it a test worth having: a few seconds, the tracker's head poses (a head pose
  // with status 1, tracked), the orders script (checked in the recording, not assumed).
  const std::string lines = read(kSession / "session.jsonl");
  std::size_t tracked = 0;
  for (std::size_t at = 0; (at = lines.find("\"status\":1,", at)) != std::string::npos; ++at) ++tracked;
  EXPECT_GE(frames, 120u);
  EXPECT_GE(tracked, frames / 2) << "the head tracked in at least half the frames";
  EXPECT_TRUE(fs::exists(kSession / "snapshot/orders.csv"));

  Tmp tmp;
  build_database(tmp.path);
  ReplayOptions ro;
  ro.data_dir = tmp.path;
  const ReplayReport rep = replay_session(kSession, ro);
  for (const auto& n : rep.notes) ADD_FAILURE() << n << kReRecord;
  ASSERT_TRUE(rep.compared);
  EXPECT_TRUE(rep.identical) << fmt::format("{}: frame {}: {} differs from the recording (frames before it identical)",
                                            (kSession / "session.jsonl").string(),
                                            rep.first_difference_frame.value_or(0), rep.first_difference_field)
                             << kReRecord;
  if (rep.identical) {
    EXPECT_EQ(rep.frames_replayed, frames);
  }
}

TEST(RecordedSession, AChangedStepIsCaughtAtItsFrameAndField) {
  // The same session with the fighter told to strike from 1.6 m instead of 0.9 m (its
  // snapshot changed, its checksum kept in step): the replay must differ, in the fighter.
  // (0.6 m changed nothing in the session recorded at the glide fix: its fighter strikes or
  // recovers through all 200 frames and never rests at its strike distance there.)
  Tmp tmp;
  build_database(tmp.path);
  fs::copy(kSession, tmp.path / "s", fs::copy_options::recursive);
  const fs::path snap = tmp.path / "s/snapshot/installation.toml";
  std::string text = read(snap);
  const auto at = text.find("strike_distance_m = ");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, text.find('\n', at) - at, "strike_distance_m = 1.6");
  std::ofstream(snap, std::ios::trunc | std::ios::binary) << text;
  auto m = nlohmann::json::parse(read(tmp.path / "s/manifest.json"));
  for (auto& f : m["files"])
    if (f["role"] == "config") {
      f["fnv"] = fmt::format("{:016x}", file_checksum(snap));
      f["bytes"] = text.size();
    }
  std::ofstream(tmp.path / "s/manifest.json", std::ios::trunc) << m.dump();
  ReplayOptions ro;
  ro.data_dir = tmp.path;
  const ReplayReport rep = replay_session(tmp.path / "s", ro);
  EXPECT_TRUE(rep.notes.empty()) << rep.notes.front();
  EXPECT_FALSE(rep.identical);
  ASSERT_TRUE(rep.first_difference_frame);
  EXPECT_EQ(rep.first_difference_field, "fighter");
  EXPECT_LT(rep.frames_replayed, m.at("frames").get<std::uint64_t>());
}
