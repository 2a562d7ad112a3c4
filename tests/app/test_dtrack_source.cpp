// `[tracking] source = "dtrack"` (issue 55, "Tracker interop"): a room's own ART DTrack tracker
// feeds the head and the visitor's bodies, and recognition, as the cameras and the poses file
// do. A SYNTHETIC visitor (head, two gloves, two shoes; positions made up for this test) is
// sent as DTrack ASCII over UDP on 127.0.0.1, each packet written here by hand (not through
// the interop library's formatter), and the installation's frames are stepped on the wall
// clock. The positions expected in Kumite's room are computed here from the DTrack room's
// definition ((x, y, z)_kumite = (x, z, -y)_dtrack for DTrack's default Z-up room, plus the
// configured translation; a yawed head's offset rotated by hand), not by the library.
// Waits are generous (up to seconds for what takes milliseconds); nothing depends on how
// fast the machine is beyond them.
#include <gtest/gtest.h>

#include <spdlog/sinks/ringbuffer_sink.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "kumite/app/config.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/session.hpp"
#include "kumite/app/tracking_input.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/time.hpp"
#include "kumite/tracking/interop.hpp"

using namespace kumite::app;
namespace fs = std::filesystem;
using kumite::TrackingStatus;

namespace {

struct Tmp {
  fs::path path = fs::temp_directory_path() / ("kumite_app_test_dtrack_" + std::to_string(::getpid()));
  Tmp() {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Tmp() { fs::remove_all(path); }
};

// The room: DTrack's default (Z up) room, Kumite's origin 0.5 m behind DTrack's along Kumite's
// +Z; the glasses are body 10, the gloves 11 and 12, the shoes 13 and 14; the eyes 10 cm ahead
// of the glasses' calibrated origin (-Z in Kumite's axes with the glasses in their calibrated pose).
const char* kConfig = R"(# SYNTHETIC test room
[[walls]]
name = "front"
lower_left = [-1.5, 0.0, -1.5]
lower_right = [1.5, 0.0, -1.5]
upper_left = [-1.5, 2.4, -1.5]
resolution = [320, 180]
[stereo]
mode = "side_by_side"
[[characters]]
name = "A"
bvh = "a.bvh"
[fighter]
database = "/nonexistent/fighter.kdb"
[recognition]
model = "{model}"
[tracking]
source = "dtrack"
lost_after_s = 0.25
[tracking.dtrack]
port = 5000
bind_address = "127.0.0.1"
room_axes = "z_up"
translation_m = [0.0, 0.0, 0.5]
[tracking.dtrack.bodies]
head = 10
left_hand = 11
right_hand = 12
left_foot = 13
right_foot = 14
[tracking.dtrack.offsets]
head = [0.0, 0.0, -0.1]
)";

/// The config above, in `dir` (a session copies it), listening on a free port (0).
InstallationConfig room(const fs::path& dir) {
  std::string text = kConfig;
  text.replace(text.find("{model}"), 7, std::string(KUMITE_SOURCE_DIR) + "/recognition/models/strikes.krec");
  std::ofstream(dir / "room.toml") << text;
  InstallationConfig c = load_installation_config(dir / "room.toml");
  c.tracking.dtrack.port = 0;  // any free one (the file must say 1..65535)
  return c;
}

/// The UDP port the input listens on, from its description ("DTrack on UDP port 40123").
int port_of(const TrackingInput& in) {
  std::smatch m;
  const std::string d = in.describe();
  if (!std::regex_search(d, m, std::regex("UDP port ([0-9]+)"))) return -1;
  return std::stoi(m[1]);
}

/// One 6d body as DTrack sends it: position mm in DTrack's room, yaw about DTrack's Z (deg).
struct SentBody {
  int id = 0;
  double quality = 1.0;
  double x = 0, y = 0, z = 0;  // mm
  double yaw_deg = 0;
};

/// A DTrack ASCII packet written by hand: fr, ts, 6dcal, 6d with the Euler angles (R = Rz(yaw):
/// η = θ = 0, φ = yaw) and the rotation matrix column-wise; CR LF.
std::string packet(int frame, double ts, const std::vector<SentBody>& bodies) {
  std::string p = fmt::format("fr {}\r\nts {:.6f}\r\n6dcal {}\r\n6d {}", frame, ts, 15, bodies.size());
  for (const SentBody& b : bodies) {
    const double a = b.yaw_deg * M_PI / 180, c = std::cos(a), s = std::sin(a);
    // Rz rows [[c, -s, 0], [s, c, 0], [0, 0, 1]], sent column by column.
    p += fmt::format(" [{} {:.3f}][{:.3f} {:.3f} {:.3f} 0.0000 0.0000 {:.4f}][{:.6f} {:.6f} 0.000000 {:.6f} {:.6f} "
                     "0.000000 0.000000 0.000000 1.000000]",
                     b.id, b.quality, b.x, b.y, b.z, b.yaw_deg, c, s, -s, c);
  }
  return p + "\r\n";
}

/// Where Kumite should have a body sent at DTrack (x, y, z) mm: (x, z, -y) m + (0, 0, 0.5).
std::array<double, 3> kumite_of(const SentBody& b) { return {b.x / 1000, b.z / 1000, -b.y / 1000 + 0.5}; }

/// The synthetic visitor at frame k: the head walks +X at 0.5 m/s (DTrack's x), yawed 90° (so
/// its 10 cm eye offset, -Z in Kumite's axes, points along Kumite's -X); gloves and shoes still.
/// The right shoe is tracked up to `right_foot_until` frames, then sent with quality -1.
std::vector<SentBody> visitor(int k, int moving_frames, int right_foot_until = 1 << 30) {
  const double x = std::round(1000 * (100.0 + 500.0 * std::min(k, moving_frames) / 60.0)) / 1000;  // mm, as sent (3 decimals)
  std::vector<SentBody> b{{10, 1.0, x, -500, 1650, 90},
                          {11, 0.9, -250, -800, 1200, 0},
                          {12, 0.8, 250, -750, 1250, 0},
                          {13, 1.0, -150, -400, 50, 0},
                          {14, 1.0, 150, -450, 60, 0}};
  if (k >= right_foot_until) b[4] = {14, -1.0, 0, 0, 0, 0};
  return b;
}

/// The head's expected eye point: the glasses' origin plus the offset (0, 0, -0.1) rotated by
/// the yaw, which in Kumite's room is a rotation about +Y by the same angle: (-0.1 sin, 0, -0.1 cos).
std::array<double, 3> eyes_of(const SentBody& head) {
  auto p = kumite_of(head);
  const double a = head.yaw_deg * M_PI / 180;
  p[0] += -0.1 * std::sin(a);
  p[2] += -0.1 * std::cos(a);
  return p;
}

void sleep_s(double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }

/// Steps `inst` on the wall clock until `done()` or `limit_s` passed; true when done.
template <typename F>
bool step_until(Installation& inst, double limit_s, F&& done) {
  const double end = kumite::now() + limit_s;
  while (kumite::now() < end) {
    inst.step(kumite::now());
    if (done()) return true;
    sleep_s(0.005);
  }
  return false;
}

struct LogCapture {
  std::shared_ptr<spdlog::sinks::ringbuffer_sink_mt> sink = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(512);
  LogCapture() { spdlog::default_logger()->sinks().push_back(sink); }
  ~LogCapture() { spdlog::default_logger()->sinks().pop_back(); }
  int count(const std::string& text) const {
    int n = 0;
    for (const auto& line : sink->last_formatted()) n += line.find(text) != std::string::npos;
    return n;
  }
};

bool has_problem(const ConsoleState& c, const std::string& text) {
  return std::any_of(c.problems.begin(), c.problems.end(),
                     [&](const std::string& p) { return p.find(text) != std::string::npos; });
}

using Bodies = std::array<std::optional<kumite::BodyPose>, kumite::recognition::kRoleCount>;
bool same_bits(const Bodies& a, const Bodies& b) {
  for (std::size_t r = 0; r < a.size(); ++r) {
    if (a[r].has_value() != b[r].has_value()) return false;
    if (!a[r]) continue;
    const auto& x = *a[r];
    const auto& y = *b[r];
    if (std::memcmp(&x.timestamp, &y.timestamp, sizeof x.timestamp) != 0 || x.frame != y.frame || x.body != y.body ||
        x.status != y.status || std::memcmp(x.position.data(), y.position.data(), sizeof x.position) != 0 ||
        std::memcmp(x.orientation.data(), y.orientation.data(), sizeof x.orientation) != 0 ||
        std::memcmp(&x.ready_at, &y.ready_at, sizeof x.ready_at) != 0)
      return false;
  }
  return true;
}

}  // namespace

