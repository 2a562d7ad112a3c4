// The render cluster through the kumite binary: a master (the demo, sparring, simulated time)
// and two headless render nodes (`--node`) on one machine over ipc://; the nodes draw the
// frames the master stepped, as a single process stepping the same demo makes them, their
// events' texts and console lines (the planner's line among them) the master's; a node with another installation file is refused in one
// line; a node whose master is gone says so on its walls.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "kumite/app/wall_notice.hpp"

namespace fs = std::filesystem;

namespace {

const fs::path kSource = KUMITE_SOURCE_DIR;

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("kumite_cluster_run_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

void replace_all(std::string& s, const std::string& from, const std::string& to) {
  for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) s.replace(at, from.size(), to);
}

/// config/demo-cluster.toml (or demo.toml, `cluster` false) written into `dir` with its
/// relative paths made absolute and its ipc endpoints in `dir`; `extra` appended.
fs::path write_config(const fs::path& dir, const std::string& name, bool cluster, const std::string& extra = "") {
  std::ifstream in(kSource / (cluster ? "config/demo-cluster.toml" : "config/demo.toml"));
  std::stringstream ss;
  ss << in.rdbuf();
  std::string t = ss.str();
  const std::string src = kSource.string() + "/";
  replace_all(t, "\"../", "\"" + src);
  replace_all(t, "\"rig/", "\"" + src + "config/rig/");
  replace_all(t, "\"tracking.toml\"", "\"" + src + "config/tracking.toml\"");
  replace_all(t, "\"orders-demo.csv\"", "\"" + src + "config/orders-demo.csv\"");
  replace_all(t, "ipc:///tmp/kumite-demo-", "ipc://" + dir.string() + "/");
  const fs::path p = dir / name;
  std::ofstream(p) << t << extra;
  return p;
}

pid_t spawn(const std::vector<std::string>& args, const fs::path& log) {
  const std::string exe = std::string(KUMITE_BINARY_DIR) + "/bin/kumite";
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(fd, 1);
    dup2(fd, 2);
    std::vector<char*> argv{const_cast<char*>(exe.c_str())};
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(exe.c_str(), argv.data());
    _exit(127);
  }
  return pid;
}

int wait_exit(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::map<std::uint64_t, nlohmann::json> frames_of(const fs::path& file) {
  std::map<std::uint64_t, nlohmann::json> out;
  std::ifstream in(file);
  for (std::string line; std::getline(in, line);) {
    auto j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_discarded()) continue;
    const auto frame = j["frame"].get<std::uint64_t>();
    out[frame] = std::move(j);
  }
  return out;
}

std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

bool demo_data() { return fs::exists(kSource / "build/demo/fighter.kdb"); }

}  // namespace

