// Blocks in the motion database: the shipped motions.toml's reviewed blocks (gedan-barai, age-uke,
// shuto-uke) go into the database keyed by (forearm, height), and an incoming fist path retrieves
// the block whose forearm is across it, through the same search as a strike (equal to brute force).
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <random>

#include "kumite/common/error.hpp"
#include "kumite/content/annotation.hpp"
#include "kumite/content/block_retrieval.hpp"
#include "kumite/content/database.hpp"
#include "mocap_data.hpp"

using namespace kumite::content;

namespace {

struct Shipped {
  AnnotationSet set;
  std::vector<Clip> clips;
  Database db;
  std::map<std::string, const MotionAnnotation*> by_name;
};
const Shipped& shipped() {
  static const Shipped s = [] {
    Shipped r;
    r.set = read_annotations(kumite::content::testing::source_dir() / "content" / "motions" / "motions.toml");
    r.clips = load_annotated_clips(r.set);
    r.db = build_database(segment_sources(r.set, r.clips), {});
    for (const auto& c : r.set.clips)
      for (const auto& m : c.motions) r.by_name[m.name] = &m;
    return r;
  }();
  return s;
}

// What the annotation says of a database segment (a mirrored copy blocks with the other forearm).
std::pair<Forearm, StrikeHeight> annotated(const MotionSegment& seg) {
  const std::string name = seg.mirrored ? seg.name.substr(0, seg.name.size() - std::string(":mirror").size()) : seg.name;
  const MotionAnnotation& m = *shipped().by_name.at(name);
  Forearm f = *m.forearm;
  if (seg.mirrored) f = f == Forearm::left ? Forearm::right : Forearm::left;
  return {f, *m.height};
}

// A pose query that favours neither side: the mean of the block rows' features (the mirrored
// copies make it symmetric).
std::array<float, kFeatureDim> mean_block_features(const RetrievalIndex& ix) {
  std::array<double, kFeatureDim> sum{};
  for (int r = 0; r < ix.size; ++r)
    for (int a = 0; a < kFeatureDim; ++a) sum[static_cast<std::size_t>(a)] += ix.features[static_cast<std::size_t>(r) * kFeatureDim + static_cast<std::size_t>(a)];
  std::array<float, kFeatureDim> out{};
  for (int a = 0; a < kFeatureDim; ++a) out[static_cast<std::size_t>(a)] = static_cast<float>(sum[static_cast<std::size_t>(a)] / ix.size);
  return out;
}

void expect_same(const BlockChoice& a, const BlockChoice& b) {
  ASSERT_EQ(a.choice.row, b.choice.row);
  EXPECT_EQ(a.choice.cost, b.choice.cost);
  EXPECT_EQ(a.choice.window_sample, b.choice.window_sample);
  EXPECT_EQ(a.choice.target_in_box, b.choice.target_in_box);
  EXPECT_EQ(a.segment, b.segment);
  EXPECT_EQ(a.intercept_frame, b.intercept_frame);
}

}  // namespace

TEST(Blocks, TheShippedDatabaseHoldsBlocksAtEveryHeightForBothForearms) {
  const Database& db = shipped().db;
  std::map<std::pair<int, int>, int> segments;  // (forearm, height) -> count
  bool block_seen = false;
  for (const MotionSegment& s : db.segments) {
    if (s.kind != SegmentKind::block) {
      EXPECT_FALSE(block_seen) << s.name << ": blocks come after every other segment";
      continue;
    }
    block_seen = true;
    ASSERT_TRUE(s.effector_group == 0 || s.effector_group == 1) << s.name;
    ASSERT_GE(s.height, 0) << s.name;
    const auto [forearm, height] = annotated(s);
    EXPECT_EQ(s.effector_group, static_cast<int>(forearm)) << s.name;
    EXPECT_EQ(s.height, static_cast<int>(height)) << s.name;
    ASSERT_EQ(s.hit_path_m.size(), s.frames.size());
    ASSERT_EQ(s.elbow_path_m.size(), s.frames.size());
    ASSERT_LE(0, s.intercept_first);
    ASSERT_LE(s.intercept_first, s.intercept_last);
    ASSERT_LT(s.intercept_last, s.frame_count());
    ++segments[{s.effector_group, s.height}];
  }
  std::map<int, int> rows;
  for (int r = 0; r < db.block_index.size; ++r) ++rows[db.block_index.group[static_cast<std::size_t>(r)]];
  for (Forearm f : {Forearm::left, Forearm::right}) {
    for (StrikeHeight h : {StrikeHeight::low, StrikeHeight::mid, StrikeHeight::high}) {
      EXPECT_GE((segments[{static_cast<int>(f), static_cast<int>(h)}]), 3) << to_string(f) << " " << to_string(h);
      EXPECT_GT(rows[block_group(f, h)], 0) << to_string(f) << " " << to_string(h);
    }
  }
  // The guard: where blocks meet a fist, a forearm's length or so in front of the pelvis.
  EXPECT_GT(db.block_reach_m, 0.15);
  EXPECT_LT(db.block_reach_m, 0.6);
  // The strikes' index knows nothing of them.
  for (int r = 0; r < db.index.size; ++r)
    EXPECT_EQ(db.segments[static_cast<std::size_t>(db.index.segment[static_cast<std::size_t>(r)])].kind, SegmentKind::strike);
}

