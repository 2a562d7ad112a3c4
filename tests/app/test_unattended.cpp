// Running all day unattended: a run stopped by SIGINT/SIGTERM ends cleanly (frames.jsonl in
// place, every line whole, exit status 128 + the signal), one killed with SIGKILL leaves the
// frames it logged as complete lines, and output folders are made or refused before a run.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <csignal>
#include <fstream>
#include <thread>
#include <atomic>
#include <memory>

#include <nlohmann/json.hpp>

#include "kumite/app/config.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/run.hpp"
#include "kumite/app/service.hpp"
#include "kumite/common/atomic_file.hpp"
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
pid_t spawn_kumite(const std::vector<std::string>& args, const fs::path& log,
                   const std::vector<std::string>& extra_env = {}) {
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
  std::vector<std::string> env_strings(extra_env);
  for (char** e = environ; *e; ++e) env_strings.emplace_back(*e);
  std::vector<char*> env;
  for (auto& e : env_strings) env.push_back(e.data());
  env.push_back(nullptr);
  const int rc = posix_spawn(&pid, exe.c_str(), &fa, &at, argv.data(), env.data());
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
  // Every line but the last is whole. The last may be cut: a fatal signal can end a write(2) of
  // a long line part-way (the kernel stops copying when SIGKILL is pending), so the README
  // promises whole lines up to the last, and every reader of the log takes a cut last line as
  // cut (kumite export says so: Demo.ExportFromTheLogReproducesTheLoggedJoints).
  std::string text = text_of(out / "frames.jsonl");
  const auto last_newline = text.rfind('\n');
  ASSERT_NE(last_newline, std::string::npos);
  const bool cut = last_newline + 1 != text.size();
  if (cut) {
    EXPECT_TRUE(nlohmann::json::parse(text.substr(last_newline + 1), nullptr, false).is_discarded())
        << "an unterminated last line must be a cut one";
    text.resize(last_newline + 1);
  }
  const fs::path whole = out / "frames-whole.jsonl";
  std::ofstream(whole, std::ios::binary) << text;
  const auto frames = read_frames(whole);
  ASSERT_GE(frames.size(), 40u);
  for (std::size_t i = 0; i < frames.size(); ++i) ASSERT_EQ(frames[i]["frame"].get<std::size_t>(), i);
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

/// frames.jsonl's lines without the console (its frame rate and CPU times are the machine's).
std::vector<std::string> frames_without_console(const fs::path& file) {
  std::vector<std::string> out;
  for (auto& j : read_frames(file)) {
    j.erase("console");
    out.push_back(j.dump());
  }
  return out;
}

/// Busy loops on every core while it lives (a machine loaded by other work).
struct CpuHog {
  std::atomic<bool> stop{false};
  std::vector<std::thread> threads;
  CpuHog() {
    for (unsigned k = 0; k < std::max(2u, std::thread::hardware_concurrency()); ++k)
      threads.emplace_back([this] {
        volatile std::uint64_t x = 0;
        while (!stop.load(std::memory_order_relaxed)) x = x + 1;
      });
  }
  ~CpuHog() {
    stop = true;
    for (auto& t : threads) t.join();
  }
};

/// One headless --simulated-time run of a shipped config (config/NAME) on the demo data in
/// `data`, writing to `out`: its frames.jsonl without the console lines, or nothing (a failure
/// added) when kumite did not exit 0.
std::vector<std::string> simulated_run(const fs::path& dir, const fs::path& data, const std::string& config,
                                       const std::string& frames, const fs::path& out) {
  const pid_t pid = spawn_kumite({"--config", (fs::path(KUMITE_SOURCE_DIR) / "config" / config).string(), "--data-dir",
                                  data.string(), "--headless", "--simulated-time", "--frames", frames, "--save-every",
                                  "0", "--resolution", "64x36", "--out", out.string()},
                                 dir / "console.txt");
  if (pid <= 0) {
    ADD_FAILURE() << "kumite did not start";
    return {};
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (!(WIFEXITED(status) && WEXITSTATUS(status) == 0)) {
    ADD_FAILURE() << text_of(dir / "console.txt");
    return {};
  }
  return frames_without_console(out / "frames.jsonl");
}

// Under --simulated-time the poses file and the camera recording follow the frames' clock: the
// same run gives the same frames, quiet or beside a CPU hog on every core (the visitor and the
// fighter drifted apart by however loaded the machine was: a head logged at 1.70 m at 4.4 s in
// one run, down at 4.07 s in another, the same punch scored hit in one and dodged in the other).
TEST(Unattended, ASimulatedTimeRunGivesTheSameFramesUnderLoad) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "four headless runs of the sanitized kumite beside a hog take minutes; the plain build runs it";
#endif
  const fs::path data = fs::path(KUMITE_BINARY_DIR) / "demo";
  if (!fs::exists(data / "fighter.kdb") || !fs::exists(data / "recording")) GTEST_SKIP() << "no demo data";
  const fs::path dir = fresh_dir("simclock");
  for (const auto& [config, frames] : {std::pair{"demo-poses.toml", "240"}, std::pair{"demo.toml", "120"}}) {
    SCOPED_TRACE(config);
    std::vector<std::vector<std::string>> runs;
    for (int run = 0; run < 2; ++run) {
      std::unique_ptr<CpuHog> hog;
      if (run == 1) hog = std::make_unique<CpuHog>();
      runs.push_back(simulated_run(dir, data, config, frames, dir / (std::string(config) + std::to_string(run))));
    }
    ASSERT_EQ(runs[0].size(), static_cast<std::size_t>(std::stoi(frames)));
    ASSERT_EQ(runs[1].size(), runs[0].size());
    for (std::size_t i = 0; i < runs[0].size(); ++i) ASSERT_EQ(runs[0][i], runs[1][i]) << "frame " << i;
    // The visitor is tracked and moves; the orders script's strikes are played.
    const auto first = nlohmann::json::parse(runs[0][10]), last = nlohmann::json::parse(runs[0].back());
    EXPECT_TRUE(last["head"]["live"].get<bool>());
    EXPECT_NE(first["head"]["position"], last["head"]["position"]);
  }
  fs::remove_all(dir);
}

// The shipped spar demo (config/demo-spar.toml: the mocap visitor, [fighter.planner] mode spar,
// no orders script): the fighter strikes on its own and counters the visitor's recognised
// strikes, and the same run under --simulated-time gives the same frames (the planner's draws
// come from the seed in the frame's input).
TEST(Unattended, TheSparDemoStrikesWithoutOrdersAndRepeatsItself) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "two 20 s headless runs of the sanitized kumite take minutes; the plain build runs it";
#endif
  const fs::path data = fs::path(KUMITE_BINARY_DIR) / "demo";
  if (!fs::exists(data / "fighter.kdb")) GTEST_SKIP() << "no demo data";
  const fs::path dir = fresh_dir("spar");
  std::vector<std::vector<std::string>> runs;
  for (int run = 0; run < 2; ++run) runs.push_back(simulated_run(dir, data, "demo-spar.toml", "1200", dir / std::to_string(run)));
  ASSERT_EQ(runs[0].size(), 1200u);
  ASSERT_EQ(runs[1].size(), runs[0].size());
  for (std::size_t i = 0; i < runs[0].size(); ++i) ASSERT_EQ(runs[0][i], runs[1][i]) << "frame " << i;
  int orders = 0, outcomes = 0, visitor_strikes = 0;
  // The score each frame logs ("spar") against the events logged up to it, counted here.
  std::map<std::string, int> seen;
  for (const std::string& line : runs[0]) {
    const auto frame = nlohmann::json::parse(line);
    if (frame.contains("events"))
      for (const auto& e : frame["events"]) {
        const std::string type = e.value("type", "");
        orders += type == "order";
        outcomes += type == "hit" || type == "dodged" || type == "miss";
        visitor_strikes += type == "visitor_strike";
        ++seen[type];
      }
    ASSERT_TRUE(frame.contains("spar")) << "frame " << frame["frame"] << ": spar mode logs the bout";
    const auto& sp = frame["spar"];
    EXPECT_NE(sp["state"].get<std::string>(), "off");
    EXPECT_EQ(sp["fighter_hits"].get<int>(), seen["hit"]) << "frame " << frame["frame"];
    EXPECT_EQ(sp["visitor_dodges"].get<int>(), seen["dodged"]) << "frame " << frame["frame"];
    EXPECT_EQ(sp["visitor_hits"].get<int>(), seen["visitor_hit"]) << "frame " << frame["frame"];
    EXPECT_EQ(sp["blocks"].get<int>(), seen["block"]) << "frame " << frame["frame"];
    EXPECT_EQ(sp["blocked"].get<int>(), seen["blocked"]) << "frame " << frame["frame"];
  }
  EXPECT_GE(seen["hit"] + seen["dodged"] + seen["block"], 1) << "a bout with nothing to score";
  EXPECT_GE(orders, 3) << "no orders script: every strike is the planner's";
  EXPECT_GE(outcomes, 2);
  EXPECT_GE(visitor_strikes, 1) << "the mocap visitor's strikes are recognised";
  fs::remove_all(dir);
}

