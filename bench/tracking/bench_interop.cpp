// A room's own tracker (issue 55): DTrack ASCII and OSC packet -> pose published, over
// 127.0.0.1, and the parser's CPU per packet.
//   build/bin/kumite_tracking_interop_bench --benchmark_format=json
// Loopback benchmarks: a 5-body frame (head, hands, feet) is sent every 2 ms (the receiver's
// thread goes back to sleep in poll() between packets, as it does at DTrack's 60-300 Hz); per
// packet the receiver's own stamps give
//   recv_to_publish: datagram read -> frame pollable (parse, room transform, publish),
//   send_to_publish: before sendto() -> frame pollable (adds the kernel's loopback delivery and
//                    the receiver thread's wake-up; what the app sees);
// counters in ms: p50, p99, max over the run; the iteration time is send_to_publish.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "kumite/common/time.hpp"
#include "kumite/tracking/interop.hpp"

using namespace kumite::tracking;

namespace {

RoomFrame visitor(std::uint64_t n) {
  RoomFrame f;
  f.frame = n;
  f.source_time_s = kumite::now();
  const double s = std::sin(static_cast<double>(n) * 0.05);
  const std::array<std::array<double, 3>, 5> p{{{0.05 * s, 1.7, -0.1}, {-0.25, 1.3 + 0.1 * s, -0.3},
                                               {0.25, 1.3 - 0.1 * s, -0.3}, {-0.15, 0.1, 0}, {0.15, 0.1, 0}}};
  for (int i = 0; i < 5; ++i) {
    RoomBody& b = f.bodies[static_cast<std::size_t>(f.body_count++)];
    b.id = i;
    b.role = i;
    b.tracked = true;
    b.quality = 1;
    b.position_m = p[static_cast<std::size_t>(i)];
    b.orientation = {std::cos(0.1 * s), 0, std::sin(0.1 * s), 0};
  }
  return f;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(pos);
  const double f = pos - static_cast<double>(i);
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

void report(benchmark::State& state, const std::vector<double>& recv_to_pub, const std::vector<double>& send_to_pub,
            std::uint64_t late) {
  auto ms = [](double s) { return benchmark::Counter(s * 1e3); };
  state.counters["recv_to_publish_p50_ms"] = ms(percentile(recv_to_pub, 0.5));
  state.counters["recv_to_publish_p99_ms"] = ms(percentile(recv_to_pub, 0.99));
  state.counters["recv_to_publish_max_ms"] = ms(percentile(recv_to_pub, 1.0));
  state.counters["send_to_publish_p50_ms"] = ms(percentile(send_to_pub, 0.5));
  state.counters["send_to_publish_p99_ms"] = ms(percentile(send_to_pub, 0.99));
  state.counters["send_to_publish_max_ms"] = ms(percentile(send_to_pub, 1.0));
  state.counters["packets"] = static_cast<double>(send_to_pub.size());
  state.counters["not_published_within_100ms"] = static_cast<double>(late);
}

/// Sends with `send(frame)`, waits for the receiver to publish that frame, records its stamps.
template <typename Send>
void loopback(benchmark::State& state, Receiver& rx, Send send) {
  std::vector<double> recv_to_pub, send_to_pub;
  std::uint64_t n = 0, late = 0;
  for (auto _ : state) {
    const RoomFrame f = visitor(++n);
    const double t_send = kumite::now();
    send(f);
    kumite::sleep_until(t_send + 0.002);
    std::optional<RoomFrame> got = rx.poll();
    while ((!got || got->frame != n) && kumite::now() < t_send + 0.1) {
      kumite::sleep_until(kumite::now() + 1e-4);
      got = rx.poll();
    }
    if (!got || got->frame != n) {
      ++late;
      state.SetIterationTime(0.1);
      continue;
    }
    recv_to_pub.push_back(got->published_at - got->received_at);
    send_to_pub.push_back(got->published_at - t_send);
    state.SetIterationTime(got->published_at - t_send);
  }
  report(state, recv_to_pub, send_to_pub, late);
}

void BM_DtrackLoopbackPacketToPose(benchmark::State& state) {
  DtrackInput in;
  in.port = 0;
  in.bind_address = "127.0.0.1";
  in.role_body = {0, 1, 2, 3, 4};
  DtrackReceiver rx(in);
  rx.start();
  DtrackSender tx("127.0.0.1", rx.port());
  DtrackFrame out;
  loopback(state, rx, [&](const RoomFrame& f) {
    to_dtrack_frame(f, in.room, out);
    tx.send(out);
  });
  if (rx.counters().bad_packets) state.SkipWithError("bad packets");
}
BENCHMARK(BM_DtrackLoopbackPacketToPose)->Iterations(2000)->UseManualTime()->Unit(benchmark::kMillisecond);

void BM_OscLoopbackPacketToPose(benchmark::State& state) {
  OscReceiverOptions o;
  o.role_body = {0, 1, 2, 3, 4};
  OscReceiver rx(0, o);
  rx.start();
  OscSender tx("127.0.0.1", rx.port());
  loopback(state, rx, [&](const RoomFrame& f) { tx.send(f); });
  if (rx.counters().bad_packets) state.SkipWithError("bad packets");
}
BENCHMARK(BM_OscLoopbackPacketToPose)->Iterations(2000)->UseManualTime()->Unit(benchmark::kMillisecond);

/// CPU per packet on the receiver's thread, without the network: parse a 5-body 6d packet
/// and convert it to Kumite's room.
void BM_DtrackParseAndConvert5Bodies(benchmark::State& state) {
  DtrackFrame d;
  to_dtrack_frame(visitor(1), RoomTransform::z_up(), d);
  const std::string packet = format_dtrack(d);
  DtrackInput in;
  in.role_body = {0, 1, 2, 3, 4};
  DtrackFrame parsed;
  RoomFrame room;
  for (auto _ : state) {
    parse_dtrack(packet, parsed);
    to_room_frame(parsed, in, room);
    benchmark::DoNotOptimize(room.bodies[0].position_m[0]);
  }
  state.counters["packet_bytes"] = static_cast<double>(packet.size());
}
BENCHMARK(BM_DtrackParseAndConvert5Bodies)->Unit(benchmark::kMicrosecond);

void BM_DtrackFormat5Bodies(benchmark::State& state) {
  DtrackFrame d;
  to_dtrack_frame(visitor(1), RoomTransform::z_up(), d);
  std::string out;
  for (auto _ : state) {
    format_dtrack(d, out);
    benchmark::DoNotOptimize(out.data());
  }
}
BENCHMARK(BM_DtrackFormat5Bodies)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
