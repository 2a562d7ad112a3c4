// kumite-dtrack: a room's own tracker on the network (issue 55, tracker interop).
//
//   kumite-dtrack listen [--port 5000] [--multicast 224.0.1.0] [--config room.toml] [--osc]
//                        [--count N] [--duration S]
//       prints each frame received (bodies in Kumite's room, their roles), each bad packet
//       one line, and a summary (packets, frames, bad, oversized, unconfigured, frame gaps)
//   kumite-dtrack send --port 5000 [--host 127.0.0.1] [--from poses.csv | --synthetic]
//                      [--rate 60] [--duration S] [--loop] [--osc] [--config room.toml]
//       sends DTrack ASCII (6d with Euler angles; --osc: OSC bundles) of a poses.csv
//       (kumite-track --out, kumite-recognise poses) on its timestamps, or a synthetic visitor
//   kumite-dtrack bridge --port 5000 --osc-host 127.0.0.1 --osc-port 9000 [--config room.toml]
//       DTrack in -> OSC out, each frame forwarded from the receiver's thread as it arrives
//
// --config: a TOML file with a [dtrack] table (tracking/README.md: port, multicast_group,
// room_axes, rotation, translation_m, conjugate_body, [dtrack.bodies] role = id).
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <map>

#include "kumite/common/error.hpp"
#include "kumite/common/time.hpp"
#include "kumite/recognition/poses_file.hpp"
#include "kumite/tracking/interop.hpp"

using namespace kumite;
using namespace kumite::tracking;