// A number on the command line outside its range is refused in one line naming the option, with
// a non-zero exit: `--frames -5` ran "0 frames" and exited 0.
TEST(Unattended, CommandLineNumbersOutOfRangeAreRefused) {
  const fs::path dir = fresh_dir("cli");
  std::ofstream(dir / "room.toml") << kConfig;
  for (const std::vector<std::string>& bad :
       {std::vector<std::string>{"--frames", "-5"}, {"--frames", "0"}, {"--save-every", "-1"}, {"--seconds", "nan"},
        {"--render-nice", "40"}, {"--record-budget-mb", "-3"}, {"-v", "7"}}) {
    std::vector<std::string> args{"--config", (dir / "room.toml").string(), "--headless", "--simulated-time",
                                  "--out", (dir / "out").string()};
    args.insert(args.end(), bad.begin(), bad.end());
    const pid_t pid = spawn_kumite(args, dir / "console.txt");
    ASSERT_GT(pid, 0);
    int status = 0;
    ::waitpid(pid, &status, 0);
    const std::string console = text_of(dir / "console.txt");
    ASSERT_TRUE(WIFEXITED(status)) << bad[0];
    EXPECT_NE(WEXITSTATUS(status), 0) << bad[0] << " " << bad[1] << ": " << console;
    EXPECT_NE(console.find(bad[0]), std::string::npos) << console;
    EXPECT_FALSE(fs::exists(dir / "out" / "frames.jsonl")) << bad[0] << " " << bad[1] << ": it ran";
  }
  fs::remove_all(dir);
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

TEST(Unattended, WindowOptionsOfAHeadlessRunAreSaidNotDropped) {
  // --log with --headless (or with no display) wrote nothing and said nothing (issue 15 audit).
  const fs::path dir = fresh_dir("headlesslog");
  std::ofstream(dir / "room.toml") << kConfig;
  const pid_t pid = spawn_kumite({"--config", (dir / "room.toml").string(), "--headless", "--frames", "3", "-v", "0",
                                  "--out", (dir / "out").string(), "--log", (dir / "log" / "frames.jsonl").string()},
                                 dir / "console.txt");
  ASSERT_GT(pid, 0);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  const std::string text = text_of(dir / "console.txt");
  EXPECT_NE(text.find("--log " + (dir / "log" / "frames.jsonl").string() +
                      ": for windowed runs; this run is headless and writes frames.jsonl and PNGs in --out " +
                      (dir / "out").string()),
            std::string::npos)
      << text;
  EXPECT_TRUE(fs::exists(dir / "out" / "frames.jsonl"));
  fs::remove_all(dir);
}

// --- the service manager's side (sd_notify), without systemd --------------------------------

namespace {

/// A unix datagram socket as systemd's $NOTIFY_SOCKET: what kumite sends, with arrival times.
class NotifySocket {
 public:
  explicit NotifySocket(const fs::path& path) : path_(path) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::snprintf(a.sun_path, sizeof a.sun_path, "%s", path.c_str());
    ::unlink(path.c_str());
    ok_ = fd_ >= 0 && ::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  }
  ~NotifySocket() {
    if (fd_ >= 0) ::close(fd_);
    ::unlink(path_.c_str());
  }
  bool ok() const { return ok_; }
  struct Message {
    std::string text;
    double at_s;  ///< since the socket was made
  };
  /// Receives for up to `seconds`, or until `until` is true of a message.
  void receive(double seconds, const std::function<bool(const Message&)>& until = {}) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      char buf[4096];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) continue;
      messages.push_back({std::string(buf, static_cast<std::size_t>(n)),
                          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count()});
      if (until && until(messages.back())) return;
    }
  }
  std::vector<Message> messages;
  /// s since the socket was made (the messages' clock).
  double now_s() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count(); }

 private:
  fs::path path_;
  int fd_ = -1;
  bool ok_ = false;
  std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
};

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

