#pragma once
// The fighter's skinned bodies ([render] fighter = "skinned"), GL-free: which body each
// configured character wears (bodies.toml), loaded, its outfit applied and the retarget of the
// character's skeleton onto it built once; per frame the retarget of the frame's pose gives the
// joint palette the renderer skins with (the GPU) or skin_cpu (the reference).
//
// A body that cannot be worn (a model that does not load, a skeleton no bone map fits, a
// character without an entry) is one warning line naming the file; that character is drawn
// as capsules. A frame whose palette comes out not finite is drawn as capsules too.
#include <array>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "kumite/app/config.hpp"
#include "kumite/body/model.hpp"
#include "kumite/body/retarget.hpp"

namespace kumite::app {

struct FighterPose;

/// One configured character's body.
struct CharacterBody {
  int model = -1;                          ///< index into FighterBodies::models(); -1: capsules
  std::vector<std::array<float, 4>> colours;  ///< per primitive of the model: base colour (outfit applied)
  std::shared_ptr<const body::RetargetSetup> setup;
};

/// What a frame draws of the body: the model and its palette (one matrix per model joint,
/// room frame, metres).
struct BodyFrame {
  int model = -1;
  int character = -1;
  std::span<const Eigen::Matrix4f> palette;
  std::span<const std::array<float, 4>> colours;
  /// m, room frame: the body's lowest points for the contact shadow (the pelvis and the feet),
  /// from the retargeted joints.
  std::array<Eigen::Vector3f, 3> shadow_points{};
};

class FighterBodies {
 public:
  /// Reads config.render.bodies and every character's BVH and body. Never throws for a body:
  /// each problem is a line in warnings() (also logged) and that character stays capsules.
  explicit FighterBodies(const InstallationConfig& config);

  const std::vector<body::SkinnedModel>& models() const { return models_; }
  const std::vector<CharacterBody>& characters() const { return characters_; }
  const std::vector<std::string>& warnings() const { return warnings_; }

  /// Retargets the pose onto its character's body. Nullptr when the character has none or
  /// the pose gives no finite palette (then: capsules). Allocates nothing once warm.
  const BodyFrame* pose(const FighterPose& pose);

 private:
  std::vector<body::SkinnedModel> models_;
  std::vector<CharacterBody> characters_;
  std::vector<std::string> warnings_;
  // Scratch of the per-frame retarget (sized to the largest skeleton / model).
  std::vector<Eigen::Quaterniond> locals_, src_rot_, rot_;
  std::vector<Eigen::Vector3d> src_pos_, pos_, drawn_;
  std::vector<Eigen::Matrix4d> deltas_;
  std::vector<Eigen::Matrix4f> palette_;
  BodyFrame frame_;
};

}  // namespace kumite::app
