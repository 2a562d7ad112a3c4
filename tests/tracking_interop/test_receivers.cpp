// The DTrack and OSC receivers over 127.0.0.1: newest frame by poll(), bad packets counted and
// said one line each, never a stall.
#include <gtest/gtest.h>
#include <lo/lo.h>

#include <cmath>
#include <string>

#include "kumite/common/error.hpp"
#include "kumite/common/time.hpp"
#include "kumite/tracking/interop.hpp"

using namespace kumite::tracking;

namespace {

/// Waits up to `timeout_s` for `pred`.
template <typename P>
bool wait_for(P pred, double timeout_s = 2.0) {
  const double end = kumite::now() + timeout_s;
  while (kumite::now() < end) {
    if (pred()) return true;
    kumite::sleep_until(kumite::now() + 0.001);
  }
  return pred();
}

std::string joined(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += l + "\n";
  return s;
}

DtrackInput loopback_input() {
  DtrackInput in;
  in.port = 0;  // any free port
  in.bind_address = "127.0.0.1";
  in.role_body = {0, 1, 2, -1, -1};
  return in;
}

DtrackFrame frame_with_head(std::uint64_t n, double x_m) {
  DtrackFrame f;
  f.has_frame = true;
  f.frame = n;
  f.timestamp_s = static_cast<double>(n) / 60;
  DtrackBody b;
  b.id = 0;
  b.quality = 1;
  b.position_m = {x_m, 0.5, 1.7};  // DTrack's z-up room
  f.bodies.push_back(b);
  return f;
}

}  // namespace

TEST(DtrackReceiver, PollGivesTheNewestFrameWithItsReceiveTime) {
  DtrackReceiver rx(loopback_input());
  EXPECT_FALSE(rx.poll().has_value());  // nothing yet, and no wait
  rx.start();
  ASSERT_GT(rx.port(), 0);
  DtrackSender tx("127.0.0.1", rx.port());
  const double sent = kumite::now();
  for (std::uint64_t n = 1; n <= 3; ++n) ASSERT_TRUE(tx.send(frame_with_head(n, 0.1 * static_cast<double>(n))));
  ASSERT_TRUE(wait_for([&] { return rx.counters().frames == 3; }));
  const auto f = rx.poll();
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->frame, 3u);
  EXPECT_EQ(f->sequence, 3u);
  EXPECT_GE(f->received_at, sent);
  EXPECT_GE(f->published_at, f->received_at);
  EXPECT_LE(f->published_at, kumite::now());
  const RoomBody* head = find_role(*f, "head");
  ASSERT_NE(head, nullptr);
  EXPECT_NEAR(head->position_m[0], 0.3, 1e-6);
  EXPECT_NEAR(head->position_m[1], 1.7, 1e-6);  // DTrack z (up) -> Kumite y
  EXPECT_NEAR(head->position_m[2], -0.5, 1e-6);  // DTrack +y (toward the front) -> Kumite -z
  const ReceiverCounters c = rx.counters();
  EXPECT_EQ(c.packets, 3u);
  EXPECT_EQ(c.bad_packets, 0u);
  EXPECT_TRUE(rx.take_problems().empty());
  rx.stop();
}