namespace {

std::atomic<bool> g_interrupted{false};
void on_signal(int) { g_interrupted.store(true); }

struct Common {
  std::string config, table = "dtrack";
  int port = -1;
  bool osc = false;
};

DtrackInput load_input(const Common& c) {
  DtrackInput in = c.config.empty() ? DtrackInput{} : read_dtrack_config(c.config, c.table);
  if (c.port >= 0) in.port = c.port;
  return in;
}

std::string describe(const RoomBody& b) {
  const std::string name = b.role >= 0 ? std::string(kRoleNames[static_cast<std::size_t>(b.role)])
                                       : fmt::format("{} {}", b.kind == RoomBodyKind::flystick ? "flystick" : "body", b.id);
  if (!b.tracked) return name + " not tracked";
  return fmt::format("{} ({:.3f}, {:.3f}, {:.3f}) m q {:.2f}", name, b.position_m[0], b.position_m[1], b.position_m[2],
                     b.quality);
}

void print_frame(const RoomFrame& f, std::uint64_t skipped) {
  std::string line = fmt::format("fr {}", f.frame);
  if (f.source_time_s >= 0) line += fmt::format(" ts {:.3f}", f.source_time_s);
  if (f.latency_us >= 0) line += fmt::format(" latency {:.1f} ms", f.latency_us * 1e-3);
  line += fmt::format(" (+{:.2f} ms to publish):", (f.published_at - f.received_at) * 1e3);
  if (f.body_count == 0) line += " no bodies";
  for (int i = 0; i < f.body_count; ++i) line += (i ? "; " : " ") + describe(f.bodies[static_cast<std::size_t>(i)]);
  if (f.bodies_dropped) line += fmt::format("; {} more left out", f.bodies_dropped);
  if (skipped) line += fmt::format("  [{} frames not printed]", skipped);
  std::printf("%s\n", line.c_str());
}

int run_listen(const Common& c, const std::string& multicast, long count, double duration_s) {
  DtrackInput in = load_input(c);
  if (!multicast.empty()) in.multicast_group = multicast;
  std::unique_ptr<Receiver> rx;
  if (c.osc) {
    OscReceiverOptions o;
    o.multicast_group = in.multicast_group;
    o.role_body = in.role_body;
    rx = std::make_unique<OscReceiver>(in.port, o);
  } else {
    rx = std::make_unique<DtrackReceiver>(in);
  }
  rx->start();
  std::printf("listening for %s on udp %s:%d%s (Ctrl-C to stop)\n", c.osc ? "OSC" : "DTrack ASCII",
              in.bind_address.c_str(), rx->port(),
              in.multicast_group.empty() ? "" : fmt::format(", multicast {}", in.multicast_group).c_str());
  std::fflush(stdout);
  const double end = duration_s > 0 ? now() + duration_s : 1e300;
  std::uint64_t printed_version = 0;
  while (!g_interrupted.load() && now() < end && (count <= 0 || rx->counters().packets < static_cast<std::uint64_t>(count))) {
    sleep_until(now() + 0.002);
    for (const auto& line : rx->take_problems()) std::printf("BAD %s\n", line.c_str());
    const std::uint64_t v = rx->version();
    if (v != printed_version) {
      if (const auto f = rx->poll()) print_frame(*f, v - printed_version - 1);
      printed_version = v;
    }
    std::fflush(stdout);
  }
  sleep_until(now() + 0.01);
  for (const auto& line : rx->take_problems()) std::printf("BAD %s\n", line.c_str());
  rx->stop();
  const ReceiverCounters k = rx->counters();
  std::printf("packets %llu, frames %llu, bad %llu (oversized %llu), bodies not configured %llu, frames skipped by "
              "the sender %llu\n",
              static_cast<unsigned long long>(k.packets), static_cast<unsigned long long>(k.frames),
              static_cast<unsigned long long>(k.bad_packets), static_cast<unsigned long long>(k.oversized),
              static_cast<unsigned long long>(k.unconfigured_bodies), static_cast<unsigned long long>(k.frame_gaps));
  return 0;
}

/// Frames of poses in Kumite's room, with their time from the start (s).
struct Script {
  std::vector<double> t;
  std::vector<RoomFrame> frames;
};

Script from_poses(const std::string& path, const DtrackInput& in) {
  const auto file = recognition::read_poses_csv(path);
  Script s;
  std::map<double, RoomFrame> by_time;
  for (const auto& p : file.samples) {
    RoomFrame& f = by_time[p.t];
    const int role = static_cast<int>(p.role);
    if (f.body_count >= kRoomFrameBodies) continue;
    RoomBody& b = f.bodies[static_cast<std::size_t>(f.body_count++)];
    b.role = role;
    b.id = in.role_body[static_cast<std::size_t>(role)] >= 0 ? in.role_body[static_cast<std::size_t>(role)] : role;
    b.tracked = p.tracked;
    b.quality = p.tracked ? 1 : -1;
    b.position_m = p.position;
    b.orientation = p.orientation;
  }
  if (by_time.empty()) throw Error("cli", "args", fmt::format("{}: no poses of head, hands or feet in it", path));
  const double t0 = by_time.begin()->first;
  for (auto& [t, f] : by_time) {
    s.t.push_back(t - t0);
    s.frames.push_back(f);
  }
  return s;
}

/// A synthetic visitor: the head swaying on a 10 cm circle at 1.7 m, the hands before it.
RoomFrame synthetic(double t, const DtrackInput& in) {
  RoomFrame f;
  const double a = 2 * 3.14159265358979 * 0.5 * t;
  const std::array<std::array<double, 3>, 3> p{{{0.1 * std::cos(a), 1.7, -0.1 * std::sin(a)},
                                               {-0.25, 1.3 + 0.1 * std::sin(a), -0.3},
                                               {0.25, 1.3 - 0.1 * std::sin(a), -0.3}}};
  for (int r = 0; r < 3; ++r) {
    RoomBody& b = f.bodies[static_cast<std::size_t>(f.body_count++)];
    b.role = r;
    b.id = in.role_body[static_cast<std::size_t>(r)] >= 0 ? in.role_body[static_cast<std::size_t>(r)] : r;
    b.tracked = true;
    b.quality = 1;
    b.position_m = p[static_cast<std::size_t>(r)];
    const double yaw = 0.3 * std::sin(a);
    b.orientation = {std::cos(yaw / 2), 0, std::sin(yaw / 2), 0};
  }
  return f;
}

int run_send(const Common& c, const std::string& host, const std::string& from, double rate, double duration_s, bool loop) {
  DtrackInput in = load_input(c);
  Script script;
  if (!from.empty()) script = from_poses(from, in);
  std::unique_ptr<DtrackSender> dtrack;
  std::unique_ptr<OscSender> osc;
  if (c.osc) osc = std::make_unique<OscSender>(host, in.port);
  else dtrack = std::make_unique<DtrackSender>(host, in.port);
  std::printf("sending %s to udp %s:%d from %s\n", c.osc ? "OSC" : "DTrack ASCII", host.c_str(), in.port,
              from.empty() ? "a synthetic visitor" : from.c_str());
  std::fflush(stdout);
  const double start = now();
  const double end = duration_s > 0 ? start + duration_s : 1e300;
  DtrackFrame out;
  std::uint64_t n = 0, failed = 0;
  std::size_t i = 0;
  double offset = 0;
  while (!g_interrupted.load() && now() < end) {
    RoomFrame f;
    if (script.frames.empty()) {
      sleep_until(start + static_cast<double>(n) / rate);
      f = synthetic(static_cast<double>(n) / rate, in);
    } else {
      if (i >= script.frames.size()) {
        if (!loop) break;
        offset += script.t.back() + 1.0 / rate;
        i = 0;
      }
      sleep_until(start + offset + script.t[i]);
      f = script.frames[i++];
    }
    f.frame = ++n;
    f.source_time_s = now();
    bool ok = false;
    if (osc) {
      ok = osc->send(f);
    } else {
      to_dtrack_frame(f, in.room, out);
      ok = dtrack->send(out);
    }
    if (!ok && failed++ == 0)
      std::fprintf(stderr, "kumite-dtrack: send failed: %s\n", osc ? osc->last_error().c_str() : dtrack->last_error().c_str());
  }
  std::printf("sent %llu frames (%llu failed)\n", static_cast<unsigned long long>(n), static_cast<unsigned long long>(failed));
  return failed == 0 ? 0 : 1;
}

int run_bridge(const Common& c, const std::string& osc_host, int osc_port, double duration_s) {
  const DtrackInput in = load_input(c);
  auto osc = std::make_shared<OscSender>(osc_host, osc_port);
  DtrackReceiverOptions o;
  std::atomic<std::uint64_t> sent{0};
  o.on_packet = [osc, &sent](const DtrackFrame& f, const RoomFrame& room) {
    if (f.has_frame && osc->send(room)) sent.fetch_add(1);
  };
  DtrackReceiver rx(in, o);
  rx.start();
  std::printf("bridging DTrack udp %s:%d -> OSC %s:%d (Ctrl-C to stop)\n", in.bind_address.c_str(), rx.port(),
              osc_host.c_str(), osc_port);
  std::fflush(stdout);
  const double end = duration_s > 0 ? now() + duration_s : 1e300;
  while (!g_interrupted.load() && now() < end) {
    sleep_until(now() + 0.05);
    for (const auto& line : rx.take_problems()) std::printf("BAD %s\n", line.c_str());
    std::fflush(stdout);
  }
  rx.stop();
  const ReceiverCounters k = rx.counters();
  std::printf("packets %llu, frames forwarded %llu, bad %llu\n", static_cast<unsigned long long>(k.packets),
              static_cast<unsigned long long>(sent.load()), static_cast<unsigned long long>(k.bad_packets));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"kumite-dtrack: a room's own tracker (ART DTrack ASCII, OSC) in and out"};
  app.require_subcommand(1);
  Common common;
  auto add_common = [&](CLI::App* sc, bool osc_flag) {
    sc->add_option("--port", common.port, "UDP port (default: the config's, else 5000)")->check(CLI::Range(0, 65535));
    sc->add_option("--config", common.config, "TOML file with a [dtrack] table (room transform, roles)")
        ->check(CLI::ExistingFile);
    sc->add_option("--table", common.table, "the table's dotted name in --config")->capture_default_str();
    if (osc_flag) sc->add_flag("--osc", common.osc, "OSC (/rigidbody/<id>/transformation) instead of DTrack ASCII");
  };

