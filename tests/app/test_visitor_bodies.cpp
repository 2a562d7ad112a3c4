// The visitor's gloves and shoes reach the fighter (issue 53, item 3 needs them): every body a
// source has goes into TrackingSnapshot::bodies as measured, from there to the fighter's input
// (content::FighterInput::bodies), into a session recording and back out of its replay bit for
// bit. The poses demo is checked against the poses file's own rows, read here with a parser of
// this test's (an independent path); a glove lost mid-run reads tracked = false with its last
// pose; a session of the version before (no bodies) still replays, the fighter given the head.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <unistd.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "kumite/app/config.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/session.hpp"
#include "kumite/app/tracking_input.hpp"
#include "kumite/common/error.hpp"

using namespace kumite::app;
namespace fs = std::filesystem;
namespace rec = kumite::recognition;
using kumite::BodyPose;
using kumite::TrackingStatus;

namespace {

const fs::path kSource = KUMITE_SOURCE_DIR;

struct Tmp {
  fs::path path = fs::temp_directory_path() / ("kumite_app_test_bodies_" + std::to_string(::getpid()));
  Tmp() {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Tmp() { fs::remove_all(path); }
};

/// The shipped demo's config with its data folder (made at set-up); nullopt when absent.
std::optional<InstallationConfig> demo(const char* file) {
  const fs::path data = fs::path(KUMITE_BINARY_DIR) / "demo";
  if (!fs::exists(data / "fighter.kdb")) return std::nullopt;
  return load_installation_config(kSource / "config" / file, data);
}

/// One row of a poses.csv as this test reads it (not recognition::read_poses_csv).
struct Row {
  double t = 0;
  std::string body;
  bool tracked = false;
  double p[3] = {0, 0, 0};
};
std::vector<Row> read_rows(const fs::path& file) {
  std::ifstream in(file);
  std::vector<Row> rows;
  bool header = false;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    if (!header) {
      header = true;  // frame,timestamp_s,body,status,x,y,z,...
      continue;
    }
    std::vector<std::string> c;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) c.push_back(cell);
    Row r;
    r.t = std::stod(c.at(1));
    r.body = c.at(2);
    r.tracked = c.at(3) != "lost";
    for (int k = 0; k < 3; ++k) r.p[k] = std::stod(c.at(4 + static_cast<std::size_t>(k)));
    rows.push_back(r);
  }
  return rows;
}

std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v); }

/// The same pose to the bit (every field; -0.0 is not 0.0).
bool same_bits(const BodyPose& a, const BodyPose& b) {
  bool same = bits(a.timestamp) == bits(b.timestamp) && a.frame == b.frame && a.body == b.body && a.status == b.status &&
              a.markers == b.markers && a.cameras == b.cameras && bits(a.ready_at) == bits(b.ready_at);
  for (int k = 0; k < 3; ++k) same = same && bits(a.position[k]) == bits(b.position[k]);
  for (int k = 0; k < 4; ++k) same = same && bits(a.orientation[k]) == bits(b.orientation[k]);
  return same;
}

using Bodies = std::array<std::optional<BodyPose>, rec::kRoleCount>;
bool same_bits(const Bodies& a, const Bodies& b) {
  for (std::size_t r = 0; r < a.size(); ++r) {
    if (a[r].has_value() != b[r].has_value()) return false;
    if (a[r] && !same_bits(*a[r], *b[r])) return false;
  }
  return true;
}

struct FighterBody {
  rec::Role role;
  std::uint64_t p[3], q[4], t;
  bool tracked;
  bool operator==(const FighterBody&) const = default;
};
std::vector<FighterBody> fighter_bodies(const Installation& inst) {
  std::vector<FighterBody> out;
  for (const auto& b : inst.visitor_bodies())
    out.push_back({b.role,
                   {bits(b.position_m.x()), bits(b.position_m.y()), bits(b.position_m.z())},
                   {bits(b.orientation.w()), bits(b.orientation.x()), bits(b.orientation.y()), bits(b.orientation.z())},
                   bits(b.t),
                   b.tracked});
  return out;
}