TEST(ClusterRun, NodesDrawTheMastersFramesAsOneProcessMakesThem) {
  if (!demo_data()) GTEST_SKIP() << "no demo data (scripts/make-demo-data.sh)";
  const fs::path dir = fresh_dir("nodes");
  // The fighter spars (config/demo-spar.toml's planner, with the demo's orders script), at a
  // fighting distance the demo's visitor is at from the start: the console's planner line holds
  // its state, its next decision with cause and due time, and the score.
  const std::string spar = "\n[fighter.planner]\nmode = \"spar\"\npreset = \"defensive_skilled\"\nseed = 1\nfighting_distance_m = 2.5\n";
  const fs::path cfg = write_config(dir, "room.toml", true, spar);
  const std::vector<std::string> small{"--headless", "--resolution", "32x18", "--save-every", "0", "-v", "1"};
  std::vector<pid_t> nodes;
  for (const std::string name : {"walls", "floor"}) {
    std::vector<std::string> args{"--config", cfg.string(), "--node", name, "--out", (dir / name).string(),
                                  "--cluster-timing", (dir / (name + ".csv")).string()};
    args.insert(args.end(), small.begin(), small.end());
    nodes.push_back(spawn(args, dir / (name + ".log")));
  }
  // The master waits for nobody: nodes join when they are up. It steps until both have been
  // in the barrier a while (its frames are simulated, as fast as the barrier lets them go).
  std::vector<std::string> margs{"--config", cfg.string(), "--simulated-time", "--frames", "90", "--out",
                                 (dir / "master").string(), "--cluster-timing", (dir / "master.csv").string()};
  margs.insert(margs.end(), small.begin(), small.end());
  // Nodes up first (EGL and the config take a moment), so that they see most frames.
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  ASSERT_EQ(wait_exit(spawn(margs, dir / "master.log")), 0) << read(dir / "master.log");
  // Both nodes wait for the master (not exit) until told to stop.
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  for (pid_t p : nodes) EXPECT_EQ(waitpid(p, nullptr, WNOHANG), 0) << "a node exited without being told";
  for (pid_t p : nodes) kill(p, SIGTERM);
  for (pid_t p : nodes) EXPECT_EQ(wait_exit(p), 128 + SIGTERM);
  EXPECT_NE(read(dir / "walls.log").find("waiting for master"), std::string::npos) << read(dir / "walls.log");

  // The same demo in one process: the reference frames.
  const fs::path one = write_config(dir, "one.toml", false, spar);
  std::vector<std::string> rargs{"--config", one.string(), "--simulated-time", "--frames", "90", "--out", (dir / "one").string()};
  rargs.insert(rargs.end(), small.begin(), small.end());
  ASSERT_EQ(wait_exit(spawn(rargs, dir / "one.log")), 0) << read(dir / "one.log");
  const auto ref = frames_of(dir / "one/frames.jsonl");
  ASSERT_EQ(ref.size(), 90u);
  const auto master = frames_of(dir / "master/frames.jsonl");
  ASSERT_EQ(master.size(), 90u);
  for (const auto& [f, j] : master) EXPECT_EQ(j["fighter"], ref.at(f)["fighter"]) << "master frame " << f;
  int decisions = 0;  // frames whose planner line (as a node logged it) names the next decision
  int texts = 0;  // events the nodes logged with the master's text
  for (const std::string name : {"walls", "floor"}) {
    const auto got = frames_of(dir / name / "frames.jsonl");
    EXPECT_GE(got.size(), 30u) << name << " drew too few of the master's frames";
    std::uint64_t last = 0;
    for (const auto& [f, j] : got) {
      EXPECT_TRUE(last == 0 || f > last);
      last = f;
      const auto& r = ref.at(f);
      for (const char* key : {"head", "eyes", "fighter"}) EXPECT_EQ(j[key], r[key]) << name << " frame " << f << " " << key;
      // Its walls only, each drawn from the views one process computes for that frame.
      ASSERT_EQ(j["walls"].size(), name == "walls" ? 3u : 1u);
      for (const auto& [wall, views] : j["walls"].items()) EXPECT_EQ(views, r["walls"][wall]) << name << " " << f << " " << wall;
      // The master's events with their texts, and the master's console: its lines, its
      // problems, then the node's own ("waiting for master", "not in the swap barrier").
      const auto& m = master.at(f);
      EXPECT_EQ(j["events"], m["events"]) << name << " frame " << f;
      for (const auto& e : j["events"]) texts += e.contains("text") ? 1 : 0;
      auto console = j["console"], master_console = m["console"];
      const auto problems = console["problems"], master_problems = master_console["problems"];
      ASSERT_GE(problems.size(), master_problems.size()) << name << " frame " << f << ": " << problems.dump();
      for (std::size_t k = 0; k < problems.size(); ++k)
        if (k < master_problems.size())
          EXPECT_EQ(problems[k], master_problems[k]) << name << " frame " << f;
        else
          EXPECT_TRUE(problems[k] == "waiting for master" || problems[k] == "not in the swap barrier") << problems[k];
      console.erase("problems");
      master_console.erase("problems");
      EXPECT_EQ(console, master_console) << name << " frame " << f;
      // The planner's line among them: the master's, not made on the node (which has no fighter).
      ASSERT_TRUE(master_console.contains("planner")) << "master frame " << f << ": " << master_console.dump();
      const auto line = master_console["planner"].get<std::string>();
      EXPECT_EQ(line.rfind("spar  ", 0), 0u) << line;
      EXPECT_EQ(console.value("planner", ""), line) << name << " frame " << f;
      decisions += line.find("  next ") != std::string::npos ? 1 : 0;
    }
    // Its timing log: every frame's STATE received, READY sent, GO received, in that order.
    std::ifstream csv(dir / (name + ".csv"));
    std::string line;
    std::getline(csv, line);
    EXPECT_EQ(line, "frame,master_time_s,state_rx_s,ready_tx_s,go_rx_s,bytes");
    int released = 0;
    while (std::getline(csv, line)) {
      unsigned long long f = 0;
      double mt = 0, rx = 0, ready = 0, go = 0;
      unsigned bytes = 0;
      ASSERT_EQ(std::sscanf(line.c_str(), "%llu,%lf,%lf,%lf,%lf,%u", &f, &mt, &rx, &ready, &go, &bytes), 6) << line;
      EXPECT_LT(bytes, 10000u) << "frame state over 10 kB";
      EXPECT_GT(bytes, 1000u);
      if (go >= 0) {
        ++released;
        EXPECT_LE(rx, ready);
        EXPECT_LE(ready, go);
      }
    }
    EXPECT_GE(released, 20) << name;
  }
  EXPECT_GT(texts, 0) << "the frames the nodes drew had no event with a text: nothing compared";
  EXPECT_GT(decisions, 0) << "no planner line the nodes logged named a next decision: little compared";
}

