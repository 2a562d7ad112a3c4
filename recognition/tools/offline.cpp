// Offline side of recognition: mocap -> pose streams and labelled strikes, training, the
// cross-actor evaluation, SYNTHETIC visitors. See offline.hpp.
#include "offline.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <map>
#include <numbers>
#include <set>

#include <fmt/format.h>
#include <functional>
#include <memory>

#include "kumite/common/error.hpp"
#include "kumite/content/annotation.hpp"
#include "kumite/content/bvh.hpp"

namespace kumite::recognition::offline {

namespace {
using content::CanonicalJoint;
using Eigen::Vector3d;

Vec3 v3(const Vector3d& v) { return {v.x(), v.y(), v.z()}; }

/// Horizontal forward of a body whose left side points along `left` (Y up).
Vector3d forward_of(const Vector3d& left) {
  Vector3d f(-left.z(), 0, left.x());
  const double n = f.norm();
  return n > 1e-9 ? Vector3d(f / n) : Vector3d(0, 0, -1);
}

std::optional<Role> role_of(content::HitSegment s) {
  switch (s) {
    case content::HitSegment::left_hand: return Role::left_hand;
    case content::HitSegment::right_hand: return Role::right_hand;
    case content::HitSegment::left_foot: return Role::left_foot;
    case content::HitSegment::right_foot: return Role::right_foot;
  }
  return std::nullopt;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double idx = p * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(idx));
  const auto hi = std::min(v.size() - 1, lo + 1);
  return v[lo] + (v[hi] - v[lo]) * (idx - static_cast<double>(lo));
}

nlohmann::json num_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }
}  // namespace

Recording recording_from_clip(const content::Clip& clip) {
  const auto& sk = clip.skeleton;
  const CanonicalJoint need[] = {CanonicalJoint::head,    CanonicalJoint::l_wrist, CanonicalJoint::r_wrist,
                                 CanonicalJoint::l_ankle, CanonicalJoint::r_ankle, CanonicalJoint::l_hip,
                                 CanonicalJoint::r_hip,   CanonicalJoint::l_shoulder, CanonicalJoint::r_shoulder,
                                 CanonicalJoint::pelvis};
  for (auto j : need)
    if (sk.index(j) < 0)
      throw Error("recognition", "canonical", fmt::format("{}: joint {} not mapped", clip.name, content::to_string(j)));
  const auto P = content::all_joint_positions(clip);
  const int J = sk.joint_count();
  auto at = [&](int f, CanonicalJoint j) { return P[static_cast<std::size_t>(f * J + sk.index(j))]; };
  // Face -Z at the first frame, pelvis over the origin.
  const Vector3d fwd0 = forward_of(at(0, CanonicalJoint::l_hip) - at(0, CanonicalJoint::r_hip));
  const double phi = std::atan2(fwd0.x(), fwd0.z());
  const Eigen::Matrix3d R = Eigen::AngleAxisd(std::numbers::pi - phi, Vector3d::UnitY()).toRotationMatrix();
  const Vector3d p0 = at(0, CanonicalJoint::pelvis);
  const Vector3d origin(p0.x(), 0, p0.z());
  auto room = [&](const Vector3d& p) { return Vector3d(R * (p - origin)); };

  Recording r;
  r.name = clip.name;
  r.actor = actor_of_clip(clip.name);
  r.fps = clip.frame_rate_hz();
  r.frames = clip.frame_count;
  r.samples.reserve(static_cast<std::size_t>(clip.frame_count) * kRoleCount);
  r.limb_positions.resize(static_cast<std::size_t>(clip.frame_count));
  const CanonicalJoint limb_joint[kLimbCount] = {CanonicalJoint::l_wrist, CanonicalJoint::r_wrist,
                                                 CanonicalJoint::l_ankle, CanonicalJoint::r_ankle};
  for (int f = 0; f < clip.frame_count; ++f) {
    const double t = f * clip.frame_time_s;
    const Vector3d fwd = forward_of(room(at(f, CanonicalJoint::l_shoulder)) - room(at(f, CanonicalJoint::r_shoulder)));
    const double yaw = std::atan2(fwd.x(), fwd.z()) - std::numbers::pi;  // rotates -Z onto fwd
    PoseSample h;
    h.t = t;
    h.role = Role::head;
    h.position = v3(room(at(f, CanonicalJoint::head)));
    h.orientation = {std::cos(yaw / 2), 0, std::sin(yaw / 2), 0};
    r.samples.push_back(h);
    for (int l = 0; l < kLimbCount; ++l) {
      PoseSample s;
      s.t = t;
      s.role = static_cast<Role>(l + 1);
      s.position = v3(room(at(f, limb_joint[l])));
      r.samples.push_back(s);
      r.limb_positions[static_cast<std::size_t>(f)][static_cast<std::size_t>(l)] = s.position;
    }
  }
  return r;
}

std::string action_of_clip(const std::string& clip_name, bool hand) {
  if (hand) {
    if (clip_name == "135_09" || clip_name == "135_06") return "straight_punch";
    return "";
  }
  if (clip_name == "135_04") return "front_kick";
  if (clip_name == "135_07") return "roundhouse_kick";
  if (clip_name == "135_11") return "side_kick";
  if (clip_name.starts_with("HDM_") && clip_name.find("kickLFront") != std::string::npos) return "front_kick";
  return "";
}

std::string actor_of_clip(const std::string& clip_name) {
  if (clip_name.starts_with("135_")) return "135";
  if (clip_name.starts_with("HDM_") && clip_name.size() > 6) return clip_name.substr(4, 2);
  return clip_name;
}

