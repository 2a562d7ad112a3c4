// Bone maps and the retarget of a character's skeleton onto a model's (retarget.hpp).
#include <algorithm>
#include <cctype>
#include <cmath>
#include <functional>

#include "kumite/body/retarget.hpp"
#include "kumite/common/error.hpp"

namespace kumite::body {
namespace {

using CJ = content::CanonicalJoint;
constexpr std::size_t idx(CJ j) { return static_cast<std::size_t>(j); }

BoneMap make_map(std::string family, std::initializer_list<std::pair<CJ, const char*>> pairs) {
  BoneMap m;
  m.family = std::move(family);
  for (const auto& [j, n] : pairs) m.joints[idx(j)] = n;
  return m;
}

std::string lower(std::string_view s) {
  std::string o(s);
  std::transform(o.begin(), o.end(), o.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return o;
}
std::string_view strip_namespace(std::string_view s) {
  const auto p = s.rfind(':');
  return p == std::string_view::npos ? s : s.substr(p + 1);
}

constexpr CJ kCore[] = {CJ::pelvis, CJ::head, CJ::l_shoulder, CJ::r_shoulder, CJ::l_elbow, CJ::r_elbow,
                        CJ::l_wrist, CJ::r_wrist, CJ::l_hip, CJ::r_hip, CJ::l_knee, CJ::r_knee,
                        CJ::l_ankle, CJ::r_ankle};

/// The canonical joint a bone from `j` points at (its direction), or count.
CJ successor(CJ j) {
  switch (j) {
    case CJ::pelvis: return CJ::spine;
    case CJ::spine: return CJ::chest;
    case CJ::chest: return CJ::neck;
    case CJ::neck: return CJ::head;
    case CJ::l_clavicle: return CJ::l_shoulder;
    case CJ::l_shoulder: return CJ::l_elbow;
    case CJ::l_elbow: return CJ::l_wrist;
    case CJ::r_clavicle: return CJ::r_shoulder;
    case CJ::r_shoulder: return CJ::r_elbow;
    case CJ::r_elbow: return CJ::r_wrist;
    case CJ::l_hip: return CJ::l_knee;
    case CJ::l_knee: return CJ::l_ankle;
    case CJ::l_ankle: return CJ::l_toe;
    case CJ::r_hip: return CJ::r_knee;
    case CJ::r_knee: return CJ::r_ankle;
    case CJ::r_ankle: return CJ::r_toe;
    default: return CJ::count;
  }
}

bool is_finger(std::string_view name) {
  const std::string n = lower(strip_namespace(name));
  for (const char* k : {"thumb", "index", "middle", "ring", "pinky", "little", "finger", "f_"})
    if (n.find(k) != std::string::npos) return true;
  return false;
}
bool is_thumb(std::string_view name) { return lower(name).find("thumb") != std::string::npos; }

Eigen::Quaterniond rotation_of(const Eigen::Matrix4d& m) {
  Eigen::Matrix3d l = m.topLeftCorner<3, 3>();
  for (int c = 0; c < 3; ++c) {
    const double n = l.col(c).norm();
    if (n > 1e-12) l.col(c) /= n;
  }
  // Nearest rotation (a scaled rotation's columns, normalised, are one already).
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(l, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d r = svd.matrixU() * svd.matrixV().transpose();
  if (r.determinant() < 0) {
    Eigen::Matrix3d u = svd.matrixU();
    u.col(2) *= -1;
    r = u * svd.matrixV().transpose();
  }
  return Eigen::Quaterniond(r).normalized();
}

Eigen::Vector3d origin(const Eigen::Matrix4d& m) { return m.topRightCorner<3, 1>(); }

/// Left, up, forward of a body at rest from its canonical joints' positions (a right-handed
/// frame: columns left, up, left x up).
Eigen::Matrix3d body_frame(const std::array<int, content::kCanonicalJointCount>& c,
                           const std::function<Eigen::Vector3d(int)>& pos, const std::string& who) {
  auto p = [&](CJ j) {
    if (c[idx(j)] < 0) throw Error("body", "bone_map", who + ": no " + std::string(content::to_string(j)) + " joint");
    return pos(c[idx(j)]);
  };
  const Eigen::Vector3d left = (p(CJ::l_hip) - p(CJ::r_hip)) + (p(CJ::l_shoulder) - p(CJ::r_shoulder));
  const Eigen::Vector3d up = p(CJ::head) - p(CJ::pelvis);
  Eigen::Vector3d u = up.normalized();
  Eigen::Vector3d f = left.cross(u);
  if (f.norm() < 1e-9 || !f.allFinite()) throw Error("body", "bone_map", who + ": cannot tell the body's front at rest");
  f.normalize();
  Eigen::Matrix3d out;
  out.col(0) = u.cross(f);
  out.col(1) = u;
  out.col(2) = f;
  return out;
}

double leg_length(const std::array<int, content::kCanonicalJointCount>& c, const std::function<Eigen::Vector3d(int)>& pos) {
  double sum = 0;
  for (auto [h, k, a] : {std::array<CJ, 3>{CJ::l_hip, CJ::l_knee, CJ::l_ankle}, std::array<CJ, 3>{CJ::r_hip, CJ::r_knee, CJ::r_ankle}})
    sum += (pos(c[idx(k)]) - pos(c[idx(h)])).norm() + (pos(c[idx(a)]) - pos(c[idx(k)])).norm();
  return sum / 2;
}

Eigen::Matrix4d affine(const Eigen::Matrix3d& l, const Eigen::Vector3d& t) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = l;
  m.topRightCorner<3, 1>() = t;
  return m;
}

}  // namespace

const std::vector<BoneMap>& builtin_bone_maps() {
  static const std::vector<BoneMap> maps = {
      make_map("quaternius", {{CJ::pelvis, "Hips"}, {CJ::spine, "Torso"}, {CJ::chest, "Chest"}, {CJ::neck, "Neck"},
                              {CJ::head, "Head"}, {CJ::l_clavicle, "Shoulder.L"}, {CJ::l_shoulder, "UpperArm.L"},
                              {CJ::l_elbow, "LowerArm.L"}, {CJ::l_wrist, "Hand.L"}, {CJ::r_clavicle, "Shoulder.R"},
                              {CJ::r_shoulder, "UpperArm.R"}, {CJ::r_elbow, "LowerArm.R"}, {CJ::r_wrist, "Hand.R"},
                              {CJ::l_hip, "UpperLeg.L"}, {CJ::l_knee, "LowerLeg.L"}, {CJ::l_ankle, "Foot.L"},
                              {CJ::r_hip, "UpperLeg.R"}, {CJ::r_knee, "LowerLeg.R"}, {CJ::r_ankle, "Foot.R"}}),
      make_map("rigify", {{CJ::pelvis, "spine"}, {CJ::spine, "spine.002"}, {CJ::chest, "spine.003"}, {CJ::neck, "spine.004"},
                          {CJ::head, "spine.005"}, {CJ::l_clavicle, "shoulder.L"}, {CJ::l_shoulder, "upper_arm.L"},
                          {CJ::l_elbow, "forearm.L"}, {CJ::l_wrist, "hand.L"}, {CJ::r_clavicle, "shoulder.R"},
                          {CJ::r_shoulder, "upper_arm.R"}, {CJ::r_elbow, "forearm.R"}, {CJ::r_wrist, "hand.R"},
                          {CJ::l_hip, "thigh.L"}, {CJ::l_knee, "shin.L"}, {CJ::l_ankle, "foot.L"}, {CJ::l_toe, "toe.L"},
                          {CJ::r_hip, "thigh.R"}, {CJ::r_knee, "shin.R"}, {CJ::r_ankle, "foot.R"}, {CJ::r_toe, "toe.R"}}),
      make_map("ue_mannequin", {{CJ::pelvis, "pelvis"}, {CJ::spine, "spine_02"}, {CJ::chest, "spine_03"}, {CJ::neck, "neck_01"},
                                {CJ::head, "head"}, {CJ::l_clavicle, "clavicle_l"}, {CJ::l_shoulder, "upperarm_l"},
                                {CJ::l_elbow, "lowerarm_l"}, {CJ::l_wrist, "hand_l"}, {CJ::r_clavicle, "clavicle_r"},
                                {CJ::r_shoulder, "upperarm_r"}, {CJ::r_elbow, "lowerarm_r"}, {CJ::r_wrist, "hand_r"},
                                {CJ::l_hip, "thigh_l"}, {CJ::l_knee, "calf_l"}, {CJ::l_ankle, "foot_l"}, {CJ::l_toe, "ball_l"},
                                {CJ::r_hip, "thigh_r"}, {CJ::r_knee, "calf_r"}, {CJ::r_ankle, "foot_r"}, {CJ::r_toe, "ball_r"}}),
      make_map("mixamo", {{CJ::pelvis, "Hips"}, {CJ::spine, "Spine1"}, {CJ::chest, "Spine2"}, {CJ::neck, "Neck"},
                          {CJ::head, "Head"}, {CJ::l_clavicle, "LeftShoulder"}, {CJ::l_shoulder, "LeftArm"},
                          {CJ::l_elbow, "LeftForeArm"}, {CJ::l_wrist, "LeftHand"}, {CJ::r_clavicle, "RightShoulder"},
                          {CJ::r_shoulder, "RightArm"}, {CJ::r_elbow, "RightForeArm"}, {CJ::r_wrist, "RightHand"},
                          {CJ::l_hip, "LeftUpLeg"}, {CJ::l_knee, "LeftLeg"}, {CJ::l_ankle, "LeftFoot"}, {CJ::l_toe, "LeftToeBase"},
                          {CJ::r_hip, "RightUpLeg"}, {CJ::r_knee, "RightLeg"}, {CJ::r_ankle, "RightFoot"}, {CJ::r_toe, "RightToeBase"}}),
  };
  return maps;
}

int find_joint(std::span<const std::string> names, std::string_view name) {
  if (name.empty()) return -1;
  const std::string want = lower(name);
  for (std::size_t i = 0; i < names.size(); ++i)
    if (lower(strip_namespace(names[i])) == want) return static_cast<int>(i);
  return -1;
}

const BoneMap* detect_bone_map(std::span<const std::string> names) {
  const BoneMap* best = nullptr;
  int best_count = 0;
  for (const BoneMap& m : builtin_bone_maps()) {
    bool core = true;
    for (CJ j : kCore) core = core && find_joint(names, m.joint(j)) >= 0;
    if (!core) continue;
    int count = 0;
    for (const auto& n : m.joints) count += find_joint(names, n) >= 0;
    if (count > best_count) best = &m, best_count = count;
  }
  return best;
}

TargetRig model_rig(const SkinnedModel& model, const content::Skeleton& source, const BoneMap& map) {
  const ModelSkeleton& s = model.skeleton;
  TargetRig r;
  r.source_name = model.source;
  r.names = s.names;
  r.parents = s.parents;
  r.rest_globals.resize(s.names.size());
  rest_globals(s, r.rest_globals);
  r.top_parent_globals = s.top_parent_globals;
  for (std::size_t j = 0; j < s.names.size(); ++j) r.bind.push_back(r.rest_globals[j] * s.inverse_bind[j]);
  r.source.assign(s.names.size(), -1);
  r.canonical.fill(-1);
  for (std::size_t c = 0; c < content::kCanonicalJointCount; ++c) {
    const int t = find_joint(s.names, map.joints[c]);
    r.canonical[c] = t;
    if (t >= 0 && source.canonical[c] >= 0) r.source[static_cast<std::size_t>(t)] = source.canonical[c];
  }
  if (r.canonical[idx(CJ::pelvis)] < 0 || r.source[static_cast<std::size_t>(r.canonical[idx(CJ::pelvis)])] < 0)
    throw Error("body", "bone_map", model.source + ": the " + map.family + " bone map finds no pelvis to follow the fighter's");
  // The shoes: vertices whose largest weight is on an ankle or a joint under it, at rest.
  for (int side = 0; side < 2; ++side) {
    const int ankle = r.canonical[idx(side == 0 ? CJ::l_ankle : CJ::r_ankle)];
    if (ankle < 0) continue;
    std::vector<bool> under(s.names.size(), false);
    for (std::size_t j = 0; j < s.names.size(); ++j)
      under[j] = static_cast<int>(j) == ankle || (s.parents[j] >= 0 && under[static_cast<std::size_t>(s.parents[j])]);
    for (std::size_t v = 0; v < model.vertex_count(); ++v) {
      const std::size_t j = model.joints[v][0];  // weights sorted largest first
      if (j >= under.size() || !under[j]) continue;
      const Eigen::Vector4d p = r.bind[j] * model.positions[v].cast<double>().homogeneous();
      r.foot_points[static_cast<std::size_t>(side)].push_back(p.head<3>());
    }
  }
  for (const auto& n : s.names) r.finger.push_back(is_finger(n));
  for (std::size_t c = 0; c < content::kCanonicalJointCount; ++c)  // a mapped joint is never curled
    if (r.canonical[c] >= 0) r.finger[static_cast<std::size_t>(r.canonical[c])] = false;
  return r;
}

TargetRig skeleton_rig(const content::Skeleton& t, const content::Skeleton& source) {
  TargetRig r;
  r.source_name = "skeleton";
  r.names = t.names;
  r.parents = t.parents;
  const std::size_t n = t.names.size();
  r.rest_globals.resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    const Eigen::Matrix4d l = affine(Eigen::Matrix3d::Identity(), t.offsets[j]);
    r.rest_globals[j] = t.parents[j] < 0 ? l : r.rest_globals[static_cast<std::size_t>(t.parents[j])] * l;
  }
  r.top_parent_globals.assign(n, Eigen::Matrix4d::Identity());
  r.bind.assign(n, Eigen::Matrix4d::Identity());
  r.finger.assign(n, false);
  r.canonical = t.canonical;
  for (std::size_t j = 0; j < n; ++j) r.source.push_back(source.find(t.names[j]));
  return r;
}

RetargetSetup RetargetSetup::build(const content::Skeleton& source, const Eigen::Vector3d& source_rest_root,
                                   TargetRig target, const RetargetOptions& options) {
  RetargetSetup s;
  s.source = source;
  s.options = options;
  const std::size_t ns = static_cast<std::size_t>(source.joint_count());
  const std::size_t nt = target.names.size();
  const std::string who = target.source_name;
  if (nt == 0 || ns == 0) throw Error("body", "retarget", who + ": empty skeleton");
  // Source rest (the BVH offsets' pose).
  s.source_rest_positions.resize(ns);
  s.source_rest_rotations.resize(ns);
  const std::vector<Eigen::Quaterniond> identity(ns, Eigen::Quaterniond::Identity());
  content::forward_kinematics(source, source_rest_root, identity, s.source_rest_positions, s.source_rest_rotations);
  const int pelvis = target.canonical[idx(CJ::pelvis)];
  if (pelvis < 0 || target.source[static_cast<std::size_t>(pelvis)] < 0)
    throw Error("body", "bone_map", who + ": no pelvis joint follows the fighter's");
  s.pelvis = pelvis;

  // Normalise: face the character's way, leg length, pelvis on the character's.
  auto tpos = [&](int j) { return origin(target.rest_globals[static_cast<std::size_t>(j)]); };
  auto spos = [&](int j) { return s.source_rest_positions[static_cast<std::size_t>(j)]; };
  const Eigen::Matrix3d ft = body_frame(target.canonical, tpos, who);
  const Eigen::Matrix3d fs = body_frame(source.canonical, spos, "the fighter's skeleton");
  const Eigen::Matrix3d turn = fs * ft.transpose();
  const double lt = leg_length(target.canonical, tpos), ls = leg_length(source.canonical, spos);
  if (!(lt > 1e-9) || !(ls > 1e-9)) throw Error("body", "retarget", who + ": no leg length to scale by");
  s.scale = ls / lt;
  const Eigen::Vector3d sp = spos(source.canonical[idx(CJ::pelvis)]);
  s.normalise = affine(s.scale * turn, sp - s.scale * turn * tpos(pelvis));
  const Eigen::Quaterniond turn_q(turn);

  s.rest_positions.resize(nt);
  s.rest_rotations.resize(nt);
  s.top_parent_rotations.resize(nt);
  s.bind.resize(nt);
  for (std::size_t j = 0; j < nt; ++j) {
    const Eigen::Matrix4d g = s.normalise * target.rest_globals[j];
    s.rest_positions[j] = origin(g);
    s.rest_rotations[j] = (turn_q * rotation_of(target.rest_globals[j])).normalized();
    s.top_parent_rotations[j] = (turn_q * rotation_of(target.top_parent_globals[j])).normalized();
    s.bind[j] = (s.normalise * target.bind[j]).cast<float>();
  }
  // Direction children: along canonical successor chains, the nearest mapped joint on the way.
  s.direction_child.assign(nt, -1);
  for (std::size_t c = 0; c < content::kCanonicalJointCount; ++c) {
    const CJ next = successor(static_cast<CJ>(c));
    if (next == CJ::count) continue;
    const int a = target.canonical[c], b = target.canonical[idx(next)];
    if (a < 0 || b < 0 || target.source[static_cast<std::size_t>(a)] < 0 || target.source[static_cast<std::size_t>(b)] < 0) continue;
    int cand = b;
    bool below = false;
    for (int x = b; x != -1; x = target.parents[static_cast<std::size_t>(x)]) {
      if (x == a) { below = true; break; }
      if (target.source[static_cast<std::size_t>(x)] >= 0) cand = x;
    }
    if (below) s.direction_child[static_cast<std::size_t>(a)] = cand;
  }
  // The retarget pose: each mapped bone's swing onto the character's rest direction.
  s.align.assign(nt, Eigen::Quaterniond::Identity());
  s.rest_direction.assign(nt, Eigen::Vector3d::Zero());
  s.rest_length.assign(nt, 0.0);
  s.foot_toe.assign(nt, -1);
  for (std::size_t j = 0; j < nt; ++j) {
    const int src = target.source[j];
    if (src < 0) continue;
    const int k = s.direction_child[j];
    if (k >= 0) {
      const Eigen::Vector3d m = s.rest_positions[static_cast<std::size_t>(k)] - s.rest_positions[j];
      const Eigen::Vector3d c = s.source_rest_positions[static_cast<std::size_t>(target.source[static_cast<std::size_t>(k)])] -
                                s.source_rest_positions[static_cast<std::size_t>(src)];
      if (m.norm() > 1e-9 && c.norm() > 1e-9) {
        s.align[j] = Eigen::Quaterniond::FromTwoVectors(m, c).normalized();
        s.rest_direction[j] = m.normalized();
        s.rest_length[j] = m.norm();
        continue;
      }
    }
    // An ankle without a toe joint keeps the model's rest orientation: both rests stand on
    // the floor, the shoe flat under the character's flat foot (the shin's alignment pitched
    // and rolled it by the legs' difference: a heel or an edge 1 cm through the floor).
    for (int side = 0; side < 2; ++side) {
      const CJ ankle = side == 0 ? CJ::l_ankle : CJ::r_ankle, toe = side == 0 ? CJ::l_toe : CJ::r_toe;
      if (static_cast<int>(j) != target.canonical[idx(ankle)]) continue;
      // It turns with the character's foot: a swing from its rest ankle -> toe (the model's
      // rest the character's) onto the character's now (pitch and heading; roll its own).
      const int st = source.canonical[idx(toe)];
      if (st >= 0) {
        const Eigen::Vector3d d = spos(st) - s.source_rest_positions[static_cast<std::size_t>(src)];
        if (d.norm() > 1e-3) {
          s.foot_toe[j] = st;
          s.rest_direction[j] = d.normalized();
        }
      }
    }
    if (static_cast<int>(j) == target.canonical[idx(CJ::l_ankle)] || static_cast<int>(j) == target.canonical[idx(CJ::r_ankle)])
      continue;
    // No bone of its own (head, hands, a zero-length source bone): keep its parent's alignment.
    for (int p = target.parents[j]; p != -1; p = target.parents[static_cast<std::size_t>(p)])
      if (target.source[static_cast<std::size_t>(p)] >= 0) { s.align[j] = s.align[static_cast<std::size_t>(p)]; break; }
  }
  // The model's torso: its joints placed by their parents, the bones pointing at them unstretched.
  s.rigid.assign(nt, false);
  s.unstretched.assign(nt, false);
  if (options.model_torso)
    for (CJ c : {CJ::spine, CJ::chest, CJ::neck, CJ::head, CJ::l_clavicle, CJ::r_clavicle})
      if (const int j = target.canonical[idx(c)]; j >= 0 && j != pelvis) s.rigid[static_cast<std::size_t>(j)] = true;
  for (std::size_t j = 0; j < nt; ++j)
    s.unstretched[j] = s.direction_child[j] >= 0 && s.rigid[static_cast<std::size_t>(s.direction_child[j])];
  // The clavicles keep their length too, pointing at the character's shoulders: the CMU
  // humerus joints lie wider than the bodies' (stretched onto them, a clavicle pulled the top
  // of the shoulder and the collar out into a wing, the shoulders 1.6-1.7 times the joints'
  // distance wide in front; the upper arm's own skin now bridges the gap).
  if (options.model_torso)
    for (CJ c : {CJ::l_clavicle, CJ::r_clavicle})
      if (const int j = target.canonical[idx(c)]; j >= 0) s.unstretched[static_cast<std::size_t>(j)] = true;
  if (const int th = target.canonical[idx(CJ::head)], sh = source.canonical[idx(CJ::head)]; options.model_torso && th >= 0 && sh >= 0) {
    const double model_torso = (s.rest_positions[static_cast<std::size_t>(th)] - s.rest_positions[static_cast<std::size_t>(pelvis)]).norm();
    const double character_torso = (spos(sh) - sp).norm();
    if (model_torso > 1e-6) s.torso_scale = std::clamp(character_torso / model_torso, 0.7, 1.3);
  }
  // The foot fit: the model's sole under its ankle onto the character's floor.
  s.foot_side.assign(nt, -1);
  for (int side = 0; side < 2; ++side) {
    const std::size_t k = static_cast<std::size_t>(side);
    const int ta = target.canonical[idx(side == 0 ? CJ::l_ankle : CJ::r_ankle)];
    const int sa = source.canonical[idx(side == 0 ? CJ::l_ankle : CJ::r_ankle)];
    const int st = source.canonical[idx(side == 0 ? CJ::l_toe : CJ::r_toe)];
    if (ta < 0 || sa < 0 || st < 0 || target.foot_points[k].empty()) continue;
    double lowest = 1e300;
    for (const Eigen::Vector3d& p : target.foot_points[k]) lowest = std::min(lowest, (s.normalise * p.homogeneous()).y());
    const double ankle_y = s.rest_positions[static_cast<std::size_t>(ta)].y();
    s.sole_depth[k] = ankle_y - lowest;
    s.ankle_height[k] = spos(sa).y() - std::min(spos(sa).y(), spos(st).y());
    const double fit = s.sole_depth[k] > 1e-3 ? s.ankle_height[k] / s.sole_depth[k] : 1.0;
    if (!(fit >= 0.5 && fit <= 1.5)) continue;
    s.foot_fit[k] = fit;
    s.shoe_ankle[k] = ta;
    s.shoe_toe[k] = st;
    for (const Eigen::Vector3d& p : target.foot_points[k]) s.shoe_points[k].push_back((s.normalise * p.homogeneous()).head<3>());
    for (std::size_t j = 0; j < nt; ++j)
      if (static_cast<int>(j) == ta || (target.parents[j] >= 0 && s.foot_side[static_cast<std::size_t>(target.parents[j])] == side))
        s.foot_side[j] = side;
  }
  // The fist: fingers curl about the body's forward axis, toward the palm (down in a T-pose).
  // The thumb (half as far a joint) swings in across the front of the curled fingers, about
  // the body's up axis tipped half toward its forward one: turned about the forward axis as the
  // fingers are, it stood out sideways from the fist (its tip 11-12 cm from the curled fingers'
  // centre on the shipped bodies; 3-6 cm now, test Retarget.TheThumbLiesAcrossTheFist).
  s.curl.assign(nt, Eigen::Quaterniond::Identity());
  const Eigen::Vector3d forward = fs.col(2), left = fs.col(0);
  const Eigen::Vector3d thumb_axis = (fs.col(1) + 0.5 * forward).normalized();
  for (std::size_t j = 0; j < nt; ++j) {
    if (!target.finger[j]) continue;
    const double side = (s.rest_positions[j] - sp).dot(left) >= 0 ? 1.0 : -1.0;
    if (is_thumb(target.names[j]))
      s.curl[j] = Eigen::Quaterniond(Eigen::AngleAxisd(side * 0.5 * options.fist_deg * M_PI / 180, thumb_axis));
    else
      s.curl[j] = Eigen::Quaterniond(Eigen::AngleAxisd(-side * options.fist_deg * M_PI / 180, forward));
  }
  s.target = std::move(target);
  return s;
}

bool RetargetJob::Validate() const {
  if (!setup) return false;
  const std::size_t ns = static_cast<std::size_t>(setup->source.joint_count());
  const std::size_t nt = setup->target.names.size();
  return local_rotations.size() >= ns && source_positions.size() >= ns && source_rotations.size() >= ns &&
         deltas.size() >= nt && rotations.size() >= nt && positions.size() >= nt &&
         (locals.empty() || locals.size() >= nt) && (palette.empty() || palette.size() >= nt) && root_position.allFinite() &&
         (drawn_positions.empty() || drawn_positions.size() >= ns);
}

bool RetargetJob::Run() const {
  if (!Validate()) return false;
  const RetargetSetup& s = *setup;
  const TargetRig& t = s.target;
  const std::size_t ns = static_cast<std::size_t>(s.source.joint_count());
  const std::size_t nt = t.names.size();
  content::forward_kinematics(s.source, root_position, local_rotations.first(ns), source_positions.first(ns),
                              source_rotations.first(ns));
  if (!drawn_positions.empty())
    for (std::size_t j = 0; j < ns; ++j)
      if (drawn_positions[j].allFinite()) source_positions[j] = drawn_positions[j];
  // Mapped joint j: its world rotation delta (rest -> now) and linear part with the stretch.
  auto mapped = [&](std::size_t j, Eigen::Quaterniond& delta, Eigen::Matrix3d& linear) {
    const std::size_t src = static_cast<std::size_t>(t.source[j]);
    const Eigen::Quaterniond q = source_rotations[src] * s.source_rest_rotations[src].conjugate();
    delta = (q * s.align[j]).normalized();
    linear = delta.toRotationMatrix();
    if (s.foot_toe[j] >= 0) {
      // An ankle without a toe joint: the shoe swung from the rest foot onto the character's
      // foot now, without the foot's roll about its own length (a flat foot's shoe stays flat:
      // the mocap's rolled feet sank a shoe's edge 1-3 cm into the floor).
      const Eigen::Vector3d now = source_positions[static_cast<std::size_t>(s.foot_toe[j])] - source_positions[src];
      if (now.norm() < 1e-9) return;
      delta = Eigen::Quaterniond::FromTwoVectors(s.rest_direction[j], now).normalized();
      linear = delta.toRotationMatrix();
      return;
    }
    const int k = s.direction_child[j];
    if (k < 0 || s.rest_length[j] <= 0) return;
    const Eigen::Vector3d now = source_positions[static_cast<std::size_t>(t.source[static_cast<std::size_t>(k)])] - source_positions[src];
    const double len = now.norm();
    if (len < 1e-9) return;
    const Eigen::Vector3d was = delta * s.rest_direction[j];
    delta = (Eigen::Quaterniond::FromTwoVectors(was, now) * delta).normalized();
    linear = delta.toRotationMatrix();
    if (s.options.proportions && !s.unstretched[j]) {
      const Eigen::Vector3d& u = s.rest_direction[j];
      linear = linear * (Eigen::Matrix3d::Identity() + (len / s.rest_length[j] - 1.0) * u * u.transpose());
    }
  };
  // The foot fit: the shoe scaled vertically about its joint in the rest frame.
  auto fit_foot = [&](std::size_t j, Eigen::Matrix3d& linear) {
    const int side = s.foot_side[j];
    if (side < 0) return;
    const double k = s.foot_fit[static_cast<std::size_t>(side)];
    Eigen::Matrix3d f = Eigen::Matrix3d::Identity();
    f(1, 1) = k;
    linear = linear * f;
  };
  Eigen::Quaterniond pelvis_delta;
  Eigen::Matrix3d pelvis_linear;
  mapped(static_cast<std::size_t>(s.pelvis), pelvis_delta, pelvis_linear);
  const Eigen::Vector3d pelvis_at = source_positions[static_cast<std::size_t>(t.source[static_cast<std::size_t>(s.pelvis)])];
  for (std::size_t j = 0; j < nt; ++j) {
    const Eigen::Vector3d& b = s.rest_positions[j];
    Eigen::Quaterniond delta;
    if (t.source[j] >= 0) {
      Eigen::Matrix3d linear;
      mapped(j, delta, linear);
      fit_foot(j, linear);
      Eigen::Vector3d at = source_positions[static_cast<std::size_t>(t.source[j])];
      if ((!s.options.proportions || s.rigid[j]) && t.parents[j] >= 0 && static_cast<int>(j) != s.pelvis) {
        const std::size_t p = static_cast<std::size_t>(t.parents[j]);
        const Eigen::Matrix4d& dp = deltas[p];
        at = dp.topLeftCorner<3, 3>() * b + dp.topRightCorner<3, 1>();
        if (s.rigid[j]) at = positions[p] + s.torso_scale * (at - positions[p]);
      }
      deltas[j] = affine(linear, at - linear * b);
    } else if (t.parents[j] >= 0) {
      const std::size_t p = static_cast<std::size_t>(t.parents[j]);
      delta = rotations[p] * s.rest_rotations[p].conjugate();
      if (t.finger[j]) {
        const Eigen::Matrix3d c = s.curl[j].toRotationMatrix();
        deltas[j] = deltas[p] * affine(c, b - c * b);
        delta = delta * s.curl[j];
      } else {
        deltas[j] = deltas[p];
      }
    } else {  // a top joint above the pelvis: rides with it, unstretched
      delta = pelvis_delta;
      const Eigen::Matrix3d r = pelvis_delta.toRotationMatrix();
      deltas[j] = affine(r, pelvis_at - r * s.rest_positions[static_cast<std::size_t>(s.pelvis)]);
    }
    rotations[j] = (delta * s.rest_rotations[j]).normalized();
    positions[j] = deltas[j].topLeftCorner<3, 3>() * b + deltas[j].topRightCorner<3, 1>();
  }
  // The floor: a shoe under it (its lowest vertex as its ankle's deltas pose it) is lifted
  // onto it, the ankle's subtree with it; where the character's own toe is under the floor,
  // only up to that toe (the shoe stays on the foot it is drawn on).
  for (std::size_t k = 0; k < 2; ++k) {
    const int ankle = s.shoe_ankle[k];
    if (ankle < 0) continue;
    const double floor_y = std::min(0.0, source_positions[static_cast<std::size_t>(s.shoe_toe[k])].y());
    const Eigen::Matrix4d& d = deltas[static_cast<std::size_t>(ankle)];
    double lowest = floor_y;
    for (const Eigen::Vector3d& p : s.shoe_points[k]) lowest = std::min(lowest, d.row(1).head<3>().dot(p) + d(1, 3));
    // At most 2.5 cm: a steeply pitched toeless shoe (the heel raised, the character's toes
    // bent flat on the floor) dips its tip up to 5 cm; lifted that far it would leave the
    // character's toe joint under it (3 px out of the mask, seen from the side).
    constexpr double kMaxLift = 0.025;
    const double lift = std::min(floor_y - lowest, kMaxLift);
    if (!(lift > 0)) continue;
    for (std::size_t j = 0; j < nt; ++j)
      if (s.foot_side[j] == static_cast<int>(k)) {
        deltas[j](1, 3) += lift;
        positions[j].y() += lift;
      }
  }
  if (!locals.empty())
    for (std::size_t j = 0; j < nt; ++j) {
      const Eigen::Quaterniond parent = t.parents[j] < 0 ? s.top_parent_rotations[j] : rotations[static_cast<std::size_t>(t.parents[j])];
      locals[j] = (parent.conjugate() * rotations[j]).normalized();
    }
  if (!palette.empty())
    for (std::size_t j = 0; j < nt; ++j) palette[j] = deltas[j].cast<float>() * s.bind[j];
  return true;
}

}  // namespace kumite::body
