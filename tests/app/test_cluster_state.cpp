// A render node's STATE as the app packs it (frame_states.hpp): the master's console (every
// text the node shows or logs, its events' texts among them) travels with the frame and reads
// back as it was; the frame's and skeleton's records are those of states.bin, byte for byte; a
// console record cut or malformed anywhere is a console problem (the frame still reads), never
// a crash; two consoles, or a cut frame, are a frame that does not read; a render node draws a
// frame whose console does not read, says why on its console and counts it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <thread>
#include <vector>


#include "kumite/app/cluster_source.hpp"
#include "kumite/app/config.hpp"
#include "kumite/app/frame_states.hpp"
#include "../app_core/frame_records.hpp"

using namespace kumite::app;
using kumite::app::test::pack_record;
using kumite::app::test::unpack_records;

namespace {

FrameData frame_with_events() {
  FrameData f;
  f.frame = 41;
  f.time_s = 0.5;
  f.now = 12.25;
  f.head_live = true;
  f.head.position = {0.1, 1.6, -0.2};
  for (int k = 0; k < 3; ++k) {
    FrameEvent e;
    e.type = k == 0 ? EventType::visitor_near_wall : EventType::warning;
    e.cause = k == 0 ? EventCause::visitor : EventCause::fighter;
    e.time_s = 0.5;
    e.wall = k == 0 ? 1 : -1;
    e.distance_m = 0.25 * k;
    f.events.push_back(e);
  }
  return f;
}

ConsoleState full_console() {
  ConsoleState c;
  c.fps = 119.8;
  c.frame_cpu_ms = 1.25;
  c.tracking = "tracked, 120 frame sets";
  c.tracking_source = "synthetic: 120 frame sets/s";
  c.recognition = "strike recognition: 7200 pose samples, 12 events";
  c.cameras = {{"cam0", kumite::CameraState::ok, "ok", 4, 3.5}, {"cam1", kumite::CameraState::blind, "blind", 0, -1}};
  c.markers_seen = 7;
  c.head_live = true;
  c.pose_age_ms = 18.5;
  c.tracking_latency_ms = -1;
  c.latch_ms = 2.0;
  c.draw_budget_ms = 5.5;
  c.late_latch = true;
  c.fighter_state = "guard";
  c.character = 1;
  c.character_name = "kenji";
  c.paused = true;
  c.last_order = "punch_right";
  c.last_outcome = "hit (0.04 m)";
  c.planner = "spar  guarding  next punch_left (timer) in 1.2 s  attacks 3  counters 2  score: visitor hits 1 dodges 0, "
              "fighter hits 2 blocks 1 (met 1)";
  c.problems = {"camera cam1: blind", "visitor: 0.25 m from wall left"};
  c.recent = {"   0.40 s  order_accepted punch_right", "   0.50 s  hit punch_right: 0.04 m"};
  c.frame_events = {"the visitor is 0.00 m from wall left (limit 0.40 m)", "", "a warning's text, \xff not UTF-8"};
  return c;
}

void expect_same(const ConsoleState& a, const ConsoleState& b) {
  EXPECT_EQ(a.fps, b.fps);
  EXPECT_EQ(a.frame_cpu_ms, b.frame_cpu_ms);
  EXPECT_EQ(a.tracking, b.tracking);
  EXPECT_EQ(a.tracking_source, b.tracking_source);
  EXPECT_EQ(a.recognition, b.recognition);
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  for (std::size_t k = 0; k < a.cameras.size(); ++k) {
    EXPECT_EQ(a.cameras[k].name, b.cameras[k].name);
    EXPECT_EQ(a.cameras[k].state, b.cameras[k].state);
    EXPECT_EQ(a.cameras[k].status, b.cameras[k].status);
    EXPECT_EQ(a.cameras[k].blobs, b.cameras[k].blobs);
    EXPECT_EQ(a.cameras[k].since_last_ms, b.cameras[k].since_last_ms);
  }
  EXPECT_EQ(a.markers_seen, b.markers_seen);
  EXPECT_EQ(a.head_live, b.head_live);
  EXPECT_EQ(a.pose_age_ms, b.pose_age_ms);
  EXPECT_EQ(a.tracking_latency_ms, b.tracking_latency_ms);
  EXPECT_EQ(a.latch_ms, b.latch_ms);
  EXPECT_EQ(a.draw_budget_ms, b.draw_budget_ms);
  EXPECT_EQ(a.late_latch, b.late_latch);
  EXPECT_EQ(a.fighter_state, b.fighter_state);
  EXPECT_EQ(a.character, b.character);
  EXPECT_EQ(a.character_name, b.character_name);
  EXPECT_EQ(a.paused, b.paused);
  EXPECT_EQ(a.last_order, b.last_order);
  EXPECT_EQ(a.last_outcome, b.last_outcome);
  EXPECT_EQ(a.planner, b.planner);
  EXPECT_EQ(a.problems, b.problems);
  EXPECT_EQ(a.recent, b.recent);
  EXPECT_EQ(a.frame_events, b.frame_events);
}

}  // namespace