TEST(ClusterRun, ANodeWithAnotherInstallationFileIsRefusedInOneLine) {
  if (!demo_data()) GTEST_SKIP() << "no demo data (scripts/make-demo-data.sh)";
  const fs::path dir = fresh_dir("refused");
  const fs::path cfg = write_config(dir, "room.toml", true);
  const fs::path other = write_config(dir, "other.toml", true, "\n# edited on the node's machine only\n");
  const pid_t node = spawn({"--config", other.string(), "--node", "floor", "--headless", "--resolution", "32x18", "--out",
                            (dir / "floor").string()},
                           dir / "floor.log");
  const pid_t master = spawn({"--config", cfg.string(), "--headless", "--resolution", "32x18", "--simulated-time",
                              "--frames", "600", "--save-every", "0", "--out", (dir / "master").string()},
                             dir / "master.log");
  const int rc = wait_exit(node);
  kill(master, SIGTERM);
  wait_exit(master);
  EXPECT_EQ(rc, 1) << read(dir / "floor.log");
  const std::string log = read(dir / "floor.log");
  EXPECT_NE(log.find("kumite: node \"floor\" refused: its installation file (hash"), std::string::npos) << log;
}

namespace {

/// Waits until `pred` holds (true) or `seconds` pass (false).
template <typename P>
bool within(double seconds, P pred) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return pred();
}

std::size_t count_of(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

/// The notice's letters in a wall's PNG (BGR, top row first): how many of its pixels are the
/// letters' colour, and whether any of them lies outside the notice's band.
struct Letters {
  std::size_t pixels = 0;
  bool outside_band = false;
};
Letters letters_in(const cv::Mat& img, const kumite::app::NoticeLayout& l) {
  Letters out;
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) {
      const auto& p = img.at<cv::Vec3b>(y, x);
      bool lit = true;
      for (int k = 0; k < 3; ++k)
        if (std::abs(p[2 - k] - static_cast<int>(kumite::app::kNoticeText[k] * 255.0f + 0.5f)) > 2) lit = false;
      if (!lit) continue;
      ++out.pixels;
      const int gl_y = img.rows - 1 - y;
      if (gl_y < l.band_y || gl_y >= l.band_y + l.band_h) out.outside_band = true;
    }
  return out;
}

}  // namespace

