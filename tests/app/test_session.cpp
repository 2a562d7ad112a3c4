// Issue 13: a session recorded (every frame's inputs and state hashes) replays bit for bit;
// a changed input is caught at its frame and field; a killed recording replays up to its
// last complete frame; a newer or missing manifest is refused in one line.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>
#include <unistd.h>

#include "kumite/app/config.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/session.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/annotation.hpp"
#include "kumite/content/database.hpp"

using namespace kumite::app;
namespace fs = std::filesystem;

namespace {

const fs::path kSource = KUMITE_SOURCE_DIR;

struct Tmp {
  fs::path path = fs::temp_directory_path() / ("kumite_app_test_session_" + std::to_string(::getpid()));
  Tmp() {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Tmp() { fs::remove_all(path); }
};

fs::path database(const fs::path& dir) {
  const auto set = kumite::content::read_annotations(kSource / "content/motions/motions.toml");
  const auto clips = kumite::content::load_annotated_clips(set);
  const auto db = kumite::content::build_database(kumite::content::segment_sources(set, clips), {});
  kumite::content::save_database(db, dir / "fighter.kdb");
  return dir / "fighter.kdb";
}

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// A config file the replay can load by itself: the demo's, with the test database and no tracker.
fs::path write_config(const fs::path& dir) {
  std::string text = read(kSource / "config/demo.toml");
  auto cfg = parse_installation_config(text, (kSource / "config/demo.toml").string());
  cfg.fighter.database = database(dir);
  cfg.tracking.source = TrackingSource::none;
  cfg.orders_script.reset();
  for (auto& c : cfg.characters) c.bvh = cfg.resolve(c.bvh);
  const fs::path path = dir / "installation.toml";
  std::ofstream(path) << to_toml(cfg);
  return path;
}

/// Records `frames` frames at 60 Hz: a scripted punch, a keyed kick and character switch.
void record(const fs::path& config_path, const fs::path& orders, const fs::path& out, int frames) {
  auto cfg = load_installation_config(config_path);
  InstallationOptions io;
  io.orders_script = orders;
  Installation inst(cfg, make_fixed_head_input("test"), io);
  SessionInfo info{fs::absolute(config_path), fs::absolute(orders), false};
  SessionRecorder rec(out, info);
  inst.record_to(&rec);
  const double t0 = 5000.0;
  inst.start(t0);
  for (int i = 0; i < frames; ++i) {
    if (i == 70) inst.order(*kumite::parse_order("kick_left", t0 + i / 60.0));
    if (i == 100) inst.order(*kumite::parse_order("character 2", t0 + i / 60.0));
    inst.step(t0 + i / 60.0 + (i % 3) * 1e-4);  // uneven frame times, as a real loop has
  }
  inst.record_to(nullptr);
  rec.close();
  EXPECT_EQ(rec.frames_written(), static_cast<std::uint64_t>(frames));
  EXPECT_EQ(rec.dropped(), 0u);
}

}  // namespace

TEST(Session, ARecordedSessionReplaysBitForBit) {
  Tmp tmp;
  const fs::path config = write_config(tmp.path);
  const fs::path orders = tmp.path / "orders.csv";
  std::ofstream(orders) << "time_s,order\n0.2,punch_right\n";
  record(config, orders, tmp.path / "s", 180);
  const auto manifest = nlohmann::json::parse(read(tmp.path / "s/manifest.json"));
  EXPECT_TRUE(manifest["complete"].get<bool>());
  EXPECT_EQ(manifest["frames"], 180);
  EXPECT_EQ(manifest["session_fnv"].get<std::string>(), fmt::format("{:016x}", file_checksum(tmp.path / "s/session.jsonl")));

  const ReplayReport rep = replay_session(tmp.path / "s");
  EXPECT_TRUE(rep.identical) << "frame " << rep.first_difference_frame.value_or(0) << " " << rep.first_difference_field;
  EXPECT_EQ(rep.frames_replayed, 180u);
  EXPECT_TRUE(rep.notes.empty()) << rep.notes.front();

  // Twice more: the same again (the fighter's worker timing does not enter).
  EXPECT_TRUE(replay_session(tmp.path / "s").identical);

  // A changed input is caught at its frame: the keyed kick given one frame later.
  {
    std::string s = read(tmp.path / "s/session.jsonl");
    std::istringstream in(s);
    std::string out, line;
    std::string moved;
    while (std::getline(in, line)) {
      auto j = nlohmann::json::parse(line);
      if (j.contains("frame") && j["frame"] == 70) {
        moved = j["input"]["keyed"].dump();
        j["input"]["keyed"] = nlohmann::json::array();
      } else if (j.contains("frame") && j["frame"] == 71) {
        j["input"]["keyed"] = nlohmann::json::parse(moved);
      }
      out += j.dump() + "\n";
    }
    fs::create_directories(tmp.path / "changed");
    fs::copy_file(tmp.path / "s/manifest.json", tmp.path / "changed/manifest.json");
    std::ofstream(tmp.path / "changed/session.jsonl") << out;
    const ReplayReport d = replay_session(tmp.path / "changed");
    EXPECT_FALSE(d.identical);
    ASSERT_TRUE(d.first_difference_frame);
    EXPECT_EQ(*d.first_difference_frame, 70u);
    EXPECT_EQ(d.first_difference_field, "fighter");  // the kick not ordered there: no target frozen
  }

  // A recorder killed mid-line: the complete frames replay, the cut line is said.
  {
    const std::string s = read(tmp.path / "s/session.jsonl");
    fs::create_directories(tmp.path / "killed");
    auto m = manifest;
    m["complete"] = false;
    std::ofstream(tmp.path / "killed/manifest.json") << m.dump();
    std::ofstream(tmp.path / "killed/session.jsonl") << s.substr(0, s.size() - 200);
    const ReplayReport k = replay_session(tmp.path / "killed");
    EXPECT_TRUE(k.identical);
    EXPECT_EQ(k.frames_replayed, 179u);
    ASSERT_EQ(k.notes.size(), 2u);
    EXPECT_NE(k.notes[1].find("session.jsonl:181: the last line is cut short"), std::string::npos) << k.notes[1];
  }

  // A dropped frame: the replay stops before the gap and says which frames are missing.
  {
    const std::string s = read(tmp.path / "s/session.jsonl");
    std::istringstream in(s);
    std::string out, line;
    while (std::getline(in, line))
      if (line.find("\"frame\":90,") == std::string::npos) out += line + "\n";
    fs::create_directories(tmp.path / "gap");
    fs::copy_file(tmp.path / "s/manifest.json", tmp.path / "gap/manifest.json");
    std::ofstream(tmp.path / "gap/session.jsonl") << out;
    const ReplayReport g = replay_session(tmp.path / "gap");
    EXPECT_TRUE(g.identical);
    EXPECT_EQ(g.frames_replayed, 90u);
    ASSERT_EQ(g.notes.size(), 1u);
    EXPECT_NE(g.notes[0].find("frames 90..90 were dropped"), std::string::npos) << g.notes[0];
  }

  // A changed orders script is said, and its effect caught.
  std::ofstream(orders) << "time_s,order\n0.25,punch_right\n";
  const ReplayReport o = replay_session(tmp.path / "s");
  EXPECT_FALSE(o.identical);
  ASSERT_FALSE(o.notes.empty());
  EXPECT_NE(o.notes[0].find("differs from the recorded orders script"), std::string::npos);
}

TEST(Session, ANewerOrMissingManifestIsRefusedInOneLine) {
  Tmp tmp;
  try {
    replay_session(tmp.path);
    ADD_FAILURE();
  } catch (const kumite::Error& e) {
    EXPECT_NE(std::string(e.what()).find("manifest.json: cannot read"), std::string::npos) << e.what();
  }
  std::ofstream(tmp.path / "manifest.json") << R"({"format": "kumite-session", "version": 2})";
  try {
    replay_session(tmp.path);
    ADD_FAILURE();
  } catch (const kumite::Error& e) {
    EXPECT_NE(std::string(e.what()).find("manifest.json: version: session version 2 is newer"), std::string::npos)
        << e.what();
  }
}

TEST(Session, AFullQueueDropsFramesAndCountsThemNeverWaiting) {
  Tmp tmp;
  SessionRecorder rec(tmp.path / "s", SessionInfo{tmp.path / "none.toml", std::nullopt, false}, 2);
  rec.started(1.0, false);
  FrameInput in;
  in.tracking.status = "no tracking";
  for (int i = 0; i < 5000; ++i) {
    in.now = 1.0 + i / 60.0;
    rec.push(static_cast<std::uint64_t>(i), in, StateHashes{});
  }
  rec.close();
  EXPECT_GT(rec.dropped(), 0u) << "5000 frames pushed at once into 2 slots";
  EXPECT_EQ(rec.frames_written() + rec.dropped(), 5000u);
  const auto m = nlohmann::json::parse(read(tmp.path / "s/manifest.json"));
  EXPECT_EQ(m["dropped"].get<std::uint64_t>(), rec.dropped());
  EXPECT_EQ(m["frames_offered"], 5000);
  EXPECT_EQ(m["session_fnv"].get<std::string>(), fmt::format("{:016x}", file_checksum(tmp.path / "s/session.jsonl")));
}