TEST(DtrackReceiver, BadPacketsAreCountedAndSaidOneLineEach) {
  DtrackReceiverOptions options;
  options.buffer_bytes = 512;
  DtrackReceiver rx(loopback_input(), options);
  rx.start();
  DtrackSender tx("127.0.0.1", rx.port());
  ASSERT_TRUE(tx.send_raw("fr 1\n6d 1 [0 nan][1 2 3][1 0 0 0 1 0 0 0 1]\n"));             // nan
  ASSERT_TRUE(tx.send_raw("fr 2\n6d 1 [0 1.0][1 2 3][1 0 0 0 1 0 0 0 1"));                // cut
  ASSERT_TRUE(tx.send_raw(std::string("#bundle\0\0\0\0\0\0\0\0\1", 16)));                 // OSC
  ASSERT_TRUE(tx.send_raw("fr 3\n6d 1 [0 1.0][1 2 3][1 0 0 0 1 0 0 0 1]" + std::string(1000, ' ')));  // oversized
  ASSERT_TRUE(tx.send_raw("fr 4\n6d 2 [0 1.0][1 2 3][1 0 0 0 1 0 0 0 1][9 1.0][1 2 3][1 0 0 0 1 0 0 0 1]\n"));
  ASSERT_TRUE(tx.send_raw("fr 5\n6d 1 [9 1.0][1 2 3][1 0 0 0 1 0 0 0 1]\n"));             // 9 again: said once
  // (packets is counted as a datagram is read, frames once it is published: wait for both)
  ASSERT_TRUE(wait_for([&] { return rx.counters().packets == 6 && rx.counters().frames == 4; }));
  kumite::sleep_until(kumite::now() + 0.05);  // nothing more comes
  const ReceiverCounters c = rx.counters();
  EXPECT_EQ(c.bad_packets, 4u);
  EXPECT_EQ(c.oversized, 1u);
  EXPECT_EQ(c.unconfigured_bodies, 2u);
  EXPECT_EQ(c.frames, 4u);  // 1, 2 (nothing in them usable but the counter), 4, 5
  EXPECT_EQ(c.frame_gaps, 1u);  // 3 never arrived whole
  const std::string lines = joined(rx.take_problems());
  EXPECT_NE(lines.find("dtrack 127.0.0.1:"), std::string::npos) << lines;
  EXPECT_NE(lines.find(": packet:2: 6d[0]: must be a finite number, found 'nan'"), std::string::npos) << lines;
  EXPECT_NE(lines.find(": packet:2: 6d[0]: cut short: a block '[' without its ']'"), std::string::npos) << lines;
  EXPECT_NE(lines.find("(an OSC packet?)"), std::string::npos) << lines;
  EXPECT_NE(lines.find("more than the receive buffer (512): oversized (ignored)"), std::string::npos) << lines;
  EXPECT_NE(lines.find("6d: body 9 is not configured in [dtrack.bodies] (ignored; said once)"), std::string::npos) << lines;
  EXPECT_EQ(lines.find("body 9", lines.find("body 9") + 1), std::string::npos) << lines;
  EXPECT_TRUE(rx.take_problems().empty());
  const auto f = rx.poll();
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->frame, 5u);
  EXPECT_EQ(f->body_count, 0);  // body 9 is not used
}

TEST(DtrackReceiver, APortInUseIsOneErrorAndStopIsPrompt) {
  DtrackReceiver a(loopback_input());
  a.start();
  DtrackInput same = loopback_input();
  same.port = a.port();
  DtrackReceiver b(same);
  try {
    b.start();
    FAIL() << "a second receiver on the same port started";
  } catch (const kumite::Error& e) {
    EXPECT_NE(std::string(e.what()).find("dtrack: cannot listen on udp 127.0.0.1:"), std::string::npos) << e.what();
  }
  const double t0 = kumite::now();
  a.stop();
  EXPECT_LT(kumite::now() - t0, 0.5);
}

TEST(DtrackReceiver, Multicast) {
  DtrackInput in = loopback_input();
  in.bind_address = "0.0.0.0";
  in.multicast_group = "239.255.42.55";
  DtrackReceiver rx(in);
  try {
    rx.start();
  } catch (const kumite::Error& e) {
    GTEST_SKIP() << "no multicast here: " << e.what();
  }
  DtrackSender tx("239.255.42.55", rx.port());
  if (!tx.send(frame_with_head(1, 0)) || !wait_for([&] { return rx.counters().frames == 1; }, 1.0))
    GTEST_SKIP() << "multicast is not delivered on this machine (no multicast route)";
  EXPECT_EQ(rx.poll()->frame, 1u);
}

TEST(OscReceiver, ReadsWhatOscSenderSendsOneBundlePerFrame) {
  OscReceiverOptions options;
  options.role_body = {4, -1, 6, -1, -1};
  OscReceiver rx(0, options);
  rx.start();
  ASSERT_GT(rx.port(), 0);
  OscSender tx("127.0.0.1", rx.port());
  RoomFrame f;
  f.frame = 41;
  f.body_count = 3;
  f.bodies[0] = {4, 0, RoomBodyKind::body, true, 1, {0.25, 1.72, -0.5}, {0.9238795, 0, 0.3826834, 0}};
  f.bodies[1] = {6, 2, RoomBodyKind::body, true, 1, {0.4, 1.1, -0.7}, {1, 0, 0, 0}};
  f.bodies[2] = {8, -1, RoomBodyKind::body, false, -1, {0, 0, 0}, {1, 0, 0, 0}};
  const double sent = kumite::now();
  ASSERT_TRUE(tx.send(f)) << tx.last_error();
  f.frame = 42;
  f.bodies[0].position_m[0] = 0.3;
  ASSERT_TRUE(tx.send(f)) << tx.last_error();
  ASSERT_TRUE(wait_for([&] { return rx.counters().frames == 2; }));
  const auto g = rx.poll();
  ASSERT_TRUE(g.has_value());
  EXPECT_EQ(g->frame, 42u);
  EXPECT_GE(g->received_at, sent);
  ASSERT_EQ(g->body_count, 3);
  const RoomBody* head = find_role(*g, "head");
  ASSERT_NE(head, nullptr);
  EXPECT_NEAR(head->position_m[0], 0.3, 1e-6);
  EXPECT_NEAR(head->position_m[1], 1.72, 1e-6);
  EXPECT_NEAR(head->orientation[0], 0.9238795, 1e-6);
  EXPECT_NEAR(head->orientation[2], 0.3826834, 1e-6);
  EXPECT_NE(find_role(*g, "right_hand"), nullptr);
  const RoomBody* hidden = find_body(*g, 8);
  ASSERT_NE(hidden, nullptr);
  EXPECT_FALSE(hidden->tracked);
  EXPECT_EQ(rx.counters().bad_packets, 0u);
}