/// The health report as soon as it is running with more than 10 frames and `also` holds, or
/// the last one read after 30 s (discarded when never readable).
nlohmann::json wait_for_running_report(const fs::path& report,
                                       const std::function<bool(const nlohmann::json&)>& also = {}) {
  nlohmann::json j;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    j = nlohmann::json::parse(text_of(report), nullptr, false);
    if (!j.is_discarded() && j.value("state", "") == "running" && j.value("frames", 0) > 10 && (!also || also(j))) break;
  }
  return j;
}

}  // namespace

TEST(Service, ReadyThenWatchdogPingsWhileFramesAdvanceAndNoneOnceTheLoopHangs) {
  const fs::path dir = fresh_dir("notify");
  std::ofstream(dir / "room.toml") << kConfig;
  NotifySocket sock(dir / "notify.sock");
  ASSERT_TRUE(sock.ok()) << std::strerror(errno);
  // Real time at 60 Hz: 90 frames = 1.5 s of pings at every 0.1 s (a 0.4 s watchdog), then
  // the loop hangs (the test aid) and no ping may come.
  const pid_t pid = spawn_kumite({"--config", (dir / "room.toml").string(), "--headless", "--frames", "100000",
                                  "--save-every", "0", "--out", (dir / "out").string(), "--health-file",
                                  (dir / "health.json").string(), "--debug-hang-after-frames", "90"},
                                 dir / "console.txt",
                                 {"NOTIFY_SOCKET=" + (dir / "notify.sock").string(), "WATCHDOG_USEC=400000"});
  ASSERT_GT(pid, 0);
  // Until the hang is logged (frame 90), then 1.5 s more: the loop is hung.
  sock.receive(30, [](const auto& m) { return has(m.text, "READY=1"); });
  const auto hang_logged = [&] { return has(text_of(dir / "console.txt"), "the frame loop hangs now"); };
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!hang_logged() && std::chrono::steady_clock::now() < until) sock.receive(0.05);
  ASSERT_TRUE(hang_logged()) << text_of(dir / "console.txt");
  // A ping sent with the hang's frame may still wait in the socket: 0.3 s of grace.
  const double hang_seen = sock.now_s();
  sock.receive(1.5);
  ::kill(pid, SIGTERM);
  int status = 0;
  ::waitpid(pid, &status, 0);
  sock.receive(0.3);
  ASSERT_TRUE(WIFEXITED(status)) << text_of(dir / "console.txt");
  EXPECT_EQ(WEXITSTATUS(status), 143) << text_of(dir / "console.txt");

  std::size_t ready = 0, first_ping = 0, pings = 0, stopping = 0;
  double last_ping_at = -1;
  for (std::size_t i = 0; i < sock.messages.size(); ++i) {
    const auto& m = sock.messages[i];
    if (has(m.text, "READY=1") && !ready) ready = i + 1;
    if (has(m.text, "WATCHDOG=1")) {
      if (!first_ping) first_ping = i + 1;
      ++pings;
      last_ping_at = m.at_s;
    }
    if (has(m.text, "STOPPING=1")) stopping = i + 1;
  }
  ASSERT_GT(ready, 0u) << "no READY=1";
  ASSERT_GT(first_ping, 0u) << "no WATCHDOG=1";
  EXPECT_LE(ready, first_ping) << "READY=1 comes with or before the first ping";
  // 1.5 s of frames at a ping per 0.1 s: about 15 (a loaded machine renders slower, not fewer pings).
  EXPECT_GE(pings, 8u);
  // No ping while the loop hangs (1.5 s: the 0.4 s watchdog would have fired 3 times over).
  EXPECT_LE(last_ping_at, hang_seen + 0.3) << "pings went on while the frame loop hung";
  EXPECT_GT(stopping, 0u) << "no STOPPING=1 at SIGTERM";
  EXPECT_TRUE(has(text_of(dir / "console.txt"), "watchdog 0.4 s")) << text_of(dir / "console.txt");
}

