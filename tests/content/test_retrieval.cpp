// Retrieval equals the brute-force search with the same cost, on the SYNTHETIC database and
// on a replicated, perturbed one; the box filter falls back to the nearest box.
#include <gtest/gtest.h>

#include <random>

#include "fighter_fixtures.hpp"
#include "kumite/content/behaviour.hpp"
#include "kumite/content/retrieval.hpp"

using namespace kumite::content;

namespace {

RetrievalQuery random_query(const RetrievalIndex& ix, std::mt19937& rng, double target_spread_m,
                            double feature_noise = 0.3) {
  std::uniform_int_distribution<int> row(0, ix.size - 1);
  std::normal_distribution<double> n01(0, 1);
  RetrievalQuery q;
  const int r = row(rng);
  q.group = ix.group[static_cast<std::size_t>(r)];
  for (int a = 0; a < kFeatureDim; ++a)
    q.features[static_cast<std::size_t>(a)] = ix.features[static_cast<std::size_t>(r) * kFeatureDim + static_cast<std::size_t>(a)] +
                                                static_cast<float>(feature_noise * n01(rng));
  const float* w = ix.window.data() + static_cast<std::size_t>(r) * kWindowMax * 3;
  q.target_m = Eigen::Vector3f(w[0], w[1], w[2]) + (Eigen::Vector3d(n01(rng), n01(rng), n01(rng)) * target_spread_m).cast<float>();
  return q;
}

void expect_same(const RetrievalChoice& a, const RetrievalChoice& b) {
  ASSERT_EQ(a.row, b.row);
  EXPECT_EQ(a.cost, b.cost);
  EXPECT_EQ(a.window_sample, b.window_sample);
  EXPECT_EQ(a.target_in_box, b.target_in_box);
}

}  // namespace

TEST(Retrieval, EqualsBruteForceOnTheSyntheticDatabase) {
  const auto& ix = kumite::content::testing::synthetic_database().db->index;
  ASSERT_GT(ix.size, 20);
  std::mt19937 rng(3);
  int outside = 0;
  for (double spread : {0.02, 0.2, 1.0}) {
    for (RetrievalTunables tu : {RetrievalTunables{}, RetrievalTunables{0.2, 20.0, 0.0}, RetrievalTunables{5.0, 1.0, 0.3}}) {
      for (int i = 0; i < 300; ++i) {
        const RetrievalQuery q = random_query(ix, rng, spread);
        const RetrievalChoice fast = retrieve(ix, q, tu);
        expect_same(fast, retrieve_brute_force(ix, q, tu));
        if (!fast.target_in_box) ++outside;
      }
    }
  }
  EXPECT_GT(outside, 50);  // the fallback path was exercised too
}

TEST(Retrieval, EqualsBruteForceOnAReplicatedPerturbedDatabaseAndPrunes) {
  const auto& base = kumite::content::testing::synthetic_database().db->index;
  const RetrievalIndex ix = replicated_index(base, 100, 0.05, 0.03, 11);
  ASSERT_EQ(ix.size, base.size * 100);
  std::mt19937 rng(5);
  long visited = 0;
  for (int i = 0; i < 150; ++i) {
    const RetrievalQuery q = random_query(ix, rng, 0.1, 0.05);
    RetrievalStats st;
    const RetrievalChoice fast = retrieve(ix, q, {}, &st);
    expect_same(fast, retrieve_brute_force(ix, q, {}));
    visited += st.rows_costed;
  }
  EXPECT_LT(visited / 150, ix.size / 10);  // the index prunes most rows
}

TEST(Retrieval, TheStartPoseOfAClipRetrievesThatClipsStart) {
  const auto& set = kumite::content::testing::synthetic_database();
  const Database& db = *set.db;
  const StrikePlanner planner(set.db);
  // Query with the MKM frames of a stored candidate's start, target on its own hit window.
  int exact = 0, total = 0;
  for (int r = 0; r < db.index.size; r += 3) {
    const auto ur = static_cast<std::size_t>(r);
    const MotionSegment& seg = db.segments[static_cast<std::size_t>(db.index.segment[ur])];
    const int f = db.index.start_frame[ur];
    if (f == 0) continue;
    StrikeRequest req;
    req.group = db.index.group[ur];
    req.now = seg.frames[static_cast<std::size_t>(f)];
    req.before = seg.frames[static_cast<std::size_t>(f - 1)];
    req.dt_s = seg.frame_time_s;
    const GroundFrame g = ground_frame_of(req.now);
    const int hit = db.index.window_first[ur] + db.index.window_stride[ur] * (db.index.window_count[ur] / 2);
    req.target_local_m = g.to_local(seg.hit_path_m[static_cast<std::size_t>(hit)].cast<double>());
    req.character_leg_length_m = db.actor.leg_length_m;
    const StrikePlan p = planner.plan(req);
    ++total;
    EXPECT_LT(p.choice.pose_distance, 0.02);  // the actor's own pose retargets onto itself
    if (p.segment == db.index.segment[ur] && p.start_frame == f) ++exact;
  }
  EXPECT_GT(total, 5);
  EXPECT_GE(exact, total * 8 / 10);
}
