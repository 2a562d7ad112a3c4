// A fault takes out the feature that needs the broken input and nothing else, and says so:
// in-process checks of the installation's start-up on damaged inputs (the whole matrix, run on
// the built kumite as a technician would, is scripts/fault-matrix.py: ctest faults.matrix).
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "kumite/app/config.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/tracking_input.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/time.hpp"

using namespace kumite::app;
namespace fs = std::filesystem;

namespace {

const fs::path kSource = KUMITE_SOURCE_DIR;

struct Tmp {
  fs::path path = fs::temp_directory_path() / ("kumite_app_test_faults_" + std::to_string(::getpid()));
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

/// Keeps the first half of `p` (a file cut short: a copy or a download that stopped).
void truncate_half(const fs::path& p) {
  const std::string s = read(p);
  std::ofstream(p, std::ios::binary | std::ios::trunc) << s.substr(0, s.size() / 2);
}

/// Flips every bit of the middle byte of `p`.
void corrupt_middle(const fs::path& p) {
  std::string s = read(p);
  s[s.size() / 2] = static_cast<char>(~s[s.size() / 2]);
  std::ofstream(p, std::ios::binary | std::ios::trunc) << s;
}

bool has_problem(const std::vector<std::string>& problems, std::string_view what) {
  for (const auto& p : problems)
    if (p.find(what) != std::string::npos) return true;
  return false;
}

/// The shipped demo's config with its data folder (made at set-up); nullopt when absent.
std::optional<InstallationConfig> demo(const char* file) {
  const fs::path data = fs::path(KUMITE_BINARY_DIR) / "demo";
  if (!fs::exists(data / "fighter.kdb")) return std::nullopt;
  return load_installation_config(kSource / "config" / file, data);
}

}  // namespace

// A recognition model that is missing, cut or damaged turns recognition off, with one line
// naming the file; the poses file still feeds the head (it did not: "tracking unavailable", the
// head at its default for the whole show).
TEST(Faults, ABrokenRecognitionModelTurnsRecognitionOffAndTheHeadIsStillTracked) {
  Tmp tmp;
  auto base = demo("demo-poses.toml");
  if (!base) GTEST_SKIP() << "no demo data (scripts/setup.sh makes it)";
  const fs::path model = kSource / "recognition/models/strikes.krec";
  for (const char* fault : {"missing", "truncated", "corrupted"}) {
    SCOPED_TRACE(fault);
    auto cfg = *base;
    const fs::path copy = tmp.path / (std::string(fault) + ".krec");
    if (std::string(fault) != "missing") {
      fs::copy_file(model, copy, fs::copy_options::overwrite_existing);
      if (std::string(fault) == "truncated") truncate_half(copy);
      else corrupt_middle(copy);
    }
    cfg.recognition.model = copy;
    std::unique_ptr<TrackingInput> input;
    ASSERT_NO_THROW(input = make_tracking_input(cfg));
    const auto faults = input->faults();
    ASSERT_EQ(faults.size(), 1u);
    EXPECT_EQ(faults[0].rfind("strike recognition off: ", 0), 0u) << faults[0];
    EXPECT_NE(faults[0].find(copy.string()), std::string::npos) << faults[0];
    EXPECT_NE(faults[0].find("recognition.model"), std::string::npos) << "names the config key: " << faults[0];
    // The head is played from the poses file as ever; recognition says it is not running.
    TrackingSnapshot s;
    const auto deadline = kumite::now() + 5;
    do {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      input->poll(kumite::now(), kumite::now(), s);
    } while (s.state != TrackerState::tracked && kumite::now() < deadline);
    EXPECT_EQ(s.state, TrackerState::tracked);
    EXPECT_FALSE(s.recognition.running);
    // The installation shows it with its problems (console, log, health report).
    Installation inst(cfg, std::move(input), {});
    inst.start(kumite::now());
    inst.step(kumite::now());
    EXPECT_TRUE(has_problem(inst.problems(), "strike recognition off: ")) << fault;
  }
}

// A character file that is there but cannot be read leaves that character out, as a missing
// file does; the other four fight (it took out all five: "no fighter" for the whole show).
TEST(Faults, AnUnreadableCharacterIsLeftOutAndTheOthersFight) {
  Tmp tmp;
  auto base = demo("demo.toml");
  if (!base) GTEST_SKIP() << "no demo data (scripts/setup.sh makes it)";
  for (const char* fault : {"truncated", "corrupted", "a folder"}) {
    SCOPED_TRACE(fault);
    auto cfg = *base;
    cfg.tracking.source = TrackingSource::none;
    cfg.orders_script.reset();
    for (std::size_t i = 0; i < cfg.characters.size(); ++i) {
      const fs::path copy = tmp.path / fault / cfg.resolve(cfg.characters[i].bvh).filename();
      fs::create_directories(copy.parent_path());
      if (i == 2 && std::string(fault) == "a folder") {
        fs::create_directories(copy);
      } else {
        fs::copy_file(cfg.resolve(cfg.characters[i].bvh), copy, fs::copy_options::overwrite_existing);
        if (i == 2 && std::string(fault) == "truncated") truncate_half(copy);
        if (i == 2 && std::string(fault) == "corrupted") {
          // A digit of the skeleton's first offset turned into a byte no number has.
          std::string s = read(copy);
          const auto at = s.find("OFFSET") + 7;
          s[at] = '\xCC';
          std::ofstream(copy, std::ios::binary | std::ios::trunc) << s;
        }
      }
      cfg.characters[i].bvh = copy;
    }
    Installation inst(cfg, make_fixed_head_input("test"), {});
    inst.start(0);
    const auto problems = inst.problems();
    ASSERT_TRUE(has_problem(problems, "character 3 \"Bruno\" left out: ")) << ::testing::PrintToString(problems);
    EXPECT_FALSE(has_problem(problems, "no fighter"));
    EXPECT_EQ(problems.size(), 1u) << ::testing::PrintToString(problems);
    // The fighter is there with the others: Aiko (character 4) answers her key and punches.
    inst.order(kumite::Order{0.0, kumite::OrderKind::select_character, 3});
    const FrameData* f = nullptr;
    for (int k = 0; k < 5; ++k) f = &inst.step(k / 60.0);
    ASSERT_TRUE(f->fighter.present);
    EXPECT_EQ(f->fighter.character, 3);
    bool ignored = false;
    for (const auto& e : f->events) ignored |= e.type == EventType::order_ignored;
    EXPECT_FALSE(ignored);
    // Bruno's key is ignored, with the reason.
    inst.order(kumite::Order{0.1, kumite::OrderKind::select_character, 2});
    const FrameData& g = inst.step(6 / 60.0);
    ASSERT_FALSE(g.events.empty());
    EXPECT_EQ(g.events[0].type, EventType::order_ignored);
    EXPECT_EQ(g.events[0].cause, EventCause::character_not_loaded);
  }
}

// An orders script that cannot be read turns the scripted orders off, with its file and line;
// the show starts (it stopped start-up: under systemd, a restart loop until the unit failed).
TEST(Faults, ABrokenOrdersScriptTurnsScriptedOrdersOffNotTheShow) {
  Tmp tmp;
  const std::string room = R"(
[[walls]]
name = "front"
lower_left = [-1.5, 0.0, -1.5]
lower_right = [1.5, 0.0, -1.5]
upper_left = [-1.5, 2.4, -1.5]
resolution = [32, 18]
)";
  const auto cfg = parse_installation_config(room, (tmp.path / "room.toml").string());
  std::ofstream(tmp.path / "bad.csv") << "time_s,order\n0.5,punch_right\n1.0,uppercut\n";
  fs::create_directories(tmp.path / "folder.csv");
  for (const fs::path& script : {tmp.path / "missing.csv", tmp.path / "bad.csv", tmp.path / "folder.csv"}) {
    InstallationOptions io;
    io.orders_script = script;
    std::unique_ptr<Installation> inst;
    ASSERT_NO_THROW(inst = std::make_unique<Installation>(cfg, make_fixed_head_input("test"), io)) << script;
    inst->start(0);
    inst->step(0);
    const auto problems = inst->problems();
    ASSERT_TRUE(has_problem(problems, "orders script off: " + script.string())) << ::testing::PrintToString(problems);
  }
  InstallationOptions io;
  io.orders_script = tmp.path / "bad.csv";
  Installation inst(cfg, make_fixed_head_input("test"), io);
  EXPECT_TRUE(has_problem(inst.problems(), "bad.csv:3: order: unknown order \"uppercut\""));
}
