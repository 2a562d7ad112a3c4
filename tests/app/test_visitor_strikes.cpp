// Issue 14 in the installation: a poses.csv played as if tracked (`[tracking] source = "poses"`),
// every pose sample to the recognition thread, its events in the frame (FrameEvent
// visitor_strike), recorded and replayed. The recognition thread's events are checked against
// the recognition library run over the same samples in one batch (recognition::recognise), an
// independent path. Data: config/visitor-135_06.poses.csv (CMU 135_06, a kata, placed in the
// room: SYNTHETIC placement, see its header).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include <unistd.h>

#include <fmt/format.h>

#include "kumite/app/config.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/session.hpp"
#include "kumite/app/tracking_input.hpp"
#include "kumite/app/visitor_strikes.hpp"
#include "kumite/common/error.hpp"
#include "kumite/recognition/poses_file.hpp"
#include "kumite/tracking/calibration_file.hpp"
#include "kumite/tracking/config.hpp"
#include "kumite/tracking/synth.hpp"
#include "kumite/tracking/tracker.hpp"

using namespace kumite::app;
namespace fs = std::filesystem;
namespace rec = kumite::recognition;

namespace {

const std::string kVisitor = KUMITE_SOURCE_DIR + "/config/visitor-135_06.poses.csv";
const std::string kModel = KUMITE_SOURCE_DIR + "/recognition/models/strikes.krec";

const char* kRoom = R"(
[[walls]]
name = "front"
lower_left = [-1.5, 0.0, -1.5]
lower_right = [1.5, 0.0, -1.5]
upper_left = [-1.5, 2.4, -1.5]
[fighter]
database = "/nonexistent/fighter.kdb"
)";

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const kumite::Error& e) {
    return e.what();
  }
  return "";
}


}  // namespace

TEST(PosesSource, ConfigKeysAreReadCheckedAndWrittenBack) {
  const std::string poses = std::string(kRoom) +
                            "[tracking]\nsource = \"poses\"\nposes = \"v.csv\"\nposes_loop = false\n"
                            "[recognition]\nmodel = \"m.krec\"\n";
  const auto c = parse_installation_config(poses, "room.toml");
  EXPECT_EQ(c.tracking.source, TrackingSource::poses);
  EXPECT_EQ(c.tracking.poses, "v.csv");
  EXPECT_FALSE(c.tracking.poses_loop);
  EXPECT_EQ(c.recognition.model, "m.krec");
  EXPECT_EQ(parse_installation_config(to_toml(c), "back.toml"), c) << to_toml(c);
  // No calibration is needed for a poses file; the file itself is.
  const std::string missing =
      error_of([&] { parse_installation_config(std::string(kRoom) + "[tracking]\nsource = \"poses\"\n", "room.toml"); });
  EXPECT_EQ(missing.rfind("room.toml:", 0), 0u) << missing;
  EXPECT_NE(missing.find("tracking.poses (a poses.csv) is needed"), std::string::npos) << missing;
  EXPECT_NE(error_of([&] { parse_installation_config(std::string(kRoom) + "[recognition]\nmodle = \"m\"\n", "room.toml"); })
                .find("modle"),
            std::string::npos);
  EXPECT_NE(error_of([&] { parse_installation_config(std::string(kRoom) + "[tracking]\nsource = \"gloves\"\n", "room.toml"); })
                .find("none, recording, live, poses"),
            std::string::npos);
}

TEST(StrikeRecognition, TheThreadGivesTheEventsOfTheRecogniserRunInOneBatch) {
  const auto file = rec::read_poses_csv(kVisitor);
  ASSERT_GT(file.samples.size(), 3000u);
  const rec::Model model = rec::read_model(kModel);
  const std::vector<rec::Event> batch = rec::recognise(model, file.samples);
  ASSERT_GE(std::count_if(batch.begin(), batch.end(), [](const auto& e) { return e.type == rec::EventType::begin; }), 4)
      << "the kata's first 12 s hold several strikes";
  StrikeRecognition thread(model, "test");
  for (std::size_t i = 0; i < file.samples.size(); ++i) {
    thread.push(file.samples[i]);
    if (i + 1 == file.samples.size() || file.samples[i + 1].t != file.samples[i].t) thread.end_of_set(file.samples[i].t);
    // A tracker hands over 5 samples a frame set, 60 sets a second; this loop, all 12 s at
    // once: it lets the thread catch up now and then (its queue holds ~14 s: not all of it).
    if (i % 1000 == 999) thread.drain_for_tests();
  }
  thread.restart(file.samples.back().t);  // as recognise() finishes at its last sample
  thread.drain_for_tests();
  std::vector<VisitorStrike> got;
  thread.take(got);
  ASSERT_EQ(got.size(), batch.size());
  for (std::size_t k = 0; k < got.size(); ++k) {
    SCOPED_TRACE(k);
    EXPECT_EQ(got[k].t, batch[k].t);
    EXPECT_EQ(got[k].type, batch[k].type);
    EXPECT_EQ(got[k].limb, batch[k].limb);
    EXPECT_EQ(rec::to_string(got[k].action), batch[k].action);
    EXPECT_EQ(got[k].progress, batch[k].progress);
    EXPECT_EQ(got[k].confidence, batch[k].confidence);
    EXPECT_EQ(got[k].impact, batch[k].impact);
    EXPECT_GE(got[k].decided_at, 0);
  }
  const RecognitionStats st = thread.stats();
  EXPECT_EQ(st.samples, file.samples.size());
  EXPECT_EQ(st.dropped, 0u);
  EXPECT_EQ(st.events, batch.size());
}