// The visitor sent at 60 Hz reaches the frame: the head (the eyes' point: the offset applied)
// predicted to the display time from its DTrack timestamps, each body by its role at the sent
// position in Kumite's room, measured when its packet was received; every frame's bodies go to
// the recognition thread; a body sent with quality -1 coasts with its last pose, then is lost;
// the console names the tracker's state. A session recorded from the run replays bit for bit.
TEST(DtrackSource, TheVisitorsBodiesArriveWhereTheySentThemAndASessionReplaysThem) {
  Tmp tmp;
  InstallationConfig cfg = room(tmp.path);
  auto input = make_tracking_input(cfg);
  const int port = port_of(*input);
  ASSERT_GT(port, 0) << input->describe();
  Installation inst(cfg, std::move(input), {});
  InstallationOptions io;
  SessionRecorder rec(tmp.path / "session", session_info(cfg, io));
  inst.record_to(&rec);
  kumite::tracking::DtrackSender tx("127.0.0.1", port);

  constexpr int kMoving = 40, kFrames = 70, kFootUntil = 40;
  std::vector<Bodies> recorded;
  int predictions_checked = 0;
  inst.start(kumite::now());
  for (int k = 0; k < kFrames; ++k) {
    const auto sent = visitor(k, kMoving, kFootUntil);
    ASSERT_TRUE(tx.send_raw(packet(1000 + k, 3600.0 + k / 60.0, sent))) << tx.last_error();
    const double t_end = kumite::now() + 1.0 / 60;
    do {
      const double now = kumite::now(), shown = now + 0.02;
      inst.step(now, shown);
      recorded.push_back(inst.input().tracking.bodies);
      const TrackingSnapshot& s = inst.input().tracking;
      const auto& head = s.bodies[0];
      if (s.head && head && s.head->status == TrackingStatus::tracked && s.head->position != head->position) {
        // Extrapolated: 0.5 m/s along Kumite's +X (the sender's clock gives the velocity), to the display time.
        const double ahead = std::clamp(shown - head->timestamp, 0.0, 0.1);
        EXPECT_NEAR(s.head->position[0] - head->position[0], 0.5 * ahead, 1e-4) << "frame " << k;
        EXPECT_EQ(s.head->position[1], head->position[1]);
        ++predictions_checked;
      }
      sleep_s(0.004);
    } while (kumite::now() < t_end);
  }
  const std::size_t loop_steps = recorded.size();
  // The last packet in: every role where it was sent (the head no longer moving: no extrapolation).
  const auto last = visitor(kFrames - 1, kMoving, kFootUntil);
  ASSERT_TRUE(step_until(inst, 3.0, [&] {
    const auto& h = inst.input().tracking.bodies[0];
    return h && h->frame == static_cast<std::uint64_t>(kFrames) && inst.input().tracking.head;
  })) << "the last frame never came";
  const TrackingSnapshot& s = inst.input().tracking;
  EXPECT_GT(predictions_checked, 5) << "the head was predicted while it moved";
  for (std::size_t r = 0; r < 4; ++r) {
    SCOPED_TRACE(fmt::format("role {}", r));
    ASSERT_TRUE(s.bodies[r]);
    const auto want = r == 0 ? eyes_of(last[0]) : kumite_of(last[r]);
    for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(s.bodies[r]->position[k], want[k], 1e-9);
    EXPECT_EQ(s.bodies[r]->body, last[r].id);
    EXPECT_EQ(s.bodies[r]->frame, static_cast<std::uint64_t>(kFrames)) << "the receiver's count of frames";
    EXPECT_LE(s.bodies[r]->timestamp, s.bodies[r]->ready_at) << "measured when received, then published";
    EXPECT_NE(s.bodies[r]->status, TrackingStatus::lost);
  }
  ASSERT_TRUE(s.head);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(s.head->position[k], eyes_of(last[0])[k], 1e-9);
  // Yawed 90° about DTrack's Z = about Kumite's +Y: (w, x, y, z) = (cos 45°, 0, sin 45°, 0).
  EXPECT_NEAR(s.head->orientation[0], std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(s.head->orientation[2], std::sqrt(0.5), 1e-6);
  EXPECT_TRUE(inst.head_live());
  EXPECT_EQ(inst.frame().head.position.x, s.head->position[0]) << "the head drawn is the tracked one";
  // The right shoe, sent with quality -1 from frame kFootUntil: its last pose, not tracked.
  ASSERT_TRUE(s.bodies[4]);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(s.bodies[4]->position[k], kumite_of(visitor(0, 0)[4])[k], 1e-9);
  EXPECT_EQ(s.bodies[4]->frame, static_cast<std::uint64_t>(kFootUntil)) << "measured last by frame " << kFootUntil;
  EXPECT_NE(s.bodies[4]->status, TrackingStatus::tracked);
  const double foot_age = kumite::now() - s.bodies[4]->timestamp;
  ASSERT_GT(foot_age, 0.4) << "30 frames at 60 Hz have passed since";
  EXPECT_EQ(s.bodies[4]->status, TrackingStatus::lost) << "not measured for " << foot_age << " s";
  // The fighter is given them (no fighter here: its database is missing), recognition every frame's.
  ASSERT_TRUE(step_until(inst, 3.0, [&] { return inst.input().tracking.recognition.samples >= 5u * kFrames; }))
      << inst.input().tracking.recognition.samples << " pose samples";
  EXPECT_EQ(inst.input().tracking.recognition.samples, 5u * kFrames) << "5 roles a frame, each frame once";
  EXPECT_EQ(inst.input().tracking.frame_sets, static_cast<std::uint64_t>(kFrames));
  const ConsoleState con = inst.console();
  EXPECT_NE(con.tracking_source.find(fmt::format("dtrack: port {}, {} frames, 0 bad packets, last from 127.0.0.1:",
                                                 port, kFrames)),
            std::string::npos)
      << con.tracking_source;
  EXPECT_EQ(con.tracking.rfind("tracked", 0), 0u) << con.tracking;
  EXPECT_NE(con.recognition.find("strike recognition: "), std::string::npos);

  inst.record_to(nullptr);
  rec.close();
  const auto frames = rec.frames_written();
  // The replay (kumite --replay's path) gives every frame again, bit for bit, without the network.
  const Installation* replaying = nullptr;
  ReplayOptions ro;
  ro.on_start = [&](const Installation& i) { replaying = &i; };
  std::vector<Bodies> replayed;
  ro.on_frame = [&](const FrameData&) { replayed.push_back(replaying->input().tracking.bodies); };
  const ReplayReport rep = replay_session(tmp.path / "session", ro);
  EXPECT_TRUE(rep.identical) << rep.first_difference_detail;
  EXPECT_EQ(rep.frames_replayed, frames);
  ASSERT_EQ(replayed.size(), frames);
  // The frames whose bodies this test kept (the sending loop's) come back to the bit.
  ASSERT_GE(replayed.size(), loop_steps);
  for (std::size_t i = 0; i < loop_steps; ++i) EXPECT_TRUE(same_bits(recorded[i], replayed[i])) << "frame " << i;
}

// The packets stop: the head and the bodies coast, then are lost after [tracking] lost_after_s;
// the log says "no DTrack packets" once (not once a frame), the console has it as a problem
// while it lasts, and the packets coming back are said once too.
TEST(DtrackSource, PacketsStoppingLoseTheVisitorSaidOnce) {
  Tmp tmp;
  InstallationConfig cfg = room(tmp.path);
  cfg.recognition.model.clear();
  LogCapture log;
  auto input = make_tracking_input(cfg);
  const int port = port_of(*input);
  ASSERT_GT(port, 0);
  Installation inst(cfg, std::move(input), {});
  kumite::tracking::DtrackSender tx("127.0.0.1", port);
  inst.start(kumite::now());
  for (int k = 0; k < 10; ++k) {
    tx.send_raw(packet(k + 1, k / 60.0, visitor(k, 0)));
    sleep_s(1.0 / 60);
  }
  ASSERT_TRUE(step_until(inst, 3.0, [&] { return inst.head_live(); })) << inst.console().tracking;
  // Silence: coasting, then lost.
  bool coasted = false;
  ASSERT_TRUE(step_until(inst, 3.0, [&] {
    const TrackingSnapshot& s = inst.input().tracking;
    coasted = coasted || s.state == TrackerState::coasting;
    return s.state == TrackerState::lost && has_problem(inst.console(), "dtrack: no DTrack packets for");
  })) << inst.console().tracking;
  EXPECT_TRUE(coasted) << "coasting before lost";
  EXPECT_FALSE(inst.head_live());
  for (const auto& b : inst.input().tracking.bodies) {
    ASSERT_TRUE(b);
    EXPECT_EQ(b->status, TrackingStatus::lost);
  }
  EXPECT_TRUE(has_problem(inst.console(), "head not tracked (lost"));
  EXPECT_TRUE(has_problem(inst.console(), "(the last from 127.0.0.1:"));
  step_until(inst, 0.5, [] { return false; });  // more silent frames
  EXPECT_EQ(log.count("dtrack: no DTrack packets for"), 1) << "said once";
  // Back.
  for (int k = 10; k < 14; ++k) {
    tx.send_raw(packet(k + 1, k / 60.0, visitor(k, 0)));
    sleep_s(1.0 / 60);
  }
  ASSERT_TRUE(step_until(inst, 3.0, [&] { return inst.head_live(); }));
  EXPECT_FALSE(has_problem(inst.console(), "no DTrack packets"));
  EXPECT_EQ(log.count("dtrack: packets again from 127.0.0.1:"), 1);
  EXPECT_EQ(log.count("dtrack: no DTrack packets for"), 1);
}

// Malformed packets among good ones: each counted as a bad packet and said in one line, a body
// of an id not in [tracking.dtrack.bodies] said once; the frame loop never waits on them and the
// visitor stays where the good packets put it.
TEST(DtrackSource, MalformedPacketsAreCountedAndSaidNeverAStall) {
  Tmp tmp;
  InstallationConfig cfg = room(tmp.path);
  cfg.recognition.model.clear();
  LogCapture log;
  auto input = make_tracking_input(cfg);
  const int port = port_of(*input);
  ASSERT_GT(port, 0);
  Installation inst(cfg, std::move(input), {});
  kumite::tracking::DtrackSender tx("127.0.0.1", port);
  const std::vector<std::string> bad{
      "fr 7\r\n6d 1 [10 1.000][nan 0 0 0 0 0][1 0 0 0 1 0 0 0 1]\r\n",  // a body's nan: the frame kept without it
      std::string("\0\0\0\x07/rigidbody", 14),                             // binary (an OSC packet?)
      std::string(20000, 'x'),                                             // more than the receive buffer
      "fr 9\r\n6d 2 [10 1.000][0 0 0 0 0 0][1 0 0 0 1 0 0 0 1]\r\n",      // 2 announced, 1 sent
      "fr 10\r\n6d 1 [10 1.000][0 0 0 0 0 0][1 0 0 0 1 0 0 0 1\r\n",      // cut short
  };
  inst.start(kumite::now());
  double worst_step = 0;
  int sent = 0;
  for (int k = 0; k < 30; ++k) {
    std::vector<SentBody> v = visitor(k, 0);
    if (k % 3 == 1) v.push_back({9, 1.0, 0, 0, 1000, 0});  // body 9: no role
    tx.send_raw(packet(100 + k, k / 60.0, v));
    if (k % 6 == 2 && sent < static_cast<int>(bad.size())) tx.send_raw(bad[static_cast<std::size_t>(sent++)]);
    const double t0 = kumite::now();
    inst.step(t0);
    worst_step = std::max(worst_step, kumite::now() - t0);
    sleep_s(1.0 / 60);
  }
  ASSERT_EQ(sent, static_cast<int>(bad.size()));
  const double last_sent = kumite::now();
  tx.send_raw(packet(200, 1.0, visitor(0, 0)));
  ASSERT_TRUE(step_until(inst, 3.0, [&] {
    return inst.console().tracking_source.find(fmt::format("{} bad packets", bad.size())) != std::string::npos &&
           inst.input().tracking.bodies[1] && inst.input().tracking.bodies[1]->timestamp >= last_sent;
  })) << inst.console().tracking_source;
  EXPECT_LT(worst_step, 0.25) << "s: a step never waits on the network (generous: a loaded machine)";
  const TrackingSnapshot& s = inst.input().tracking;
  for (std::size_t r = 1; r < 5; ++r) {
    ASSERT_TRUE(s.bodies[r]);
    const auto want = kumite_of(visitor(0, 0)[r]);
    for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(s.bodies[r]->position[k], want[k], 1e-9);
  }
  EXPECT_TRUE(inst.head_live());
  const std::string line = inst.console().tracking_source;
  EXPECT_NE(line.find("(1 oversized)"), std::string::npos) << line;
  EXPECT_NE(line.find("bodies of unconfigured ids"), std::string::npos) << line;
  step_until(inst, 0.3, [] { return false; });
  EXPECT_EQ(log.count("packet:2: 6d[0]: must be a finite number, found 'nan'"), 1);
  EXPECT_EQ(log.count("not DTrack ASCII"), 1);
  EXPECT_EQ(log.count("oversized"), 1);
  EXPECT_EQ(log.count("6d: cut short: 2 announced, 1 found"), 1);
  EXPECT_EQ(log.count("body 9 is not configured in [dtrack.bodies] (ignored; said once)"), 1);
}

// `source = "osc"`: the same input over the interop library's OscReceiver. A SYNTHETIC head and
// glove sent as OSC bundles (in Kumite's room: no transform) reach the frame where they were
// sent (float32 on the wire: within 1e-6 m), the head tracked and drawn.
TEST(DtrackSource, OscFeedsTheHeadAndBodiesToo) {
  Tmp tmp;
  InstallationConfig cfg = room(tmp.path);
  cfg.recognition.model.clear();
  cfg.tracking.source = TrackingSource::osc;
  cfg.tracking.osc.port = 0;
  cfg.tracking.osc.role_body = {21, 22, -1, -1, -1};
  auto input = make_tracking_input(cfg);
  const int port = port_of(*input);
  ASSERT_GT(port, 0) << input->describe();
  Installation inst(cfg, std::move(input), {});
  kumite::tracking::OscSender tx("127.0.0.1", port);
  inst.start(kumite::now());
  kumite::tracking::RoomFrame f;
  f.body_count = 2;
  f.bodies[0].id = 21;
  f.bodies[0].tracked = true;
  f.bodies[0].position_m = {0.25, 1.625, 0.5};
  f.bodies[1].id = 22;
  f.bodies[1].tracked = true;
  f.bodies[1].position_m = {-0.25, 1.125, 0.25};
  for (int k = 0; k < 5; ++k) {
    f.frame = static_cast<std::uint64_t>(k + 1);
    ASSERT_TRUE(tx.send(f)) << tx.last_error();
    sleep_s(1.0 / 60);
  }
  ASSERT_TRUE(step_until(inst, 3.0, [&] { return inst.head_live() && inst.input().tracking.bodies[1]; }))
      << inst.console().tracking_source;
  const TrackingSnapshot& s = inst.input().tracking;
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(s.head->position[k], f.bodies[0].position_m[k], 1e-6);
    EXPECT_NEAR(s.bodies[1]->position[k], f.bodies[1].position_m[k], 1e-6);
  }
  EXPECT_EQ(s.bodies[1]->body, 22);
  EXPECT_FALSE(s.bodies[2]);
  EXPECT_EQ(inst.console().tracking_source.rfind(fmt::format("osc: port {}, ", port), 0), 0u)
      << inst.console().tracking_source;
}

// A port that cannot be opened (another program listens there) is one error naming the config's
// file, line and table and the address; kumite then runs from the default head ("tracking
// unavailable: ..."), as for a missing recording: the error is not a config mistake.
TEST(DtrackSource, APortInUseIsOneErrorNamingTheTableAndAddress) {
  Tmp tmp;
  InstallationConfig cfg = room(tmp.path);
  cfg.recognition.model.clear();
  kumite::tracking::DtrackInput other;
  other.port = 0;
  other.bind_address = "127.0.0.1";
  kumite::tracking::DtrackReceiver squatter(other);
  squatter.start();
  cfg.tracking.dtrack.port = squatter.port();
  try {
    (void)make_tracking_input(cfg);
    ADD_FAILURE() << "listened on a port in use";
  } catch (const kumite::Error& e) {
    EXPECT_NE(e.component(), "config");
    const std::string what = e.what();
    EXPECT_NE(what.find((tmp.path / "room.toml").string() + ":20: tracking.dtrack: "), std::string::npos) << what;
    EXPECT_NE(what.find(fmt::format("cannot listen on udp 127.0.0.1:{}", squatter.port())), std::string::npos) << what;
  }
}