std::vector<Recording> load_motions(const std::filesystem::path& motions_toml) {
  const content::AnnotationSet set = content::read_annotations(motions_toml);
  std::vector<Recording> out;
  for (std::size_t ci = 0; ci < set.clips.size(); ++ci) {
    const auto& ca = set.clips[ci];
    content::Clip clip = content::read_bvh(set.resolve(ca));
    clip.name = ca.name;
    content::validate_annotations(set, ci, clip);
    Recording r = recording_from_clip(clip);
    r.source = fmt::format("{} ({})", set.resolve(ca).string(), "content/motions: shippable");
    r.trainable = true;
    bool any_motion = false;
    for (const auto& m : ca.motions) {
      if (m.semantics == content::Semantics::other) any_motion = true;
      if (!content::is_strike(m.semantics) || !m.hit_segment || !m.hit_frame) continue;
      any_motion = true;
      Strike s;
      s.name = m.name;
      s.limb = *role_of(*m.hit_segment);
      s.action = action_of_clip(ca.name, content::is_hand(*m.hit_segment));
      s.first = m.first_frame;
      s.hit = *m.hit_frame;
      s.last = m.last_frame;
      r.strikes.push_back(s);
    }
    r.negative = !any_motion;
    out.push_back(std::move(r));
  }
  return out;
}

std::vector<Recording> load_external(const std::filesystem::path& mocap_dir) {
  std::vector<Recording> out;
  auto load = [&](const std::string& rel) -> std::optional<Recording> {
    const auto path = mocap_dir / rel;
    if (!std::filesystem::exists(path)) return std::nullopt;
    content::Clip clip = content::read_bvh(path);
    if (clip.skeleton.index(CanonicalJoint::head) < 0 && clip.skeleton.find("neck") >= 0) {
      // DeepMimic humanoid3d (Sony): no head joint; the neck's end site is the head's top.
      auto& sk = clip.skeleton;
      auto set = [&](CanonicalJoint j, int i) { sk.canonical[static_cast<std::size_t>(j)] = i; };
      const int neck = sk.find("neck");
      for (int i = 0; i < sk.joint_count(); ++i)
        if (sk.parents[static_cast<std::size_t>(i)] == neck && sk.end_site[static_cast<std::size_t>(i)]) set(CanonicalJoint::head, i);
      set(CanonicalJoint::pelvis, sk.find("root"));
      for (auto [j, n] : {std::pair{CanonicalJoint::l_wrist, "left_wrist"}, {CanonicalJoint::r_wrist, "right_wrist"},
                          {CanonicalJoint::l_ankle, "left_ankle"}, {CanonicalJoint::r_ankle, "right_ankle"},
                          {CanonicalJoint::l_hip, "left_hip"}, {CanonicalJoint::r_hip, "right_hip"},
                          {CanonicalJoint::l_shoulder, "left_shoulder"}, {CanonicalJoint::r_shoulder, "right_shoulder"}})
        set(j, sk.find(n));
    }
    if (clip.skeleton.index(CanonicalJoint::head) < 0) return std::nullopt;
    try {
      Recording r = recording_from_clip(clip);
      r.source = path.string() + " (development only: never shipped)";
      return r;
    } catch (const Error&) {
      return std::nullopt;
    }
  };
  // Hit frame inside a listed window: where the wrist is farthest from the head.
  auto hit_in = [](const Recording& r, Role limb, int first, int last) {
    int best = first;
    double bd = -1;
    const int l = static_cast<int>(limb) - 1;
    for (int f = first; f <= last && f < r.frames; ++f) {
      const Vec3& p = r.limb_positions[static_cast<std::size_t>(f)][static_cast<std::size_t>(l)];
      const Vec3& h = r.samples[static_cast<std::size_t>(f * kRoleCount)].position;
      const double d = std::hypot(p[0] - h[0], p[2] - h[2]);
      if (d > bd) {
        bd = d;
        best = f;
      }
    }
    return best;
  };
  if (auto r = load("assimp/Boxing_Toes.bvh")) {
    r->actor = "boxer";
    struct W { Role limb; int first, last; };
    const W w[] = {{Role::left_hand, 555, 617},  {Role::left_hand, 905, 963},   {Role::right_hand, 349, 394},
                   {Role::right_hand, 533, 574}, {Role::right_hand, 627, 683},  {Role::right_hand, 974, 1026},
                   {Role::right_hand, 1207, 1292}, {Role::right_hand, 1392, 1459}};
    int n = 0;
    for (const W& x : w) {
      Strike s;
      s.name = fmt::format("boxer_{}_{}", to_string(x.limb), ++n);
      s.action = "straight_punch";
      s.limb = x.limb;
      s.first = x.first;
      s.last = x.last;
      s.hit = hit_in(*r, x.limb, x.first, x.last);
      r->strikes.push_back(s);
    }
    out.push_back(std::move(*r));
  }
  const std::pair<const char*, int> sony[] = {{"sie_humanoid3d_punch_forward00", 107},
                                              {"sie_humanoid3d_punch_forward01", 146},
                                              {"sie_humanoid3d_punch_forward02", 68},
                                              {"sie_humanoid3d_punch_left00", 92}};
  for (const auto& [name, peak] : sony) {
    auto r = load(std::string("sony-deepmimic/") + name + ".bvh");
    if (!r) continue;
    r->actor = "sony";
    Strike s;
    s.name = name;
    s.action = "straight_punch";
    s.limb = Role::right_hand;
    s.first = std::max(0, peak - 40);
    s.last = std::min(r->frames - 1, peak + 40);
    s.hit = hit_in(*r, Role::right_hand, s.first, s.last);
    r->strikes.push_back(s);
    out.push_back(std::move(*r));
  }
  for (const char* neg : {"cmu/07_05.bvh", "cmu/09_06.bvh"}) {
    auto r = load(neg);
    if (!r) continue;
    r->negative = true;
    out.push_back(std::move(*r));
  }
  return out;
}