TEST(PosesSource, PlaysTheFileOnItsTimestampsAsIfTracked) {
  // SYNTHETIC: a head walking along +x at 0.5 m/s for 0.6 s at 60 Hz (a glove body of no
  // role is ignored), then the file ends (no loop): the tracker has stopped.
  const fs::path dir = fs::temp_directory_path() / fmt::format("kumite-poses-{}", ::getpid());
  fs::create_directories(dir);
  {
    std::ofstream out(dir / "walk.csv");
    out << "# SYNTHETIC\n" << rec::kPosesHeader << "\n";
    for (int i = 0; i <= 36; ++i) {
      const double t = 100 + i / 60.0;  // the file's own clock: played from the input's start
      out << fmt::format("{},{:.6f},head,tracked,{:.5f},1.6,0,1,0,0,0,4,4,1\n", i, t, 0.5 * (t - 100));
      out << fmt::format("{},{:.6f},stick,tracked,0,1,0,1,0,0,0,4,4,1\n", i, t);
    }
  }
  auto cfg = parse_installation_config(std::string(kRoom) + "[tracking]\nsource = \"poses\"\nposes = \"" +
                                           (dir / "walk.csv").string() + "\"\nposes_loop = false\n",
                                       "room.toml");
  const kumite::Timestamp t0 = kumite::now();
  auto input = make_tracking_input(cfg);
  EXPECT_NE(input->describe().find("37 of the head"), std::string::npos) << input->describe();
  TrackingSnapshot s;
  int tracked = 0;
  double worst = 0;
  while (kumite::now() - t0 < 1.2) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    const kumite::Timestamp now = kumite::now();
    input->poll(now, now, s);
    if (s.state != TrackerState::tracked) continue;
    ++tracked;
    ASSERT_TRUE(s.head);
    // Played from about t0 (the input's start), predicted to now: x = 0.5 m/s x (now - start).
    const double want = 0.5 * std::min(now - t0, 0.6);
    worst = std::max(worst, std::abs(s.head->position[0] - want));
    EXPECT_NEAR(s.head->position[1], 1.6, 1e-9);
    EXPECT_GE(s.measured_at, t0);
    EXPECT_LE(s.measured_at, now);
  }
  EXPECT_GT(tracked, 20) << "played over ~0.6 s, polled every 10 ms";
  EXPECT_LT(worst, 0.05) << "m: the head where the file has it at the moment (a few ms of start-up; 0.1 s late at most)";
  EXPECT_EQ(s.state, TrackerState::stopped) << describe(s);
  EXPECT_NEAR(s.head->position[0], 0.3, 0.01);
  EXPECT_EQ(s.frame_sets, 36u);
  // A broken file is one line naming the config key, the file and its line.
  {
    std::ofstream(dir / "bad.csv") << rec::kPosesHeader << "\n0,0,head,tracked,0,nan,0,1,0,0,0,4,4,1\n";
  }
  cfg.tracking.poses = dir / "bad.csv";
  const std::string e = error_of([&] { (void)make_tracking_input(cfg); });
  EXPECT_NE(e.find("tracking.poses"), std::string::npos) << e;
  EXPECT_NE(e.find("bad.csv:2: y:"), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos) << e;
  fs::remove_all(dir);
}

