#include "kumite/content/canonical.hpp"

#include <algorithm>
#include <cctype>

#include <fmt/format.h>

#include "kumite/common/error.hpp"
#include "text.hpp"

namespace kumite::content {

namespace {

using CJ = CanonicalJoint;

Dialect make_dialect(std::string name, std::string description,
                     std::initializer_list<std::pair<CJ, const char*>> joints) {
  Dialect d;
  d.name = std::move(name);
  d.description = std::move(description);
  d.source = "built-in";
  for (const auto& [j, n] : joints) d.joints[static_cast<std::size_t>(j)] = n;
  return d;
}

using detail::lower;

/// The name without a namespace prefix ("mixamorig:LeftArm" -> "LeftArm").
std::string_view base_name(std::string_view name) {
  const auto colon = name.rfind(':');
  return colon == std::string_view::npos ? name : name.substr(colon + 1);
}

bool contains(std::string_view hay, std::string_view needle) { return hay.find(needle) != std::string_view::npos; }

bool ends_with(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

// Body words a CMU-style one-letter side prefix may precede ("lhumerus", "rfoot").
constexpr std::string_view kBodyWords[] = {
    "humerus", "radius", "wrist", "hand", "femur", "tibia", "foot", "toe", "clavicle", "hipjoint", "finger",
    "thumb", "shoulder", "elbow", "knee", "ankle", "hip", "leg", "arm", "forearm", "upleg", "collar", "uparm",
    "lowarm", "thigh", "shin", "calf", "heel", "ball"};

/// 'L', 'R' or 0 (centre) from the joint's name.
char side_of(std::string_view full) {
  const std::string_view raw = base_name(full);
  const std::string l = lower(raw);
  if (contains(l, "left")) return 'L';
  if (contains(l, "right")) return 'R';
  for (std::string_view suf : {"_l", ".l", "-l", " l"}) if (ends_with(l, suf)) return 'L';
  for (std::string_view suf : {"_r", ".r", "-r", " r"}) if (ends_with(l, suf)) return 'R';
  if (l.size() > 2 && (l.rfind("l_", 0) == 0 || l.rfind("l.", 0) == 0)) return 'L';
  if (l.size() > 2 && (l.rfind("r_", 0) == 0 || l.rfind("r.", 0) == 0)) return 'R';
  if (l.size() > 1 && (l[0] == 'l' || l[0] == 'r')) {
    const bool upper_next = std::isupper(static_cast<unsigned char>(raw[1])) != 0 && std::isupper(static_cast<unsigned char>(raw[0])) != 0;
    bool body_next = false;
    for (auto w : kBodyWords) body_next = body_next || l.compare(1, w.size(), w) == 0;
    if (upper_next || body_next) return l[0] == 'l' ? 'L' : 'R';
  }
  return 0;
}

bool is_finger(const std::string& l) {
  for (std::string_view w : {"finger", "thumb", "index", "middle", "ring", "pinky", "little", "carpal"}) {
    if (contains(l, w)) return true;
  }
  return false;
}
bool is_twist(const std::string& l) { return contains(l, "roll") || contains(l, "twist"); }

struct Structural {
  std::array<int, kCanonicalJointCount> j{};
  Structural() { j.fill(-1); }
  int& operator[](CJ c) { return j[static_cast<std::size_t>(c)]; }
};

int depth_of(const Skeleton& s, int i) {
  int d = 0;
  while (i >= 0 && s.parents[static_cast<std::size_t>(i)] >= 0) {
    i = s.parents[static_cast<std::size_t>(i)];
    ++d;
  }
  return d;
}

/// Shallowest non-end-site joint of `side` whose lower-cased base name contains one of
/// `words` (earlier words preferred), excluding fingers and twist joints.
int find_by_words(const Skeleton& s, char side, std::initializer_list<std::string_view> words,
                  std::initializer_list<std::string_view> exclude = {}) {
  for (std::string_view w : words) {
    int best = -1;
    for (int i = 0; i < s.joint_count(); ++i) {
      if (s.end_site[static_cast<std::size_t>(i)]) continue;
      const std::string l = lower(base_name(s.names[static_cast<std::size_t>(i)]));
      if (!contains(l, w) || is_finger(l) || is_twist(l)) continue;
      bool excluded = false;
      for (auto e : exclude) excluded = excluded || contains(l, e);
      if (excluded || side_of(s.names[static_cast<std::size_t>(i)]) != side) continue;
      if (best < 0 || depth_of(s, i) < depth_of(s, best)) best = i;
    }
    if (best >= 0) return best;
  }
  return -1;
}

/// Parent of `i`, skipping twist/roll helper joints.
int real_parent(const Skeleton& s, int i) {
  if (i < 0) return -1;
  int p = s.parents[static_cast<std::size_t>(i)];
  while (p >= 0 && is_twist(lower(base_name(s.names[static_cast<std::size_t>(p)])))) p = s.parents[static_cast<std::size_t>(p)];
  return p;
}

std::vector<int> path_to_root(const Skeleton& s, int i) {
  std::vector<int> out;
  for (; i >= 0; i = s.parents[static_cast<std::size_t>(i)]) out.push_back(i);
  return out;
}

int common_ancestor(const Skeleton& s, int a, int b) {
  if (a < 0 || b < 0) return -1;
  const auto pa = path_to_root(s, a);
  const auto pb = path_to_root(s, b);
  for (int x : pa) {
    if (std::find(pb.begin(), pb.end(), x) != pb.end()) return x;
  }
  return -1;
}

/// Joints strictly between `ancestor` and `descendant`, from the ancestor down.
std::vector<int> between(const Skeleton& s, int ancestor, int descendant) {
  std::vector<int> out;
  if (ancestor < 0 || descendant < 0) return out;
  for (int i = s.parents[static_cast<std::size_t>(descendant)]; i >= 0 && i != ancestor; i = s.parents[static_cast<std::size_t>(i)]) {
    out.push_back(i);
  }
  std::reverse(out.begin(), out.end());
  return out;
}

Structural structural_map(const Skeleton& s) {
  Structural m;
  for (char side : {'L', 'R'}) {
    const bool left = side == 'L';
    const int wrist = find_by_words(s, side, {"wrist", "hand"});
    const int elbow = real_parent(s, wrist);
    const int shoulder = real_parent(s, elbow);
    int clavicle = real_parent(s, shoulder);
    if (clavicle >= 0 && side_of(s.names[static_cast<std::size_t>(clavicle)]) != side) clavicle = -1;
    const int ankle = find_by_words(s, side, {"ankle", "foot"}, {"toe"});
    const int knee = real_parent(s, ankle);
    const int hip = real_parent(s, knee);
    int toe = -1;
    for (int i = ankle + 1; ankle >= 0 && i < s.joint_count(); ++i) {
      if (s.parents[static_cast<std::size_t>(i)] == ankle && !s.end_site[static_cast<std::size_t>(i)]) {
        toe = i;
        break;
      }
    }
    m[left ? CJ::l_wrist : CJ::r_wrist] = wrist;
    m[left ? CJ::l_elbow : CJ::r_elbow] = elbow;
    m[left ? CJ::l_shoulder : CJ::r_shoulder] = shoulder;
    m[left ? CJ::l_clavicle : CJ::r_clavicle] = clavicle;
    m[left ? CJ::l_ankle : CJ::r_ankle] = ankle;
    m[left ? CJ::l_knee : CJ::r_knee] = knee;
    m[left ? CJ::l_hip : CJ::r_hip] = hip;
    m[left ? CJ::l_toe : CJ::r_toe] = toe;
  }
  m[CJ::pelvis] = common_ancestor(s, m[CJ::l_hip], m[CJ::r_hip]);
  m[CJ::head] = find_by_words(s, 0, {"head"}, {"end", "top", "nub"});
  const int chest = common_ancestor(s, m[CJ::l_shoulder], m[CJ::r_shoulder]);
  m[CJ::chest] = chest;
  const auto to_head = between(s, chest, m[CJ::head]);
  m[CJ::neck] = to_head.empty() ? -1 : to_head.front();
  const auto spine = between(s, m[CJ::pelvis], chest);
  m[CJ::spine] = spine.empty() ? -1 : spine[spine.size() / 2];
  return m;
}

constexpr CJ kCore[] = {CJ::pelvis, CJ::head, CJ::l_shoulder, CJ::l_elbow, CJ::l_wrist, CJ::r_shoulder,
                        CJ::r_elbow, CJ::r_wrist, CJ::l_hip, CJ::l_knee, CJ::l_ankle, CJ::r_hip, CJ::r_knee,
                        CJ::r_ankle};

/// Candidate names of the other side's partner of `name`.
std::vector<std::string> swapped_names(const std::string& name) {
  std::vector<std::string> out;
  auto swap_sub = [&](std::string_view a, std::string_view b) {
    const auto at = name.find(a);
    if (at != std::string::npos) out.push_back(std::string(name).replace(at, a.size(), b));
  };
  for (auto [a, b] : {std::pair{"Left", "Right"}, {"Right", "Left"}, {"left", "right"}, {"right", "left"},
                      {"LEFT", "RIGHT"}, {"RIGHT", "LEFT"}}) {
    swap_sub(a, b);
  }
  auto swap_suffix = [&](std::string_view a, std::string_view b) {
    if (ends_with(name, a)) out.push_back(name.substr(0, name.size() - a.size()) + std::string(b));
    const std::string a_end = std::string(a) + "_end";
    if (ends_with(name, a_end)) out.push_back(name.substr(0, name.size() - a_end.size()) + std::string(b) + "_end");
  };
  for (auto [a, b] : {std::pair{"_L", "_R"}, {"_R", "_L"}, {"_l", "_r"}, {"_r", "_l"}, {".L", ".R"}, {".R", ".L"},
                      {".l", ".r"}, {".r", ".l"}}) {
    swap_suffix(a, b);
  }
  const auto colon = name.rfind(':');
  const std::size_t b0 = colon == std::string::npos ? 0 : colon + 1;
  if (b0 < name.size()) {
    const char c = name[b0];
    const char swapped = c == 'l' ? 'r' : c == 'r' ? 'l' : c == 'L' ? 'R' : c == 'R' ? 'L' : 0;
    if (swapped) {
      std::string s = name;
      s[b0] = swapped;
      out.push_back(s);
    }
  }
  return out;
}

}  // namespace

const std::vector<Dialect>& builtin_dialects() {
  static const std::vector<Dialect> dialects = {
      make_dialect("cmu", "CMU ASF/AMC conversions (joints named after the bone starting there)",
                   {{CJ::pelvis, "root"}, {CJ::spine, "upperback"}, {CJ::chest, "thorax"},
                    {CJ::neck, "lowerneck"}, {CJ::head, "head"},
                    {CJ::l_clavicle, "lclavicle"}, {CJ::l_shoulder, "lhumerus"}, {CJ::l_elbow, "lradius"},
                    {CJ::l_wrist, "lwrist"}, {CJ::r_clavicle, "rclavicle"}, {CJ::r_shoulder, "rhumerus"},
                    {CJ::r_elbow, "rradius"}, {CJ::r_wrist, "rwrist"}, {CJ::l_hip, "lfemur"},
                    {CJ::l_knee, "ltibia"}, {CJ::l_ankle, "lfoot"}, {CJ::l_toe, "ltoes"}, {CJ::r_hip, "rfemur"},
                    {CJ::r_knee, "rtibia"}, {CJ::r_ankle, "rfoot"}, {CJ::r_toe, "rtoes"}}),
      make_dialect("assimp_boxer", "assimp test model Boxing_Toes.bvh (Hips, Ab, Chest, LeftCollar ...)",
                   {{CJ::pelvis, "Hips"}, {CJ::spine, "Ab"}, {CJ::chest, "Chest"}, {CJ::neck, "Neck"},
                    {CJ::head, "Head"}, {CJ::l_clavicle, "LeftCollar"}, {CJ::l_shoulder, "LeftShoulder"},
                    {CJ::l_elbow, "LeftElbow"}, {CJ::l_wrist, "LeftWrist"}, {CJ::r_clavicle, "RightCollar"},
                    {CJ::r_shoulder, "RightShoulder"}, {CJ::r_elbow, "RightElbow"}, {CJ::r_wrist, "RightWrist"},
                    {CJ::l_hip, "LeftHip"}, {CJ::l_knee, "LeftKnee"}, {CJ::l_ankle, "LeftAnkle"},
                    {CJ::l_toe, "LeftToes"}, {CJ::r_hip, "RightHip"}, {CJ::r_knee, "RightKnee"},
                    {CJ::r_ankle, "RightAnkle"}, {CJ::r_toe, "RightToes"}}),
  };
  return dialects;
}

std::vector<Dialect> load_dialects(const std::filesystem::path& dir) {
  std::vector<Dialect> out = builtin_dialects();
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return out;
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    if (e.path().extension() == ".toml") files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  for (const auto& f : files) out.push_back(read_dialect_toml(f));
  return out;
}

const std::vector<Dialect>& default_dialects() {
  static const std::vector<Dialect> dialects = load_dialects(default_content_dir() / "dialects");
  return dialects;
}

DialectMatch detect_dialect(const Skeleton& skeleton, std::span<const Dialect> dialects) {
  DialectMatch best;
  for (const Dialect& d : dialects) {
    int named = 0, matched = 0;
    for (const auto& n : d.joints) {
      if (n.empty()) continue;
      ++named;
      if (skeleton.find(n) >= 0) ++matched;
    }
    if (named == 0 || matched * 10 < named * 6) continue;
    if (matched > best.matched) best = {&d, matched, named};
  }
  return best;
}

std::string map_canonical(Skeleton& skeleton, const Dialect* dialect, std::string_view source) {
  Structural found = structural_map(skeleton);
  if (dialect != nullptr) {
    for (std::size_t c = 0; c < kCanonicalJointCount; ++c) {
      const std::string& n = dialect->joints[c];
      if (n.empty()) continue;
      const int i = skeleton.find(n);
      if (i >= 0) found.j[c] = i;
    }
  }
  std::string missing;
  for (CJ c : kCore) {
    if (found[c] < 0) missing += (missing.empty() ? "" : ", ") + std::string(to_string(c));
  }
  if (!missing.empty()) {
    throw file_error("skeleton", "canonical", source, 0, dialect ? dialect->name : "structural",
                     fmt::format("cannot find canonical joint(s) {} (add a dialect map in content/dialects/)", missing));
  }
  skeleton.canonical = found.j;
  skeleton.dialect = dialect ? dialect->name : "structural";
  return skeleton.dialect;
}

std::string map_canonical(Skeleton& skeleton, std::span<const Dialect> dialects, std::string_view source) {
  const DialectMatch m = detect_dialect(skeleton, dialects);
  return map_canonical(skeleton, m.dialect, source);
}

std::string map_canonical(Skeleton& skeleton, std::string_view source) {
  return map_canonical(skeleton, default_dialects(), source);
}

std::string structural_mapping_warning(const Skeleton& skeleton, std::string_view source) {
  if (skeleton.dialect != "structural") return {};
  return fmt::format("{}: skeleton: no dialect map matched its joint names; its canonical joints were guessed "
                     "from names and structure: check its motion, or add a map in content/dialects/",
                     source);
}

CanonicalJoint mirror_joint(CanonicalJoint j) {
  const std::string_view n = to_string(j);
  if (n.size() > 2 && (n[0] == 'l' || n[0] == 'r') && n[1] == '_') {
    std::string other(n);
    other[0] = n[0] == 'l' ? 'r' : 'l';
    if (auto o = canonical_joint_from_string(other)) return *o;
  }
  return j;
}

int mirror_partner(const Skeleton& skeleton, int index) {
  for (std::size_t c = 0; c < kCanonicalJointCount; ++c) {
    if (skeleton.canonical[c] == index && index >= 0) {
      const int other = skeleton.index(mirror_joint(static_cast<CJ>(c)));
      if (other >= 0) return other;
    }
  }
  const std::string& name = skeleton.names[static_cast<std::size_t>(index)];
  for (const auto& cand : swapped_names(name)) {
    const int i = skeleton.find(cand);
    if (i >= 0 && i != index) return i;
  }
  return index;
}

}  // namespace kumite::content
