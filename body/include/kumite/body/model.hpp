#pragma once
// A skinned character model read from glTF 2.0 (.glb / .gltf): its skeleton (the skin's
// joints, parents first), inverse bind matrices, skinned vertices (up to four influences
// each) and flat or textured materials. Engine-agnostic: no GL, no cameras.
//
// Skinning follows the glTF spec: a vertex's bind position v (as stored, in the mesh's own
// space) goes to Σ w_i · (G_ji · IBM_ji) · v, where G_j is the joint node's global transform
// (every node above it included) and the mesh node's own transform is ignored.
#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace kumite::body {

/// The most joints a model may have: the size of the renderer's joint palette
/// (std140 uniform block of mat4[128], 8 KiB). A model with more is refused.
inline constexpr int kMaxJoints = 128;

/// The model's skeleton: the skin's joints, reordered parents-first (parents[j] < j; a
/// top joint has -1). Rest transforms are the joint nodes' own TRS.
struct ModelSkeleton {
  std::vector<std::string> names;
  std::vector<int> parents;
  std::vector<Eigen::Vector3d> rest_translations;
  std::vector<Eigen::Quaterniond> rest_rotations;
  std::vector<Eigen::Vector3d> rest_scales;
  /// Per joint: the global transform of the node above a top joint (identity for the others
  /// and for a joint at the scene's top).
  std::vector<Eigen::Matrix4d> top_parent_globals;
  std::vector<Eigen::Matrix4d> inverse_bind;  ///< per joint, as in the file (identity when absent)

  int joint_count() const { return static_cast<int>(names.size()); }
  int find(std::string_view name) const;  ///< joint index or -1
};

/// Rest global transforms (parents first): G_j = G_parent · T · R · S.
void rest_globals(const ModelSkeleton& skeleton, std::span<Eigen::Matrix4d> out);

struct Texture {
  std::string name;
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgba;  ///< width * height * 4, row 0 first as in the image
  /// The texture's glTF sampler, as its GL enum values (glTF's defaults where the file gives
  /// none: repeat, linear, trilinear).
  int wrap_s = 10497, wrap_t = 10497;  ///< REPEAT 10497, CLAMP_TO_EDGE 33071, MIRRORED_REPEAT 33648
  int mag_filter = 9729;               ///< NEAREST 9728, LINEAR 9729
  int min_filter = 9987;               ///< those, or NEAREST/LINEAR_MIPMAP_NEAREST/LINEAR 9984-9987
};

struct Material {
  std::string name;
  std::array<float, 4> base_color{1, 1, 1, 1};  ///< linear RGBA factor
  int base_color_texture = -1;                  ///< index into textures (-1: none)
};

/// One drawable range: triangles indices[first_index, first_index + index_count) with one material.
struct Primitive {
  std::string mesh;
  std::uint32_t first_index = 0, index_count = 0;
  int material = -1;  ///< -1: default (white)
};

struct SkinnedModel {
  std::string source;  ///< the file, for messages
  ModelSkeleton skeleton;
  // Vertices of every primitive bound to the skin, in the order read (bind pose, mesh space).
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;  ///< unit (0,0,0 where the file has none)
  std::vector<Eigen::Vector2f> uvs;      ///< (0,0) where the file has none
  std::vector<std::array<std::uint16_t, 4>> joints;  ///< skeleton joint indices
  std::vector<std::array<float, 4>> weights;         ///< sum to 1 (renormalised), sorted largest first
  std::vector<std::uint32_t> indices;                ///< triangles, into the vertex arrays
  std::vector<Primitive> primitives;
  std::vector<Material> materials;
  std::vector<Texture> textures;

  std::size_t vertex_count() const { return positions.size(); }
};

/// Reads a .glb or .gltf file. Throws kumite::Error (component "body") with one line naming
/// the file when it cannot be drawn right: unreadable or malformed, extensionsRequired
/// (Draco, meshopt, ...), no skin, more than kMaxJoints joints, a value that is not finite, an
/// index out of range, an accessor that does not fit its buffer.
SkinnedModel load_model(const std::filesystem::path& path);

/// Linear blend skinning on the CPU (the reference for the GPU path): per vertex
/// Σ w_i · palette[j_i] · v; normals by the same matrices' linear parts, renormalised.
/// Spans must hold model.vertex_count() entries; `palette` one matrix per joint.
/// Allocates nothing.
void skin_cpu(const SkinnedModel& model, std::span<const Eigen::Matrix4f> palette,
              std::span<Eigen::Vector3f> positions, std::span<Eigen::Vector3f> normals);

/// The rest palette: G_j,rest · IBM_j per joint (one matrix for all joints in a
/// well-formed file: the bind pose's mesh-to-world transform).
void rest_palette(const SkinnedModel& model, std::span<Eigen::Matrix4f> palette);

}  // namespace kumite::body