/// A tracker of this test's: every body's pose made of awkward doubles (-0.0, a subnormal, the
/// last bits set), a right foot never seen, a left foot lost from frame 40 on (its last pose kept).
class AwkwardBodies final : public TrackingInput {
 public:
  void poll(kumite::Timestamp now, kumite::Timestamp, TrackingSnapshot& s) override {
    ++n_;
    now_ = now;
    s = {};
    s.state = TrackerState::tracked;
    s.frame_sets = n_;
    BodyPose head;
    head.status = TrackingStatus::tracked;
    head.timestamp = now - 0.0123456789012345;
    head.position = {0.1 + 0.2, 1.6 + n_ * 1e-3 / 3, 1.0 / 3};
    head.orientation = {std::sqrt(0.5), 0, std::sqrt(0.5) * -1, -0.0};
    head.frame = n_;
    head.markers = 4;
    head.cameras = 3;
    head.ready_at = now - 0.001;
    s.head = head;
    s.measured_at = head.timestamp;
    s.measured_ready_at = head.ready_at;
    s.bodies[0] = head;
    for (std::size_t r = 1; r < 4; ++r) {
      BodyPose p = head;
      p.body = static_cast<std::int32_t>(r);
      p.position = {std::nextafter(0.25 * r, 1.0) * (r == 2 ? -1 : 1), 1e-310 * static_cast<double>(n_), std::sin(n_ * 0.1 + r)};
      p.orientation = {std::cos(n_ * 0.01), std::sin(n_ * 0.01) / 3, -0.0, 2.0 / 3};
      p.timestamp = now - std::ldexp(1.0, -7) * static_cast<double>(r);
      s.bodies[r] = p;
    }
    if (n_ >= 40) {  // the left foot lost: its last pose
      left_foot_.status = TrackingStatus::lost;
      s.bodies[3] = left_foot_;
    } else {
      left_foot_ = *s.bodies[3];
    }
  }
  kumite::Timestamp clock() const override { return now_; }
  std::string describe() const override { return "awkward bodies"; }

 private:
  std::uint64_t n_ = 0;
  kumite::Timestamp now_ = 0;
  BodyPose left_foot_;
};

}  // namespace

// The mocap visitor of config/demo-poses.toml on the simulated clock: each frame the fighter is
// given the head, both gloves and both shoes, each where the poses file's newest row due by the
// frame's time has it (to the bit: no prediction), measured at that row's time, tracked.
TEST(VisitorBodies, ThePosesDemoGivesTheFighterTheGlovesOfThePosesFileEachFrame) {
  auto cfg = demo("demo-poses.toml");
  if (!cfg) GTEST_SKIP() << "no demo data (scripts/setup.sh makes it)";
  cfg->recognition.model.clear();  // not needed here
  const auto rows = read_rows(cfg->resolve(cfg->tracking.poses));
  ASSERT_GT(rows.size(), 3000u);
  TrackingInputOptions o;
  o.simulated_clock = true;
  Installation inst(*cfg, make_tracking_input(*cfg, o), {});
  const double t0 = 7000.0;
  inst.start(t0);
  const std::array<const char*, 5> names = {"head", "left_hand", "right_hand", "left_foot", "right_foot"};
  std::size_t next = 0;
  std::map<std::string, std::pair<Row, double>> newest;  // body -> its newest row due, and when it was due
  int gloves_checked = 0;
  for (int i = 0; i < 400; ++i) {  // 6.7 s, within the file's first loop (12 s)
    const double now = t0 + i / 60.0;
    while (next < rows.size() && t0 + 0.0 + (rows[next].t - rows.front().t) <= now) {
      newest[rows[next].body] = {rows[next], t0 + 0.0 + (rows[next].t - rows.front().t)};
      ++next;
    }
    inst.step(now);
    const auto got = inst.visitor_bodies();
    ASSERT_EQ(got.size(), 5u) << "frame " << i << ": the head, two gloves, two shoes";
    for (std::size_t r = 0; r < got.size(); ++r) {
      SCOPED_TRACE(fmt::format("frame {}, {}", i, names[r]));
      ASSERT_EQ(got[r].role, static_cast<rec::Role>(r));
      ASSERT_TRUE(newest.contains(names[r]));
      const auto& [row, due] = newest.at(names[r]);
      EXPECT_TRUE(got[r].tracked);
      EXPECT_EQ(got[r].position_m.x(), row.p[0]);
      EXPECT_EQ(got[r].position_m.y(), row.p[1]);
      EXPECT_EQ(got[r].position_m.z(), row.p[2]);
      EXPECT_EQ(got[r].t, due) << "s: measured when the row was due";
      if (r == 1 || r == 2) ++gloves_checked;
    }
  }
  EXPECT_EQ(gloves_checked, 800);
  // The gloves move: they are not the head's offset nor frozen.
  EXPECT_NE(inst.visitor_bodies()[1].position_m, inst.visitor_bodies()[2].position_m);
}