TEST(ClusterRun, ANodeWhoseMasterIsGoneSaysSoOnItsWalls) {
  if (!demo_data()) GTEST_SKIP() << "no demo data (scripts/make-demo-data.sh)";
  const fs::path dir = fresh_dir("notice");
  const fs::path cfg = write_config(dir, "room.toml", true);
  const fs::path out = dir / "floor";
  const pid_t node = spawn({"--config", cfg.string(), "--node", "floor", "--headless", "--resolution", "320x320",
                            "--save-every", "1", "--out", out.string(), "-v", "1"},
                           dir / "floor.log");
  const std::string text = "waiting for master";
  const auto layout = kumite::app::notice_layout(text.size(), 320, 320);
  const std::size_t lit = kumite::app::notice_pixels_lit(text) * static_cast<std::size_t>(layout.scale * layout.scale);
  // No master yet: once master_lost_ms has passed, the empty room with the notice.
  ASSERT_TRUE(within(60, [&] { return fs::exists(out / "floor_left_00000_notice.png"); })) << read(dir / "floor.log");
  // The master runs until the node has drawn a frame of its state, then stops (a master of a
  // fixed 30 simulated frames could be done before the node's socket had reconnected: the node
  // never saw it, 1 run in 3 on a quiet machine).
  const std::vector<std::string> margs{"--config", cfg.string(), "--headless", "--resolution", "32x18", "--simulated-time",
                                       "--frames", "100000", "--save-every", "0", "--out", (dir / "master").string()};
  const pid_t master = spawn(margs, dir / "master.log");
  const bool drew = within(60, [&] { return !frames_of(out / "frames.jsonl").empty(); });
  kill(master, SIGTERM);
  const int master_rc = wait_exit(master);
  ASSERT_TRUE(drew) << "the node drew no frame of the master's\n" << read(dir / "floor.log") << read(dir / "master.log");
  ASSERT_TRUE(master_rc == 0 || master_rc == 128 + SIGTERM) << master_rc << read(dir / "master.log");
  // The master gone: the node waits for it again (its second wait), its last frame shown.
  ASSERT_TRUE(within(30, [&] { return count_of(read(dir / "floor.log"), "waiting for master") >= 2; }))
      << read(dir / "floor.log");
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  kill(node, SIGTERM);
  ASSERT_EQ(wait_exit(node), 128 + SIGTERM) << read(dir / "floor.log");

  const auto frames = frames_of(out / "frames.jsonl");
  ASSERT_FALSE(frames.empty()) << read(dir / "floor.log");
  // The notice's frames are drawn, not logged: one line per frame of the master's.
  std::ifstream lines(out / "frames.jsonl");
  std::size_t n = 0;
  for (std::string line; std::getline(lines, line);) ++n;
  EXPECT_EQ(n, frames.size());
  const std::uint64_t last = frames.rbegin()->first;
  for (const std::string eye : {"left", "right"}) {
    char name[64];
    std::snprintf(name, sizeof name, "floor_%s_%05llu", eye.c_str(), static_cast<unsigned long long>(last));
    const cv::Mat shown = cv::imread((out / (std::string(name) + ".png")).string());
    const cv::Mat notice = cv::imread((out / (std::string(name) + "_notice.png")).string());
    ASSERT_FALSE(shown.empty()) << name;
    ASSERT_FALSE(notice.empty()) << name << "_notice.png: the walls did not say that the master is gone";
    ASSERT_EQ(notice.size(), shown.size());
    // The letters, all of them, on the band; above and below it the last frame kept as it was.
    const Letters l = letters_in(notice, layout);
    EXPECT_EQ(l.pixels, lit) << name;
    EXPECT_FALSE(l.outside_band);
    EXPECT_EQ(letters_in(shown, layout).pixels, 0u) << name << ": letters on a frame of the master's";
    std::size_t differ = 0;
    for (int y = 0; y < shown.rows; ++y) {
      const int gl_y = shown.rows - 1 - y;
      if (gl_y >= layout.band_y && gl_y < layout.band_y + layout.band_h) continue;
      for (int x = 0; x < shown.cols; ++x)
        if (shown.at<cv::Vec3b>(y, x) != notice.at<cv::Vec3b>(y, x)) ++differ;
    }
    EXPECT_EQ(differ, 0u) << name << ": the last picture was not kept around the notice";
  }
  const cv::Mat before = cv::imread((out / "floor_left_00000_notice.png").string());
  EXPECT_EQ(letters_in(before, layout).pixels, lit);
}

// A node asking for a hardware swap group on a display without GLX_NV_swap_group (Xvfb): one
// line says so and what its walls do instead; the node runs on. Needs a display (the ctest
// ClusterWindows.UnderXvfb runs it under xvfb-run); skipped without one.
TEST(ClusterWindows, ASwapGroupTheDisplayDoesNotOfferIsSaidInOneLine) {
  const char* display = std::getenv("DISPLAY");
  if (!display || !*display) GTEST_SKIP() << "no display (ctest ClusterWindows.UnderXvfb runs this under xvfb-run)";
  const fs::path dir = fresh_dir("swap_group");
  // The file's last table is the floor node's: it asks for group 1 bound to barrier 1.
  const fs::path cfg = write_config(dir, "room.toml", true, "swap_group = 1\nswap_barrier = 1\n");
  const pid_t node = spawn({"--config", cfg.string(), "--node", "floor", "-v", "1"}, dir / "floor.log");
  const std::string line =
      "node floor: swap_group = 1, swap_barrier = 1 asked for, but the display does not offer GLX_NV_swap_group";
  bool said = false;
  for (int i = 0; i < 600 && !said; ++i) {
    said = read(dir / "floor.log").find(line) != std::string::npos;
    if (!said) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(waitpid(node, nullptr, WNOHANG), 0) << "the node stopped: " << read(dir / "floor.log");
  kill(node, SIGTERM);
  EXPECT_EQ(wait_exit(node), 128 + SIGTERM) << read(dir / "floor.log");
  EXPECT_TRUE(said) << read(dir / "floor.log");
}
