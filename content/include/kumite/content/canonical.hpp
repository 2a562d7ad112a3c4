#pragma once
// Canonical joints: which joint of a dialect's skeleton is the pelvis, the left elbow, ...
//
// A dialect is a map canonical joint -> joint name. Built in: "cmu" (ASF/AMC conversions:
// joints named after the bone that STARTS there, so lhumerus = shoulder, lradius = elbow,
// lfemur = hip, ltibia = knee, lfoot = ankle, ltoes = ball of the foot) and "assimp_boxer"
// (Hips, Ab, Chest, LeftCollar, LeftShoulder, ...). Others come from TOML files
// (content/dialects/*.toml, see README). Detection picks the dialect with most names present;
// canonical joints a dialect leaves out are then found structurally (hands/feet/head by
// name, elbows/knees/shoulders/hips by walking up the chain), so an unknown dialect with
// ordinary names (LeftArm / UpperArm_L / l_forearm ...) still maps.
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "kumite/content/skeleton.hpp"

namespace kumite::content {

struct Dialect {
  std::string name;         ///< "cmu", "assimp_boxer", or the TOML file's `name`
  std::string description;  ///< one line for people
  /// Joint name for each canonical joint (empty = the dialect has none; found structurally).
  std::array<std::string, kCanonicalJointCount> joints{};
  std::string source;       ///< where it came from ("built-in" or the TOML path)

  const std::string& joint(CanonicalJoint j) const { return joints[static_cast<std::size_t>(j)]; }
};

/// The built-in dialects ("cmu", "assimp_boxer").
const std::vector<Dialect>& builtin_dialects();

/// Parses a dialect map (TOML). Keys: name (string), description (string, optional),
/// [joints] canonical_name = "JointName". Unknown keys / canonical names and non-string
/// values throw kumite::Error "file:line: key: message".
Dialect parse_dialect_toml(std::string_view text, std::string_view source);
Dialect read_dialect_toml(const std::filesystem::path& path);

/// Built-ins plus every *.toml in `dir` (sorted by file name; a missing dir adds nothing).
std::vector<Dialect> load_dialects(const std::filesystem::path& dir);

/// The content folder (dialects/, characters/, motions/): $KUMITE_CONTENT_DIR when set,
/// else the source tree's content/ folder this library was built from.
std::filesystem::path default_content_dir();
/// load_dialects(default_content_dir() / "dialects").
const std::vector<Dialect>& default_dialects();

struct DialectMatch {
  const Dialect* dialect = nullptr;  ///< nullptr: no dialect fits, structural mapping only
  int matched = 0;                   ///< how many of its joint names the skeleton has
  int named = 0;                     ///< how many joint names the dialect lists
};

/// The dialect whose names the skeleton holds most of (at least 60 % of its list).
DialectMatch detect_dialect(const Skeleton& skeleton, std::span<const Dialect> dialects);

/// Fills skeleton.canonical from `dialect` (may be null), completing gaps structurally.
/// Throws kumite::Error (component "skeleton", code "canonical") naming `source` when the
/// core joints (pelvis, head, shoulders, elbows, wrists, hips, knees, ankles) cannot all be
/// found. Returns the dialect's name or "structural".
std::string map_canonical(Skeleton& skeleton, const Dialect* dialect, std::string_view source = "skeleton");

/// detect_dialect + map_canonical with default_dialects() (or the given list).
std::string map_canonical(Skeleton& skeleton, std::string_view source = "skeleton");
std::string map_canonical(Skeleton& skeleton, std::span<const Dialect> dialects, std::string_view source);
/// "" for a skeleton a dialect map named (or not mapped at all), else one line naming `source`:
/// its canonical joints were guessed from names and structure ("structural"), which can put
/// a joint one bone off and distort every motion played on it without any error.
std::string structural_mapping_warning(const Skeleton& skeleton, std::string_view source);

/// Is `j` a left-side joint / its right-side partner (and vice versa; centre joints map to
/// themselves).
CanonicalJoint mirror_joint(CanonicalJoint j);

/// The skeleton joint index of the left/right partner of joint `index` (by canonical joint
/// or by name: l/r prefix, Left/Right, _L/_R, .L/.R ...); `index` itself for centre joints.
int mirror_partner(const Skeleton& skeleton, int index);

}  // namespace kumite::content
