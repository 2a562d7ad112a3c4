// kumite-cluster: the render cluster's barrier on its own, with synthetic frame states of a
// given size and synthetic drawing times: a master, a node, and `bench`, which runs a master
// and N node processes on this machine and prints the figures as JSON.
//
//   kumite-cluster master --config FILE --frames N [--rate HZ] [--payload BYTES] [--log CSV]
//   kumite-cluster node   --config FILE --node NAME [--draw-ms MS] [--frames N] [--log CSV]
//   kumite-cluster bench  [--nodes 2,4,8] [--frames N] [--transport ipc|tcp] [--payload BYTES]
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "kumite/cluster/cluster.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/time.hpp"

namespace kc = kumite::cluster;
using kumite::now;

namespace {

std::atomic<int> g_stop{0};
void on_signal(int s) { g_stop = s; }

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw kumite::Error("cli", "io", fmt::format("{}: cannot read", path));
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

struct Loaded {
  kc::ClusterConfig config;
  std::uint64_t hash = 0;
};
Loaded load(const std::string& path) {
  const std::string text = read_file(path);
  auto c = kc::parse_cluster_config(text, path);
  if (!c) throw kumite::Error("cli", "config", fmt::format("{}: no [cluster] table", path));
  return {*c, kc::config_hash(text)};
}

int run_master(const std::string& config, int frames, double rate, std::size_t payload, const std::string& log) {
  const Loaded l = load(config);
  kc::MasterOptions mo;
  mo.config = l.config;
  mo.config_hash = l.hash;
  mo.deadline_s = l.config.deadline_ms ? *l.config.deadline_ms * 1e-3 : 2.0 / rate;
  kc::Master master(mo);
  std::vector<std::byte> state(payload);
  std::FILE* out = log.empty() ? nullptr : std::fopen(log.c_str(), "w");
  if (out) std::fprintf(out, "frame,publish_s,members,ready,deadline_hit,gather_ms,step_ms\n");
  const double period = 1.0 / rate;
  const kumite::Timestamp t0 = now();
  for (int i = 0; (frames <= 0 || i < frames) && !g_stop; ++i) {
    const kumite::Timestamp t = t0 + i * period;
    kumite::sleep_until(t);
    // The frame number's 8 bytes, little-endian (shifted as 64 bits: an int shifted by 32 or
    // more is undefined, UBSan's finding).
    const auto number = static_cast<std::uint64_t>(i);
    for (std::size_t k = 0; k < std::min<std::size_t>(payload, 8); ++k) state[k] = static_cast<std::byte>(number >> (8 * k));
    const kumite::Timestamp pub = now();
    master.publish(static_cast<std::uint64_t>(i), t - t0, state);
    // The master's own work for the frame: publishing the state (to every node's pipe); the
    // gather that follows waits for the nodes and is the barrier's, not the step's.
    const double step_ms = (now() - pub) * 1e3;
    const auto& r = master.release();
    if (out)
      std::fprintf(out, "%d,%.6f,%d,%d,%d,%.3f,%.4f\n", i, pub, r.members, r.ready, r.deadline_hit ? 1 : 0,
                   r.gather_s * 1e3, step_ms);
    for (const auto& e : master.take_events()) std::fprintf(stderr, "master: %s\n", e.c_str());
  }
  if (out) std::fclose(out);
  const auto& s = master.stats();
  std::fprintf(stderr, "master: %llu frames, %llu bytes/frame (max %llu), %llu deadlines hit, %llu joins, %llu leaves, "
               "%llu refused, %llu bad messages\n",
               static_cast<unsigned long long>(s.frames), static_cast<unsigned long long>(s.state_bytes_last),
               static_cast<unsigned long long>(s.state_bytes_max), static_cast<unsigned long long>(s.deadlines_hit),
               static_cast<unsigned long long>(s.joins), static_cast<unsigned long long>(s.leaves),
               static_cast<unsigned long long>(s.refusals), static_cast<unsigned long long>(s.defects.total()));
  return 0;
}

int run_node(const std::string& config, const std::string& name, double draw_ms, int frames, const std::string& log,
             double idle_exit_s) {
  const Loaded l = load(config);
  kc::NodeOptions no;
  no.config = l.config;
  no.name = name;
  no.config_hash = l.hash;
  kc::Node node(no);
  std::mt19937 rng(static_cast<unsigned>(std::hash<std::string>{}(name)));
  std::uniform_real_distribution<double> draw(0, draw_ms * 1e-3);
  int taken = 0;
  kumite::Timestamp last = now();
  int rc = 0;
  while ((frames <= 0 || taken < frames) && !g_stop) {
    const auto w = node.next_state(0.05);
    for (const auto& e : node.take_events()) std::fprintf(stderr, "%s\n", e.c_str());
    if (w == kc::Node::Wait::refused) {
      rc = 3;
      break;
    }
    if (w == kc::Node::Wait::timeout) {
      if (idle_exit_s > 0 && now() - last > idle_exit_s) break;
      continue;
    }
    last = now();
    // "Drawing": a wait of a random time up to --draw-ms (what glFinish would wait for).
    kumite::sleep_until(now() + draw(rng));
    node.ready();
    node.wait_go();
    ++taken;
  }
  for (const auto& e : node.take_events()) std::fprintf(stderr, "%s\n", e.c_str());
  if (!log.empty()) {
    std::FILE* out = std::fopen(log.c_str(), "w");
    if (!out) throw kumite::Error("cli", "io", fmt::format("{}: cannot write", log));
    std::fprintf(out, "frame,master_time_s,state_rx_s,ready_tx_s,go_rx_s,bytes\n");
    for (const auto& t : node.timings())
      std::fprintf(out, "%llu,%.6f,%.6f,%.6f,%.6f,%u\n", static_cast<unsigned long long>(t.frame), t.master_time_s,
                   t.state_rx_s, t.ready_tx_s, t.go_rx_s, t.state_bytes);
    std::fclose(out);
  }
  const auto& s = node.stats();
  std::fprintf(stderr, "node %s: %llu states (%llu skipped), %llu GO, %llu GO timeouts, %llu welcomes, %llu lefts, "
               "%llu bad messages\n",
               name.c_str(), static_cast<unsigned long long>(s.states), static_cast<unsigned long long>(s.skipped),
               static_cast<unsigned long long>(s.gos), static_cast<unsigned long long>(s.go_timeouts),
               static_cast<unsigned long long>(s.welcomes), static_cast<unsigned long long>(s.lefts),
               static_cast<unsigned long long>(s.defects.total()));
  return rc;
}

// ---- bench --------------------------------------------------------------------------------

struct Row {
  double master_time = 0, state_rx = 0, ready_tx = 0, go_rx = 0;
};
std::map<std::uint64_t, Row> read_log(const std::filesystem::path& p) {
  std::map<std::uint64_t, Row> rows;
  std::ifstream in(p);
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    unsigned long long f = 0;
    Row r;
    unsigned b = 0;
    if (std::sscanf(line.c_str(), "%llu,%lf,%lf,%lf,%lf,%u", &f, &r.master_time, &r.state_rx, &r.ready_tx, &r.go_rx, &b) == 6)
      rows[f] = r;
  }
  return rows;
}
struct PublishRow {
  double publish_s = 0, step_ms = 0;
  int members = 0;
};
std::map<std::uint64_t, PublishRow> read_publish(const std::filesystem::path& p) {
  std::map<std::uint64_t, PublishRow> rows;
  std::ifstream in(p);
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    unsigned long long f = 0;
    PublishRow r;
    int ready = 0, hit = 0;
    double gather = 0;
    if (std::sscanf(line.c_str(), "%llu,%lf,%d,%d,%d,%lf,%lf", &f, &r.publish_s, &r.members, &ready, &hit, &gather,
                    &r.step_ms) == 7)
      rows[f] = r;
  }
  return rows;
}
struct BarrierRow {
  double publish_s = 0;
  int members = 0, ready = 0;
};
std::map<std::uint64_t, BarrierRow> read_barrier(const std::filesystem::path& p) {
  std::map<std::uint64_t, BarrierRow> rows;
  std::ifstream in(p);
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    unsigned long long f = 0;
    BarrierRow r;
    if (std::sscanf(line.c_str(), "%llu,%lf,%d,%d", &f, &r.publish_s, &r.members, &r.ready) == 4) rows[f] = r;
  }
  return rows;
}