  std::string multicast;
  long count = 0;
  double duration_s = 0;
  auto* listen = app.add_subcommand("listen", "print what arrives (each bad packet one line) and a summary");
  add_common(listen, true);
  listen->add_option("--multicast", multicast, "join this IPv4 multicast group");
  listen->add_option("--count", count, "stop after this many packets");
  listen->add_option("--duration", duration_s, "stop after this many seconds");

  std::string host = "127.0.0.1", from;
  double rate = 60;
  bool synthetic_flag = false, loop = false;
  auto* send = app.add_subcommand("send", "send a poses.csv or a synthetic visitor as DTrack ASCII (or OSC)");
  add_common(send, true);
  send->add_option("--host", host, "destination (IPv4 address, name or multicast group)")->capture_default_str();
  send->add_option("--from", from, "poses.csv (kumite-track --out, kumite-recognise poses)")->check(CLI::ExistingFile);
  send->add_flag("--synthetic", synthetic_flag, "a synthetic visitor (the default without --from)");
  send->add_option("--rate", rate, "frames per second of the synthetic visitor")->capture_default_str()->check(CLI::Range(1.0, 1000.0));
  send->add_option("--duration", duration_s, "stop after this many seconds");
  send->add_flag("--loop", loop, "play --from again and again");

  std::string osc_host = "127.0.0.1";
  int osc_port = 9000;
  auto* bridge = app.add_subcommand("bridge", "DTrack ASCII in -> OSC out, each frame as it arrives");
  add_common(bridge, false);
  bridge->add_option("--osc-host", osc_host, "OSC destination")->capture_default_str();
  bridge->add_option("--osc-port", osc_port, "OSC destination port")->capture_default_str()->check(CLI::Range(1, 65535));
  bridge->add_option("--duration", duration_s, "stop after this many seconds");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  try {
    if (listen->parsed()) return run_listen(common, multicast, count, duration_s);
    if (send->parsed()) {
      if (synthetic_flag && !from.empty()) throw Error("cli", "args", "--synthetic or --from, not both");
      return run_send(common, host, from, rate, duration_s, loop);
    }
    return run_bridge(common, osc_host, osc_port, duration_s);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kumite-dtrack: %s\n", e.what());
    return 1;
  }
}