TEST(Service, HealthReportSaysRunningThenStaleWhenTheLoopHangsThenStopped) {
  const fs::path dir = fresh_dir("health");
  std::ofstream(dir / "room.toml") << kConfig << "[health]\nfile = \"state/health.json\"\ninterval_s = 0.2\n";
  const fs::path report = dir / "state" / "health.json";  // relative to the config; the folder is made
  const pid_t pid = spawn_kumite({"--config", (dir / "room.toml").string(), "--headless", "--frames", "100000",
                                  "--save-every", "0", "--out", (dir / "out").string(),
                                  "--debug-hang-after-frames", "120"},
                                 dir / "console.txt");
  ASSERT_GT(pid, 0);
  // Running: a fresh report with frames counting up.
  nlohmann::json j = wait_for_running_report(report);
  ASSERT_FALSE(j.is_discarded()) << text_of(dir / "console.txt");
  EXPECT_EQ(j.value("state", ""), "running") << j.dump();
  EXPECT_EQ(j.value("mode", ""), "headless");
  for (const char* key : {"uptime_s", "fps", "frames", "tracking", "fighter", "recording", "events", "problems",
                          "last_problem", "written_at", "pid"})
    EXPECT_TRUE(j.contains(key)) << key << " missing: " << j.dump();
  EXPECT_EQ(j["tracking"]["bodies"][0].value("role", ""), "head");
  EXPECT_EQ(j["recording"].value("active", false), true);  // frames.jsonl is being written
  // Memory: the resident set (read here from /proc as well) beside what the allocator has in
  // use and holds (in use <= held <= resident); both null where a sanitizer's allocator
  // replaces glibc's (it does not say).
  ASSERT_TRUE(j.contains("memory") && j["memory"].is_object()) << j.dump();
  {
    const nlohmann::json& m = j["memory"];
    const double rss = m.value("rss_mb", -1.0);
    ASSERT_TRUE(m.contains("in_use_mb") && m.contains("held_mb")) << j.dump();
#if !defined(__SANITIZE_ADDRESS__)
    ASSERT_TRUE(m["in_use_mb"].is_number() && m["held_mb"].is_number()) << j.dump();
    const double in_use = m["in_use_mb"].get<double>(), held = m["held_mb"].get<double>();
    EXPECT_GT(in_use, 1.0) << j.dump();
    EXPECT_LE(in_use, held) << j.dump();
    EXPECT_LE(held, rss) << j.dump();
#endif
    std::ifstream status_file("/proc/" + std::to_string(pid) + "/status");
    double vm_rss_mb = -1;
    for (std::string l; std::getline(status_file, l);)
      if (l.rfind("VmRSS:", 0) == 0) vm_rss_mb = std::atof(l.c_str() + 6) / 1024.0;
    EXPECT_NEAR(rss, vm_rss_mb, 0.25 * vm_rss_mb) << j.dump();  // 0.2 s apart, both of one process
  }
  // This room has no fighter database: running, with that problem (exit 1).
  const auto line = read_status(report, unix_now());
  EXPECT_EQ(line.exit_code, 1) << line.text;
  EXPECT_TRUE(has(line.text, "kumite running") && has(line.text, "1 problem: no fighter")) << line.text;
  EXPECT_TRUE(has(line.text, "frames logged, no session recorded")) << line.text;  // not "recording on"
  // Hung after 120 frames (2 s): no new report; 3 x 0.2 s + 2 s later it is stale.
  const auto hung_until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!has(text_of(dir / "console.txt"), "the frame loop hangs now") &&
         std::chrono::steady_clock::now() < hung_until)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  std::this_thread::sleep_for(std::chrono::milliseconds(3000));
  const auto stale = read_status(report, unix_now());
  EXPECT_EQ(stale.exit_code, 2) << stale.text;
  EXPECT_TRUE(has(stale.text, "STALE")) << stale.text;
  ::kill(pid, SIGTERM);
  int status = 0;
  ::waitpid(pid, &status, 0);
  const auto stopped = read_status(report, unix_now());
  EXPECT_EQ(stopped.exit_code, 1) << stopped.text;
  EXPECT_TRUE(has(stopped.text, "stopped")) << stopped.text;
  // `kumite status --config` finds the report through the config; its exit status is the line's.
  const std::string cmd = std::string(KUMITE_BINARY_DIR) + "/bin/kumite status --config " + (dir / "room.toml").string() +
                          " > " + (dir / "status.txt").string() + " 2>&1";
  const int rc = std::system(cmd.c_str());
  EXPECT_EQ(WEXITSTATUS(rc), 1) << text_of(dir / "status.txt");
  EXPECT_TRUE(has(text_of(dir / "status.txt"), "kumite stopped")) << text_of(dir / "status.txt");
}