/// s from `since` to the first frame published after it whose barrier satisfies `pred`
/// (NAN: none).
template <typename P>
double first_after(const std::map<std::uint64_t, BarrierRow>& rows, double since, P pred) {
  for (const auto& [f, r] : rows)
    if (r.publish_s > since && pred(r)) return r.publish_s - since;
  return NAN;
}

double pct(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))];
}

pid_t spawn(const std::vector<std::string>& args) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv("/proc/self/exe", argv.data());
    _exit(127);
  }
  return pid;
}

std::string write_config(const std::filesystem::path& dir, int nodes, const std::string& transport, int port) {
  std::string text = "[cluster]\n";
  if (transport == "tcp")
    text += fmt::format("state = \"tcp://127.0.0.1:{}\"\ncontrol = \"tcp://127.0.0.1:{}\"\n", port, port + 1);
  else
    text += fmt::format("state = \"ipc://{}/state\"\ncontrol = \"ipc://{}/control\"\n", dir.string(), dir.string());
  for (int i = 0; i < nodes; ++i) text += fmt::format("[[cluster.nodes]]\nname = \"n{}\"\nwalls = [\"w{}\"]\n", i, i);
  const auto path = dir / "cluster.toml";
  std::ofstream(path) << text;
  return path.string();
}

int run_bench(const std::vector<int>& counts, int frames, const std::string& transport, std::size_t payload,
              double rate, double draw_ms) {
  const auto dir = std::filesystem::temp_directory_path() / fmt::format("kumite-cluster-bench-{}", getpid());
  std::filesystem::create_directories(dir);
  std::printf("{\n  \"transport\": \"%s\", \"rate_hz\": %.1f, \"payload_bytes\": %zu, \"frames\": %d, \"draw_ms_max\": %.1f,\n"
              "  \"runs\": [\n", transport.c_str(), rate, payload, frames, draw_ms);
  for (std::size_t ci = 0; ci < counts.size(); ++ci) {
    const int n = counts[ci];
    // A cluster names one node at least: with none attached, n0 is named and never started.
    const std::string config = write_config(dir, std::max(n, 1), transport, 27700 + 10 * static_cast<int>(ci));
    std::vector<pid_t> pids;
    for (int i = 0; i < n; ++i)
      pids.push_back(spawn({"kumite-cluster", "node", "--config", config, "--node", fmt::format("n{}", i), "--draw-ms",
                            fmt::format("{}", draw_ms), "--idle-exit-s", "1.5", "--log",
                            (dir / fmt::format("n{}.csv", i)).string()}));
    // Nodes say HELLO as they start; the master's first frames welcome them. The figures are
    // taken from frames where every node was in the barrier.
    const pid_t master = spawn({"kumite-cluster", "master", "--config", config, "--frames", std::to_string(frames), "--rate",
                                fmt::format("{}", rate), "--payload", std::to_string(payload), "--log",
                                (dir / "master.csv").string()});
    int status = 0;
    waitpid(master, &status, 0);
    for (pid_t p : pids) waitpid(p, &status, 0);
    std::vector<std::map<std::uint64_t, Row>> logs;
    for (int i = 0; i < n; ++i) logs.push_back(read_log(dir / fmt::format("n{}.csv", i)));
    const auto published = read_publish(dir / "master.csv");
    std::vector<double> skew, latency, step;
    for (const auto& [f, row] : published) {
      // The master's step: frames with every node in the barrier (all of them with none).
      if (row.members == n) step.push_back(row.step_ms * 1e-3);
      const double pub = row.publish_s;
      double lo = INFINITY, hi = -INFINITY;
      bool all = true;
      for (const auto& l : logs) {
        const auto it = l.find(f);
        if (it == l.end() || it->second.go_rx < 0) {
          all = false;
          break;
        }
        lo = std::min(lo, it->second.go_rx);
        hi = std::max(hi, it->second.go_rx);
        latency.push_back(it->second.state_rx - pub);
      }
      if (all && !logs.empty()) skew.push_back(hi - lo);
    }
    // JSON has no NaN: a figure without frames (no nodes: no skew) is null.
    const auto ms = [](double s) { return std::isfinite(s) ? fmt::format("{:.3f}", s * 1e3) : std::string("null"); };
    std::printf("    {\"nodes\": %d, \"frames_all_released\": %zu, \"go_skew_ms\": {\"p50\": %s, \"p99\": %s, \"max\": %s}, "
                "\"state_to_node_ms\": {\"p50\": %s, \"p99\": %s}, "
                "\"master_step_ms\": {\"frames\": %zu, \"p50\": %s, \"p99\": %s}}%s\n",
                n, skew.size(), ms(pct(skew, 0.5)).c_str(), ms(pct(skew, 0.99)).c_str(), ms(pct(skew, 1.0)).c_str(),
                ms(pct(latency, 0.5)).c_str(), ms(pct(latency, 0.99)).c_str(), step.size(), ms(pct(step, 0.5)).c_str(),
                ms(pct(step, 0.99)).c_str(), ci + 1 < counts.size() ? "," : "");
    std::fflush(stdout);
  }
  std::printf("  ],\n");
  // Faults, 3 nodes: n0 stopped (SIGSTOP) then continued, n1 killed (SIGKILL) then restarted.
  // Times from the signal to the first frame the master publishes with the node out of (or
  // back in) its barrier, read from the master's per-frame log.
  {
    const int n = 3;
    const std::string config = write_config(dir, n, transport, 27790);
    const auto node_args = [&](int i) {
      return std::vector<std::string>{"kumite-cluster", "node", "--config", config, "--node", fmt::format("n{}", i),
                                      "--draw-ms", fmt::format("{}", draw_ms), "--idle-exit-s", "1.5"};
    };
    std::vector<pid_t> pids;
    for (int i = 0; i < n; ++i) pids.push_back(spawn(node_args(i)));
    const int frames_f = static_cast<int>(rate * 6);
    const pid_t master = spawn({"kumite-cluster", "master", "--config", config, "--frames", std::to_string(frames_f), "--rate",
                                fmt::format("{}", rate), "--payload", std::to_string(payload), "--log",
                                (dir / "faults.csv").string()});
    const auto after = [](double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); };
    after(1.5);
    const double t_stop = now();
    kill(pids[0], SIGSTOP);
    after(1.0);
    const double t_cont = now();
    kill(pids[0], SIGCONT);
    after(1.0);
    const double t_kill = now();
    kill(pids[1], SIGKILL);
    int status = 0;
    waitpid(pids[1], &status, 0);
    after(0.5);
    const double t_restart = now();
    pids[1] = spawn(node_args(1));
    waitpid(master, &status, 0);
    for (pid_t p : pids) waitpid(p, &status, 0);
    const auto rows = read_barrier(dir / "faults.csv");
    const auto out_of = [&](const BarrierRow& r) { return r.members == n - 1; };
    const auto all_in = [&](const BarrierRow& r) { return r.members == n && r.ready == n; };
    std::printf("  \"faults_3_nodes_ms\": {\"stopped_node_dropped_within\": %.0f, \"continued_node_back_within\": %.0f, "
                "\"killed_node_dropped_within\": %.0f, \"restarted_node_back_within\": %.0f}\n}\n",
                first_after(rows, t_stop, out_of) * 1e3, first_after(rows, t_cont, all_in) * 1e3,
                first_after(rows, t_kill, out_of) * 1e3, first_after(rows, t_restart, all_in) * 1e3);
  }
  std::filesystem::remove_all(dir);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"kumite-cluster: the render cluster's barrier with synthetic frames"};
  app.require_subcommand(1);
  std::string config, name, log, transport = "ipc", nodes_list = "2,4,8";
  int frames = 0;
  double rate = 120, draw_ms = 3, idle_exit_s = 0;
  std::size_t payload = 6000;
  auto* m = app.add_subcommand("master", "publish synthetic frames and run the barrier");
  m->add_option("--config", config, "TOML file with a [cluster] table")->required();
  m->add_option("--frames", frames, "frames (0: until SIGINT/SIGTERM)")->check(CLI::Range(0, 100000000));
  m->add_option("--rate", rate, "Hz")->check(CLI::Range(1.0, 1000.0));
  m->add_option("--payload", payload, "bytes of state per frame")->check(CLI::Range(0, 1 << 20));
  m->add_option("--log", log, "CSV of each frame's barrier");
  auto* nd = app.add_subcommand("node", "take frames, draw for a random time, READY, GO");
  nd->add_option("--config", config, "TOML file with a [cluster] table")->required();
  nd->add_option("--node", name, "its name in [[cluster.nodes]]")->required();
  nd->add_option("--draw-ms", draw_ms, "drawing time, uniform in [0, MS]")->check(CLI::Range(0.0, 1000.0));
  nd->add_option("--frames", frames, "frames then exit (0: until a signal)")->check(CLI::Range(0, 100000000));
  nd->add_option("--idle-exit-s", idle_exit_s, "exit after this long without a state (0: never)")->check(CLI::Range(0.0, 3600.0));
  nd->add_option("--log", log, "CSV of each frame's times (state received, READY sent, GO received)");
  auto* b = app.add_subcommand("bench", "a master and N nodes on this machine: GO skew and STATE latency as JSON");
  b->add_option("--nodes", nodes_list, "node counts, comma-separated");
  b->add_option("--frames", frames, "frames per run")->check(CLI::Range(10, 1000000))->default_val(1200);
  b->add_option("--transport", transport, "ipc or tcp")->check(CLI::IsMember({"ipc", "tcp"}));
  b->add_option("--payload", payload, "bytes of state per frame")->check(CLI::Range(0, 1 << 20));
  b->add_option("--rate", rate, "Hz")->check(CLI::Range(1.0, 1000.0));
  b->add_option("--draw-ms", draw_ms, "nodes' drawing time, uniform in [0, MS]")->check(CLI::Range(0.0, 1000.0));
  CLI11_PARSE(app, argc, argv);
  signal(SIGINT, on_signal);
  signal(SIGTERM, on_signal);
  try {
    if (*m) return run_master(config, frames, rate, payload, log);
    if (*nd) return run_node(config, name, draw_ms, frames, log, idle_exit_s);
    std::vector<int> counts;
    std::stringstream ss(nodes_list);
    for (std::string item; std::getline(ss, item, ',');) {
      const int c = std::atoi(item.c_str());
      if (c < 0 || c > 64 || item.find_first_not_of("0123456789") != std::string::npos || item.empty())
        throw kumite::Error("cli", "nodes", fmt::format("--nodes: \"{}\": counts 0 to 64 (0: the master alone)", item));
      counts.push_back(c);
    }
    return run_bench(counts, frames, transport, payload, rate, draw_ms);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kumite-cluster: %s\n", e.what());
    return 2;
  }
}
