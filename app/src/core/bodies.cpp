#include "kumite/app/bodies.hpp"

#include <algorithm>
#include <cctype>
#include <map>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "kumite/app/installation.hpp"
#include "kumite/body/catalog.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/character.hpp"

namespace kumite::app {

namespace {
std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}
}  // namespace

FighterBodies::FighterBodies(const InstallationConfig& config) {
  characters_.resize(config.characters.size());
  const auto warn = [&](std::string line) {
    spdlog::warn("{}", line);
    warnings_.push_back(std::move(line));
  };
  const std::filesystem::path catalog_file = config.resolve(config.render.bodies);
  body::BodyCatalog catalog;
  try {
    catalog = body::read_bodies(catalog_file);
  } catch (const std::exception& e) {
    warn(fmt::format("{}: the capsule figure drawn instead of every body", e.what()));
    return;
  }
  std::map<std::string, int> loaded;  // model file -> index into models_
  std::size_t most_source = 0, most_target = 0;
  for (std::size_t i = 0; i < config.characters.size(); ++i) {
    const auto& ch = config.characters[i];
    // The catalog names characters as content's characters.toml does ("kenji"); the installation
    // file may name them for people ("Kenji"): the name, else the BVH's file name.
    const body::BodyEntry* entry = catalog.find(lower(ch.name));
    if (!entry) entry = catalog.find(lower(ch.bvh.stem().string()));
    if (!entry) {
      warn(fmt::format("{}: no body for character {} \"{}\": the capsule figure drawn instead", catalog_file.string(),
                       i + 1, ch.name));
      continue;
    }
    const std::filesystem::path model_file = catalog.resolve(*entry);
    try {
      const content::Character character = content::load_character({}, config.resolve(ch.bvh).string());
      int index = -1;
      if (const auto it = loaded.find(model_file.string()); it != loaded.end()) {
        index = it->second;
      } else {
        models_.push_back(body::load_model(model_file));
        index = static_cast<int>(models_.size()) - 1;
        loaded[model_file.string()] = index;
      }
      const body::SkinnedModel& shared = models_[static_cast<std::size_t>(index)];
      body::SkinnedModel tinted;  // the outfit on a copy of the materials only
      tinted.source = shared.source;
      tinted.materials = shared.materials;
      body::apply_outfit(tinted, catalog, *entry);
      const body::BoneMap* map = body::detect_bone_map(shared.skeleton.names);
      if (!map) throw Error("body", "bone_map", model_file.string() + ": no bone map fits its skeleton");
      auto setup = std::make_shared<body::RetargetSetup>(body::RetargetSetup::build(
          character.rest.skeleton, character.rest.root_positions.at(0),
          body::model_rig(shared, character.rest.skeleton, *map)));
      // A model of the wrong scale (a 180-unit-tall body in metres) comes out at the
      // character's size (the leg-length scale) but is said: its file is wrong.
      if (!(setup->scale > 0.2 && setup->scale < 5))
        throw Error("body", "scale", fmt::format("{}: scaled by {:.3g} to the character's legs: not a body in metres",
                                                 model_file.string(), setup->scale));
      CharacterBody& b = characters_[i];
      b.model = index;
      b.colours.clear();
      for (const auto& p : shared.primitives) {
        std::array<float, 4> c{0.8f, 0.8f, 0.8f, 1.0f};
        if (p.material >= 0) c = tinted.materials[static_cast<std::size_t>(p.material)].base_color;
        b.colours.push_back(c);
      }
      b.setup = std::move(setup);
      most_source = std::max(most_source, static_cast<std::size_t>(character.rest.skeleton.joint_count()));
      most_target = std::max(most_target, static_cast<std::size_t>(shared.skeleton.joint_count()));
    } catch (const std::exception& e) {
      warn(fmt::format("character {} \"{}\": {}: the capsule figure drawn instead", i + 1, ch.name, e.what()));
      characters_[i] = {};
    }
  }
  locals_.resize(most_source);
  src_rot_.resize(most_source);
  src_pos_.resize(most_source);
  drawn_.resize(most_source);
  rot_.resize(most_target);
  pos_.resize(most_target);
  deltas_.resize(most_target);
  palette_.resize(most_target);
}

const BodyFrame* FighterBodies::pose(const FighterPose& p) {
  if (!p.present || p.character < 0 || static_cast<std::size_t>(p.character) >= characters_.size()) return nullptr;
  const CharacterBody& b = characters_[static_cast<std::size_t>(p.character)];
  if (!b.setup) return nullptr;
  const body::RetargetSetup& s = *b.setup;
  const std::size_t ns = static_cast<std::size_t>(s.source.joint_count());
  const std::size_t nt = static_cast<std::size_t>(s.target.joint_count());
  if (p.local_rotations.size() != ns || ns > locals_.size() || nt > palette_.size()) return nullptr;
  for (std::size_t j = 0; j < ns; ++j) {
    const auto& q = p.local_rotations[j];
    locals_[j] = Eigen::Quaterniond(q.w, q.x, q.y, q.z);
  }
  body::RetargetJob job;
  job.setup = &s;
  job.local_rotations = std::span<const Eigen::Quaterniond>(locals_.data(), ns);
  job.root_position = Eigen::Vector3d(p.root_joint.x, p.root_joint.y, p.root_joint.z);
  // The joints as drawn: a character switch eases them from the old character's pose, and the
  // new body follows the easing (forward kinematics alone popped it onto the new pose).
  if (p.joints.size() == ns) {
    for (std::size_t j = 0; j < ns; ++j) drawn_[j] = Eigen::Vector3d(p.joints[j].x, p.joints[j].y, p.joints[j].z);
    job.drawn_positions = std::span<const Eigen::Vector3d>(drawn_.data(), ns);
  }
  job.source_positions = std::span(src_pos_.data(), ns);
  job.source_rotations = std::span(src_rot_.data(), ns);
  job.deltas = std::span(deltas_.data(), nt);
  job.rotations = std::span(rot_.data(), nt);
  job.positions = std::span(pos_.data(), nt);
  job.palette = std::span(palette_.data(), nt);
  if (!job.Run()) return nullptr;
  for (std::size_t j = 0; j < nt; ++j)
    if (!palette_[j].allFinite()) return nullptr;  // an exploded body never reaches the wall
  frame_.model = b.model;
  frame_.character = p.character;
  frame_.palette = std::span<const Eigen::Matrix4f>(palette_.data(), nt);
  frame_.colours = b.colours;
  const auto at = [&](content::CanonicalJoint c) -> Eigen::Vector3f {
    const int t = s.target.canonical[static_cast<std::size_t>(c)];
    return t >= 0 ? pos_[static_cast<std::size_t>(t)].cast<float>() : job.root_position.cast<float>();
  };
  frame_.shadow_points = {at(content::CanonicalJoint::pelvis), at(content::CanonicalJoint::l_ankle),
                          at(content::CanonicalJoint::r_ankle)};
  return &frame_;
}

}  // namespace kumite::app