TEST(Service, HealthReportSaysWhichSessionIsRecordedAndHowFar) {
  // "recording on" said the same of a frames log and of a session; the report now names the
  // session folder a recorder writes now, with the console's line for it.
  const fs::path dir = fresh_dir("health_record");
  std::ofstream(dir / "room.toml") << kConfig << "[health]\nfile = \"health.json\"\ninterval_s = 0.2\n";
  const fs::path report = dir / "health.json";
  const pid_t pid = spawn_kumite({"--config", (dir / "room.toml").string(), "--headless", "--frames", "100000",
                                  "--save-every", "0", "--record", (dir / "session").string()},
                                 dir / "console.txt");
  ASSERT_GT(pid, 0);
  nlohmann::json j = wait_for_running_report(report, [](const nlohmann::json& r) {
    return r.contains("recording") && r["recording"].contains("session_status") && r["recording"]["session_status"].is_string();
  });
  const auto line = read_status(report, unix_now());
  ::kill(pid, SIGTERM);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_FALSE(j.is_discarded()) << text_of(dir / "console.txt");
  EXPECT_EQ(j["recording"].value("session", ""), (dir / "session").string()) << j.dump();
  ASSERT_TRUE(j["recording"]["session_status"].is_string()) << j.dump();
  const std::string want = "recording " + (dir / "session").string() + ": ";
  EXPECT_TRUE(has(j["recording"]["session_status"].get<std::string>(), want)) << j.dump();
  EXPECT_TRUE(has(line.text, want) && has(line.text, " frames, ")) << line.text;
}

