// The frame's formats pinned to their bytes: a version 3 session kept for it (tests/app/data/
// session-v3, recorded before the database held blocks, so it no longer replays without a
// note) read back and written again gives its states.bin records, its session.jsonl state hashes and the same frames.jsonl lines; and a made-up frame with every field set (every
// event kind, a visitor's strike, the visitor near a wall, a target) encodes, hashes and logs
// to the bytes pinned here. A change to how a frame is walked that alters any of them fails.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "kumite/app/frame_log.hpp"
#include "kumite/app/frame_states.hpp"
#include "kumite/app/session.hpp"
#include "kumite/common/checksum.hpp"
#include "frame_records.hpp"

using namespace kumite::app;
using kumite::app::test::unpack_records;
namespace fs = std::filesystem;

namespace {

const fs::path kSession = fs::path(KUMITE_SOURCE_DIR) / "tests/app/data/session-v3";

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

ConsoleState console_of(const FrameData& f) {
  ConsoleState c;
  c.head_live = f.head_live;
  c.character_name = fmt::format("character {}", f.fighter.character + 1);
  for (std::size_t k = 0; k < f.events.size(); ++k) c.frame_events.push_back(fmt::format("event {} text", k));
  c.tracking = "tracked";
  return c;
}

const std::vector<std::string> kWalls = {"front", "left", "right", "floor", "fifth"};

std::string hashes_text(const StateHashes& h) {
  std::string s;
  for (std::size_t k = 0; k < h.value.size(); ++k) s += fmt::format("{:016x} ", h.value[k]);
  return s;
}

/// A frame with every field set to something of its own.
FrameData every_field() {
  FrameData f;
  f.frame = 1234;
  f.time_s = 20.5;
  f.now = 1020.25;
  f.head.position = {0.1, 1.65, 0.3};
  f.head.orientation = glm::dquat(0.9, 0.1, 0.3, -0.2);
  f.head_live = true;
  f.eyes.left = {0.07, 1.6, 0.25};
  f.eyes.right = {0.13, 1.6, 0.25};
  f.views.resize(2);
  for (std::size_t w = 0; w < 2; ++w)
    for (std::size_t e = 0; e < 2; ++e) {
      EyeView& v = f.views[w][e];
      v.frustum = {-0.1 * (w + 1), 0.2, -0.3, 0.4 + e, 0.05, 50};
      for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) v.view[c][r] = 0.01 * (c * 4 + r) + w + 0.5 * e, v.projection[c][r] = -0.02 * (c + r * 4) + e;
      v.valid = (w + e) % 2 == 0;
    }
  f.pose_age_ms = 12.5;
  f.pose_measured_at = 1020.2;
  f.tracking_latency_ms = -1;
  f.latch_ms = 3.25;
  f.predicted_ahead_ms = 30.125;
  FighterPose& p = f.fighter;
  p.present = true;
  p.state = kumite::content::FighterState::striking;
  p.character = 1;
  auto sk = std::make_shared<FighterSkeleton>();
  sk->character = 1;
  sk->character_name = "second";
  sk->joint_names = {"Hips", "Spine", "Head"};
  sk->parents = {-1, 0, 1};
  p.skeleton = sk;
  p.joints = {{0.0, 1.0, -1.0}, {0.01, 1.2, -1.02}, {0.02, 1.6, -1.0312345678}};
  p.local_rotations = {glm::dquat(1, 0, 0, 0), glm::dquat(0.7071067811865476, 0.7071067811865476, 0, 0),
                       glm::dquat(0.5, 0.5, 0.5, 0.5)};
  p.root_joint = {0.0, 1.0, -1.0};
  p.target = glm::dvec3(0.1, 1.6, 0.2);
  p.root = {0.0, 0.0, -1.0};
  p.heading_rad = 0.125;
  f.visitor_near_wall = VisitorNearWall{1, 0.35, false, true};
  f.spar = SparFrame{.state = kumite::content::PlannerState::countering, .visitor_hits = 1, .visitor_dodges = 2,
                     .fighter_hits = 3, .blocks = 4, .blocks_late = 5, .blocked = 6, .unanswered = 7};
  for (int k = 0; k <= static_cast<int>(EventType::stepping_back); ++k) {
    FrameEvent e;
    e.type = static_cast<EventType>(k);
    if (k % 3 != 0) e.order = kumite::Order{1000.5 + k, kumite::OrderKind::kick_left, -1};
    e.distance_m = 0.01 * k;
    e.time_s = 20.0 + 0.001 * k;
    e.cause = k >= 7 && k <= 9 ? EventCause::visitor : EventCause::fighter;
    if (e.cause == EventCause::fighter) {
      e.fighter.time = 1020.0 + k;
      e.fighter.kind = e.type;
      e.fighter.order = e.order.value_or(kumite::Order{});
      e.fighter.reason = kumite::content::FighterEvent::Reason::strike;
      e.fighter.distance_m = 0.02 * k;
      e.fighter.target = {0.5, 1.5, 0.25 * k};
      e.fighter.segment = 40 + k;
      e.fighter.start_frame = 3;
      e.fighter.contact_frame = 30 + k;
      e.fighter.contact_distance_m = 0.004 * k;
      e.fighter.out_of_reach = k % 2 == 1;
      e.fighter.character_count = 5;
      e.fighter.limb = kumite::recognition::Role::left_foot;
      e.fighter.side = k % 2;
      e.fighter.margin_s = 0.0625 * k;
      e.fighter.speed_mps = 4.5;
      e.fighter.recognised = k % 2 == 0;
    } else {
      e.wall = k - 7;
      e.outside = k == 8;
      e.lost = k == 7;
    }
    if (e.type == EventType::visitor_strike) {
      e.strike.t = 1020.1;
      e.strike.decided_at = 1020.15;
      e.strike.type = kumite::recognition::EventType::end;
      e.strike.limb = kumite::recognition::Role::left_foot;
      e.strike.action = kumite::recognition::Action::side_kick;
      e.strike.progress = 0.75;
      e.strike.confidence = 0.875;
      e.strike.impact = {0.2, 1.1, -0.4};
    }
    f.events.push_back(e);
  }
  for (int k = 0; k < 3; ++k) {
    DrawItem it;
    it.model = glm::mat4(1.0f + k);
    it.model[3][1] = 0.5f * k;
    it.colour = {0.1f * k, 0.5f, 0.9f};
    it.mesh = k == 1 ? Mesh::cylinder : Mesh::sphere;
    f.items.push_back(it);
  }
  return f;
}

}  // namespace

