#include "kumite/content/character.hpp"

#include <algorithm>
#include <map>

#include <fmt/format.h>

#include "kumite/common/error.hpp"
#include "kumite/content/bvh.hpp"
#include "kumite/content/canonical.hpp"
#include "toml_string.hpp"

namespace kumite::content {

namespace {
constexpr std::array<std::string_view, 10> kSegmentNames = {
    "torso", "neck_head", "shoulder_width", "upper_arm", "forearm", "hand", "pelvis_width", "thigh", "shin", "foot"};

using CJ = CanonicalJoint;

std::optional<CJ> canonical_of(const Skeleton& s, int j) {
  for (std::size_t c = 0; c < kCanonicalJointCount; ++c) {
    if (s.canonical[c] == j) return static_cast<CJ>(c);
  }
  return std::nullopt;
}

/// Segment of the bone that ENDS at canonical joint c.
Segment segment_ending_at(CJ c) {
  switch (c) {
    case CJ::l_elbow: case CJ::r_elbow: return Segment::upper_arm;
    case CJ::l_wrist: case CJ::r_wrist: return Segment::forearm;
    case CJ::l_knee: case CJ::r_knee: return Segment::thigh;
    case CJ::l_ankle: case CJ::r_ankle: return Segment::shin;
    case CJ::l_toe: case CJ::r_toe: return Segment::foot;
    case CJ::l_clavicle: case CJ::r_clavicle: case CJ::l_shoulder: case CJ::r_shoulder: return Segment::shoulder_width;
    case CJ::l_hip: case CJ::r_hip: return Segment::pelvis_width;
    case CJ::head: return Segment::neck_head;
    default: return Segment::torso;  // pelvis, spine, chest, neck (base of the neck)
  }
}

/// Segment of what lies beyond canonical joint c (hand beyond the wrist, ...).
Segment segment_beyond(CJ c) {
  switch (c) {
    case CJ::l_wrist: case CJ::r_wrist: return Segment::hand;
    case CJ::l_ankle: case CJ::r_ankle: case CJ::l_toe: case CJ::r_toe: return Segment::foot;
    case CJ::l_elbow: case CJ::r_elbow: return Segment::forearm;
    case CJ::l_shoulder: case CJ::r_shoulder: return Segment::upper_arm;
    case CJ::l_knee: case CJ::r_knee: return Segment::shin;
    case CJ::l_hip: case CJ::r_hip: return Segment::thigh;
    case CJ::neck: case CJ::head: return Segment::neck_head;
    default: return Segment::torso;
  }
}

// CMU ASF names -> MotionBuilder names (as the cgspeed CMU conversion names them).
const std::map<std::string, std::string>& motionbuilder_names() {
  static const std::map<std::string, std::string> m = {
      {"root", "Hips"}, {"lowerback", "LowerBack"}, {"upperback", "Spine"}, {"thorax", "Spine1"},
      {"lowerneck", "Neck"}, {"upperneck", "Neck1"}, {"head", "Head"},
      {"lhipjoint", "LHipJoint"}, {"lfemur", "LeftUpLeg"}, {"ltibia", "LeftLeg"}, {"lfoot", "LeftFoot"},
      {"ltoes", "LeftToeBase"}, {"rhipjoint", "RHipJoint"}, {"rfemur", "RightUpLeg"}, {"rtibia", "RightLeg"},
      {"rfoot", "RightFoot"}, {"rtoes", "RightToeBase"},
      {"lclavicle", "LeftShoulder"}, {"lhumerus", "LeftArm"}, {"lradius", "LeftForeArm"}, {"lwrist", "LeftHand"},
      {"lhand", "LeftFingerBase"}, {"lfingers", "LeftHandIndex1"}, {"lthumb", "LThumb"},
      {"rclavicle", "RightShoulder"}, {"rhumerus", "RightArm"}, {"rradius", "RightForeArm"}, {"rwrist", "RightHand"},
      {"rhand", "RightFingerBase"}, {"rfingers", "RightHandIndex1"}, {"rthumb", "RThumb"}};
  return m;
}

}  // namespace

std::string_view to_string(Segment s) { return kSegmentNames[static_cast<std::size_t>(s)]; }

double scale_of(const SegmentScales& s, Segment seg) {
  switch (seg) {
    case Segment::torso: return s.torso;
    case Segment::neck_head: return s.neck_head;
    case Segment::shoulder_width: return s.shoulder_width;
    case Segment::upper_arm: return s.upper_arm;
    case Segment::forearm: return s.forearm;
    case Segment::hand: return s.hand;
    case Segment::pelvis_width: return s.pelvis_width;
    case Segment::thigh: return s.thigh;
    case Segment::shin: return s.shin;
    case Segment::foot: return s.foot;
  }
  return 1;
}

Segment bone_segment(const Skeleton& s, int j) {
  if (auto c = canonical_of(s, j)) return segment_ending_at(*c);
  // A helper joint on the way to a canonical joint (lhipjoint before lfemur, upperneck before
  // head): the segment of that joint's bone.
  std::vector<int> frontier{j};
  while (!frontier.empty()) {
    std::vector<int> next;
    for (int f : frontier) {
      for (int k = f + 1; k < s.joint_count(); ++k) {
        if (s.parents[static_cast<std::size_t>(k)] != f) continue;
        if (auto c = canonical_of(s, k)) {
          // Bones into the hip or clavicle side from the pelvis/chest belong to the widths.
          const Segment seg = segment_ending_at(*c);
          if (seg == Segment::upper_arm || seg == Segment::thigh || seg == Segment::shin || seg == Segment::forearm ||
              seg == Segment::foot) {
            continue;  // beyond a canonical ancestor: handled below
          }
          return seg;
        }
        next.push_back(k);
      }
    }
    frontier = std::move(next);
  }
  // An extremity (hand, fingers, toe tip, head top): the segment beyond the nearest
  // canonical ancestor.
  for (int a = s.parents[static_cast<std::size_t>(j)]; a >= 0; a = s.parents[static_cast<std::size_t>(a)]) {
    if (auto c = canonical_of(s, a)) return segment_beyond(*c);
  }
  return Segment::torso;
}

Clip make_character(const Skeleton& base, const CharacterSpec& spec, std::string name) {
  if (!(spec.stature_m > 0.3 && spec.stature_m < 3.0)) {
    throw Error("character", "range", fmt::format("{}: stature_m {} is outside 0.3..3 m", name, spec.stature_m));
  }
  if (spec.dialect != "cmu" && spec.dialect != "motionbuilder") {
    throw Error("character", "dialect", fmt::format("{}: dialect '{}' (expected cmu or motionbuilder)", name, spec.dialect));
  }
  Skeleton s = base;
  if (s.dialect.empty()) map_canonical(s, name);
  for (int j = 1; j < s.joint_count(); ++j) {
    s.offsets[static_cast<std::size_t>(j)] *= scale_of(spec.scales, bone_segment(s, j));
  }
  const auto rest = rest_positions(s);
  double lo = 1e300, hi = -1e300;
  for (const auto& p : rest) {
    lo = std::min(lo, p.y());
    hi = std::max(hi, p.y());
  }
  const double k = spec.stature_m / (hi - lo);
  for (auto& o : s.offsets) o *= k;
  s.offsets[0] = Eigen::Vector3d::Zero();
  const double root_height = (rest[0].y() - lo) * k;

  if (spec.dialect == "motionbuilder") {
    for (auto& n : s.names) {
      const bool end = n.size() > 4 && n.ends_with("_end");
      const std::string stem = end ? n.substr(0, n.size() - 4) : n;
      auto it = motionbuilder_names().find(stem);
      if (it == motionbuilder_names().end()) {
        throw Error("character", "dialect", fmt::format("{}: no MotionBuilder name for joint '{}'", name, n));
      }
      n = it->second + (end ? "_end" : "");
    }
  }
  s.channels.assign(s.names.size(), "");
  const bool mb = spec.dialect == "motionbuilder";
  for (std::size_t j = 0; j < s.names.size(); ++j) {
    if (s.end_site[j]) continue;
    s.channels[j] = std::string(j == 0 ? "XYZ" : "") + (mb ? "zxy" : "zyx");
  }
  s.dialect.clear();
  map_canonical(s, name);

  Clip c;
  c.name = std::move(name);
  c.skeleton = std::move(s);
  c.frame_time_s = 1.0 / 120;
  c.unit_m = 0.01;
  c.frame_count = 1;
  c.root_positions = {Eigen::Vector3d(0, root_height, 0)};
  c.local_rotations.assign(c.skeleton.names.size(), Eigen::Quaterniond::Identity());
  return c;
}

std::filesystem::path CharacterCatalog::resolve(const CharacterEntry& c) const {
  const std::filesystem::path p(c.file);
  if (p.is_absolute() || source.empty()) return p;
  return source.parent_path() / p;
}

const CharacterEntry* CharacterCatalog::find(std::string_view name) const {
  for (const auto& c : characters) {
    if (c.name == name) return &c;
  }
  return nullptr;
}

std::string format_characters(const CharacterCatalog& catalog) {
  std::string out;
  out += "# Kumite characters (see content/include/kumite/content/character.hpp). Each file is a BVH\n";
  out += "# skeleton with one rest frame. [character.generate] records how `kumite-motion\n";
  out += "# make-characters` built it from the CMU 135 skeleton: stature_m in metres, dialect\n";
  out += "# (cmu | motionbuilder), per-segment scale factors (1 = base skeleton).\n";
  out += fmt::format("version = {}\n", kCharacterCatalogVersion);
  const auto str = [](std::string_view s) { return toml_string(s); };
  for (const auto& c : catalog.characters) {
    out += "\n[[character]]\n";
    out += fmt::format("name = {}\ndisplay_name = {}\nfile = {}\nnotes = {}\n", str(c.name), str(c.display_name),
                       str(c.file), str(c.notes));
    if (c.generate) {
      const auto& g = *c.generate;
      out += "[character.generate]\n";
      out += fmt::format("stature_m = {}\ndialect = {}\n", toml_number(g.stature_m), str(g.dialect));
      for (std::size_t i = 0; i < kSegmentNames.size(); ++i) {
        const double v = scale_of(g.scales, static_cast<Segment>(i));
        if (v != 1.0) out += fmt::format("{} = {}\n", kSegmentNames[i], toml_number(v));
      }
    }
  }
  return out;
}

Character load_character(const CharacterCatalog& catalog, const CharacterEntry& entry) {
  const auto path = catalog.resolve(entry);
  if (!std::filesystem::exists(path)) {
    throw file_error("character", "missing_file", catalog.source.string(), entry.line, "character.file",
                     fmt::format("'{}' not found", path.string()));
  }
  Character c;
  c.name = entry.name;
  c.display_name = entry.display_name;
  c.rest = read_bvh(path);
  if (c.rest.frame_count < 1) throw file_error("character", "frames", path.string(), 0, "Frames", "a character needs a rest frame");
  if (c.rest.skeleton.dialect.empty()) map_canonical(c.rest.skeleton, path.string());
  c.proportions = measure_proportions(c.rest.skeleton);
  return c;
}

Character load_character(const CharacterCatalog& catalog, std::string_view name_or_file) {
  if (name_or_file.ends_with(".bvh")) {
    CharacterEntry e;
    e.file = std::filesystem::absolute(std::string(name_or_file)).string();
    e.name = std::filesystem::path(e.file).stem().string();
    e.display_name = e.name;
    return load_character(CharacterCatalog{}, e);
  }
  const CharacterEntry* e = catalog.find(name_or_file);
  if (!e) {
    std::string names;
    for (const auto& c : catalog.characters) names += (names.empty() ? "" : ", ") + c.name;
    throw Error("character", "unknown", fmt::format("unknown character '{}' (known: {})", name_or_file, names));
  }
  return load_character(catalog, *e);
}

}  // namespace kumite::content