std::vector<Frame> frontend_frames(const Recording& r, const FrontendSettings& s) {
  Frontend fe(s);
  std::vector<Frame> frames;
  for (std::size_t i = 0; i < r.samples.size(); ++i) {
    fe.push(r.samples[i], frames);
    if (i + 1 == r.samples.size() || r.samples[i + 1].t != r.samples[i].t) fe.end_of_set(r.samples[i].t, frames);
  }
  return frames;
}

std::vector<Trial> trials_of(const std::vector<const Recording*>& recs, const RecogniserSettings& s,
                             const TrainSettings& ts) {
  std::vector<Trial> out;
  for (const Recording* r : recs) {
    if (r->negative) {
      const auto frames = frontend_frames(*r, s.frontend);
      for (int l = 1; l <= kLimbCount; ++l)
        for (auto& t : none_trials(frames, static_cast<Role>(l), ts.none_frames, s)) {
          t.source = r->name;
          out.push_back(std::move(t));
        }
      continue;
    }
    if (r->strikes.empty()) continue;
    const auto frames = frontend_frames(*r, s.frontend);
    for (const Strike& st : r->strikes) {
      if (st.action.empty()) continue;
      auto t = cut_trial(frames, st.limb, st.first / r->fps, st.hit / r->fps, st.last / r->fps, s);
      if (!t) continue;
      t->action = st.action;
      t->source = st.name;
      t->style = r->actor;
      out.push_back(std::move(*t));
    }
  }
  return out;
}

Model train(const std::vector<const Recording*>& recs, const RecogniserSettings& rs, const TrainSettings& ts,
            const std::string& note) {
  Model m;
  m.settings = rs;
  m.note = note;
  const auto trials = trials_of(recs, rs, ts);
  if (trials.empty()) throw Error("recognition", "train", "no strike trials to train on");
  m.templates = build_templates(trials, rs, ts);
  return m;
}

// ---- Evaluation -----------------------------------------------------------------------------

namespace {

struct StrikeOutcome {
  std::string name, actor, action, limb, predicted = "none";
  bool right_limb = false, right_kind = false;
  double latency_s = std::nan(""), impact_error_m = std::nan("");
  double progress_error = std::nan("");  ///< |begin's progress - the truth at its time| (onset 0, hit 1)
  int other_limb_begins = 0;
  std::array<int, 5> correct_at{};  ///< progress 0, .25, .5, .75, 1
};
constexpr double kProgressPoints[5] = {0, 0.25, 0.5, 0.75, 1.0};

/// The action a limb is doing at time t ("none" when idle), from the event list.
std::string active_at(const std::vector<Event>& ev, Role limb, double t) {
  std::string cur = "none";
  for (const Event& e : ev) {
    if (e.t > t + 1e-9) break;
    if (e.limb != limb) continue;
    if (e.type == EventType::begin || e.type == EventType::switch_) cur = e.action;
    else cur = "none";
  }
  return cur;
}

}  // namespace

int onset_frame(const Recording& r, const Strike& s) {
  const auto l = static_cast<std::size_t>(static_cast<int>(s.limb) - 1);
  // The first frame of the window whose hit-joint speed exceeds 15 % of its peak.
  std::vector<double> speed(static_cast<std::size_t>(r.frames), 0.0);
  double peak = 0;
  for (int f = std::max(1, s.first); f <= s.last && f + 1 < r.frames; ++f) {
    const Vec3& a = r.limb_positions[static_cast<std::size_t>(f - 1)][l];
    const Vec3& b = r.limb_positions[static_cast<std::size_t>(f + 1)][l];
    speed[static_cast<std::size_t>(f)] = std::hypot(b[0] - a[0], b[1] - a[1], b[2] - a[2]) * r.fps / 2;
    peak = std::max(peak, speed[static_cast<std::size_t>(f)]);
  }
  for (int f = s.first; f <= s.hit && f < r.frames; ++f)
    if (speed[static_cast<std::size_t>(f)] > 0.15 * peak) return f;
  return s.first;
}