// A glove whose rows say lost, and one whose rows stop, mid-run: the fighter gets each with its
// last measured pose and tracked = false (the one that stops once [tracking] lost_after_s has passed).
TEST(VisitorBodies, AGloveLostMidRunReadsAsNotTrackedWithItsLastPose) {
  auto cfg = demo("demo-poses.toml");
  if (!cfg) GTEST_SKIP() << "no demo data (scripts/setup.sh makes it)";
  Tmp tmp;
  const fs::path file = tmp.path / "lost.csv";
  {
    std::ofstream out(file);
    out << "# SYNTHETIC: a head and two gloves; the left glove lost from row 30, the right one's rows stop there\n"
        << "frame,timestamp_s,body,status,x,y,z,qw,qx,qy,qz,markers,cameras,latency_ms\n";
    for (int k = 0; k < 90; ++k) {
      const double t = k / 60.0;
      out << fmt::format("{},{:.6f},head,tracked,0,1.6,0.3,1,0,0,0,4,4,0\n", k, t);
      out << fmt::format("{},{:.6f},left_hand,{},{:.5f},1.1,0.1,1,0,0,0,4,4,0\n", k, t, k < 30 ? "tracked" : "lost",
                         -0.2 + 0.01 * k);
      if (k < 30) out << fmt::format("{},{:.6f},right_hand,tracked,{:.5f},1.2,0.1,1,0,0,0,4,4,0\n", k, t, 0.2 + 0.01 * k);
    }
  }
  cfg->tracking.poses = file;
  cfg->tracking.poses_loop = false;
  cfg->recognition.model.clear();
  TrackingInputOptions o;
  o.simulated_clock = true;
  Installation inst(*cfg, make_tracking_input(*cfg, o), {});
  const double t0 = 100.0;
  inst.start(t0);
  const double lost_after = cfg->tracking.lost_after_s;
  for (int i = 0; i < 85; ++i) {
    SCOPED_TRACE(fmt::format("frame {}", i));
    inst.step(t0 + i / 60.0);
    const auto got = inst.visitor_bodies();
    ASSERT_EQ(got.size(), 3u);
    ASSERT_EQ(got[1].role, rec::Role::left_hand);
    ASSERT_EQ(got[2].role, rec::Role::right_hand);
    EXPECT_TRUE(got[0].tracked);
    if (i < 29) {
      EXPECT_TRUE(got[1].tracked);
      EXPECT_TRUE(got[2].tracked);
      continue;
    }
    if (i < 30) continue;  // row 29 or 30 due by now (the file's times are rounded to 1 us)
    const double t29 = t0 + 29.0 / 60.0;
    EXPECT_FALSE(got[1].tracked) << "its rows say lost";
    EXPECT_NEAR(got[1].position_m.x(), -0.2 + 0.29, 1e-9) << "the last pose measured (row 29)";
    EXPECT_NEAR(got[1].t, t29, 1e-5);
    EXPECT_NEAR(got[2].position_m.x(), 0.2 + 0.29, 1e-9) << "the last pose measured (row 29)";
    EXPECT_NEAR(got[2].t, t29, 1e-5);
    const double age = t0 + i / 60.0 - got[2].t;
    if (age > lost_after + 1e-6) {
      EXPECT_FALSE(got[2].tracked) << "no row for " << age << " s";
    }
    if (age <= lost_after - 1e-6) {
      EXPECT_TRUE(got[2].tracked) << "coasting for " << age << " s";
    }
  }
}

