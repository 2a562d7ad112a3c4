#include "kumite/content/block_retrieval.hpp"

#include <cmath>
#include <cstdlib>

namespace kumite::content {

FistPath fist_path_to_impact(const Eigen::Vector3f& fist_m, const Eigen::Vector3f& impact_m, double arrival_s) {
  FistPath p;
  p.point_m = fist_m;
  p.velocity_mps = arrival_s > 0 ? Eigen::Vector3f((impact_m - fist_m) / static_cast<float>(arrival_s))
                                 : Eigen::Vector3f::Zero();
  return p;
}

BlockIntercept block_intercept(const FistPath& fist, double reach_m, double stature_m, const StrikeHeightThresholds& th) {
  const Eigen::Vector3d p = fist.point_m.cast<double>(), v = fist.velocity_mps.cast<double>();
  // |(p + v t).xz|^2 = reach^2: a t^2 + b t + c = 0.
  const double a = v.x() * v.x() + v.z() * v.z();
  const double b = 2 * (p.x() * v.x() + p.z() * v.z());
  const double c = p.x() * p.x() + p.z() * p.z() - reach_m * reach_m;
  BlockIntercept out;
  double t = 0;
  if (c <= 0) {
    out.crosses = true;  // already inside the guard: meet it where it is
  } else if (a > 0) {
    const double disc = b * b - 4 * a * c;
    const double t1 = disc >= 0 ? (-b - std::sqrt(disc)) / (2 * a) : -1;
    if (t1 >= 0) {
      t = t1;
      out.crosses = true;
    } else {
      t = std::max(0.0, -b / (2 * a));  // passes outside (or away): the nearest point ahead
    }
  }
  out.time_s = t;
  out.point_m = (p + v * t).cast<float>();
  out.height = classify_strike_height(out.point_m.y(), stature_m, th);
  return out;
}

namespace {

template <typename Search>
BlockChoice choose(const Database& db, const BlockQuery& q, Search search) {
  BlockChoice out;
  const RetrievalIndex& ix = db.block_index;
  if (!q.fist.point_m.allFinite() || !q.fist.velocity_mps.allFinite() || ix.size == 0 || !(db.actor_stature_m > 0))
    return out;
  for (float f : q.features)
    if (!std::isfinite(f)) return out;
  out.intercept = block_intercept(q.fist, db.block_reach_m, db.actor_stature_m);
  // The target's height first; when no block guards it, the nearest height that has one.
  const int h0 = static_cast<int>(out.intercept.height);
  for (int dh : {0, -1, 1, -2, 2}) {
    const int h = h0 + dh;
    if (h < 0 || h > 2) continue;
    RetrievalQuery rq;
    rq.features = q.features;
    rq.target_m = out.intercept.point_m;
    for (Forearm f : {Forearm::left, Forearm::right}) {
      rq.group = block_group(f, static_cast<StrikeHeight>(h));
      const RetrievalChoice c = search(ix, rq);
      const RetrievalChoice& best = out.choice;
      if (c.row >= 0 && (best.row < 0 || c.cost < best.cost || (c.cost == best.cost && c.row < best.row)))
        out.choice = c;
    }
    if (out.choice.row >= 0) break;
  }
  if (out.choice.row < 0) return out;
  const auto r = static_cast<std::size_t>(out.choice.row);
  out.segment = ix.segment[r];
  const MotionSegment& seg = db.segments[static_cast<std::size_t>(out.segment)];
  out.start_frame = ix.start_frame[r];
  out.intercept_frame = ix.window_first[r] + ix.window_stride[r] * out.choice.window_sample;
  out.intercept_window = {seg.intercept_first, seg.intercept_last};
  out.forearm = ix.group[r] % 2 == 0 ? Forearm::left : Forearm::right;
  out.height = static_cast<StrikeHeight>(ix.group[r] / 2);
  out.lead_s = (out.intercept_frame - out.start_frame) * seg.frame_time_s;
  return out;
}

}  // namespace

BlockChoice retrieve_block(const Database& db, const BlockQuery& q, const RetrievalTunables& tu, RetrievalStats* stats) {
  RetrievalStats total;
  BlockChoice c = choose(db, q, [&](const RetrievalIndex& ix, const RetrievalQuery& rq) {
    RetrievalStats st;
    const RetrievalChoice r = retrieve(ix, rq, tu, &st);
    total.clusters_visited += st.clusters_visited;
    total.rows_visited += st.rows_visited;
    total.rows_costed += st.rows_costed;
    total.blocks_considered += st.blocks_considered;
    total.blocks_visited += st.blocks_visited;
    return r;
  });
  if (stats) *stats = total;
  return c;
}

BlockChoice retrieve_block_brute_force(const Database& db, const BlockQuery& q, const RetrievalTunables& tu) {
  return choose(db, q, [&](const RetrievalIndex& ix, const RetrievalQuery& rq) { return retrieve_brute_force(ix, rq, tu); });
}

}  // namespace kumite::content