TEST(FrameBytes, TheRepositorysSessionEncodesHashesAndLogsAsRecorded) {
  // A frame-version-2 file (kFrameVersion is 3 since the fighter's events carry the visitor's
  // limb, the forearm, a margin and a speed): re-encoded at its own version.
  const std::string header2 = "kumite-frame-states 2\n";
  const std::string file = read(kSession / "states.bin");
  ASSERT_EQ(file.substr(0, header2.size()), header2);
  const auto recorded = unpack_records(std::string_view(file).substr(header2.size()));
  std::ifstream lines(kSession / "session.jsonl");
  std::string line;
  ASSERT_TRUE(std::getline(lines, line));  // the start line
  FrameStatesReader reader(kSession / "states.bin");
  FrameData f;
  std::set<int> drawn;
  std::string encoded, all;
  std::uint64_t log_stereo = kumite::kFnv1a64Offset, log_mono = kumite::kFnv1a64Offset;
  std::size_t frames = 0, events = 0;
  while (reader.next(f)) {
    const bool with_skeleton = f.fighter.present && drawn.insert(f.fighter.character).second;
    encode_frame_state(f, with_skeleton, encoded, 2);
    all += encoded;
    ASSERT_TRUE(std::getline(lines, line));
    const auto j = nlohmann::json::parse(line);
    const StateHashes h = state_hashes_v3(f);  // a version 3 session
    for (std::size_t k = 0; k < StateHashes::kFields.size(); ++k)
      ASSERT_EQ(j["hash"][std::string(StateHashes::kFields[k])].get<std::string>(), fmt::format("{:016x}", h.value[k]))
          << "frame " << f.frame << ": " << StateHashes::kFields[k];
    const ConsoleState c = console_of(f);
    const std::vector<std::string> names(kWalls.begin(), kWalls.begin() + static_cast<long>(f.views.size()));
    log_stereo = kumite::fnv1a64(frame_json(f, c, names, true) + "\n", log_stereo);
    log_mono = kumite::fnv1a64(frame_json(f, c, names, false) + "\n", log_mono);
    ++frames;
    events += f.events.size();
  }
  EXPECT_TRUE(reader.problem().empty()) << reader.problem();
  EXPECT_EQ(frames, 200u);
  EXPECT_GT(events, 0u);
  const auto again = unpack_records(all);
  ASSERT_EQ(again.size(), recorded.size());
  for (std::size_t k = 0; k < again.size(); ++k) ASSERT_EQ(again[k], recorded[k]) << "record " << k;
  EXPECT_EQ(all, file.substr(header2.size())) << "the records whole, zlib's packing included";
  EXPECT_EQ(fmt::format("{:016x} {:016x}", log_stereo, log_mono), "dc6813c262837397 853d386ee45c4317");
}

TEST(FrameBytes, AFrameWithEveryFieldSetEncodesHashesAndLogsToItsPinnedBytes) {
  const FrameData f = every_field();
  std::string encoded;
  // Version 2, as pinned before version 3 (the fighter's events' limb, side, margin_s,
  // speed_mps, recognised) was added; then versions 3 and 4, whose frame records differ.
  encode_frame_state(f, true, encoded, 2);
  auto p = unpack_records(encoded);
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(fmt::format("{:016x} {:016x}", kumite::fnv1a64(p[0]), kumite::fnv1a64(p[1])), "c0a03435b616d82b ec335f8e054c99c3");
  encode_frame_state(f, true, encoded, 3);
  p = unpack_records(encoded);
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(fmt::format("{:016x} {:016x}", kumite::fnv1a64(p[0]), kumite::fnv1a64(p[1])), "c0a03435b616d82b e0e4d918c844c35a");
  // Version 4 adds the spar bout (FrameData::spar).
  encode_frame_state(f, true, encoded);
  p = unpack_records(encoded);
  ASSERT_EQ(p.size(), 2u);
  const std::string states = fmt::format("{:016x} {:016x}", kumite::fnv1a64(p[0]), kumite::fnv1a64(p[1]));
  const std::string hashes = hashes_text(state_hashes_v3(f));
  const ConsoleState c = console_of(f);
  const std::string stereo = frame_json(f, c, {"front", "left"}, true), mono = frame_json(f, c, {"front", "left"}, false);
  EXPECT_EQ(states, "c0a03435b616d82b 3c35ae0fe033b366");
  EXPECT_EQ(hashes, "c67e92f1806d1192 cbe4c998296f2803 4b6e8102b8b1bcf4 d6e2b36e29bdc4b0 66b976a4d40768e2 396bc9852c237b77 ");
  EXPECT_EQ(fmt::format("{:016x}", kumite::fnv1a64(stereo)), "dfcc729368493960") << stereo;
  EXPECT_EQ(fmt::format("{:016x}", kumite::fnv1a64(mono)), "1510c422d01249ea") << mono;
}