TEST(ClusterState, TheMastersConsoleTravelsWithTheFrameAndReadsBackWhole) {
  const FrameData f = frame_with_events();
  const ConsoleState c = full_console();
  std::string state;
  encode_frame_state(f, c, state);
  FrameStateDecoder d;
  FrameData got;
  ConsoleState con;
  ASSERT_TRUE(d.decode(state, got, &con)) << d.problem();
  EXPECT_TRUE(d.has_console()) << d.console_problem();
  EXPECT_EQ(d.console_problem(), "");
  EXPECT_EQ(first_difference(f, got), std::nullopt);
  expect_same(con, c);
  // Without a console asked for, the frame reads all the same.
  FrameStateDecoder plain;
  ASSERT_TRUE(plain.decode(state, got)) << plain.problem();
  EXPECT_EQ(first_difference(f, got), std::nullopt);

  // The frame's record is states.bin's, byte for byte: the console is a record of its own.
  std::string recorded;
  encode_frame_state(f, true, recorded);
  const auto a = unpack_records(state), b = unpack_records(recorded);
  ASSERT_EQ(a.size(), 2u);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_EQ(a[0][0], 3);  // the console
  EXPECT_EQ(a[1], b[0]);
  // A frame without a console record: the frame, no console (and nothing wrong with it said).
  ASSERT_TRUE(d.decode(recorded, got, &con)) << d.problem();
  EXPECT_FALSE(d.has_console());
  EXPECT_EQ(d.console_problem(), "");
  // states.bin never holds a console: its reader refuses one in words.
  {
    const auto file = std::filesystem::temp_directory_path() / ("kumite_cluster_state_" + std::to_string(::getpid()));
    std::ofstream(file, std::ios::binary) << kFrameStatesHeader << state;
    FrameStatesReader reader(file);
    EXPECT_FALSE(reader.next(got));
    EXPECT_NE(reader.problem().find("unknown record kind 3"), std::string::npos) << reader.problem();
    std::filesystem::remove(file);
  }
}