// The bodies recorded (session version 5) come back from the replay to the bit, in the
// tracker's snapshot and in the fighter's input, a lost body and a missing one included.
TEST(VisitorBodies, ARecordedSessionGivesTheBodiesBackBitForBit) {
  auto cfg = demo("demo.toml");
  if (!cfg) GTEST_SKIP() << "no demo data (scripts/setup.sh makes it)";
  Tmp tmp;
  cfg->orders_script.reset();
  InstallationOptions io;
  std::vector<Bodies> recorded;
  std::vector<std::vector<FighterBody>> given;
  {
    Installation inst(*cfg, std::make_unique<AwkwardBodies>(), io);
    SessionRecorder rec(tmp.path / "s", session_info(*cfg, io));
    inst.record_to(&rec);
    const double t0 = 5000.0;
    inst.start(t0);
    for (int i = 0; i < 80; ++i) {
      inst.step(t0 + i / 60.0);
      recorded.push_back(inst.input().tracking.bodies);
      given.push_back(fighter_bodies(inst));
      ASSERT_EQ(given.back().size(), 4u) << "the right foot never seen";
    }
    inst.record_to(nullptr);
    rec.close();
  }
  EXPECT_TRUE(given[38][3].tracked);
  EXPECT_FALSE(given[45][3].tracked) << "the left foot lost";
  EXPECT_EQ(given[45][3].p[0], given[38][3].p[0]) << "with its last pose";
  const auto manifest = nlohmann::json::parse(std::ifstream(tmp.path / "s/manifest.json"));
  EXPECT_EQ(manifest.at("version"), 5);

  const Installation* replaying = nullptr;
  ReplayOptions ro;
  ro.on_start = [&](const Installation& i) { replaying = &i; };
  std::size_t compared = 0;
  ro.on_frame = [&](const FrameData& f) {
    ASSERT_LT(f.frame, recorded.size());
    EXPECT_TRUE(same_bits(replaying->input().tracking.bodies, recorded[f.frame])) << "frame " << f.frame;
    EXPECT_EQ(fighter_bodies(*replaying), given[f.frame]) << "frame " << f.frame;
    ++compared;
  };
  const ReplayReport rep = replay_session(tmp.path / "s", ro);
  EXPECT_TRUE(rep.identical) << rep.first_difference_detail;
  EXPECT_EQ(rep.frames_replayed, 80u);
  EXPECT_EQ(compared, 80u);

  // A body that is no role: refused in one line naming the file, line and key.
  std::ifstream in(tmp.path / "s/session.jsonl");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto at = text.find("\"left_hand\":");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 11, "\"left_knee\"");
  std::ofstream(tmp.path / "s/session.jsonl", std::ios::trunc) << text;
  try {
    (void)replay_session(tmp.path / "s");
    ADD_FAILURE() << "a body named left_knee was read";
  } catch (const kumite::Error& e) {
    EXPECT_NE(std::string(e.what()).find("session.jsonl:2: input.tracking.bodies: not a role: \"left_knee\""),
              std::string::npos)
        << e.what();
  }
}

// tests/app/data/session-v4 was recorded at version 4, before the bodies (the repository's
// test session until the glide fix of 6 Dec 2026 changed the fighter from its frame 65): it
// still replays, and the fighter is given the head alone, as predicted to the display, as when
// it was recorded. Its fighter now differs from the recording, so the replay shows the
// recorded frames and goes on past the difference (show_recorded): every frame's input checked.
TEST(VisitorBodies, ASessionOfTheVersionBeforeGivesTheFighterTheHeadAlone) {
  const fs::path session = kSource / "tests/app/data/session-v4";
  const auto manifest = nlohmann::json::parse(std::ifstream(session / "manifest.json"));
  ASSERT_EQ(manifest.at("version"), 4);
  const fs::path data = fs::path(KUMITE_BINARY_DIR) / "demo";
  if (!fs::exists(data / "fighter.kdb")) GTEST_SKIP() << "no demo data (scripts/setup.sh makes it)";
  const Installation* replaying = nullptr;
  ReplayOptions ro;
  ro.data_dir = data;
  ro.show_recorded = true;
  ro.on_start = [&](const Installation& i) { replaying = &i; };
  std::size_t with_head = 0;
  ro.on_frame = [&](const FrameData& f) {
    const TrackingSnapshot& s = replaying->input().tracking;
    for (std::size_t r = 1; r < s.bodies.size(); ++r) EXPECT_FALSE(s.bodies[r]) << "frame " << f.frame;
    ASSERT_EQ(s.head.has_value(), s.bodies[0].has_value());
    if (!s.head) return;
    EXPECT_TRUE(same_bits(*s.head, *s.bodies[0]));
    const auto b = replaying->visitor_bodies();
    ASSERT_EQ(b.size(), 1u);
    EXPECT_EQ(b[0].position_m.x(), s.head->position[0]);
    EXPECT_EQ(b[0].tracked, s.head->status != TrackingStatus::lost);
    ++with_head;
  };
  const ReplayReport rep = replay_session(session, ro);
  EXPECT_EQ(rep.frames_replayed, manifest.at("frames").get<std::uint64_t>());
  EXPECT_GT(with_head, 100u);
}
