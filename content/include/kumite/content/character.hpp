#pragma once
// Characters: the bodies the fighter can be drawn with. Each is a BVH skeleton shipped as
// content/characters/<name>.bvh (hierarchy plus one rest frame: every rotation zero, feet on
// the floor) and listed in content/characters/characters.toml:
//
//   version = 1
//   [[character]]
//   name = "bruno"                  # key (--character, console); unique
//   display_name = "Bruno"          # shown to the supervisor
//   file = "bruno.bvh"              # relative to characters.toml
//   notes = "tall, long arms"       # free text
//   [character.generate]            # optional: how `kumite-motion make-characters` made it
//   stature_m = 1.98                # m, rest-pose height (lowest to highest joint)
//   dialect = "cmu"                 # joint names / channels: "cmu" (ZYX) or "motionbuilder" (ZXY)
//   torso = 1.05                    # per-segment scale factors (1 = the base skeleton) ...
//
// The generator scales the segments of a base skeleton (the CMU subject 135 skeleton from
// content/motions/135_08.bvh) by per-segment factors, then uniformly to the stature.
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kumite/content/proportions.hpp"
#include "kumite/content/skeleton.hpp"

namespace kumite::content {

/// Scale factors per body segment (1 = as in the base skeleton). Each bone belongs to the
/// segment of the canonical joint it ends at (see bone_segment()).
struct SegmentScales {
  double torso = 1;           ///< pelvis -> spine -> chest -> neck base
  double neck_head = 1;       ///< neck and head
  double shoulder_width = 1;  ///< chest -> clavicle -> shoulder joint
  double upper_arm = 1;       ///< shoulder -> elbow
  double forearm = 1;         ///< elbow -> wrist
  double hand = 1;            ///< beyond the wrist
  double pelvis_width = 1;    ///< pelvis -> hip joints
  double thigh = 1;           ///< hip -> knee
  double shin = 1;            ///< knee -> ankle
  double foot = 1;            ///< beyond the ankle
};

enum class Segment : std::uint8_t { torso, neck_head, shoulder_width, upper_arm, forearm, hand, pelvis_width, thigh, shin, foot };
std::string_view to_string(Segment s);
double scale_of(const SegmentScales& s, Segment seg);

/// The segment the bone from joint j's parent to j belongs to (canonical joints mapped).
Segment bone_segment(const Skeleton& skeleton, int j);

struct CharacterSpec {
  double stature_m = 1.7;          ///< m, rest-pose height after scaling
  std::string dialect = "cmu";     ///< "cmu" (CMU names, ZYX) or "motionbuilder" (MotionBuilder names, ZXY)
  SegmentScales scales;
};

struct CharacterEntry {
  std::string name;          ///< key, unique
  std::string display_name;  ///< for people
  std::string file;          ///< BVH path as written (relative to characters.toml)
  std::string notes;
  std::optional<CharacterSpec> generate;  ///< how make-characters builds the file
  int line = 0;              ///< line in characters.toml
};

struct CharacterCatalog {
  std::vector<CharacterEntry> characters;
  std::filesystem::path source;  ///< characters.toml

  std::filesystem::path resolve(const CharacterEntry& c) const;
  /// Entry by name (nullptr when absent).
  const CharacterEntry* find(std::string_view name) const;
};

inline constexpr int kCharacterCatalogVersion = 1;
CharacterCatalog parse_characters(std::string_view text, std::string_view source);
CharacterCatalog read_characters(const std::filesystem::path& path);
std::string format_characters(const CharacterCatalog& catalog);

/// A character built from `base` (its skeleton only): segments scaled, uniformly scaled to
/// spec.stature_m, renamed to the dialect, one rest frame (zero rotations, lowest joint on
/// y = 0, root above the origin), named `name`, canonical joints mapped. Units: centimetres
/// on disk (unit_m = 0.01), 120 fps frame time.
Clip make_character(const Skeleton& base, const CharacterSpec& spec, std::string name);

/// A loaded character: its rest clip (canonical joints mapped) and measured proportions.
struct Character {
  std::string name;
  std::string display_name;
  Clip rest;                ///< one frame; rest.skeleton is the character's skeleton
  Proportions proportions;  ///< measured from the skeleton
};

/// Loads an entry's BVH (throws kumite::Error naming characters.toml line or the BVH file).
Character load_character(const CharacterCatalog& catalog, const CharacterEntry& entry);
/// Loads a character by catalog name, or any BVH file when `name_or_file` ends in ".bvh".
Character load_character(const CharacterCatalog& catalog, std::string_view name_or_file);

}  // namespace kumite::content