TEST(PosesSource, TheInstallationLogsTheVisitorsStrikesAndAReplayGivesThemBack) {
  // The mocap visitor through the installation in real time (3.3 s: the kata's first punch and
  // front kick), recorded; the strike events the frames got are the batch recogniser's on the
  // same file (times in the file's clock + the run's offset), and the session replays them.
  const fs::path dir = fs::temp_directory_path() / fmt::format("kumite-visitor-{}", ::getpid());
  fs::remove_all(dir);
  fs::create_directories(dir.string() + "-config");
  const fs::path config_file = dir.string() + "-config/room.toml";
  std::ofstream(config_file) << kRoom << "[tracking]\nsource = \"poses\"\nposes = \"" << kVisitor
                             << "\"\nposes_loop = false\n[recognition]\nmodel = \"" << kModel << "\"\n";
  const auto cfg = load_installation_config(config_file);
  const auto file = rec::read_poses_csv(kVisitor);
  const auto batch = rec::recognise(rec::read_model(kModel), file.samples);
  std::vector<FrameEvent> seen;
  {
    Installation inst(cfg, make_tracking_input(cfg), InstallationOptions{});
    SessionRecorder recorder(dir, session_info(cfg, {}));
    inst.record_to(&recorder);
    const kumite::Timestamp t0 = kumite::now();
    inst.start(t0);
    while (kumite::now() - t0 < 3.3) {
      const FrameData& f = inst.step(kumite::now());
      for (const auto& e : f.events)
        if (e.type == EventType::visitor_strike) seen.push_back(e);
      std::this_thread::sleep_for(std::chrono::milliseconds(16));
    }
    for (const auto& p : inst.problems()) EXPECT_EQ(p.find("recognition"), std::string::npos) << p;
    const std::string line = inst.console().recognition;  // the console's (and health report's) line
    EXPECT_EQ(line.rfind("strike recognition: ", 0), 0u) << line;
    EXPECT_EQ(line.find(" 0 pose samples"), std::string::npos) << line;
    inst.record_to(nullptr);
    recorder.close();
  }
  ASSERT_GE(seen.size(), 3u) << "a front kick and a punch begin by 2.4 s, the kick ends by 3.0 s";
  // The run's clock = the file's + one offset (the input's start): the same for every event.
  const double offset = seen.front().strike.t - batch.front().t;
  for (std::size_t k = 0; k < seen.size(); ++k) {
    SCOPED_TRACE(k);
    ASSERT_LT(k, batch.size());
    const VisitorStrike& s = seen[k].strike;
    EXPECT_EQ(s.type, batch[k].type);
    EXPECT_EQ(s.limb, batch[k].limb);
    EXPECT_EQ(rec::to_string(s.action), batch[k].action);
    EXPECT_NEAR(s.progress, batch[k].progress, 1e-12);
    // The same loop may run at the end of its frame set or at the next set's first sample when
    // a row falls within rounding of a loop tick (the file's rows drift against 60 Hz): the
    // same values, stamped one set apart at most.
    EXPECT_NEAR(s.t - offset, batch[k].t, 0.03);
    EXPECT_GE(s.decided_at, s.t);
    EXPECT_LT(s.decided_at - s.t, 0.5) << "s: decided well within a frame or so (the recogniser's loop)";
  }
  EXPECT_EQ(batch.front().limb, rec::Role::right_foot);
  const ReplayReport r = replay_session(dir);
  EXPECT_TRUE(r.identical) << r.first_difference_detail;
  EXPECT_GT(r.frames_replayed, 100u);
  fs::remove_all(dir);
  fs::remove_all(dir.string() + "-config");
}

namespace {
/// SYNTHETIC camera frame sets of the mocap visitor's glasses, gloves and shoes
/// (config/tracking-gloves.toml), every 1/60 s of the file up to `until_s`, on the file's own
/// clock (+1000 s: far from now(), so the tracker takes the sets' times as its clock and
/// processes every set as fast as it can: the same sets whatever the machine's speed).
class MocapVisitorFrames final : public kumite::tracking::FrameSource {
 public:
  MocapVisitorFrames(const kumite::tracking::RigCalibration& rig, const kumite::tracking::TrackingConfig& tc,
                     const rec::PosesFile& file, double until_s)
      : renderer_(rig, tc.bodies, {}), until_s_(until_s) {
    for (const auto& b : tc.bodies) roles_.push_back(rec::role_from_string(b.name));
    for (const auto& s : file.samples) by_role_[static_cast<std::size_t>(s.role)].push_back(s);
  }
  bool next(kumite::tracking::FrameSet& out, double) override {
    const double t = static_cast<double>(n_) / 60;
    if (t > until_s_) {
      ended_ = true;
      return false;
    }
    std::vector<std::optional<kumite::tracking::TrajectoryPoint>> poses(roles_.size());
    for (std::size_t b = 0; b < roles_.size(); ++b) {
      if (!roles_[b]) continue;
      const auto& v = by_role_[static_cast<std::size_t>(*roles_[b])];
      // The file is at 60 Hz from t = 0: its row n is this set's.
      if (n_ >= v.size() || !v[n_].tracked) continue;
      kumite::tracking::TrajectoryPoint p;
      p.t = t;
      p.position = {v[n_].position[0], v[n_].position[1], v[n_].position[2]};
      const auto& q = v[n_].orientation;
      p.orientation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
      poses[b] = p;
    }
    out = renderer_.render(n_, 1000 + t, poses);
    ++n_;
    return true;
  }
  bool end_of_stream() const override { return ended_; }