namespace {
std::vector<StrikeOutcome> score(const Recording& r, const std::vector<Event>& ev, const std::set<std::string>& known) {
  std::vector<StrikeOutcome> out;
  for (const Strike& s : r.strikes) {
    if (s.action.empty() || !known.count(s.action)) continue;
    StrikeOutcome o;
    o.name = s.name;
    o.actor = r.actor;
    o.action = s.action;
    o.limb = std::string(to_string(s.limb));
    const auto l = static_cast<std::size_t>(static_cast<int>(s.limb) - 1);
    const int onset = onset_frame(r, s);
    const double t_first = s.first / r.fps, t_hit = s.hit / r.fps, t_last = s.last / r.fps, t_on = onset / r.fps;
    const Event* begin = nullptr;
    for (const Event& e : ev) {
      if (e.type != EventType::begin || e.t < t_first - 0.05 || e.t > t_last) continue;
      if (e.limb != s.limb) {
        ++o.other_limb_begins;
        continue;
      }
      if (!begin && e.t <= t_hit + 0.1) begin = &e;
    }
    if (begin) {
      o.right_limb = true;
      o.latency_s = begin->t - t_on;
      const Vec3& hp = r.limb_positions[static_cast<std::size_t>(s.hit)][l];
      o.impact_error_m = std::hypot(begin->impact[0] - hp[0], begin->impact[1] - hp[1], begin->impact[2] - hp[2]);
      o.progress_error = std::abs(begin->progress - std::clamp((begin->t - t_on) / std::max(1e-6, t_hit - t_on), 0.0, 1.0));
      o.predicted = active_at(ev, s.limb, std::max(t_hit, begin->t));
      if (o.predicted == "none") o.predicted = begin->action;  // ended before the hit: its last word
      o.right_kind = o.predicted == s.action;
    }
    for (int k = 0; k < 5; ++k)
      o.correct_at[static_cast<std::size_t>(k)] = active_at(ev, s.limb, t_on + kProgressPoints[k] * (t_hit - t_on)) == s.action;
    out.push_back(o);
  }
  return out;
}

nlohmann::json summarise(const std::vector<StrikeOutcome>& v) {
  nlohmann::json j;
  j["strikes"] = v.size();
  if (v.empty()) return j;
  int limb = 0, kind = 0, other = 0;
  std::vector<double> lat, imp, prog;
  std::array<int, 5> at{};
  std::map<std::string, std::map<std::string, int>> confusion;
  for (const auto& o : v) {
    limb += o.right_limb;
    kind += o.right_kind;
    other += o.other_limb_begins;
    if (std::isfinite(o.latency_s)) lat.push_back(o.latency_s * 1000);
    if (std::isfinite(o.impact_error_m)) imp.push_back(o.impact_error_m);
    if (std::isfinite(o.progress_error)) prog.push_back(o.progress_error);
    for (int k = 0; k < 5; ++k) at[static_cast<std::size_t>(k)] += o.correct_at[static_cast<std::size_t>(k)];
    ++confusion[o.action][o.predicted];
  }
  const double n = static_cast<double>(v.size());
  j["right_limb_pct"] = 100.0 * limb / n;
  j["right_kind_pct"] = 100.0 * kind / n;
  j["latency_from_onset_ms"] = {{"p50", num_or_null(percentile(lat, 0.5))}, {"p90", num_or_null(percentile(lat, 0.9))},
                                {"n", lat.size()}};
  j["impact_error_m"] = {{"p50", num_or_null(percentile(imp, 0.5))}, {"p90", num_or_null(percentile(imp, 0.9))}};
  j["progress_error_at_begin"] = {{"p50", num_or_null(percentile(prog, 0.5))}, {"p90", num_or_null(percentile(prog, 0.9))},
                                  {"within_0.2_pct", prog.empty() ? nlohmann::json(nullptr)
                                                                  : nlohmann::json(100.0 * static_cast<double>(std::count_if(
                                                                        prog.begin(), prog.end(), [](double e) { return e <= 0.2; })) /
                                                                    static_cast<double>(prog.size()))}};
  j["other_limb_begins"] = other;
  nlohmann::json acc = nlohmann::json::object();
  for (int k = 0; k < 5; ++k) acc[fmt::format("{:.2f}", kProgressPoints[k])] = 100.0 * at[static_cast<std::size_t>(k)] / n;
  j["correct_pct_at_progress"] = acc;
  j["confusion"] = confusion;
  return j;
}

nlohmann::json outcome_json(const StrikeOutcome& o) {
  return {{"name", o.name}, {"actor", o.actor}, {"action", o.action}, {"limb", o.limb}, {"predicted", o.predicted},
          {"right_limb", o.right_limb}, {"right_kind", o.right_kind}, {"latency_ms", num_or_null(o.latency_s * 1000)},
          {"impact_error_m", num_or_null(o.impact_error_m)}, {"progress_error", num_or_null(o.progress_error)},
          {"other_limb_begins", o.other_limb_begins}};
}

std::set<std::string> actions_of(const Model& m) {
  std::set<std::string> s;
  for (const auto& t : m.templates) s.insert(t.action);
  return s;
}
}  // namespace

