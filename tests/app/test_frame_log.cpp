// Issue 15: frames.jsonl of a run of any length stays within its budget: two halves,
// frames.jsonl (the newest frames) and frames.1.jsonl (the ones before), complete lines only,
// no frame lost at a rotation between them. A line's console holds the planner's line when
// there is a planner, and no such key when there is none.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "kumite/app/config.hpp"
#include "kumite/app/frame_log.hpp"
#include "kumite/common/error.hpp"

using namespace kumite::app;
namespace fs = std::filesystem;

namespace {
std::vector<std::string> lines_of(const fs::path& p) {
  std::vector<std::string> out;
  std::ifstream in(p);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}
}  // namespace

TEST(FrameLog, ALongRunKeepsItsNewestFramesWithinTheBudget) {
  const fs::path dir = fs::temp_directory_path() / ("kumite_frame_log_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  constexpr std::uint64_t kBudget = 20'000;  // bytes: 10 kB per half
  FrameLog log(dir / "frames.jsonl", kBudget);
  const std::string pad(280, 'x');
  for (int i = 0; i < 500; ++i) {
    log.write_line(fmt::format("{{\"frame\":{},\"pad\":\"{}\"}}", i, pad));
    ASSERT_LE(fs::file_size(dir / "frames.jsonl") + (fs::exists(dir / "frames.1.jsonl") ? fs::file_size(dir / "frames.1.jsonl") : 0),
              kBudget)
        << "frame " << i;
  }
  log.close();
  EXPECT_GT(log.rotations(), 10u);
  const auto older = lines_of(dir / "frames.1.jsonl"), newer = lines_of(dir / "frames.jsonl");
  ASSERT_FALSE(older.empty());
  ASSERT_FALSE(newer.empty());
  // The newest frame is last in frames.jsonl, and frames.1.jsonl runs straight into it.
  std::vector<std::string> all(older);
  all.insert(all.end(), newer.begin(), newer.end());
  const int first = 500 - static_cast<int>(all.size());
  for (std::size_t k = 0; k < all.size(); ++k)
    EXPECT_EQ(all[k].rfind(fmt::format("{{\"frame\":{},", first + static_cast<int>(k)), 0), 0u) << all[k].substr(0, 20);
  fs::remove_all(dir);
}

TEST(FrameLog, TheBudgetIsAKeyOfTheInstallationFile) {
  const std::string room = R"(
[[windows]]
name = "main"
[[walls]]
name = "front"
lower_left = [-1.5, 0.0, -1.5]
lower_right = [1.5, 0.0, -1.5]
upper_left = [-1.5, 2.4, -1.5]
window = "main"
)";
  EXPECT_EQ(parse_installation_config(room, "room.toml").frames_log_budget_mb, 2048.0);
  const auto c = parse_installation_config(room + "[log]\nframes_budget_mb = 64\n", "room.toml");
  EXPECT_EQ(c.frames_log_budget_mb, 64.0);
  EXPECT_EQ(parse_installation_config(to_toml(c), "again.toml"), c);
  try {
    parse_installation_config(room + "[log]\nframes_budget_mb = 0\n", "room.toml");
    FAIL();
  } catch (const kumite::Error& e) {
    EXPECT_EQ(std::string(e.what()), "room.toml:11: log.frames_budget_mb: must be in [1, 10000000] MB, found 0");
  }
}

TEST(FrameLog, TheConsolesPlannerLineIsLoggedWhenThereIsOne) {
  FrameData f;
  ConsoleState c;
  c.planner = "spar  guarding  next kick_left (timer) in 1.6 s  attacks 1  counters 0  score: visitor hits 0 dodges 1, "
              "fighter hits 0 blocks 2 (met 0)";
  auto j = nlohmann::json::parse(frame_json(f, c, {}, false));
  ASSERT_TRUE(j["console"].contains("planner")) << j["console"].dump();
  EXPECT_EQ(j["console"]["planner"], c.planner);
  c.planner.clear();  // no fighter: no planner
  j = nlohmann::json::parse(frame_json(f, c, {}, false));
  EXPECT_FALSE(j["console"].contains("planner")) << j["console"].dump();
}