TEST(OscReceiver, LoneMessagesAndBadOnes) {
  OscReceiver rx(0);
  rx.start();
  const std::string port = std::to_string(rx.port());
  lo_address to = lo_address_new("127.0.0.1", port.c_str());
  // A lone transformation (no bundle, no /frame/start): a frame of its own.
  ASSERT_GE(lo_send(to, "/rigidbody/3/transformation", "fffffff", 1.0f, 2.0f, 3.0f, 0.0f, 0.0f, 0.0f, 1.0f), 0);
  ASSERT_TRUE(wait_for([&] { return rx.counters().frames == 1; }));
  const RoomFrame lone = *rx.poll();
  const RoomBody* b = find_body(lone, 3);
  ASSERT_NE(b, nullptr);
  EXPECT_NEAR(b->position_m[2], 3.0, 1e-6);
  // Framed by /frame/start ... /frame/end without a bundle: published at /frame/end.
  ASSERT_GE(lo_send(to, "/frame/start", "i", 100), 0);
  ASSERT_GE(lo_send(to, "/rigidbody/5/transformation", "ddddddd", 0.5, 1.5, -2.0, 0.0, 0.0, 0.0, 1.0), 0);
  ASSERT_GE(lo_send(to, "/frame/end", "i", 100), 0);
  ASSERT_TRUE(wait_for([&] { return rx.counters().frames == 2; }));
  EXPECT_EQ(rx.poll()->frame, 100u);
  EXPECT_NE(find_body(*rx.poll(), 5), nullptr);
  // Bad: too few numbers, nan, a quaternion that is none, a path Kumite does not read (twice:
  // said once), and a DTrack packet sent to the OSC port.
  ASSERT_GE(lo_send(to, "/rigidbody/3/transformation", "ffffff", 1.0f, 2.0f, 3.0f, 0.0f, 0.0f, 0.0f), 0);
  ASSERT_GE(lo_send(to, "/rigidbody/3/transformation", "fffffff", NAN, 2.0f, 3.0f, 0.0f, 0.0f, 0.0f, 1.0f), 0);
  ASSERT_GE(lo_send(to, "/rigidbody/3/transformation", "fffffff", 1.0f, 2.0f, 3.0f, 0.0f, 0.0f, 0.0f, 3.0f), 0);
  ASSERT_GE(lo_send(to, "/tracking/trackers/head/position", "fff", 1.0f, 2.0f, 3.0f), 0);
  ASSERT_GE(lo_send(to, "/tracking/trackers/head/position", "fff", 1.0f, 2.0f, 3.0f), 0);
  ASSERT_GE(lo_send(to, "/frame/start", "s", "one"), 0);
  lo_address_free(to);
  DtrackSender dtrack("127.0.0.1", rx.port());
  ASSERT_TRUE(dtrack.send_raw("fr 1\n6d 0\n"));
  ASSERT_TRUE(wait_for([&] { return rx.counters().bad_packets == 7; })) << rx.counters().bad_packets;
  const std::string lines = joined(rx.take_problems());
  EXPECT_NE(lines.find("osc: /rigidbody/3/transformation: needs 7 numbers x y z qx qy qz qw, found 6"), std::string::npos) << lines;
  EXPECT_NE(lines.find("osc: /rigidbody/3/transformation: argument 1 must be a finite number, found nan"), std::string::npos) << lines;
  EXPECT_NE(lines.find("the quaternion's norm must be 1 (±0.1), found 3"), std::string::npos) << lines;
  EXPECT_NE(lines.find("osc: /tracking/trackers/head/position: not a path Kumite reads"), std::string::npos) << lines;
  EXPECT_EQ(lines.find("/tracking/trackers", lines.find("/tracking/trackers") + 1), std::string::npos) << lines;
  EXPECT_NE(lines.find("osc: /frame/start: needs the frame number (an integer >= 0), types 's'"), std::string::npos) << lines;
  EXPECT_EQ(rx.counters().frames, 2u);  // none of them published anything
  rx.stop();
}