namespace {
/// A recogniser under evaluation, for one training set.
struct Runner {
  std::set<std::string> known;  ///< the actions it can recognise (others are not scored)
  std::function<void(const Recording&, std::vector<Event>&, std::vector<double>& loop_us)> run;
};
/// Which training set: "fold" (key = the held-out actor; trained on the other actors), "without"
/// (key = a strike-free recording left out; all others), "all" (every trainable recording).
using RunnerFactory =
    std::function<Runner(const std::string& set, const std::string& key, const std::vector<const Recording*>& train)>;

template <class R>
void run_recogniser(R& rec, const Recording& r, std::vector<Event>& ev, std::vector<double>& loop_us) {
  rec.set_timing(true);
  for (std::size_t i = 0; i < r.samples.size(); ++i) {
    rec.push(r.samples[i], ev);
    if (i + 1 == r.samples.size() || r.samples[i + 1].t != r.samples[i].t) rec.end_of_set(r.samples[i].t, ev);
  }
  rec.finish(r.samples.empty() ? 0 : r.samples.back().t, ev);
  for (double t : rec.loop_times()) loop_us.push_back(t * 1e6);
}

nlohmann::json evaluate_with(const std::vector<Recording>& trainable, const std::vector<Recording>& external,
                             const RunnerFactory& make) {
  nlohmann::json report;
  std::set<std::string> actors;
  for (const auto& r : trainable)
    if (!r.strikes.empty()) actors.insert(r.actor);
  std::vector<StrikeOutcome> all;
  std::vector<double> loop_us;
  nlohmann::json folds = nlohmann::json::array();
  for (const std::string& held : actors) {
    std::vector<const Recording*> tr;
    for (const auto& r : trainable)
      if (r.actor != held && (!r.strikes.empty() || r.negative)) tr.push_back(&r);
    if (tr.empty()) continue;
    const Runner m = make("fold", held, tr);
    const auto& known = m.known;
    std::vector<StrikeOutcome> fold;
    int untestable = 0;
    for (const auto& r : trainable) {
      if (r.actor != held || r.strikes.empty()) continue;
      std::vector<Event> ev;
      m.run(r, ev, loop_us);
      for (const auto& o : score(r, ev, known)) fold.push_back(o);
      for (const auto& s : r.strikes) untestable += !known.count(s.action);
    }
    nlohmann::json f = summarise(fold);
    f["held_out_actor"] = held;
    std::set<std::string> tr_actors;
    for (const auto* r : tr)
      if (!r->strikes.empty()) tr_actors.insert(r->actor);
    f["trained_on_actors"] = tr_actors;
    f["actions"] = known;
    f["untestable_strikes"] = untestable;  // their action has no training data without this actor
    nlohmann::json per = nlohmann::json::array();
    for (const auto& o : fold) per.push_back(outcome_json(o));
    f["per_strike"] = per;
    folds.push_back(f);
    all.insert(all.end(), fold.begin(), fold.end());
  }
  report["leave_one_actor_out"] = folds;

  std::vector<const Recording*> everything;
  for (const auto& r : trainable)
    if (!r.strikes.empty() || r.negative) everything.push_back(&r);
  const Runner full = make("all", "", everything);
  {
    std::vector<StrikeOutcome> ext;
    for (const auto& r : external) {
      if (r.strikes.empty()) continue;
      std::vector<Event> ev;
      full.run(r, ev, loop_us);
      for (const auto& o : score(r, ev, full.known)) ext.push_back(o);
    }
    nlohmann::json e = summarise(ext);
    e["trained_on"] = "all annotated actors of content/motions";
    nlohmann::json per = nlohmann::json::array();
    for (const auto& o : ext) per.push_back(outcome_json(o));
    e["per_strike"] = per;
    report["external_actors"] = e;
    all.insert(all.end(), ext.begin(), ext.end());
  }
  // False triggers: begins per minute on recordings without strikes.
  {
    nlohmann::json per = nlohmann::json::array();
    double minutes = 0;
    int begins = 0;
    for (const auto* list : {&trainable, &external})
      for (const auto& r : *list) {
        if (!r.negative) continue;
        // The model never saw the recording being scored.
        std::vector<const Recording*> without;
        for (const Recording* o : everything)
          if (o != &r) without.push_back(o);
        std::vector<Event> ev;
        if (r.trainable) make("without", r.name, without).run(r, ev, loop_us);
        else full.run(r, ev, loop_us);
        int b = 0;
        std::map<std::string, int> by_limb;
        for (const Event& e : ev)
          if (e.type == EventType::begin) {
            ++b;
            ++by_limb[fmt::format("{} {}", to_string(e.limb), e.action)];
          }
        const double min = r.frames / r.fps / 60;
        minutes += min;
        begins += b;
        per.push_back({{"recording", r.name}, {"actor", r.actor}, {"minutes", min}, {"begins", b},
                       {"begins_by_limb_and_action", by_limb}, {"same_actor_as_training", r.trainable}});
      }
    report["false_triggers"] = {{"per_idle_minute", minutes > 0 ? begins / minutes : 0.0},
                                {"begins", begins}, {"minutes", minutes}, {"recordings", per},
                                {"note", "recordings with no strike: walks, runs, blocks, stance steps and turns, idle; "
                                         "scored by a model that was not trained on that recording"}};
  }
  report["held_out_total"] = summarise(all);
  report["loop_cpu_us"] = {{"p50", num_or_null(percentile(loop_us, 0.5))}, {"p99", num_or_null(percentile(loop_us, 0.99))},
                           {"max", num_or_null(percentile(loop_us, 1.0))}, {"loops", loop_us.size()},
                           {"note", "thread CPU time per 60 Hz loop (all limbs) during this evaluation; see the benchmark"}};
  report["not_in_the_data"] = "hooks and uppercuts (no recordings): not recognised, not measured";
  return report;
}
}  // namespace

nlohmann::json evaluate(const std::vector<Recording>& trainable, const std::vector<Recording>& external,
                        const RecogniserSettings& rs, const TrainSettings& ts) {
  const RunnerFactory dtw = [&](const std::string& set, const std::string& key, const std::vector<const Recording*>& tr) {
    auto m = std::make_shared<Model>(train(tr, rs, ts, set + " " + key));
    Runner r;
    r.known = actions_of(*m);
    r.known.erase(std::string(kNoneAction));
    r.run = [m](const Recording& rec, std::vector<Event>& ev, std::vector<double>& loop_us) {
      Recogniser x(*m);
      run_recogniser(x, rec, ev, loop_us);
    };
    return r;
  };
  nlohmann::json report = evaluate_with(trainable, external, dtw);
  report["what"] =
      "dual-buffer DTW strike recogniser, cross-actor: every figure is on actors the model was not trained on "
      "(leave-one-actor-out over the annotated actors of content/motions; the development-only boxer and Sony "
      "recordings against a model of all annotated actors)";
  std::vector<const Recording*> everything;
  for (const auto& r : trainable)
    if (!r.strikes.empty() || r.negative) everything.push_back(&r);
  const Model full = train(everything, rs, ts, "all annotated actors");
  nlohmann::json tpl = nlohmann::json::array();
  for (const auto& t : full.templates)
    tpl.push_back({{"action", t.action}, {"kind", to_string(t.kind)}, {"trials", t.trials}, {"frames", t.frames.size()},
                   {"hit", t.hit}, {"threshold", t.threshold}});
  report["templates_all_actors"] = tpl;
  report["settings"] = {{"loop_hz", rs.frontend.loop_hz}, {"smoothing_tau_s", rs.frontend.smoothing_tau_s},
                        {"heading_tau_s", rs.frontend.heading_tau_s}, {"velocity_weight", rs.frontend.velocity_weight},
                        {"absolute_weight", rs.absolute_weight}, {"onset_speed", rs.onset_speed},
                        {"null_speed", rs.null_speed}, {"null_frames", rs.null_frames}, {"main_frames", rs.main_frames},
                        {"lead_frames", rs.lead_frames}, {"max_frames", rs.max_frames},
                        {"discard_frames", rs.discard_frames}, {"none_margin", rs.none_margin},
                        {"one_at_a_time", rs.one_at_a_time}, {"threshold_factor", ts.threshold_factor},
                        {"max_none_templates", ts.max_none_templates}};
  return report;
}

