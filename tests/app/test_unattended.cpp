// Running all day unattended: a run stopped by SIGINT/SIGTERM ends cleanly (frames.jsonl in
// place, every line whole, exit status 128 + the signal), one killed with SIGKILL leaves the
// frames it logged as complete lines, and output folders are made or refused before a run.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <fstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "kumite/app/config.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/run.hpp"
#include "kumite/common/error.hpp"

extern char** environ;

using namespace kumite::app;
namespace fs = std::filesystem;

namespace {

const std::string kConfig = R"(display_rate_hz = 60
[[walls]]
name = "front"
lower_left = [-1.5, 0.0, -1.5]
lower_right = [1.5, 0.0, -1.5]
upper_left = [-1.5, 2.4, -1.5]
resolution = [32, 18]
)";

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("kumite_app_test_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

/// The lines of `file`, each parsed; a line that does not parse fails the test.
std::vector<nlohmann::json> read_frames(const fs::path& file) {
  std::vector<nlohmann::json> frames;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    const auto j = nlohmann::json::parse(line, nullptr, false);
    EXPECT_FALSE(j.is_discarded()) << file << " line " << frames.size() + 1 << " does not parse: "
                                   << line.substr(0, 200);
    if (j.is_discarded()) break;
    frames.push_back(j);
  }
  return frames;
}

std::size_t count_lines(const fs::path& file) {
  std::ifstream in(file);
  std::size_t n = 0;
  for (std::string line; std::getline(in, line);) ++n;
  return n;
}

/// Starts the kumite binary with `args` (output to `log`); returns its pid.
pid_t spawn_kumite(const std::vector<std::string>& args, const fs::path& log) {
  const std::string exe = std::string(KUMITE_BINARY_DIR) + "/bin/kumite";
  std::vector<std::string> all{exe};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&fa, 1, 2);
  // A clean signal disposition whatever the test runner left (SIG_IGN is inherited).
  posix_spawnattr_t at;
  posix_spawnattr_init(&at);
  sigset_t defaults;
  sigemptyset(&defaults);
  sigaddset(&defaults, SIGINT);
  sigaddset(&defaults, SIGTERM);
  posix_spawnattr_setsigdefault(&at, &defaults);
  sigset_t none;
  sigemptyset(&none);
  posix_spawnattr_setsigmask(&at, &none);
  posix_spawnattr_setflags(&at, POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETSIGMASK);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, exe.c_str(), &fa, &at, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  posix_spawnattr_destroy(&at);
  EXPECT_EQ(rc, 0) << "cannot start " << exe;
  return rc == 0 ? pid : -1;
}

std::string text_of(const fs::path& file) {
  std::ifstream in(file);
  return {std::istreambuf_iterator<char>(in), {}};
}

/// Runs kumite headless on a small config until frames.jsonl has `lines` lines, sends `sig`,
/// and returns the wait status; `out` receives the run's folder.
int run_until_then_signal(const std::string& name, int sig, std::size_t lines, fs::path& out) {
  const fs::path dir = fresh_dir(name);
  std::ofstream(dir / "room.toml") << kConfig;
  out = dir / "out" / "deeper";  // missing folders are made
  const pid_t pid = spawn_kumite({"--config", (dir / "room.toml").string(), "--headless", "--simulated-time",
                                  "--frames", "100000000", "--save-every", "7", "--out", out.string()},
                                 dir / "console.txt");
  if (pid < 0) return -1;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  int status = 0;
  while (count_lines(out / "frames.jsonl") < lines) {
    if (::waitpid(pid, &status, WNOHANG) == pid) {
      ADD_FAILURE() << "kumite ended before the signal: " << text_of(dir / "console.txt");
      return status;
    }
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      ADD_FAILURE() << "no " << lines << " frames in 60 s: " << text_of(dir / "console.txt");
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ::kill(pid, sig);
  ::waitpid(pid, &status, 0);
  return status;
}

}  // namespace

TEST(Unattended, SigintEndsTheRunCleanlyWithStatus130) {
  fs::path out;
  const int status = run_until_then_signal("sigint", SIGINT, 30, out);
  ASSERT_TRUE(WIFEXITED(status)) << "status " << status;
  EXPECT_EQ(WEXITSTATUS(status), 130);
  const auto frames = read_frames(out / "frames.jsonl");
  ASSERT_GE(frames.size(), 30u);
  for (std::size_t i = 0; i < frames.size(); ++i) ASSERT_EQ(frames[i]["frame"].get<std::size_t>(), i);
  // No temporary file left beside it; the PNGs of the frames logged are all written.
  std::size_t pngs = 0;
  for (const auto& e : fs::directory_iterator(out)) {
    EXPECT_NE(e.path().filename().string().front(), '.') << e.path();
    if (e.path().extension() == ".png") ++pngs;
  }
  EXPECT_EQ(pngs, (frames.size() + 6) / 7) << "frames 0, 7, 14, ... (no strikes without a fighter)";
  fs::remove_all(out.parent_path().parent_path());
}