TEST(ClusterState, ACutOrMalformedConsoleIsAProblemSaidNeverACrashAndTheFrameStillReads) {
  const FrameData f = frame_with_events();
  std::string state;
  encode_frame_state(f, full_console(), state);
  const auto raws = unpack_records(state);
  ASSERT_EQ(raws.size(), 2u);
  const std::string& console_raw = raws[0];
  const std::string frame_record = pack_record(raws[1]);
  FrameStateDecoder d;
  FrameData got;
  ConsoleState con;
  const auto expect_console_problem = [&](const std::string& raw, const std::string& what) {
    ASSERT_TRUE(d.decode(pack_record(raw) + frame_record, got, &con)) << what << ": " << d.problem();
    EXPECT_FALSE(d.has_console()) << what;
    EXPECT_FALSE(d.console_problem().empty()) << what;
    EXPECT_EQ(first_difference(f, got), std::nullopt) << what;
  };
  // Cut at every byte: each a console that does not read whole.
  for (std::size_t n = 1; n < console_raw.size(); ++n) expect_console_problem(console_raw.substr(0, n), "cut at " + std::to_string(n));
  // A byte too many.
  expect_console_problem(console_raw + "x", "a byte after it");
  // Numbers not finite or out of range, counts too large, a line longer than the bound.
  const auto at = [&](std::size_t offset, const void* v, std::size_t n) {
    std::string r = console_raw;
    std::memcpy(r.data() + offset, v, n);
    return r;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  expect_console_problem(at(1, &nan, 8), "fps NaN");
  expect_console_problem(at(9, &inf, 8), "frame_cpu_ms infinite");
  const double minus = -5;
  expect_console_problem(at(1, &minus, 8), "fps negative");
  const std::uint32_t huge = 0xFFFFFFF0u, long_line = (64u << 10) + 1;
  expect_console_problem(at(17, &huge, 4), "tracking's length past the record");
  expect_console_problem(at(17, &long_line, 4), "tracking's length past the bound");
  {
    // The cameras' count: after kind, two f64 and three strings.
    const std::size_t cams = 1 + 16 + 3 * 4 + full_console().tracking.size() + full_console().tracking_source.size() +
                             full_console().recognition.size();
    std::uint32_t n = 0;
    std::memcpy(&n, console_raw.data() + cams, 4);
    ASSERT_EQ(n, 2u);
    expect_console_problem(at(cams, &huge, 4), "cameras' count");
    const std::size_t state_at = cams + 4 + 4 + 4;  // count, then name "cam0"
    std::string r = console_raw;
    r[state_at] = 9;
    expect_console_problem(r, "a camera state out of range");
  }
  {
    // The planner's line (after last_outcome): its length past the record, past the bound.
    const std::string& line = full_console().planner;
    const std::size_t text = console_raw.find(line);
    ASSERT_NE(text, std::string::npos);
    ASSERT_EQ(console_raw.find(line, text + 1), std::string::npos);
    std::uint32_t n = 0;
    std::memcpy(&n, console_raw.data() + text - 4, 4);
    ASSERT_EQ(n, line.size());
    expect_console_problem(at(text - 4, &huge, 4), "planner's length past the record");
    expect_console_problem(at(text - 4, &long_line, 4), "planner's length past the bound");
    // A planner line as long as the bound reads; one byte longer is a problem, in words.
    ConsoleState c = full_console();
    c.planner.assign(64u << 10, 'p');
    std::string s;
    encode_frame_state(f, c, s);
    ASSERT_TRUE(d.decode(s, got, &con)) << d.problem();
    EXPECT_TRUE(d.has_console()) << d.console_problem();
    EXPECT_EQ(con.planner, c.planner);
    c.planner += 'p';
    encode_frame_state(f, c, s);
    ASSERT_TRUE(d.decode(s, got, &con)) << d.problem();
    EXPECT_FALSE(d.has_console());
    EXPECT_NE(d.console_problem().find("its console record does not read whole"), std::string::npos) << d.console_problem();
  }
  // Event texts that are not one per event.
  {
    ConsoleState c = full_console();
    c.frame_events.pop_back();
    std::string s;
    encode_frame_state(f, c, s);
    ASSERT_TRUE(d.decode(s, got, &con)) << d.problem();
    EXPECT_FALSE(d.has_console());
    EXPECT_NE(d.console_problem().find("2 event texts for the frame's 3 events"), std::string::npos) << d.console_problem();
  }
  // Two console records: the state does not read.
  EXPECT_FALSE(d.decode(pack_record(console_raw) + pack_record(console_raw) + frame_record, got, &con));
  EXPECT_EQ(d.problem(), "a second console record");
  // The whole state cut anywhere: false or whole, never a crash; then a good one reads again.
  for (std::size_t n = 0; n < state.size(); ++n) {
    const bool ok = d.decode(std::string_view(state).substr(0, n), got, &con);
    EXPECT_FALSE(ok) << n;
  }
  ASSERT_TRUE(d.decode(state, got, &con)) << d.problem();
  EXPECT_TRUE(d.has_console());
  expect_same(con, full_console());
}

namespace {

void replace_all(std::string& s, const std::string& from, const std::string& to) {
  for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) s.replace(at, from.size(), to);
}

}  // namespace