TEST(Blocks, AFistPathAtEachHeightAndSideRetrievesTheBlockAnnotatedSo) {
  const Database& db = shipped().db;
  const double stature = db.actor_stature_m;
  ASSERT_GT(stature, 1.0);
  BlockQuery q;
  q.features = mean_block_features(db.block_index);
  // Where a fist aims: below the belt, the solar plexus, the face.
  const std::map<StrikeHeight, double> aim = {{StrikeHeight::low, 0.45}, {StrikeHeight::mid, 0.66}, {StrikeHeight::high, 0.92}};
  for (const auto& [height, fraction] : aim) {
    for (Forearm side : {Forearm::left, Forearm::right}) {
      SCOPED_TRACE(std::string(to_string(height)) + " " + std::string(to_string(side)));
      const float x = static_cast<float>((side == Forearm::left ? 1 : -1) * 0.12 * stature);  // +X: the fighter's left
      const float y = static_cast<float>(fraction * stature);
      // A punch from 1 m in front, 6 m/s straight at the fighter.
      q.fist = {Eigen::Vector3f(x, y, 1.0f), Eigen::Vector3f(0, 0, -6.0f)};
      const BlockChoice c = retrieve_block(db, q, {});
      ASSERT_GE(c.choice.row, 0);
      EXPECT_TRUE(c.intercept.crosses);
      EXPECT_EQ(c.intercept.height, height);
      EXPECT_NEAR(c.intercept.time_s, (1.0 - std::sqrt(db.block_reach_m * db.block_reach_m - x * x)) / 6.0, 1e-4);
      const MotionSegment& seg = db.segments[static_cast<std::size_t>(c.segment)];
      ASSERT_EQ(seg.kind, SegmentKind::block);
      const auto [forearm, annotated_height] = annotated(seg);
      EXPECT_EQ(annotated_height, height) << seg.name;
      EXPECT_EQ(forearm, side) << seg.name;
      EXPECT_EQ(c.forearm, side);
      EXPECT_EQ(c.height, height);
      EXPECT_GE(c.intercept_frame, seg.intercept_first);
      EXPECT_LE(c.intercept_frame, seg.intercept_last);
      EXPECT_EQ(c.intercept_window[0], seg.intercept_first);
      EXPECT_EQ(c.intercept_window[1], seg.intercept_last);
      EXPECT_GT(c.lead_s, 0.09);  // the forearm travels before it is in place
      // The chosen forearm's contact point lies near the fist's path: within 0.3 m (the low
      // blocks of this actor stop with the forearm's middle at 0.6 of stature, 0.28 m above a
      // fist at 0.45: adaptation lowers them).
      EXPECT_LT(c.choice.trajectory_distance_m, 0.3) << seg.name;
      // The same fist given as a predicted impact point and arrival time.
      q.fist = fist_path_to_impact(Eigen::Vector3f(x, y, 1.0f), Eigen::Vector3f(x, y, 0.0f), 1.0 / 6.0);
      const BlockChoice d = retrieve_block(db, q, {});
      EXPECT_EQ(d.choice.row, c.choice.row);
    }
  }
}