 private:
  kumite::tracking::SyntheticRenderer renderer_;
  std::vector<std::optional<rec::Role>> roles_;
  std::array<std::vector<rec::PoseSample>, rec::kRoleCount> by_role_;
  double until_s_;
  std::size_t n_ = 0;
  bool ended_ = false;
};

/// Polls `input` every `period` until its tracker stops or `limit_s` pass: every visitor strike
/// it handed over; `s` is the last snapshot (its state says whether it stopped).
std::vector<VisitorStrike> strikes_until_stopped(TrackingInput& input, TrackingSnapshot& s, std::chrono::milliseconds period,
                                                 double limit_s) {
  std::vector<VisitorStrike> got;
  const kumite::Timestamp give_up = kumite::now() + limit_s;
  do {
    std::this_thread::sleep_for(period);
    input.poll(kumite::now(), kumite::now(), s);
    got.insert(got.end(), s.strikes.begin(), s.strikes.end());
  } while (s.state != TrackerState::stopped && kumite::now() < give_up);
  return got;
}
}  // namespace

TEST(VisitorStrikes, GlovesTrackedFromCameraFramesGiveTheMocapsStrikes) {
  // The whole path but the frame loop's clock: camera frame sets of the mocap visitor (3.4 s of
  // the kata: a front kick and a lunge punch) -> the real tracker with five bodies -> the
  // recognition thread. Beside it the recogniser on the mocap poses themselves: the strikes
  // it begins must be begun from the tracked gloves too (tracking noise may add a little).
  auto cfg = load_installation_config(KUMITE_SOURCE_DIR + "/config/demo.toml");
  cfg.tracking.tracking = KUMITE_SOURCE_DIR + "/config/tracking-gloves.toml";
  cfg.recognition.model = kModel;
  const auto rig = kumite::tracking::read_calibration(cfg.resolve(cfg.tracking.calibration));
  const auto tc = kumite::tracking::read_tracking_config(cfg.tracking.tracking);
  ASSERT_EQ(tc.bodies.size(), 5u);
  const auto file = rec::read_poses_csv(kVisitor);
  constexpr double kUntil = 3.4;
  std::vector<rec::PoseSample> truth;
  for (const auto& s : file.samples)
    if (s.t <= kUntil) truth.push_back(s);
  const auto batch = rec::recognise(rec::read_model(kModel), truth);
  auto input = make_tracking_input(cfg, std::make_unique<MocapVisitorFrames>(rig, tc, file, kUntil));
  TrackingSnapshot s;
  std::vector<VisitorStrike> got = strikes_until_stopped(*input, s, std::chrono::milliseconds(50), 300);
  ASSERT_EQ(s.state, TrackerState::stopped) << "every set tracked within 300 s";
  input.reset();  // the tracker and the recognition thread stopped: every sample recognised
  EXPECT_EQ(s.frame_sets, static_cast<std::uint64_t>(kUntil * 60) + 1);
  EXPECT_EQ(s.recognition.dropped, 0u);
  EXPECT_GE(s.recognition.samples, 4 * s.frame_sets) << "the gloves and shoes of nearly every set";
  // The gloves and shoes reach the frame too (TrackingSnapshot::bodies), as measured: each where
  // the mocap had it in the frame set that measured it (its timestamp), within the tracking's noise.
  for (std::size_t r = 0; r < rec::kRoleCount; ++r) {
    const auto role = static_cast<rec::Role>(r);
    SCOPED_TRACE(rec::to_string(role));
    ASSERT_TRUE(s.bodies[r]);
    const kumite::BodyPose& p = *s.bodies[r];
    EXPECT_EQ(p.body, static_cast<std::int32_t>(r)) << "config/tracking-gloves.toml's bodies are in role order";
    const long n = std::lround((p.timestamp - 1000) * 60);  // the file's row of that set (60 Hz from 0)
    EXPECT_NEAR(p.timestamp, 1000 + n / 60.0, 1e-9) << "a frame set's time: measured, not predicted";
    EXPECT_GE(n, static_cast<long>(kUntil * 60) - 3) << "the newest sets measured it";
    std::vector<rec::PoseSample> of_role;
    for (const auto& smp : file.samples)
      if (smp.role == role) of_role.push_back(smp);
    ASSERT_LT(static_cast<std::size_t>(n), of_role.size());
    const auto& want = of_role[static_cast<std::size_t>(n)].position;
    const double d = std::hypot(p.position[0] - want[0], p.position[1] - want[1], p.position[2] - want[2]);
    EXPECT_LT(d, 0.03) << "m from the mocap's row " << n;
  }
  std::string seen;
  for (const auto& e : got)
    seen += fmt::format("{} {} {} {:.2f}; ", rec::to_string(e.type), rec::to_string(e.limb), rec::to_string(e.action), e.t - 1000);
  int truth_begins = 0;
  for (const auto& b : batch) {
    if (b.type != rec::EventType::begin) continue;
    ++truth_begins;
    // The same limb and action begun within 0.1 s of the mocap's.
    const bool found = std::any_of(got.begin(), got.end(), [&](const VisitorStrike& e) {
      return e.type == rec::EventType::begin && e.limb == b.limb && rec::to_string(e.action) == b.action &&
             std::abs((e.t - 1000) - b.t) <= 0.1;
    });
    EXPECT_TRUE(found) << rec::to_string(b.limb) << " " << b.action << " at " << b.t << " s; tracked: " << seen;
  }
  EXPECT_EQ(truth_begins, 2) << "the kata's first kick and punch";
  const auto begins = std::count_if(got.begin(), got.end(), [](const auto& e) { return e.type == rec::EventType::begin; });
  EXPECT_LE(begins, truth_begins + 1) << "at most one begin more than on the mocap itself: " << seen;
}