TEST(Service, StatusIsZeroOnlyWhenFreshRunningAndWithoutProblems) {
  const fs::path dir = fresh_dir("status_ok");
  const double t = unix_now();
  const auto report = [&](double written_at, const std::string& state, const std::string& problems) {
    std::ofstream(dir / "h.json") << R"({"kumite_health": 1, "pid": 7, "state": ")" << state << R"(", "written_at": )"
                                  << std::fixed << written_at << R"(, "interval_s": 1.0, "uptime_s": 3725, "frames": 223500,)"
                                  << R"( "fps": 60.0, "tracking": {"status": "tracked, 900 frame sets", "cameras": [)"
                                  << R"({"name": "cam0", "status": "ok"}, {"name": "cam1", "status": "no frames"}]},)"
                                  << R"( "fighter": {"state": "resting"}, "recording": {"active": false}, "problems": )"
                                  << problems << "}";
    return read_status(dir / "h.json", t);
  };
  auto l = report(t - 0.5, "running", "[]");
  EXPECT_EQ(l.exit_code, 0) << l.text;
  EXPECT_EQ(l.text, "kumite running (pid 7): up 1h02m05s, frame 223500, 60.0 fps, tracking tracked, cameras 1/2 ok, "
                    "fighter resting, recording off");
  l = report(t - 0.5, "running", R"(["cam1: no frames"])");
  EXPECT_EQ(l.exit_code, 1) << l.text;
  l = report(t - 0.5, "loading", "[]");
  EXPECT_EQ(l.exit_code, 1) << l.text;
  l = report(t - 5.5, "running", "[]");  // 3 x 1 s + 2 s
  EXPECT_EQ(l.exit_code, 2) << l.text;
  EXPECT_TRUE(has(l.text, "STALE: last report")) << l.text;
}