TEST(Blocks, BlockRetrievalEqualsBruteForce) {
  const Database& db = shipped().db;
  const RetrievalIndex& ix = db.block_index;
  ASSERT_GT(ix.size, 50);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> row(0, ix.size - 1);
  std::normal_distribution<double> n01(0, 1);
  std::uniform_real_distribution<double> u01(0, 1);
  int heights[3] = {0, 0, 0}, outside = 0;
  for (RetrievalTunables tu : {RetrievalTunables{}, RetrievalTunables{0.2, 20.0, 0.0}, RetrievalTunables{5.0, 1.0, 0.3}}) {
    for (int i = 0; i < 300; ++i) {
      BlockQuery q;
      const int r = row(rng);
      for (int a = 0; a < kFeatureDim; ++a)
        q.features[static_cast<std::size_t>(a)] = ix.features[static_cast<std::size_t>(r) * kFeatureDim + static_cast<std::size_t>(a)] +
                                                   static_cast<float>(0.3 * n01(rng));
      // Fists from anywhere in front and beside, at any height, heading roughly for the body.
      const double yaw = 1.2 * (u01(rng) - 0.5) * 2, dist = 0.6 + 1.2 * u01(rng), h = 0.2 + 1.8 * u01(rng);
      const Eigen::Vector3f p(static_cast<float>(dist * std::sin(yaw)), static_cast<float>(h), static_cast<float>(dist * std::cos(yaw)));
      const Eigen::Vector3f aim(static_cast<float>(0.3 * n01(rng)), static_cast<float>(h + 0.2 * n01(rng)), static_cast<float>(0.1 * n01(rng)));
      q.fist = {p, (aim - p).normalized() * static_cast<float>(3 + 6 * u01(rng))};
      RetrievalStats st;
      const BlockChoice fast = retrieve_block(db, q, tu, &st);
      expect_same(fast, retrieve_block_brute_force(db, q, tu));
      ++heights[static_cast<int>(fast.intercept.height)];
      outside += !fast.choice.target_in_box;
    }
  }
  EXPECT_GT(heights[0], 50);
  EXPECT_GT(heights[1], 50);
  EXPECT_GT(heights[2], 50);
  EXPECT_GT(outside, 20);  // the nearest-box fallback was exercised too
  // And the index itself, group by group, as the strikes' is tested.
  for (int i = 0; i < 600; ++i) {
    RetrievalQuery q;
    const int r = row(rng);
    q.group = ix.group[static_cast<std::size_t>(r)];
    for (int a = 0; a < kFeatureDim; ++a)
      q.features[static_cast<std::size_t>(a)] = ix.features[static_cast<std::size_t>(r) * kFeatureDim + static_cast<std::size_t>(a)] +
                                                 static_cast<float>(0.3 * n01(rng));
    const float* w = ix.window.data() + static_cast<std::size_t>(r) * kWindowMax * 3;
    q.target_m = Eigen::Vector3f(w[0], w[1], w[2]) + (Eigen::Vector3d(n01(rng), n01(rng), n01(rng)) * (i % 2 ? 0.05 : 0.5)).cast<float>();
    const RetrievalChoice fast = retrieve(ix, q, {});
    const RetrievalChoice slow = retrieve_brute_force(ix, q, {});
    ASSERT_EQ(fast.row, slow.row);
    EXPECT_EQ(fast.cost, slow.cost);
    EXPECT_EQ(fast.window_sample, slow.window_sample);
  }
}

TEST(Blocks, BadFistPathsRetrieveNothing) {
  const Database& db = shipped().db;
  BlockQuery q;
  q.fist = {Eigen::Vector3f(0, std::nanf(""), 1), Eigen::Vector3f(0, 0, -5)};
  EXPECT_LT(retrieve_block(db, q, {}).choice.row, 0);
  q.fist = {Eigen::Vector3f(0, 1.5f, 1), Eigen::Vector3f(0, 0, std::numeric_limits<float>::infinity())};
  EXPECT_LT(retrieve_block(db, q, {}).choice.row, 0);
  // A fist moving away from the fighter: its nearest point is where it is now.
  q.fist = {Eigen::Vector3f(0, 1.5f, 1), Eigen::Vector3f(0, 0, 5)};
  const BlockChoice c = retrieve_block(db, q, {});
  EXPECT_FALSE(c.intercept.crosses);
  EXPECT_EQ(c.intercept.time_s, 0);
}

