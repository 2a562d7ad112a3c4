// Accuracy and robustness on SYNTHETIC frames (rendered in memory from a known trajectory):
// the figures of issue 4, each on a short run.
#include <gtest/gtest.h>

#include "synthetic_run.hpp"

using namespace kumite;
using namespace kumite::tracking;
using namespace kumite::tracking::ktest;

namespace {

SynthOptions noisy() {
  SynthOptions o;
  o.centroid_sigma_px = 0.3;
  o.image_noise = 2.0;
  return o;
}

// Issue 4: position <= 1 mm RMS, orientation <= 0.3 deg RMS "with 0.3 px-equivalent noise".
// Measured on the unsmoothed pose (the estimate itself; the published pose adds the filter's
// lag on a moving head) against the trajectory the frames were drawn from, 4 s of the
// scripted visitor including a dodge (~1 m/s sideways).
constexpr int kMovingFrames = 240;
TrajectoryPoint moving(double t) { return scripted_visitor(t + 3.0); }

void print(const char* what, const RunStats& s) {
  std::printf("%s: unsmoothed %.3f mm, %.3f deg (Cramer-Rao bound %.3f mm, %.3f deg); filtered %.3f mm, %.3f deg\n",
              what, s.raw_pos_rms_m * 1e3, s.raw_rot_rms_deg, s.bound_pos_rms_m * 1e3, s.bound_rot_rms_deg,
              s.filtered_pos_rms_m * 1e3, s.filtered_rot_rms_deg);
}

}  // namespace

// "0.3 px" read as 0.3 px RMS in 2-D (sigma 0.212 px per axis): both limits, with margin.
TEST(Accuracy, MovingVisitorWithPointThreePixelRmsNoiseMeetsTheLimits) {
  SynthOptions o = noisy();
  o.centroid_sigma_px = 0.3 / std::sqrt(2.0);
  const auto s = run_synthetic(corner_rig(), shipped_config(), o, moving, kMovingFrames);
  print("0.3 px RMS 2-D", s);
  EXPECT_EQ(s.tracked, kMovingFrames);
  EXPECT_LE(s.raw_pos_rms_m, 0.001) << "position RMS (m)";
  EXPECT_LE(s.raw_rot_rms_deg, 0.3) << "orientation RMS (deg)";
  EXPECT_LE(s.raw_rot_rms_deg, 1.1 * s.bound_rot_rms_deg) << "orientation RMS vs its Cramer-Rao bound (deg)";
}

// "0.3 px" read as sigma 0.3 px per axis: the Cramer-Rao bound of this rig and marker layout
// is itself 0.29-0.31 deg, so no single-frame estimator meets 0.3 deg with margin; what the
// test holds the estimator to is the bound (maximum likelihood on every usable marker image:
// measured 1.01x) and the position limit.
TEST(Accuracy, MovingVisitorWithPointThreePixelPerAxisNoiseReachesTheBound) {
  SynthOptions o = noisy();
  o.centroid_sigma_px = 0.3;
  const auto s = run_synthetic(corner_rig(), shipped_config(), o, moving, kMovingFrames);
  print("0.3 px per axis", s);
  EXPECT_EQ(s.tracked, kMovingFrames);
  EXPECT_LE(s.raw_pos_rms_m, 0.001) << "position RMS (m)";
  EXPECT_LE(s.raw_pos_rms_m, 1.1 * s.bound_pos_rms_m) << "position RMS vs its Cramer-Rao bound (m)";
  EXPECT_LE(s.raw_rot_rms_deg, 1.1 * s.bound_rot_rms_deg) << "orientation RMS vs its Cramer-Rao bound (deg)";
  // The published pose (One Euro, shipped settings) averages over frame sets: it meets both
  // limits with margin under this reading too, lag on the moving head included.
  EXPECT_LE(s.filtered_pos_rms_m, 0.001) << "filtered position RMS (m)";
  EXPECT_LE(s.filtered_rot_rms_deg, 0.26) << "filtered orientation RMS (deg)";
}

TEST(Accuracy, NoiselessFramesAreNearlyExact) {
  // What the blob detector, triangulation and fit add by themselves (image noise 2 grey
  // levels, no centre jitter): a small fraction of the limits.
  SynthOptions o = noisy();
  o.centroid_sigma_px = 0;
  const auto s = run_synthetic(corner_rig(), shipped_config(), o, moving, 60);
  print("no centre jitter", s);
  EXPECT_LE(s.raw_pos_rms_m, 0.0001);
  EXPECT_LE(s.raw_rot_rms_deg, 0.05);
}

