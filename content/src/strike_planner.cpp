// StrikePlanner: a strike request (pose, target) to a plan (segment, start and contact
// frame): retarget onto the actor, features, retrieve(). Runs on the retrieval worker.
#include <array>
#include <chrono>

#include "behaviour_internal.hpp"
#include "kumite/content/behaviour.hpp"

namespace kumite::content {

namespace {
Rig actor_rig(const Database& db) { return make_rig(db.actor_skeleton, {}, db.actor_name); }
}  // namespace

StrikePlanner::StrikePlanner(std::shared_ptr<const Database> db, RetrievalTunables tunables)
    : db_(std::move(db)), actor_(actor_rig(*db_)), tunables_(tunables) {}

namespace {
/// The query's pose features of the fighter's pose `now` (and `before`, dt_s earlier) on the
/// database's actor; returns k = actor leg / character leg, which scales the query's points.
double actor_pose_features(const Database& db, const Rig& actor, const MkmFrame& now_in, const MkmFrame& before_in,
                           double dt_s, double character_leg_length_m, std::array<float, kFeatureDim>& features) {
  const double k = db.actor.leg_length_m / character_leg_length_m;
  // Retarget onto the actor: MKM is normalised already except the root's horizontal
  // displacement, which scales with leg length (about the current root).
  MkmFrame now = now_in, before = before_in;
  before.root_xz_m = now.root_xz_m + (before.root_xz_m - now.root_xz_m) * k;
  CanonicalPose pn, pb;
  decode_canonical(actor, now, pn);
  decode_canonical(actor, before, pb);
  pose_features(pn, pb, dt_s, ground_frame_of(pn), db.actor.leg_length_m, db.velocity_weight_s, features);
  return k;
}
}  // namespace

RetrievalQuery StrikePlanner::make_query(const StrikeRequest& r) const {
  RetrievalQuery q;
  q.group = r.group;
  const double k = actor_pose_features(*db_, actor_, r.now, r.before, r.dt_s, r.character_leg_length_m, q.features);
  q.target_m = (r.target_local_m * k).cast<float>();
  return q;
}

BlockChoice StrikePlanner::plan_block(const BlockRequest& r) const {
  BlockQuery q;
  const double k = actor_pose_features(*db_, actor_, r.now, r.before, r.dt_s, r.character_leg_length_m, q.features);
  q.fist.point_m = (r.fist_local_m * k).cast<float>();
  q.fist.velocity_mps = (r.fist_velocity_local_mps * k).cast<float>();
  return retrieve_block(*db_, q, tunables_);
}

StrikePlan StrikePlanner::plan(const StrikeRequest& r) const {
  const auto t0 = std::chrono::steady_clock::now();
  const RetrievalQuery q = make_query(r);
  StrikePlan p;
  p.id = r.id;
  p.choice = retrieve(db_->index, q, tunables_);
  if (p.choice.row >= 0) {
    const auto row = static_cast<std::size_t>(p.choice.row);
    p.segment = db_->index.segment[row];
    p.start_frame = db_->index.start_frame[row];
    p.contact_frame = db_->index.window_first[row] + p.choice.window_sample * db_->index.window_stride[row];
  }
  p.retrieval_us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
  return p;
}

}  // namespace kumite::content