TEST(Blocks, TheDatabaseFileKeepsBlocksAndRefusesAnOlderVersionInOneLine) {
  const Database& db = shipped().db;
  const std::string bytes = serialize_database(db);
  const Database back = parse_database(bytes, "fighter.kdb");
  EXPECT_EQ(serialize_database(back), bytes);
  EXPECT_EQ(back.block_index.size, db.block_index.size);
  EXPECT_EQ(back.block_reach_m, db.block_reach_m);
  EXPECT_EQ(back.actor_stature_m, db.actor_stature_m);
  BlockQuery q;
  q.features = mean_block_features(db.block_index);
  q.fist = {Eigen::Vector3f(0.2f, 1.0f, 1.0f), Eigen::Vector3f(0, 0, -6)};
  EXPECT_EQ(retrieve_block(back, q, {}).choice.row, retrieve_block(db, q, {}).choice.row);
  std::string old = bytes;
  old[8] = 4;  // the version before blocks (little-endian u32 after the 8-byte magic)
  try {
    parse_database(old, "build/demo/fighter.kdb");
    FAIL() << "an old database loaded";
  } catch (const kumite::Error& e) {
    const std::string msg = e.what();
    EXPECT_EQ(e.code(), "version");
    EXPECT_NE(msg.find("build/demo/fighter.kdb"), std::string::npos) << msg;
    EXPECT_NE(msg.find("version 4"), std::string::npos) << msg;
    EXPECT_NE(msg.find("rebuild"), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
}

TEST(Blocks, BlockAnnotationsAreCheckedWithFileLineAndKey) {
  const std::string head = "version = 1\n[[clip]]\nfile = \"a.bvh\"\n[[clip.motion]]\nname = \"b\"\n";
  auto error = [](const std::string& text) -> std::string {
    try {
      parse_annotations(text, "m.toml");
    } catch (const kumite::Error& e) {
      return e.what();
    }
    return "(no error)";
  };
  const std::string block = head + "semantics = \"block\"\nframes = [10, 50]\n";
  EXPECT_EQ(error(block + "forearm = \"left\"\nheight = \"low\"\n"),
            "m.toml:4: clip[0].motion[0].intercept_frames: is required for a reviewed block (forearm, intercept_frames and "
            "height together; none: an unreviewed block, left out of the database)");
  EXPECT_EQ(error(block + "forearm = \"left\"\nheight = \"low\"\nintercept_frames = [40, 60]\n"),
            "m.toml:10: clip[0].motion[0].intercept_frames: [40, 60] must lie inside frames [10, 50], first <= last");
  EXPECT_EQ(error(block + "forearm = \"left\"\nheight = \"low\"\nintercept_frames = [40, 30]\n"),
            "m.toml:10: clip[0].motion[0].intercept_frames: [40, 30] must lie inside frames [10, 50], first <= last");
  EXPECT_NE(error(block + "forearm = \"left\"\nheight = \"low\"\nintercept_frames = [40.5, 45]\n").find("intercept_frames: must be [first, last] (two integers)"),
            std::string::npos);
  EXPECT_NE(error(block + "forearm = \"elbow\"\n").find("m.toml:8: clip[0].motion[0].forearm: unknown forearm 'elbow' (left, right)"),
            std::string::npos);
  EXPECT_NE(error(head + "semantics = \"punch\"\nframes = [10, 50]\nhit_segment = \"left_hand\"\nhit_frame = 30\nforearm = \"left\"\n")
                .find("clip[0].motion[0].forearm: only blocks have one, not punch"),
            std::string::npos);
  // A reviewed block reads back as written; an unreviewed one (as proposed) stays out of the database.
  const AnnotationSet set = parse_annotations(block + "forearm = \"right\"\nheight = \"high\"\nintercept_frames = [30, 40]\n", "m.toml");
  const MotionAnnotation& m = set.clips[0].motions[0];
  ASSERT_TRUE(is_reviewed_block(m));
  EXPECT_EQ(*m.forearm, Forearm::right);
  EXPECT_EQ(*m.height, StrikeHeight::high);
  EXPECT_EQ((*m.intercept_frames)[0], 30);
  EXPECT_EQ((*m.intercept_frames)[1], 40);
  const AnnotationSet again = parse_annotations(format_annotations(set), "m.toml");
  EXPECT_EQ(again.clips[0].motions[0].intercept_frames, m.intercept_frames);
  EXPECT_EQ(again.clips[0].motions[0].forearm, m.forearm);
  EXPECT_FALSE(is_reviewed_block(parse_annotations(block, "m.toml").clips[0].motions[0]));
}