nlohmann::json evaluate_learned(const std::vector<Recording>& trainable, const std::vector<Recording>& external,
                                const std::filesystem::path& dir, const LearnedOverrides& ov) {
  const RunnerFactory learned = [&](const std::string& set, const std::string& key,
                                    const std::vector<const Recording*>& tr) {
    const std::string file = set == "fold" ? "fold-" + key + ".klearn" : set == "without" ? "without-" + key + ".klearn"
                                                                                           : "all.klearn";
    const auto path = dir / file;
    if (!std::filesystem::exists(path))
      throw file_error("recognition", "eval", path.string(), 0, "learned",
                       "no learned fold model: run recognition/train/train_touche.py --eval-dir (see recognition/README.md)");
    auto m = std::make_shared<LearnedModel>(read_learned_model(path));
    if (ov.begin_probability) m->settings.begin_probability = *ov.begin_probability;
    if (ov.begin_progress) m->settings.begin_progress = *ov.begin_progress;
    if (ov.end_frames) m->settings.end_frames = *ov.end_frames;
    if (ov.confirm_frames) m->settings.confirm_frames = *ov.confirm_frames;
    if (ov.min_speed) m->settings.min_speed = *ov.min_speed;
    Runner r;
    // The actions it can recognise: those of the strikes it was trained on.
    for (const Recording* x : tr)
      for (const Strike& s : x->strikes)
        if (!s.action.empty()) r.known.insert(s.action);
    r.run = [m](const Recording& rec, std::vector<Event>& ev, std::vector<double>& loop_us) {
      LearnedRecogniser x(*m);
      run_recogniser(x, rec, ev, loop_us);
    };
    return r;
  };
  nlohmann::json report = evaluate_with(trainable, external, learned);
  report["what"] =
      "learned (Touche) strike recogniser, cross-actor: fold models trained by train_touche.py --eval-dir on the "
      "same splits as the DTW side (never on the held-out actor, never on the scored strike-free recording)";
  report["models"] = dir.string();
  const LearnedModel any = read_learned_model(dir / "all.klearn");
  report["settings"] = {{"begin_probability", ov.begin_probability.value_or(any.settings.begin_probability)},
                        {"begin_progress", ov.begin_progress.value_or(any.settings.begin_progress)},
                        {"end_frames", ov.end_frames.value_or(any.settings.end_frames)},
                        {"confirm_frames", ov.confirm_frames.value_or(any.settings.confirm_frames)},
                        {"min_speed", ov.min_speed.value_or(any.settings.min_speed)}};
  return report;
}

// ---- The learned recogniser's training data ------------------------------------------------

std::array<float, 6> learned_input(const LimbFrame& lf) {
  return {lf.pos[0], lf.pos[1], lf.pos[2], lf.vel[0], lf.vel[1], lf.vel[2]};
}

nlohmann::json learned_dataset(const std::vector<Recording>& recs, const FrontendSettings& fs) {
  // Classes per limb kind: "none" first, then the actions the data has (sorted).
  std::map<LimbKind, std::set<std::string>> actions;
  for (const auto& r : recs)
    for (const auto& s : r.strikes)
      if (!s.action.empty()) actions[limb_kind(s.limb)].insert(s.action);
  nlohmann::json classes;
  std::map<LimbKind, std::vector<std::string>> cls;
  for (LimbKind k : {LimbKind::hand, LimbKind::foot}) {
    cls[k] = {std::string(kNoneAction)};
    for (const auto& a : actions[k]) cls[k].push_back(a);
    classes[std::string(to_string(k))] = cls[k];
  }
  nlohmann::json out_recs = nlohmann::json::array();
  for (const auto& r : recs) {
    const auto frames = frontend_frames(r, fs);
    const std::size_t n = frames.size();
    std::array<std::vector<int>, kLimbCount> label;
    std::array<std::vector<double>, kLimbCount> progress;
    for (int l = 0; l < kLimbCount; ++l) {
      label[static_cast<std::size_t>(l)].assign(n, 0);
      progress[static_cast<std::size_t>(l)].assign(n, -1.0);
    }
    for (const Strike& s : r.strikes) {
      const auto l = static_cast<std::size_t>(static_cast<int>(s.limb) - 1);
      const auto& names = cls[limb_kind(s.limb)];
      const auto it = std::find(names.begin(), names.end(), s.action);
      const int c = s.action.empty() || it == names.end() ? -1 : static_cast<int>(it - names.begin());
      const double t_on = onset_frame(r, s) / r.fps, t_hit = s.hit / r.fps;
      for (std::size_t i = 0; i < n; ++i) {
        const double t = frames[i].t;
        if (t < t_on - 1e-9 || t > t_hit + 1e-9) continue;
        label[l][i] = c;
        progress[l][i] = c < 0 ? -1.0 : std::clamp((t - t_on) / std::max(1e-6, t_hit - t_on), 0.0, 1.0);
      }
    }
    nlohmann::json x = nlohmann::json::array(), y = nlohmann::json::array(), p = nlohmann::json::array();
    for (std::size_t i = 0; i < n; ++i) {
      nlohmann::json xi = nlohmann::json::array(), yi = nlohmann::json::array(), pi = nlohmann::json::array();
      for (int l = 0; l < kLimbCount; ++l) {
        const LimbFrame& lf = frames[i].limbs[static_cast<std::size_t>(l)];
        if (lf.valid) xi.push_back(learned_input(lf));
        else xi.push_back(nullptr);
        yi.push_back(label[static_cast<std::size_t>(l)][i]);
        pi.push_back(progress[static_cast<std::size_t>(l)][i]);
      }
      x.push_back(std::move(xi));
      y.push_back(std::move(yi));
      p.push_back(std::move(pi));
    }
    out_recs.push_back({{"name", r.name}, {"actor", r.actor}, {"negative", r.negative}, {"strikes", r.strikes.size()},
                        {"trainable", r.trainable}, {"x", std::move(x)}, {"class", std::move(y)},
                        {"progress", std::move(p)}});
  }
  return {{"what", "the learned recogniser's training set: per recording, per 60 Hz loop and limb (left_hand, "
                   "right_hand, left_foot, right_foot) the input [pos x,y,z, vel x,y,z] (head frame / head "
                   "height, left limbs mirrored; null = not valid), the class index (0 = none, -1 = unknown "
                   "kind: ignored) and progress (0 at the onset, 1 at the hit, -1 for none)"},
          {"loop_hz", fs.loop_hz}, {"velocity_weight", fs.velocity_weight}, {"frontend", {{"smoothing_tau_s", fs.smoothing_tau_s}, {"heading_tau_s", fs.heading_tau_s}, {"height_tau_s", fs.height_tau_s}, {"max_gap_s", fs.max_gap_s}}},
          {"classes", classes}, {"recordings", std::move(out_recs)}};
}