TEST(ClusterState, ANodeDrawsAFrameWhoseConsoleDoesNotReadSaysWhyAndCountsIt) {
  namespace fs = std::filesystem;
  const fs::path src = KUMITE_SOURCE_DIR;
  if (!fs::exists(src / "build/demo/fighter.kdb")) GTEST_SKIP() << "no demo data (scripts/make-demo-data.sh)";
  const fs::path dir = fs::temp_directory_path() / ("kumite_cluster_state_node_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ifstream in(src / "config/demo-cluster.toml");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  replace_all(text, "\"../", "\"" + src.string() + "/");
  replace_all(text, "\"rig/", "\"" + src.string() + "/config/rig/");
  replace_all(text, "\"tracking.toml\"", "\"" + src.string() + "/config/tracking.toml\"");
  replace_all(text, "\"orders-demo.csv\"", "\"" + src.string() + "/config/orders-demo.csv\"");
  replace_all(text, "ipc:///tmp/kumite-demo-", "ipc://" + dir.string() + "/");
  std::ofstream(dir / "room.toml") << text;
  const InstallationConfig cfg = load_installation_config(dir / "room.toml");
  ASSERT_TRUE(cfg.cluster);
  // The master publishes the state of the moment every 20 ms from a thread of its own (a
  // node's SUB may join after a first STATE: none is lost for good); a run stuck for 20 s ends.
  const FrameData f = frame_with_events();
  FrameData f2 = f;
  f2.frame = 42;
  const ConsoleState c = full_console();
  std::string good;
  encode_frame_state(f2, c, good);
  std::string first;
  encode_frame_state(f, c, first);
  const auto raws = unpack_records(first);
  ASSERT_EQ(raws.size(), 2u);
  const std::string bad = pack_record(raws[0].substr(0, 40)) + pack_record(raws[1]);  // its console cut
  std::atomic<int> which{1}, stop{0};
  std::thread publisher([&] {
    kumite::cluster::Master master({*cfg.cluster, cfg.file_hash, 0.02});
    const auto t0 = std::chrono::steady_clock::now();
    for (std::uint64_t n = 1; which.load() != 0; ++n) {
      const std::string& s = which.load() == 1 ? bad : good;
      master.publish(n, 0.02 * static_cast<double>(n), std::as_bytes(std::span(s.data(), s.size())));
      master.release();
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      if (std::chrono::steady_clock::now() - t0 > std::chrono::seconds(20)) stop = 1;
    }
  });
  struct Joined {  // the publisher stopped and joined however the test ends
    std::atomic<int>& which;
    std::thread& t;
    ~Joined() {
      which = 0;
      t.join();
    }
  } joined{which, publisher};
  ClusterRunOptions options;
  options.stop = &stop;
  ClusterNodeSource node(cfg, "floor", options);

  // A frame whose console record is cut: drawn; its console says why; counted.
  const FrameData* got = node.next();
  ASSERT_NE(got, nullptr);
  EXPECT_EQ(got->frame, f.frame);
  EXPECT_EQ(got->events, f.events);
  ConsoleState con = node.console(*got);
  ASSERT_FALSE(con.problems.empty());
  EXPECT_NE(con.problems[0].find("the master's console does not read: its console record does not read whole"),
            std::string::npos)
      << con.problems[0];
  EXPECT_TRUE(con.frame_events.empty());
  EXPECT_GE(node.bad_console(), 1u);
  EXPECT_EQ(node.undecodable(), 0u);
  node.drawn();

  // Whole again: the master's console, the node's own problems after the master's.
  which = 2;
  do {
    got = node.next();
    if (got) node.drawn();
  } while (got && got->frame != 42u);
  ASSERT_NE(got, nullptr);
  const auto bad_ones = node.bad_console();
  con = node.console(*got);
  EXPECT_EQ(con.frame_events, c.frame_events);
  EXPECT_EQ(con.tracking, c.tracking);
  EXPECT_EQ(con.last_outcome, c.last_outcome);
  EXPECT_EQ(con.planner, c.planner);
  ASSERT_GE(con.problems.size(), c.problems.size());
  EXPECT_TRUE(std::equal(c.problems.begin(), c.problems.end(), con.problems.begin()));
  for (std::size_t k = c.problems.size(); k < con.problems.size(); ++k)
    EXPECT_TRUE(con.problems[k] == "not in the swap barrier" || con.problems[k] == "waiting for master") << con.problems[k];
  got = node.next();
  ASSERT_NE(got, nullptr);
  EXPECT_EQ(node.bad_console(), bad_ones);
  fs::remove_all(dir);
}