TEST(Unattended, SigtermEndsTheRunCleanlyWithStatus143) {
  fs::path out;
  const int status = run_until_then_signal("sigterm", SIGTERM, 10, out);
  ASSERT_TRUE(WIFEXITED(status)) << "status " << status;
  EXPECT_EQ(WEXITSTATUS(status), 143);
  EXPECT_GE(read_frames(out / "frames.jsonl").size(), 10u);
  fs::remove_all(out.parent_path().parent_path());
}

TEST(Unattended, SigkillLeavesEveryLoggedFrameAsACompleteLine) {
  fs::path out;
  const int status = run_until_then_signal("sigkill", SIGKILL, 40, out);
  ASSERT_TRUE(WIFSIGNALED(status)) << "status " << status;
  const auto frames = read_frames(out / "frames.jsonl");
  ASSERT_GE(frames.size(), 40u);
  for (std::size_t i = 0; i < frames.size(); ++i) ASSERT_EQ(frames[i]["frame"].get<std::size_t>(), i);
  // The file ends with the last line's newline: nothing half-written.
  const std::string text = text_of(out / "frames.jsonl");
  EXPECT_EQ(text.back(), '\n');
  fs::remove_all(out.parent_path().parent_path());
}

// In process: the stop flag set from another thread (as the signal handler does) ends
// run_headless at its next frame, with frames.jsonl complete.
TEST(Unattended, StopFlagEndsAHeadlessRunAtTheNextFrame) {
  const fs::path out = fresh_dir("stopflag") / "a" / "b";
  auto cfg = parse_installation_config(kConfig, "room.toml");
  Installation inst(cfg, make_fixed_head_input("test"), {});
  std::atomic<int> stop{0};
  HeadlessOptions ho;
  ho.frames = 100000000;
  ho.out = out;
  ho.save_every = 0;
  ho.real_time = false;
  ho.stop = &stop;
  std::thread stopper([&] {
    while (count_lines(out / "frames.jsonl") < 20) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    stop = SIGINT;
  });
  EXPECT_EQ(run_headless(inst, ho), 0);
  stopper.join();
  const auto frames = read_frames(out / "frames.jsonl");
  EXPECT_GE(frames.size(), 20u);
  EXPECT_LT(frames.size(), 1000u) << "it ran on past the stop";
  fs::remove_all(out.parent_path().parent_path());
}

TEST(Unattended, OutputFoldersAreMadeOrRefusedInOneLine) {
  const fs::path dir = fresh_dir("folders");
  make_output_folder(dir / "x" / "y" / "z", "--out x/y/z");
  EXPECT_TRUE(fs::is_directory(dir / "x" / "y" / "z"));
  make_output_folder(dir / "x", "--out x");  // already there: fine
  std::ofstream(dir / "file") << "not a folder";
  const auto message = [](const fs::path& p, const std::string& what) -> std::string {
    try {
      make_output_folder(p, what);
    } catch (const kumite::Error& e) {
      EXPECT_EQ(e.code(), "folder");
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(message(dir / "file" / "deeper", "--out f/deeper"),
            "--out f/deeper: cannot create the folder " + (dir / "file" / "deeper").string() + ": " +
                (dir / "file").string() + " is a file, not a folder");
  EXPECT_EQ(message(dir / "file", "--out f"),
            "--out f: cannot create the folder " + (dir / "file").string() + ": " + (dir / "file").string() +
                " is a file, not a folder");
  fs::remove_all(dir);
}

TEST(Unattended, KumiteRefusesAnOutputUnderAFileBeforeTheRun) {
  const fs::path dir = fresh_dir("outfile");
  std::ofstream(dir / "room.toml") << kConfig;
  std::ofstream(dir / "file") << "not a folder";
  const pid_t pid = spawn_kumite({"--config", (dir / "room.toml").string(), "--headless", "--frames", "5", "-v", "0",
                                  "--out", (dir / "file" / "out").string()},
                                 dir / "console.txt");
  ASSERT_GT(pid, 0);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1);
  const std::string text = text_of(dir / "console.txt");
  EXPECT_EQ(text, "kumite: --out " + (dir / "file" / "out").string() + ": cannot create the folder " +
                      (dir / "file" / "out").string() + ": " + (dir / "file").string() + " is a file, not a folder\n");
  fs::remove_all(dir);
}
