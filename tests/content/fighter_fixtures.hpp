#pragma once
// Databases and characters for the database / retrieval / behaviour / fighter tests.
// synthetic_database(): SYNTHETIC clips (synthetic_body.hpp), always available.
// cmu_database(): the real CMU subject 135 clips from ../shared (strike windows from
// PROVENANCE.md), only when the shared data is present.
#include <memory>
#include <vector>

#include "kumite/content/adaptation.hpp"
#include "kumite/content/database.hpp"
#include "mocap_data.hpp"
#include "synthetic_body.hpp"

namespace kumite::content::testing {

struct SyntheticSet {
  std::vector<Clip> clips;
  std::shared_ptr<const Database> db;
};

/// Right punches of varying speed/height (mirrored into left ones) and a rest clip.
inline const SyntheticSet& synthetic_database() {
  static const SyntheticSet set = [] {
    SyntheticSet s;
    const Skeleton actor = synthetic::make_skeleton({});
    s.clips.push_back(synthetic::make_punch_clip(actor, 120, 0.5, 0.3, "rest", 0.0));
    for (int i = 0; i < 6; ++i)
      s.clips.push_back(synthetic::make_punch_clip(actor, 90 + 10 * i, 0.45 + 0.05 * (i % 3), 0.2 * i,
                                                   "punch" + std::to_string(i), 0.7 + 0.06 * i));
    std::vector<SegmentSource> src;
    src.push_back({&s.clips[0], "rest", 0, s.clips[0].frame_count - 1, SegmentKind::rest, std::nullopt, -1});
    for (std::size_t i = 1; i < s.clips.size(); ++i) {
      const Clip& c = s.clips[i];
      const int hit = static_cast<int>((0.45 + 0.05 * ((i - 1) % 3)) * (c.frame_count - 1));
      src.push_back({&c, c.name, 0, c.frame_count - 1, SegmentKind::strike, Effector{kRight, false}, hit});
    }
    s.db = std::make_shared<const Database>(build_database(src, {}));
    return s;
  }();
  return set;
}

/// Synthetic characters of clearly different sizes and proportions (1.5 m .. 2.0 m).
inline std::vector<Rig> synthetic_characters() {
  std::vector<Rig> r;
  r.push_back(make_rig(synthetic::make_skeleton({.scale = 0.86}), {}, "small"));
  r.push_back(make_rig(synthetic::make_skeleton({.scale = 1.14, .arm = 1.1, .leg = 0.95, .assimp_names = true}), {}, "tall"));
  r.push_back(make_rig(synthetic::make_skeleton({.scale = 1.0, .arm = 0.85, .leg = 1.1, .torso = 0.9,
                                                 .extra_roll_joint = true}), {}, "long_legs"));
  return r;
}

struct CmuSet {
  std::vector<const Clip*> clips;
  std::shared_ptr<const Database> db;
};

/// Punches (135_09), front kicks (135_04), rest (ready stance, first frames of 135_04).
inline const CmuSet& cmu_database() {
  static const CmuSet set = [] {
    CmuSet s;
    const Clip& punches = mocap_clip("cmu/135_09");
    const Clip& kicks = mocap_clip("cmu/135_04");
    std::vector<SegmentSource> src;
    src.push_back({&kicks, "135_04:rest", 0, 100, SegmentKind::rest, std::nullopt, -1});
    const int pw[4][3] = {{248, 304, 340}, {466, 530, 570}, {702, 760, 800}, {928, 1000, 1040}};
    for (int i = 0; i < 4; ++i)
      src.push_back({&punches, "135_09:punch" + std::to_string(i), pw[i][0] - 30, pw[i][2], SegmentKind::strike,
                     Effector{i % 2 == 0 ? kRight : kLeft, false}, pw[i][1]});
    const int kw[3][3] = {{330, 374, 410}, {536, 584, 628}, {762, 812, 850}};
    for (int i = 0; i < 3; ++i)
      src.push_back({&kicks, "135_04:kick" + std::to_string(i), kw[i][0] - 30, kw[i][2] + 30, SegmentKind::strike,
                     Effector{i % 2 == 0 ? kRight : kLeft, true}, kw[i][1]});
    s.db = std::make_shared<const Database>(build_database(src, {}));
    return s;
  }();
  return set;
}

}  // namespace kumite::content::testing

#include "kumite/content/annotation.hpp"
#include "kumite/content/behaviour.hpp"
#include "kumite/content/canonical.hpp"

namespace kumite::content::testing {

/// The SHIPPED content: content/motions/motions.toml built into a database (no ../shared
/// needed), and the shipped characters.
struct ShippedSet {
  AnnotationSet annotations;
  std::vector<Clip> clips;
  std::shared_ptr<const Database> db;
};
inline const ShippedSet& shipped_database() {
  static const ShippedSet set = [] {
    ShippedSet s;
    s.annotations = read_annotations(default_content_dir() / "motions" / "motions.toml");
    s.clips = load_annotated_clips(s.annotations);
    s.db = std::make_shared<const Database>(build_database(segment_sources(s.annotations, s.clips), {}));
    return s;
  }();
  return set;
}
inline std::vector<Rig> shipped_characters() {
  std::vector<Rig> rigs;
  for (const char* n : {"aiko", "bruno", "kenji", "mei", "viktor"}) rigs.push_back(load_character_rig(n));
  return rigs;
}

}  // namespace kumite::content::testing
