// [tracking.out] (issue 55, "DTrack ASCII out", "OSC out"): the visitor's bodies as the
// installation's own tracking measures them sent on as DTrack ASCII (6d with Euler angles) and
// OSC, whatever the source: here a poses file (the format the own cameras' tracker writes,
// kumite-track --out) stepped on the simulated clock. A SYNTHETIC visitor (head yawed 30
// degrees and walking +X, two gloves, the right one lost after 50 rows; positions made up for
// this test). The DTrack packets are read off a plain UDP socket and checked against DTrack's
// default room worked out here by hand ((x, y, z)_dtrack = (x, 0.5 - z, y)_kumite for the
// configured translation (0, 0, 0.5)), the Euler angles against the yaw (a turn about
// Kumite's +Y is one about DTrack's +Z: eta = theta = 0, phi = 30).
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "kumite/app/config.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/tracking_input.hpp"
#include "kumite/common/error.hpp"
#include "kumite/recognition/poses_file.hpp"
#include "kumite/tracking/interop.hpp"

using namespace kumite::app;
namespace fs = std::filesystem;

namespace {

struct Tmp {
  fs::path path = fs::temp_directory_path() / ("kumite_app_test_dtrack_out_" + std::to_string(::getpid()));
  Tmp() {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Tmp() { fs::remove_all(path); }
};

/// A UDP socket on 127.0.0.1, any free port; read() returns the datagrams waiting.
struct UdpSink {
  int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  int port = 0;
  UdpSink() {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) return;
    socklen_t n = sizeof a;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &n);
    port = ntohs(a.sin_port);
    const int big = 1 << 20;
    ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
  }
  ~UdpSink() { ::close(fd); }
  std::vector<std::string> read() const {
    std::vector<std::string> out;
    char buf[65536];
    for (;;) {
      const auto n = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
      if (n <= 0) break;
      out.emplace_back(buf, static_cast<std::size_t>(n));
    }
    return out;
  }
};

constexpr int kRows = 60;
constexpr double kYawDeg = 30;

/// The head at row k (Kumite's room, m).
std::array<double, 3> head_at(int k) { return {0.1 + 0.5 * k / 60.0, 1.65, -0.2}; }

void write_poses(const fs::path& p) {
  std::ofstream f(p);
  f << kumite::recognition::kPosesHeader << "\n";
  const double h = kYawDeg * M_PI / 360;  // half the angle
  for (int k = 0; k < kRows; ++k) {
    const double t = k / 60.0;
    const auto head = head_at(k);
    f << fmt::format("{},{:.6f},head,tracked,{:.6f},{:.6f},{:.6f},{:.9f},0,{:.9f},0,4,3,5\n", k, t, head[0], head[1],
                     head[2], std::cos(h), std::sin(h));
    f << fmt::format("{},{:.6f},left_hand,tracked,-0.3,1.2,-0.4,1,0,0,0,4,3,5\n", k, t);
    if (k < 50) f << fmt::format("{},{:.6f},right_hand,tracked,0.3,1.2,-0.4,1,0,0,0,4,3,5\n", k, t);
    else f << fmt::format("{},{:.6f},right_hand,lost,0,0,0,1,0,0,0,0,0,5\n", k, t);
  }
}

std::string config_text(const std::string& out) {
  return R"(# SYNTHETIC test room
[[walls]]
name = "front"
lower_left = [-1.5, 0.0, -1.5]
lower_right = [1.5, 0.0, -1.5]
upper_left = [-1.5, 2.4, -1.5]
resolution = [320, 180]
[[characters]]
name = "A"
bvh = "a.bvh"
[fighter]
database = "/nonexistent/fighter.kdb"
[tracking]
source = "poses"
poses = "poses.csv"
poses_loop = false
[tracking.dtrack]
room_axes = "z_up"
translation_m = [0.0, 0.0, 0.5]
[tracking.dtrack.bodies]
head = 10
left_hand = 11
right_hand = 12
)" + out;
}

}  // namespace