TEST(Service, StatusOfAMissingOrForeignFileIsExit3InOneLine) {
  const fs::path dir = fresh_dir("status");
  auto l = read_status(dir / "none.json", unix_now());
  EXPECT_EQ(l.exit_code, 3);
  EXPECT_TRUE(has(l.text, "none.json")) << l.text;
  std::ofstream(dir / "other.json") << R"({"hello": 1})";
  l = read_status(dir / "other.json", unix_now());
  EXPECT_EQ(l.exit_code, 3);
  EXPECT_TRUE(has(l.text, "not a kumite health report")) << l.text;
}

TEST(Service, HealthKeysAreValidatedLikeEveryKey) {
  const auto error_of = [](const std::string& extra) -> std::string {
    try {
      parse_installation_config(kConfig + extra, "room.toml");
    } catch (const kumite::Error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_TRUE(has(error_of("[health]\ninterval_s = nan\n"), "room.toml:9: health.interval_s: must be a finite number"))
      << error_of("[health]\ninterval_s = nan\n");
  EXPECT_TRUE(has(error_of("[health]\ninterval_s = 0.0\n"), "health.interval_s: must be 0.1..60"))
      << error_of("[health]\ninterval_s = 0.0\n");
  EXPECT_TRUE(has(error_of("[health]\nfile = 3\n"), "room.toml:9: health.file: must be a string"));
  EXPECT_TRUE(has(error_of("[health]\nfiles = \"x\"\n"), "health.files: unknown key")) << error_of("[health]\nfiles = \"x\"\n");
  const auto c = parse_installation_config(kConfig + "[health]\nfile = \"h.json\"\ninterval_s = 2.5\n", "room.toml");
  ASSERT_TRUE(c.health.file);
  EXPECT_EQ(*c.health.file, "h.json");
  EXPECT_EQ(c.health.interval_s, 2.5);
  EXPECT_EQ(parse_installation_config(to_toml(c), "room.toml"), c);  // written back and read again
}

// --- leftovers of killed runs ------------------------------------------------------------

namespace {
/// The pid of a process that has ended (and been reaped): no process has it now.
pid_t gone_pid() {
  const pid_t p = ::fork();
  if (p == 0) ::_exit(0);
  ::waitpid(p, nullptr, 0);
  return p;
}
}  // namespace

TEST(Service, StaleTemporariesOfGoneProcessesAreRemovedLiveOnesKept) {
  const fs::path dir = fresh_dir("stale");
  const pid_t dead = gone_pid();
  const std::vector<std::string> stale{".frames.tmp-" + std::to_string(dead) + "-0.jsonl",
                                       ".calibration.tmp-" + std::to_string(dead) + "-3.yaml",
                                       ".cal.yaml.20260101-000000.tmp-" + std::to_string(dead) + "-1.bak"};
  const std::vector<std::string> kept{".frames.tmp-" + std::to_string(::getppid()) + "-0.jsonl",  // alive
                                      "frames.jsonl", ".frames.tmp-x-0.jsonl", "a.tmp-12-0.jsonl",
                                      ".notes.tmp-" + std::to_string(dead) + "-z.txt"};
  for (const auto& n : stale) std::ofstream(dir / n) << "x";
  for (const auto& n : kept) std::ofstream(dir / n) << "x";
  auto removed = kumite::remove_stale_temporaries(dir);
  std::vector<std::string> names;
  for (const auto& r : removed) names.push_back(r.filename().string());
  std::sort(names.begin(), names.end());
  auto want = stale;
  std::sort(want.begin(), want.end());
  EXPECT_EQ(names, want);
  for (const auto& n : kept) EXPECT_TRUE(fs::exists(dir / n)) << n;
  EXPECT_TRUE(kumite::remove_stale_temporaries(dir / "missing").empty());
}

TEST(Service, TheFirstAtomicWriteIntoAFolderClearsItsStaleTemporaries) {
  // Any tool (a calibration, a recording) cleans up after killed writers at its next write there.
  const fs::path dir = fresh_dir("sweep");
  const std::string stale = ".calibration.tmp-" + std::to_string(gone_pid()) + "-0.yaml";
  std::ofstream(dir / stale) << "%YAML:1.0\n";
  kumite::write_file_atomically(dir / "calibration.yaml", std::string_view("x: 1\n"));
  EXPECT_FALSE(fs::exists(dir / stale));
  EXPECT_EQ(text_of(dir / "calibration.yaml"), "x: 1\n");
}

TEST(Service, BackupsAreCompleteOrAbsent) {
  const fs::path dir = fresh_dir("backup");
  const std::string content(100000, 'c');
  std::ofstream(dir / "cal.yaml") << content;
  const auto b = kumite::keep_previous_version(dir / "cal.yaml");
  EXPECT_EQ(text_of(b), content);
  for (const auto& e : fs::directory_iterator(dir))  // no temporary left beside it
    EXPECT_FALSE(kumite::is_temporary_name(e.path().filename().string())) << e.path();
}

TEST(Service, KumiteRemovesLeftoversOfAKilledRunAtStartInOneLine) {
  const fs::path dir = fresh_dir("leftovers");
  std::ofstream(dir / "room.toml") << kConfig;
  fs::create_directories(dir / "out");
  const std::string left = ".frames.tmp-" + std::to_string(gone_pid()) + "-0.jsonl";
  std::ofstream(dir / "out" / left) << "{\"frame\": 0}\n";
  const pid_t pid = spawn_kumite({"--config", (dir / "room.toml").string(), "--headless", "--simulated-time",
                                  "--frames", "3", "--save-every", "0", "--out", (dir / "out").string()},
                                 dir / "console.txt");
  ASSERT_GT(pid, 0);
  int status = 0;
  ::waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << text_of(dir / "console.txt");
  EXPECT_FALSE(fs::exists(dir / "out" / left));
  const std::string console = text_of(dir / "console.txt");
  EXPECT_TRUE(has(console, "removed 1 temporary file left by killed runs in") && has(console, left)) << console;
  EXPECT_TRUE(fs::exists(dir / "out" / "frames.jsonl"));
}
