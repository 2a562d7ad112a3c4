// The render cluster: protocol and config, then a master with render nodes on one machine.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <zmq.hpp>

#include "kumite/cluster/cluster.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/time.hpp"

namespace kc = kumite::cluster;
using kumite::now;

namespace {

std::filesystem::path temp_dir(const std::string& name) {
  auto d = std::filesystem::temp_directory_path() / fmt::format("kumite-cluster-test-{}-{}", name, getpid());
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

/// A [cluster] text with `n` nodes n0..n{n-1} over ipc in `dir` or tcp on `port`.
std::string cluster_text(int n, const std::filesystem::path& dir, int port = 0) {
  std::string t = "[cluster]\n";
  if (port > 0) t += fmt::format("state = \"tcp://127.0.0.1:{}\"\ncontrol = \"tcp://127.0.0.1:{}\"\n", port, port + 1);
  else t += fmt::format("state = \"ipc://{}/state\"\ncontrol = \"ipc://{}/control\"\n", dir.string(), dir.string());
  t += "deadline_ms = 20\n";
  for (int i = 0; i < n; ++i) t += fmt::format("[[cluster.nodes]]\nname = \"n{}\"\nwalls = [\"w{}\"]\n", i, i);
  return t;
}

std::string error_of(const std::string& text) {
  try {
    kc::parse_cluster_config(text, "room.toml");
  } catch (const kumite::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(ClusterProtocol, AMessageReadsBackAndEveryDefectIsNamed) {
  std::string m;
  const std::string body = "frame state bytes";
  kc::encode_message({kc::MessageType::state, 0xABCDEF, 42, 1.25, 0}, std::as_bytes(std::span(body.data(), body.size())), m);
  ASSERT_EQ(m.size(), kc::kHeaderBytes + body.size());
  kc::Header h;
  std::string_view payload;
  ASSERT_EQ(kc::decode_message(m, 0xABCDEF, h, payload), kc::Defect::none);
  EXPECT_EQ(h.type, kc::MessageType::state);
  EXPECT_EQ(h.frame, 42u);
  EXPECT_EQ(h.master_time_s, 1.25);
  EXPECT_EQ(payload, body);
  // Cut anywhere: cut.
  for (std::size_t n : {0ul, 5ul, 20ul, m.size() - 1})
    EXPECT_EQ(kc::decode_message(std::string_view(m).substr(0, n), 0xABCDEF, h, payload), kc::Defect::cut) << n;
  // A byte more than the header says: oversized; too large to be a payload: oversized.
  EXPECT_EQ(kc::decode_message(m + "x", 0xABCDEF, h, payload), kc::Defect::oversized);
  EXPECT_EQ(kc::decode_message(std::string(kc::kHeaderBytes + kc::kMaxPayloadBytes + 1, 'x'), 0xABCDEF, h, payload),
            kc::Defect::oversized);
  std::string v = m;
  v[4] = 9;  // protocol version 9
  EXPECT_EQ(kc::decode_message(v, 0xABCDEF, h, payload), kc::Defect::wrong_version);
  v[4] = 1;  // version 1: STATEs without the master's console
  EXPECT_EQ(kc::decode_message(v, 0xABCDEF, h, payload), kc::Defect::wrong_version);
  v[4] = 2;  // version 2: a console without the planner's line
  EXPECT_EQ(kc::decode_message(v, 0xABCDEF, h, payload), kc::Defect::wrong_version);
  std::string g = m;
  g[0] = 'X';
  EXPECT_EQ(kc::decode_message(g, 0xABCDEF, h, payload), kc::Defect::bad_magic);
  EXPECT_EQ(kc::decode_message(m, 0x123, h, payload), kc::Defect::wrong_config);
  std::string t = m;
  t[6] = 99;
  EXPECT_EQ(kc::decode_message(t, 0xABCDEF, h, payload), kc::Defect::bad_type);
  std::string nf = m;
  const double nan = std::nan("");
  std::memcpy(nf.data() + 24, &nan, 8);
  EXPECT_EQ(kc::decode_message(nf, 0xABCDEF, h, payload), kc::Defect::not_finite);
}

TEST(ClusterConfig, NodesReadAndMistakesSaidWithFileLineAndKey) {
  const auto c = kc::parse_cluster_config(
      "[cluster]\nstate = \"tcp://10.0.0.1:7700\"\ncontrol = \"tcp://10.0.0.1:7701\"\nstate_bind = \"tcp://*:7700\"\n"
      "[[cluster.nodes]]\nname = \"front\"\naddress = \"10.0.0.11\"\nwalls = [\"front\", \"floor\"]\n"
      "[[cluster.nodes]]\nname = \"left\"\nwalls = [\"left\"]\nwindows = [\"left\"]\n",
      "room.toml");
  ASSERT_TRUE(c);
  ASSERT_EQ(c->nodes.size(), 2u);
  EXPECT_EQ(c->nodes[0].walls, (std::vector<std::string>{"front", "floor"}));
  EXPECT_EQ(*c->nodes[0].address, "10.0.0.11");
  EXPECT_EQ(c->nodes[1].windows, std::vector<std::string>{"left"});
  EXPECT_EQ(c->max_misses, 3);
  EXPECT_EQ(*c->state_bind, "tcp://*:7700");
  EXPECT_NE(c->node("left"), nullptr);
  EXPECT_EQ(c->node("right"), nullptr);
  EXPECT_FALSE(kc::parse_cluster_config("display_rate_hz = 60\n", "room.toml"));

  const std::string head = "[cluster]\nstate = \"ipc:///tmp/s\"\ncontrol = \"ipc:///tmp/c\"\n";
  const std::string node = "[[cluster.nodes]]\nname = \"a\"\nwalls = [\"front\"]\n";
  EXPECT_EQ(error_of("[cluster]\nstate = \"udp://x:1\"\ncontrol = \"ipc:///tmp/c\"\n" + node),
            "room.toml:2: cluster.state: \"udp://x:1\": an endpoint is tcp://HOST:PORT or ipc://PATH");
  EXPECT_EQ(error_of(head + "deadline_ms = nan\n" + node).substr(0, 34), "room.toml:4: cluster.deadline_ms: ");
  EXPECT_EQ(error_of(head + "max_misses = 0\n" + node).substr(0, 33), "room.toml:4: cluster.max_misses: ");
  EXPECT_EQ(error_of(head + "colour = 1\n" + node).substr(0, 29), "room.toml:4: cluster.colour: ");
  EXPECT_EQ(error_of(head + node + node), "room.toml:8: cluster.nodes[1].name: node \"a\" named twice");
  EXPECT_EQ(error_of(head + "[[cluster.nodes]]\nname = \"a\"\n").substr(0, 35), "room.toml:4: cluster.nodes[0].walls");
  EXPECT_EQ(error_of(head), "room.toml:1: cluster.nodes: a cluster has at least one [[cluster.nodes]]");
  // A hardware swap group (and barrier) asked for by a node: 1..16; a barrier needs a group.
  const auto g = kc::parse_cluster_config(head + node + "swap_group = 2\nswap_barrier = 1\n", "room.toml");
  ASSERT_TRUE(g);
  EXPECT_EQ(g->nodes[0].swap_group, 2);
  EXPECT_EQ(g->nodes[0].swap_barrier, 1);
  EXPECT_FALSE(c->nodes[0].swap_group);
  EXPECT_EQ(error_of(head + node + "swap_group = 0\n").substr(0, 42), "room.toml:7: cluster.nodes[0].swap_group: ");
  EXPECT_EQ(error_of(head + node + "swap_group = 1.5\n").substr(0, 42), "room.toml:7: cluster.nodes[0].swap_group: ");
  EXPECT_EQ(error_of(head + node + "swap_barrier = 1\n"),
            "room.toml:7: cluster.nodes[0].swap_barrier: binds a swap group to a barrier: give swap_group too");
}

namespace {

/// A master thread stepping frames at `rate` until stopped, each frame's payload its number.
struct MasterThread {
  kc::MasterOptions options;
  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> frames{0};
  std::thread thread;
  std::mutex m;
  std::vector<std::string> events;
  std::vector<kc::BarrierReport> reports;
  double rate = 120;

  void start() {
    thread = std::thread([this] {
      kc::Master master(options);
      const double period = 1.0 / rate;
      const kumite::Timestamp t0 = now();
      for (std::uint64_t i = 0; !stop; ++i) {
        kumite::sleep_until(t0 + static_cast<double>(i) * period);
        const std::uint64_t v = i;
        master.publish(i, static_cast<double>(i) * period, std::as_bytes(std::span(&v, 1)));
        const auto& r = master.release();
        std::lock_guard lock(m);
        reports.push_back(r);
        for (auto& e : master.take_events()) events.push_back(std::move(e));
        frames = i + 1;
      }
    });
  }
  void join() {
    stop = true;
    if (thread.joinable()) thread.join();
  }
  ~MasterThread() { join(); }
  /// Whether an event containing `text` was said.
  bool said(const std::string& text) {
    std::lock_guard lock(m);
    for (const auto& e : events)
      if (e.find(text) != std::string::npos) return true;
    return false;
  }
};

/// N in-process nodes drawing every frame they get until `frames` each.
void nodes_take_frames(const kc::ClusterConfig& cfg, std::uint64_t hash, int n, int frames,
                       std::vector<std::vector<std::uint64_t>>& got, std::vector<std::vector<kc::NodeTiming>>& timings) {
  got.assign(static_cast<std::size_t>(n), {});
  timings.assign(static_cast<std::size_t>(n), {});
  std::vector<std::thread> threads;
  for (int i = 0; i < n; ++i)
    threads.emplace_back([&, i] {
      kc::NodeOptions no{cfg, fmt::format("n{}", i), hash};
      kc::Node node(no);
      const kumite::Timestamp give_up = now() + 10;
      while (static_cast<int>(got[static_cast<std::size_t>(i)].size()) < frames && now() < give_up) {
        if (node.next_state(0.05) != kc::Node::Wait::state) continue;
        std::uint64_t v = 0;
        ASSERT_EQ(node.state().size(), sizeof v);
        std::memcpy(&v, node.state().data(), sizeof v);
        ASSERT_EQ(v, node.state_header().frame);  // the payload is the frame's own
        if (!node.in_barrier()) continue;         // frames before WELCOME are not the barrier's
        node.ready();
        if (node.wait_go()) got[static_cast<std::size_t>(i)].push_back(node.state_header().frame);
      }
      timings[static_cast<std::size_t>(i)] = node.timings();
    });
  for (auto& t : threads) t.join();
}

void frames_in_order_and_released_together(const std::string& text) {
  const auto cfg = *kc::parse_cluster_config(text, "room.toml");
  const std::uint64_t hash = kc::config_hash(text);
  MasterThread master;
  master.options = {cfg, hash, 0.02};
  master.start();
  std::vector<std::vector<std::uint64_t>> got;
  std::vector<std::vector<kc::NodeTiming>> timings;
  nodes_take_frames(cfg, hash, 3, 120, got, timings);
  master.join();
  for (const auto& g : got) {
    ASSERT_EQ(g.size(), 120u);
    for (std::size_t k = 1; k < g.size(); ++k) ASSERT_LT(g[k - 1], g[k]) << "frames out of order";
  }
  // The same frame drawn by all: for every frame all three drew and the master gathered
  // without its deadline, no node was released by GO before every node had sent READY (one
  // clock on one machine). The skew itself is the benchmark's figure (load makes it vary).
  std::set<std::uint64_t> deadline_hit;
  for (const auto& r : master.reports)
    if (r.deadline_hit) deadline_hit.insert(r.frame);
  std::map<std::uint64_t, std::vector<const kc::NodeTiming*>> by_frame;
  for (const auto& t : timings)
    for (const auto& r : t)
      if (r.go_rx_s >= 0 && r.ready_tx_s >= 0) by_frame[r.frame].push_back(&r);
  // From the frame after the last node joined (the frame a node joins at is not yet its).
  std::uint64_t joined = 0;
  for (const auto& g : got) joined = std::max(joined, g.front());
  int common = 0;
  for (const auto& [f, rows] : by_frame) {
    if (rows.size() != 3 || deadline_hit.contains(f) || f <= joined) continue;
    ++common;
    double last_ready = 0, first_go = 1e300;
    for (const auto* r : rows) {
      last_ready = std::max(last_ready, r->ready_tx_s);
      first_go = std::min(first_go, r->go_rx_s);
    }
    EXPECT_GE(first_go, last_ready) << "frame " << f << ": a node swapped before another had drawn it";
  }
  EXPECT_GE(common, 60);
}

}  // namespace

TEST(ClusterBarrier, FramesArriveInOrderAndAreReleasedTogetherOverIpc) {
  const auto dir = temp_dir("ipc");
  frames_in_order_and_released_together(cluster_text(3, dir));
}

TEST(ClusterBarrier, FramesArriveInOrderAndAreReleasedTogetherOverTcp) {
  frames_in_order_and_released_together(cluster_text(3, {}, 27610));
}

TEST(ClusterBarrier, ANodeWithAnotherInstallationFileIsRefusedInOneLine) {
  const auto dir = temp_dir("refused");
  const std::string text = cluster_text(2, dir);
  const auto cfg = *kc::parse_cluster_config(text, "room.toml");
  MasterThread master;
  master.options = {cfg, kc::config_hash(text), 0.02};
  master.start();
  kc::Node node({cfg, "n1", kc::config_hash(text + "# edited\n")});
  kc::Node::Wait w = kc::Node::Wait::timeout;
  for (int i = 0; i < 40 && w != kc::Node::Wait::refused; ++i) w = node.next_state(0.05);
  ASSERT_EQ(w, kc::Node::Wait::refused);
  ASSERT_TRUE(node.refused());
  EXPECT_NE(node.refused()->find("node \"n1\" refused: its installation file (hash"), std::string::npos) << *node.refused();
  EXPECT_EQ(node.refused()->find('\n'), std::string::npos);
  EXPECT_EQ(node.stats().states, 0u);  // the master's STATEs are another file's: never taken
  for (int i = 0; i < 100 && !master.said("refused"); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_TRUE(master.said("node \"n1\" refused"));
  // A name the file does not have: refused by the node itself, naming the file's nodes.
  try {
    kc::Node stranger({cfg, "n9", kc::config_hash(text)});
    FAIL() << "a node not in the file was made";
  } catch (const kumite::Error& e) {
    EXPECT_STREQ(e.what(), "--node n9: not a node of the installation file (its nodes: n0, n1)");
  }
}

TEST(ClusterBarrier, DamagedMessagesAreCountedAndNeverStallTheFrames) {
  const auto dir = temp_dir("damaged");
  const std::string text = cluster_text(1, dir);
  const auto cfg = *kc::parse_cluster_config(text, "room.toml");
  const std::uint64_t hash = kc::config_hash(text);
  // A fake master's PUB sending the node damaged STATEs between good ones.
  zmq::context_t ctx;
  zmq::socket_t pub(ctx, zmq::socket_type::pub);
  pub.set(zmq::sockopt::linger, 0);
  pub.bind(cfg.state);
  zmq::socket_t router(ctx, zmq::socket_type::router);
  router.set(zmq::sockopt::linger, 0);
  router.bind(cfg.control);
  kc::Node node({cfg, "n0", hash});
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the SUB joined
  std::string good, other_version, other_file, cut, big;
  const std::uint64_t v = 7;
  kc::encode_message({kc::MessageType::state, hash, 7, 0.5, 0}, std::as_bytes(std::span(&v, 1)), good);
  other_version = good;
  other_version[4] = static_cast<char>(kc::kProtocolVersion + 1);
  kc::encode_message({kc::MessageType::state, hash ^ 1, 7, 0.5, 0}, std::as_bytes(std::span(&v, 1)), other_file);
  cut = good.substr(0, good.size() - 3);
  big = std::string(kc::kHeaderBytes + kc::kMaxPayloadBytes + 10, '\0');
  std::memcpy(big.data(), good.data(), 8);
  for (const std::string* m : {&other_version, &other_file, &cut, &big, &good}) pub.send(zmq::buffer(*m));
  const kumite::Timestamp t0 = now();
  ASSERT_EQ(node.next_state(2.0), kc::Node::Wait::state);
  EXPECT_LT(now() - t0, 0.5);
  EXPECT_EQ(node.state_header().frame, 7u);
  const auto& d = node.stats().defects;
  EXPECT_EQ(d.wrong_version, 1u);
  EXPECT_EQ(d.wrong_config, 1u);
  EXPECT_EQ(d.cut, 1u);
  EXPECT_EQ(d.oversized, 1u);

  // The master's side: garbage on its ROUTER is counted, the barrier goes on.
  const auto dir2 = temp_dir("damaged-master");
  const std::string text2 = cluster_text(1, dir2);
  const auto cfg2 = *kc::parse_cluster_config(text2, "room.toml");
  kc::Master master({cfg2, kc::config_hash(text2), 0.01});
  zmq::socket_t dealer(ctx, zmq::socket_type::dealer);
  dealer.set(zmq::sockopt::linger, 0);
  dealer.set(zmq::sockopt::routing_id, "n0");
  dealer.connect(cfg2.control);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  for (const std::string* m : {&other_version, &cut, &big}) dealer.send(zmq::buffer(*m));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const kumite::Timestamp t1 = now();
  for (std::uint64_t f = 0; f < 5; ++f) {
    master.publish(f, 0, {});
    master.release();
  }
  EXPECT_LT(now() - t1, 0.5);
  EXPECT_EQ(master.stats().defects.total(), 3u);
  EXPECT_EQ(master.stats().frames, 5u);
}

// ---- processes: kumite-cluster node, stopped, continued, killed, restarted -----------------

namespace {

pid_t spawn_node(const std::string& config, const std::string& name) {
  const std::string exe = KUMITE_BINARY_DIR + "/bin/kumite-cluster";
  const pid_t pid = fork();
  if (pid == 0) {
    execl(exe.c_str(), exe.c_str(), "node", "--config", config.c_str(), "--node", name.c_str(), "--draw-ms", "2",
          static_cast<char*>(nullptr));
    _exit(127);
  }
  return pid;
}

/// Waits until `pred` holds (true) or `seconds` pass (false).
template <typename P>
bool within(double seconds, P pred) {
  const kumite::Timestamp end = now() + seconds;
  while (now() < end) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return pred();
}

struct Processes {
  std::vector<pid_t> pids;
  ~Processes() {
    for (pid_t p : pids) {
      kill(p, SIGCONT);
      kill(p, SIGKILL);
      waitpid(p, nullptr, 0);
    }
  }
};

/// The master in this process; its members read from the last barrier report.
struct LiveMaster {
  MasterThread t;
  int members() {
    std::lock_guard lock(t.m);
    return t.reports.empty() ? 0 : t.reports.back().members;
  }
  bool all_ready(int n) {
    std::lock_guard lock(t.m);
    return !t.reports.empty() && t.reports.back().members == n && t.reports.back().ready == n;
  }
};

}  // namespace

TEST(ClusterProcesses, AStoppedNodeLeavesTheBarrierAndRejoinsWhenContinued) {
  const auto dir = temp_dir("stop");
  const std::string text = cluster_text(3, dir);
  const auto config = (dir / "room.toml").string();
  std::ofstream(config) << text;
  LiveMaster m;
  m.t.options = {*kc::parse_cluster_config(text, config), kc::config_hash(text), 2.0 / 120};
  m.t.start();
  Processes nodes;
  for (int i = 0; i < 3; ++i) nodes.pids.push_back(spawn_node(config, fmt::format("n{}", i)));
  ASSERT_TRUE(within(5, [&] { return m.all_ready(3); })) << "3 nodes did not join";
  const kumite::Timestamp stopped = now();
  kill(nodes.pids[1], SIGSTOP);
  ASSERT_TRUE(within(2, [&] { return m.members() == 2; })) << "the stopped node is still waited for";
  const double dropped_s = now() - stopped;
  EXPECT_LT(dropped_s, 0.3);
  EXPECT_TRUE(m.t.said("node \"n1\" left the barrier"));
  // The others go on: frames keep coming with both of them ready.
  ASSERT_TRUE(within(1, [&] { return m.all_ready(2); }));
  const kumite::Timestamp continued = now();
  kill(nodes.pids[1], SIGCONT);
  ASSERT_TRUE(within(3, [&] { return m.all_ready(3); })) << "the continued node did not rejoin";
  EXPECT_LT(now() - continued, 1.0);
  std::printf("[ figures  ] stopped node dropped within %.0f ms, back in the barrier within %.0f ms\n", dropped_s * 1e3,
              (now() - continued) * 1e3);
}

TEST(ClusterProcesses, AKilledNodeRestartedRejoins) {
  const auto dir = temp_dir("kill");
  const std::string text = cluster_text(2, {}, 27620);
  const auto config = (dir / "room.toml").string();
  std::ofstream(config) << text;
  LiveMaster m;
  m.t.options = {*kc::parse_cluster_config(text, config), kc::config_hash(text), 2.0 / 120};
  m.t.start();
  Processes nodes;
  for (int i = 0; i < 2; ++i) nodes.pids.push_back(spawn_node(config, fmt::format("n{}", i)));
  ASSERT_TRUE(within(5, [&] { return m.all_ready(2); }));
  const kumite::Timestamp killed = now();
  kill(nodes.pids[0], SIGKILL);
  waitpid(nodes.pids[0], nullptr, 0);
  ASSERT_TRUE(within(2, [&] { return m.members() == 1; }));
  EXPECT_LT(now() - killed, 0.3);
  const kumite::Timestamp restarted = now();
  nodes.pids[0] = spawn_node(config, "n0");
  ASSERT_TRUE(within(3, [&] { return m.all_ready(2); })) << "the restarted node did not rejoin";
  EXPECT_LT(now() - restarted, 1.0);
}

TEST(ClusterProcesses, NodesWaitForARestartedMasterAndRejoinIt) {
  const auto dir = temp_dir("master");
  const std::string text = cluster_text(2, dir);
  const auto config = (dir / "room.toml").string();
  std::ofstream(config) << text;
  const auto cfg = *kc::parse_cluster_config(text, config);
  Processes nodes;
  for (int i = 0; i < 2; ++i) nodes.pids.push_back(spawn_node(config, fmt::format("n{}", i)));
  {
    LiveMaster m;
    m.t.options = {cfg, kc::config_hash(text), 2.0 / 120};
    m.t.start();
    ASSERT_TRUE(within(5, [&] { return m.all_ready(2); }));
  }  // the master is gone
  std::this_thread::sleep_for(std::chrono::milliseconds(800));  // nodes wait for the master
  for (pid_t p : nodes.pids) EXPECT_EQ(waitpid(p, nullptr, WNOHANG), 0) << "a node exited without its master";
  LiveMaster again;
  again.t.options = {cfg, kc::config_hash(text), 2.0 / 120};
  const kumite::Timestamp restarted = now();
  again.t.start();
  ASSERT_TRUE(within(5, [&] { return again.all_ready(2); })) << "the nodes did not come back to a restarted master";
  EXPECT_LT(now() - restarted, 5.0);
  std::printf("[ figures  ] a restarted master had both nodes in step within %.0f ms\n", (now() - restarted) * 1e3);
}

TEST(ClusterBarrier, ASecondProcessUnderATakenNameIsRefusedAndTheFirstStays) {
  const auto dir = temp_dir("twice");
  const std::string text = cluster_text(1, dir);
  const auto cfg = *kc::parse_cluster_config(text, "room.toml");
  const std::uint64_t hash = kc::config_hash(text);
  MasterThread master;
  master.options = {cfg, hash, 0.02};
  master.start();
  std::atomic<bool> stop{false};
  std::atomic<int> drawn{0};
  std::thread first([&] {
    kc::Node node({cfg, "n0", hash});
    while (!stop) {
      if (node.next_state(0.05) != kc::Node::Wait::state) continue;
      node.ready();
      if (node.wait_go() && node.in_barrier()) ++drawn;
    }
  });
  for (int i = 0; i < 300 && drawn < 20; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_GE(drawn.load(), 20) << "the first n0 did not join";
  kc::Node second({cfg, "n0", hash});
  kc::Node::Wait w = kc::Node::Wait::timeout;
  for (int i = 0; i < 60 && w != kc::Node::Wait::refused; ++i) {
    w = second.next_state(0.05);
    if (w == kc::Node::Wait::state) {
      second.ready();
      second.wait_go();
    }
  }
  ASSERT_EQ(w, kc::Node::Wait::refused);
  EXPECT_EQ(*second.refused(), "node \"n0\" refused: named twice: another process is node \"n0\" and is in the barrier");
  // The first goes on drawing in the barrier.
  const int before = drawn;
  for (int i = 0; i < 300 && drawn < before + 30; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_GE(drawn.load(), before + 30);
  stop = true;
  first.join();
}

// The tool's own master and node (the bench's synthetic frames) as processes that end by
// themselves: both exit 0 having passed every frame (under ASan + UBSan, a finding in either
// ends it with another status: the master's synthetic state once shifted an int by 32).
TEST(ClusterProcesses, TheToolsMasterAndNodeRunTheirFramesAndExitCleanly) {
  const auto dir = temp_dir("tool");
  const std::string text = cluster_text(1, dir);
  const auto config = (dir / "room.toml").string();
  std::ofstream(config) << text;
  const std::string exe = KUMITE_BINARY_DIR + "/bin/kumite-cluster";
  const auto run = [&](std::vector<std::string> args, const std::filesystem::path& log) {
    const pid_t pid = fork();
    if (pid == 0) {
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      dup2(fd, 2);
      std::vector<char*> argv{const_cast<char*>(exe.c_str())};
      for (auto& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      execv(exe.c_str(), argv.data());
      _exit(127);
    }
    return pid;
  };
  const auto status = [](pid_t pid) {
    int s = 0;
    waitpid(pid, &s, 0);
    return WIFEXITED(s) ? WEXITSTATUS(s) : 128 + WTERMSIG(s);
  };
  const auto read = [](const std::filesystem::path& p) {
    std::ifstream in(p);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  // The node leaves 1.5 s after its last state; the master runs 2 s at 120 Hz with 32-byte states.
  const pid_t node = run({"node", "--config", config, "--node", "n0", "--idle-exit-s", "1.5"}, dir / "node.log");
  const pid_t master = run({"master", "--config", config, "--frames", "240", "--rate", "120", "--payload", "32"}, dir / "master.log");
  EXPECT_EQ(status(master), 0) << read(dir / "master.log");
  EXPECT_EQ(status(node), 0) << read(dir / "node.log");
  EXPECT_NE(read(dir / "master.log").find("master: 240 frames, 72 bytes/frame"), std::string::npos) << read(dir / "master.log");
  EXPECT_NE(read(dir / "node.log").find("node n0: "), std::string::npos) << read(dir / "node.log");
}