TEST(Accuracy, CramerRaoBoundScalesWithTheNoise) {
  // The bound the accuracy tests compare with: linear in sigma, and for the shipped rig and
  // glasses near 0.29 deg / 0.32 mm at 0.3 px per axis (an independent Eigen computation gave
  // 0.291 deg, 0.327 mm for the static pose).
  const auto rig = corner_rig();
  const RigidBodyModel body(shipped_config().bodies[0]);
  std::vector<CameraModel> cams(rig.cameras.begin(), rig.cameras.end());
  const auto t = static_visitor(0);
  RigidPose pose;
  pose.rotation = t.orientation;
  pose.translation = t.position - t.orientation * body.centroid();
  const auto a = pose_error_bound(body, pose, cams, 0.3);
  const auto b = pose_error_bound(body, pose, cams, 0.15);
  EXPECT_EQ(a.observations, 20);
  EXPECT_NEAR(a.orientation_rad * 180 / M_PI, 0.29, 0.02);
  EXPECT_NEAR(a.position_m, 0.00033, 0.00003);
  EXPECT_NEAR(b.orientation_rad, 0.5 * a.orientation_rad, 1e-9);
  const std::vector<int> hidden{0, 3};
  EXPECT_GT(pose_error_bound(body, pose, cams, 0.3, hidden).orientation_rad, a.orientation_rad);
}

TEST(Accuracy, StaticJitterAfterFilteringUnderPointThreeMillimetre) {
  const auto rig = corner_rig();
  const auto config = shipped_config();
  const int n = 150, warm = 30;
  const auto s = run_synthetic(rig, config, noisy(), static_visitor, n);
  ASSERT_EQ(s.tracked, n);
  Eigen::Vector3d mean_f = Eigen::Vector3d::Zero(), mean_r = Eigen::Vector3d::Zero();
  for (int i = warm; i < n; ++i) {
    mean_f += Eigen::Vector3d(s.filtered[i].position.data());
    mean_r += Eigen::Vector3d(s.raw[i].position.data());
  }
  mean_f /= n - warm;
  mean_r /= n - warm;
  double jf = 0, jr = 0;
  for (int i = warm; i < n; ++i) {
    jf += (Eigen::Vector3d(s.filtered[i].position.data()) - mean_f).squaredNorm();
    jr += (Eigen::Vector3d(s.raw[i].position.data()) - mean_r).squaredNorm();
  }
  jf = std::sqrt(jf / (n - warm));
  jr = std::sqrt(jr / (n - warm));
  std::printf("static jitter: raw %.3f mm, filtered %.3f mm (RMS distance from the mean)\n", jr * 1e3, jf * 1e3);
  EXPECT_LE(jf, 0.0003);
  EXPECT_LT(jf, jr);  // the filter does smooth
}

TEST(Accuracy, OneOrTwoHiddenMarkersStayWithinTwoMillimetres) {
  const auto rig = corner_rig();
  const auto config = shipped_config();
  for (const std::vector<int>& hidden : {std::vector<int>{3}, std::vector<int>{0, 2}}) {
    SynthOptions o = noisy();
    o.hidden_markers = hidden;
    const auto s = run_synthetic(rig, config, o, [](double t) { return scripted_visitor(t + 1.0); }, 60);
    EXPECT_EQ(s.tracked, 60) << hidden.size() << " hidden";
    EXPECT_LE(s.raw_pos_rms_m, 0.002) << hidden.size() << " hidden";
    std::printf("%zu hidden: position RMS %.3f mm, orientation RMS %.3f deg\n", hidden.size(),
                s.raw_pos_rms_m * 1e3, s.raw_rot_rms_deg);
  }
}

TEST(Accuracy, OneCameraDiesAndTrackingContinuesAtOnce) {
  const auto rig = corner_rig();
  const auto config = shipped_config();
  SynthOptions o = noisy();
  o.dead_camera = 2;
  o.dead_after_s = 0.25;  // from frame 15 on
  const auto s = run_synthetic(rig, config, o, [](double t) { return scripted_visitor(t + 2.0); }, 60);
  for (int i = 0; i < s.frames; ++i) {
    EXPECT_EQ(s.raw[i].status, TrackingStatus::tracked) << "frame " << i;
    if (i >= 15) {
      EXPECT_LE(s.raw[i].cameras, 3);
    }
  }
  EXPECT_LE(s.raw_pos_rms_m, 0.002);
}

TEST(Accuracy, TwentySpuriousBlobsPerCameraCauseNoIdentitySwap) {
  const auto rig = corner_rig();
  const auto config = shipped_config();
  SynthOptions o = noisy();
  o.spurious_blobs = 20;
  o.seed = 11;
  const auto s = run_synthetic(rig, config, o, [](double t) { return scripted_visitor(t + 5.0); }, 60);
  EXPECT_EQ(s.tracked, 60);
  // A swap of two marker identities turns the orientation by tens of degrees.
  EXPECT_LT(s.max_rot_err_deg, 2.0);
  EXPECT_LT(s.max_pos_err_m, 0.005);
  std::printf("20 spurious blobs: worst orientation error %.3f deg, worst position error %.3f mm\n",
              s.max_rot_err_deg, s.max_pos_err_m * 1e3);
}