std::vector<PoseSample> resample(const std::vector<PoseSample>& samples, double hz) {
  if (samples.empty() || !(hz > 0)) return samples;
  std::array<std::vector<const PoseSample*>, kRoleCount> by_role;
  for (const PoseSample& s : samples) by_role[static_cast<std::size_t>(s.role)].push_back(&s);
  const double t0 = samples.front().t, t1 = samples.back().t;
  std::vector<PoseSample> out;
  std::array<std::size_t, kRoleCount> at{};
  for (long k = 0;; ++k) {
    const double t = t0 + static_cast<double>(k) / hz;
    if (t > t1 + 1e-9) break;
    for (int r = 0; r < kRoleCount; ++r) {
      const auto& v = by_role[static_cast<std::size_t>(r)];
      if (v.empty() || t < v.front()->t || t > v.back()->t) continue;
      std::size_t& i = at[static_cast<std::size_t>(r)];
      while (i + 1 < v.size() && v[i + 1]->t <= t) ++i;
      const PoseSample& a = *v[i];
      const PoseSample& b = i + 1 < v.size() ? *v[i + 1] : a;
      PoseSample s = a;
      s.t = t;
      s.tracked = a.tracked && b.tracked;
      const double f = b.t > a.t ? (t - a.t) / (b.t - a.t) : 0;
      for (std::size_t c = 0; c < 3; ++c) s.position[c] = a.position[c] + f * (b.position[c] - a.position[c]);
      double dot = 0;
      for (std::size_t c = 0; c < 4; ++c) dot += a.orientation[c] * b.orientation[c];
      const double sign = dot < 0 ? -1 : 1;
      double n = 0;
      for (std::size_t c = 0; c < 4; ++c) {
        s.orientation[c] = a.orientation[c] + f * (sign * b.orientation[c] - a.orientation[c]);
        n += s.orientation[c] * s.orientation[c];
      }
      n = std::sqrt(n);
      if (n > 1e-9)
        for (double& q : s.orientation) q /= n;
      out.push_back(s);
    }
  }
  return out;
}

void place_visitor(std::vector<PoseSample>& samples, std::optional<std::array<double, 2>> place, double stay_s) {
  std::vector<std::pair<double, std::array<double, 2>>> head;  // time, x z
  for (const PoseSample& s : samples)
    if (s.role == Role::head && s.tracked) head.push_back({s.t, {s.position[0], s.position[2]}});
  if (head.empty()) return;
  std::array<double, 2> mean{0, 0};
  for (const auto& h : head) mean[0] += h.second[0] / static_cast<double>(head.size()), mean[1] += h.second[1] / static_cast<double>(head.size());
  // The centred moving average of the head's floor position at each head sample (two pointers).
  std::vector<std::array<double, 2>> drift(head.size(), {0, 0});
  if (stay_s > 0) {
    std::size_t lo = 0, hi = 0;
    std::array<double, 2> sum{0, 0};
    for (std::size_t i = 0; i < head.size(); ++i) {
      while (hi < head.size() && head[hi].first <= head[i].first + stay_s / 2) sum[0] += head[hi].second[0], sum[1] += head[hi].second[1], ++hi;
      while (head[lo].first < head[i].first - stay_s / 2) sum[0] -= head[lo].second[0], sum[1] -= head[lo].second[1], ++lo;
      const double n = static_cast<double>(hi - lo);
      drift[i] = {sum[0] / n - mean[0], sum[1] / n - mean[1]};
    }
  }
  const std::array<double, 2> to = place.value_or(mean);
  std::size_t k = 0;
  for (PoseSample& s : samples) {
    while (k + 1 < head.size() && head[k + 1].first <= s.t) ++k;  // the head sample at or before s
    s.position[0] += to[0] - mean[0] - drift[k][0];
    s.position[2] += to[1] - mean[1] - drift[k][1];
  }
}

// ---- SYNTHETIC visitors ---------------------------------------------------------------------

namespace {
double minjerk(double u) {
  u = std::clamp(u, 0.0, 1.0);
  return u * u * u * (10 - 15 * u + 6 * u * u);
}
}  // namespace