TEST(PosesSource, AFileThatStopsMidStrikeCancelsIt) {
  // The mocap visitor cut at 2.9 s of its file: the front kick and the lunge punch begun at
  // ~2.5 s are under way when the rows stop (no loop): both end in `cancel`, nothing stalls.
  const fs::path dir = fs::temp_directory_path() / fmt::format("kumite-cut-{}", ::getpid());
  fs::create_directories(dir);
  {
    std::ifstream in(kVisitor);
    std::ofstream out(dir / "cut.csv");
    for (std::string line; std::getline(in, line);) {
      if (!line.empty() && line[0] != '#' && line.rfind("frame,", 0) != 0) {
        const auto a = line.find(','), b = line.find(',', a + 1);
        if (std::stod(line.substr(a + 1, b - a - 1)) > 2.9) break;
      }
      out << line << "\n";
    }
  }
  const auto cfg = parse_installation_config(std::string(kRoom) + "[tracking]\nsource = \"poses\"\nposes = \"" +
                                                 (dir / "cut.csv").string() + "\"\nposes_loop = false\n[recognition]\nmodel = \"" +
                                                 kModel + "\"\n",
                                             "room.toml");
  auto input = make_tracking_input(cfg);
  TrackingSnapshot s;
  std::vector<VisitorStrike> got = strikes_until_stopped(*input, s, std::chrono::milliseconds(20), 30);
  ASSERT_EQ(s.state, TrackerState::stopped);
  // The cancels are published by the recognition thread just after the file's end.
  for (int i = 0; i < 50 && std::none_of(got.begin(), got.end(), [](const auto& e) { return e.type == rec::EventType::cancel; }); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    input->poll(kumite::now(), kumite::now(), s);
    got.insert(got.end(), s.strikes.begin(), s.strikes.end());
  }
  std::string seen;
  for (const auto& e : got) seen += fmt::format("{} {}; ", rec::to_string(e.type), rec::to_string(e.limb));
  int begins = 0, cancels = 0;
  for (const auto& e : got) {
    if (e.type == rec::EventType::begin) ++begins;
    if (e.type != rec::EventType::cancel) continue;
    ++cancels;
    EXPECT_TRUE(std::any_of(got.begin(), got.end(), [&](const auto& b) { return b.type == rec::EventType::begin && b.limb == e.limb; }))
        << "a cancel ends a strike that began: " << seen;
  }
  EXPECT_GE(begins, 2) << seen;
  EXPECT_EQ(cancels, begins) << "every strike under way at the cut is cancelled, none ended: " << seen;
  fs::remove_all(dir);
}