TEST(Accuracy, StaticLampsAreMaskedAndDoNotDisturb) {
  const auto rig = corner_rig();
  auto config = shipped_config();
  config.mask.learn_s = 0.5;
  SynthOptions o = noisy();
  o.static_lamps = 3;
  SyntheticRenderer renderer(rig, config.bodies[0], o);
  Pipeline pipeline(rig, config);
  int masked_last = 0;
  for (int i = 0; i < 60; ++i) {
    const auto& r = pipeline.process(renderer.render(i, static_visitor(i / 60.0)));
    EXPECT_EQ(r.raw[0].status, TrackingStatus::tracked);
    masked_last = 0;
    for (int m : r.masked) masked_last += m;
  }
  EXPECT_EQ(masked_last, 3 * 4) << "every lamp masked in every camera after learn_s";
}

TEST(Accuracy, LostAfterCoastingLimitThenReacquired) {
  const auto rig = corner_rig();
  const auto config = shipped_config();
  SyntheticRenderer visible(rig, config.bodies[0], noisy());
  SynthOptions gone = noisy();
  gone.hidden_markers = {0, 1, 2, 3, 4};
  SyntheticRenderer hidden(rig, config.bodies[0], gone);
  Pipeline pipeline(rig, config);
  std::vector<TrackingStatus> st;
  for (int i = 0; i < 40; ++i) {
    auto& r = (i >= 10 && i < 25 ? hidden : visible);
    st.push_back(pipeline.process(r.render(i, static_visitor(i / 60.0))).filtered[0].status);
  }
  EXPECT_EQ(st[9], TrackingStatus::tracked);
  EXPECT_EQ(st[10], TrackingStatus::coasting);
  EXPECT_EQ(st[14], TrackingStatus::coasting);  // 83 ms after the last measurement
  EXPECT_EQ(st[17], TrackingStatus::lost);      // 133 ms: past coasting_s = 100 ms
  EXPECT_EQ(st[24], TrackingStatus::lost);
  EXPECT_EQ(st[25], TrackingStatus::tracked);
}

TEST(Accuracy, SecondBodyIsIndependentAndNeverStealsTheHeadsMarkers) {
  const auto rig = corner_rig();
  auto config = shipped_config();
  // A hand prop that is not in the room, and whose distances partly resemble the head's.
  BodyConfig prop;
  prop.name = "prop";
  prop.markers = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(config.bodies[0].markers[0] - config.bodies[0].markers[1]),
                  Eigen::Vector3d(0.0, 0.0, 0.09)};
  config.bodies.push_back(prop);
  SyntheticRenderer renderer(rig, config.bodies[0], noisy());
  Pipeline pipeline(rig, config);
  for (int i = 0; i < 30; ++i) {
    const auto truth = scripted_visitor(i / 60.0);
    const auto& r = pipeline.process(renderer.render(i, truth));
    ASSERT_EQ(r.raw.size(), 2U);
    EXPECT_EQ(r.raw[0].status, TrackingStatus::tracked);
    EXPECT_EQ(r.raw[0].markers, 5);
    EXPECT_EQ(r.raw[1].status, TrackingStatus::lost);
    EXPECT_EQ(r.raw[1].body, 1);
  }
}

TEST(Accuracy, TwoMarkersLeftGivePositionWithTheLastOrientation) {
  const auto rig = corner_rig();
  const auto config = shipped_config();
  SyntheticRenderer all(rig, config.bodies[0], noisy());
  SynthOptions two = noisy();
  two.hidden_markers = {0, 2, 4};
  SyntheticRenderer few(rig, config.bodies[0], two);
  Pipeline pipeline(rig, config);
  for (int i = 0; i < 40; ++i) {
    // Walking slowly sideways; from frame 20 on only markers 1 and 3 are visible.
    auto truth = static_visitor(i / 60.0);
    truth.position.x() += 0.3 * i / 60.0;
    const auto& r = pipeline.process((i < 20 ? all : few).render(i, truth));
    ASSERT_EQ(r.raw[0].status, TrackingStatus::tracked) << i;
    EXPECT_EQ(r.raw[0].markers, i < 20 ? 5 : 2);
    const Eigen::Vector3d p(r.raw[0].position.data());
    EXPECT_LT((p - truth.position).norm(), 0.002) << i;  // centroid of ALL 5 model markers
  }
}