SynthRecording synthesise(const std::vector<SynthSegment>& segments, double rate_hz, double scale) {
  SynthRecording out;
  const double s = scale;
  // Stance (visitor at the origin facing -Z): head, left/right hand guard, left/right foot.
  const Vec3 head0{0, 1.62 * s, 0};
  const Vec3 guard[2] = {{-0.18 * s, 1.30 * s, -0.25 * s}, {0.18 * s, 1.30 * s, -0.25 * s}};
  const Vec3 foot[2] = {{-0.15 * s, 0.08, -0.05 * s}, {0.15 * s, 0.08, 0.05 * s}};
  double t0 = 0, body_z = 0;
  long frame = 0;
  for (const SynthSegment& seg : segments) {
    const long n = std::lround(seg.duration_s * rate_hz);
    const int side = is_left(seg.limb) ? 0 : 1;
    const double sign = side == 0 ? -1 : 1;
    const double out_s = (seg.move == SynthMove::front_kick ? 0.30 : 0.15) / seg.speed;
    const double hold_s = 0.05 / seg.speed;
    const double back_s = (seg.move == SynthMove::front_kick ? 0.35 : 0.30) / seg.speed;
    if (seg.move == SynthMove::straight_punch || seg.move == SynthMove::front_kick) {
      Strike st;
      st.name = seg.move == SynthMove::front_kick ? "synthetic_front_kick" : "synthetic_straight_punch";
      st.action = seg.move == SynthMove::front_kick ? "front_kick" : "straight_punch";
      st.limb = seg.limb;
      st.first = static_cast<int>(frame);
      st.hit = static_cast<int>(frame + std::lround(out_s * rate_hz));
      st.last = static_cast<int>(frame + std::lround((out_s + hold_s + back_s) * rate_hz));
      out.strikes.push_back(st);
    }
    for (long k = 0; k < n; ++k, ++frame) {
      const double u = k / rate_hz;  // time in the segment
      const double t = t0 + u;
      Vec3 head = head0, hand[2] = {guard[0], guard[1]}, ft[2] = {foot[0], foot[1]};
      head[0] += 0.01 * s * std::sin(2 * std::numbers::pi * 0.3 * t);  // idle sway
      double dz = body_z;
      auto strike_amount = [&]() {
        if (u < out_s) return minjerk(u / out_s);
        if (u < out_s + hold_s) return 1.0;
        return 1 - minjerk((u - out_s - hold_s) / back_s);
      };
      if (seg.move == SynthMove::straight_punch) {
        const double a = strike_amount();
        const Vec3 target{sign * 0.05 * s, 1.45 * s, -0.72 * s};
        for (int i = 0; i < 3; ++i) hand[side][i] += a * (target[i] - guard[side][i]);
      } else if (seg.move == SynthMove::front_kick) {
        const double a = strike_amount();
        const Vec3 target{sign * 0.12 * s, 1.0 * s, -0.65 * s};
        for (int i = 0; i < 3; ++i) ft[side][i] += a * (target[i] - foot[side][i]);
        // Knee lifts first: the foot rises before it goes forward.
        ft[side][1] += 0.15 * s * std::sin(std::numbers::pi * a) * (u < out_s ? 1 : 0);
        hand[0][2] += 0.05 * s * a;
        hand[1][2] += 0.05 * s * a;
      } else if (seg.move == SynthMove::walk) {
        const double v = 1.3 * s;  // m/s, one stride (2 steps) a second
        dz = body_z - v * u;
        head[1] += 0.02 * s * std::sin(4 * std::numbers::pi * u);
        for (int h = 0; h < 2; ++h) hand[h][2] += (h == 0 ? 1 : -1) * 0.12 * s * std::sin(2 * std::numbers::pi * u);
        for (int f = 0; f < 2; ++f) {
          // Each foot: planted for half a stride, then swung a stride forward (left half a
          // stride later); both end a whole number of strides on, beside each other.
          const double phase = f == 0 ? 0.5 : 0.0;
          auto travelled = [](double tau) {
            const double c = std::floor(tau), w = tau - c;
            return c + (w < 0.5 ? 0 : minjerk((w - 0.5) / 0.5));
          };
          const double tau = u + phase, w = tau - std::floor(tau);
          ft[f][2] = foot[f][2] + body_z - v * (travelled(tau) - travelled(phase));
          if (w >= 0.5) ft[f][1] = 0.08 + 0.1 * s * std::sin(std::numbers::pi * (w - 0.5) / 0.5);
        }
      }
      if (seg.move != SynthMove::walk) {
        for (int f = 0; f < 2; ++f) ft[f][2] += body_z;
      }
      head[2] += dz;
      hand[0][2] += dz;
      hand[1][2] += dz;
      const Vec3 pos[kRoleCount] = {head, hand[0], hand[1], ft[0], ft[1]};
      for (int r = 0; r < kRoleCount; ++r) {
        PoseSample p;
        p.t = t;
        p.role = static_cast<Role>(r);
        p.position = pos[r];
        out.samples.push_back(p);
      }
    }
    if (seg.move == SynthMove::walk) body_z -= 1.3 * s * std::round(seg.duration_s);
    t0 += n / rate_hz;
  }
  return out;
}

Model synthetic_model(const RecogniserSettings& rs) {
  std::vector<Recording> recs;
  for (double speed : {0.8, 1.0, 1.25})
    for (double scale : {0.92, 1.0, 1.08})
      for (SynthMove mv : {SynthMove::straight_punch, SynthMove::front_kick}) {
        const Role limb = mv == SynthMove::front_kick ? Role::right_foot : Role::right_hand;
        const auto syn = synthesise({{SynthMove::idle, limb, 0.5, 1}, {mv, limb, 1.2, speed}, {SynthMove::idle, limb, 0.5, 1}},
                                    120, scale);
        Recording r;
        r.name = "synthetic";
        r.fps = 120;
        r.frames = static_cast<int>(syn.samples.size() / kRoleCount);
        r.samples = syn.samples;
        r.strikes = syn.strikes;
        recs.push_back(std::move(r));
      }
  std::vector<const Recording*> p;
  for (const auto& r : recs) p.push_back(&r);
  return train(p, rs, {}, "SYNTHETIC: minimum-jerk punches and front kicks (tests only)");
}

}  // namespace kumite::recognition::offline