TEST(TrackingOut, APosesFileGoesOutAsDtrackSixDWithEulerAnglesAndAsOsc) {
  Tmp tmp;
  write_poses(tmp.path / "poses.csv");
  UdpSink dtrack;
  ASSERT_GT(dtrack.port, 0);
  kumite::tracking::OscReceiverOptions oo;
  oo.role_body = {10, 11, 12, -1, -1};
  kumite::tracking::OscReceiver osc(0, oo);
  osc.start();
  std::ofstream(tmp.path / "room.toml") << config_text(
      fmt::format("[tracking.out]\ndtrack = \"127.0.0.1:{}\"\nosc = \"127.0.0.1:{}\"\n", dtrack.port, osc.port()));
  const InstallationConfig c = load_installation_config(tmp.path / "room.toml");
  EXPECT_EQ(c.tracking.out_dtrack, fmt::format("127.0.0.1:{}", dtrack.port));

  std::vector<std::string> packets;
  {
    TrackingInputOptions o;
    o.simulated_clock = true;
    auto in = make_tracking_input(c, o);
    TrackingSnapshot s;
    // 1.2 s of frames at 120 Hz: every row due is delivered and measured once.
    for (int i = 0; i <= 144; ++i) {
      in->poll(i / 120.0, i / 120.0, s);
      for (auto& p : dtrack.read()) packets.push_back(std::move(p));
    }
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  for (auto& p : dtrack.read()) packets.push_back(std::move(p));

  // One packet per row time (each a new measurement), frame numbers 1, 2, ...
  ASSERT_EQ(packets.size(), static_cast<std::size_t>(kRows));
  for (int k = 0; k < kRows; ++k) {
    const auto f = kumite::tracking::parse_dtrack(packets[static_cast<std::size_t>(k)]);
    ASSERT_TRUE(f.ok()) << packets[static_cast<std::size_t>(k)] << (f.problems.empty() ? "" : f.problems[0]);
    EXPECT_EQ(f.frame, static_cast<std::uint64_t>(k + 1));
    const auto* head = f.body(10);
    ASSERT_NE(head, nullptr) << packets[static_cast<std::size_t>(k)];
    const auto h = head_at(k);
    EXPECT_NEAR(head->position_m[0], h[0], 1e-6);
    EXPECT_NEAR(head->position_m[1], 0.5 - h[2], 1e-6);
    EXPECT_NEAR(head->position_m[2], h[1], 1e-6);
    ASSERT_NE(f.body(11), nullptr);
    EXPECT_NEAR(f.body(11)->position_m[1], 0.9, 1e-6);
    // The right glove lost from row 50: left out of the 6d line, as DTrack does.
    EXPECT_EQ(f.body(12) != nullptr, k < 50) << packets[static_cast<std::size_t>(k)];
  }
  // The 6d line carries the Euler angles after the position: [10 1.000][x y z eta theta phi][...].
  std::smatch m;
  const std::string last = packets.back();
  ASSERT_TRUE(std::regex_search(last, m, std::regex(R"(\[10 [0-9.]+\]\[(\S+) (\S+) (\S+) (\S+) (\S+) (\S+)\])")))
      << last;
  EXPECT_NEAR(std::stod(m[4]), 0.0, 1e-3);
  EXPECT_NEAR(std::stod(m[5]), 0.0, 1e-3);
  EXPECT_NEAR(std::stod(m[6]), kYawDeg, 1e-3);
  EXPECT_NE(last.find("6d 2 "), std::string::npos) << last;

  // OSC: the same bodies in Kumite's room, the newest frame the last row's.
  std::optional<kumite::tracking::RoomFrame> got;
  for (int i = 0; i < 100 && !(got = osc.poll()); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_TRUE(got.has_value());
  EXPECT_EQ(osc.counters().frames, static_cast<std::uint64_t>(kRows));
  const auto* head = kumite::tracking::find_role(*got, "head");
  ASSERT_NE(head, nullptr);
  const auto h = head_at(kRows - 1);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(head->position_m[static_cast<std::size_t>(k)], h[static_cast<std::size_t>(k)], 1e-5);
  EXPECT_NEAR(head->orientation[2], std::sin(kYawDeg * M_PI / 360), 1e-5);
  EXPECT_EQ(kumite::tracking::find_role(*got, "right_hand"), nullptr);  // lost: not tracked
  EXPECT_NE(kumite::tracking::find_role(*got, "left_hand"), nullptr);
  osc.stop();
}

TEST(TrackingOut, AnAddressThatIsNotHostColonPortIsOneLineAtItsKey) {
  Tmp tmp;
  write_poses(tmp.path / "poses.csv");
  const auto error_of = [&](const std::string& out) {
    std::ofstream(tmp.path / "room.toml") << config_text(out);
    try {
      const InstallationConfig c = load_installation_config(tmp.path / "room.toml");
      make_tracking_input(c);
    } catch (const kumite::Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error_of("[tracking.out]\ndtrack = \"127.0.0.1\"\n").find(
                "room.toml:25: tracking.out.dtrack: \"127.0.0.1\": must be \"host:port\" (port 1..65535)"),
            std::string::npos)
      << error_of("[tracking.out]\ndtrack = \"127.0.0.1\"\n");
  EXPECT_NE(error_of("[tracking.out]\nosc = \"host:70000\"\n").find("tracking.out.osc: \"host:70000\": must be"),
            std::string::npos);
  EXPECT_NE(error_of("[tracking.out]\nosc = \"127.0.0.1:-5\"\n").find("tracking.out.osc:"), std::string::npos);
  EXPECT_NE(error_of("[tracking.out]\nvrpn = \"127.0.0.1:5\"\n").find("vrpn"), std::string::npos);
  // A host that does not resolve: the run does not start, the key named.
  EXPECT_NE(error_of("[tracking.out]\ndtrack = \"no-such-host.invalid:5000\"\n").find("tracking.out.dtrack: "),
            std::string::npos)
      << error_of("[tracking.out]\ndtrack = \"no-such-host.invalid:5000\"\n");
}
