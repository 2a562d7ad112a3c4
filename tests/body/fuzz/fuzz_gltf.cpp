// libFuzzer target: the glTF loader (load_model) turns any file into a model or a
// kumite::Error, never crashes, hangs or exhausts memory; and a model it returns can be drawn
// right: every weight set sums to 1, every joint and index is in range, every number finite,
// and CPU skinning at the rest pose gives finite vertices (never an exploded mesh).
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "kumite/body/model.hpp"
#include "kumite/common/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // load_model reads a path (.glb by its magic, else .gltf): the input as this process's file.
  const bool glb = size >= 4 && data[0] == 'g' && data[1] == 'l' && data[2] == 'T' && data[3] == 'F';
  static const std::filesystem::path dir = [] {
    const auto d = std::filesystem::temp_directory_path() / ("kumite_fuzz_gltf_" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(std::filesystem::temp_directory_path() / ("kumite_fuzz_gltf_" + std::to_string(::getpid())), ec);
    });
    return d;
  }();
  const std::filesystem::path file = dir / (glb ? "model.glb" : "model.gltf");
  std::ofstream(file, std::ios::binary | std::ios::trunc).write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  kumite::body::SkinnedModel m;
  try {
    m = kumite::body::load_model(file);
  } catch (const kumite::Error&) {
    return 0;
  }
  const std::size_t n = m.vertex_count();
  const int joints = m.skeleton.joint_count();
  if (joints <= 0 || joints > kumite::body::kMaxJoints) std::abort();
  if (m.normals.size() != n || m.uvs.size() != n || m.joints.size() != n || m.weights.size() != n) std::abort();
  for (std::size_t v = 0; v < n; ++v) {
    if (!m.positions[v].allFinite() || !m.normals[v].allFinite() || !m.uvs[v].allFinite()) std::abort();
    double sum = 0;
    for (int k = 0; k < 4; ++k) {
      const float w = m.weights[v][static_cast<std::size_t>(k)];
      if (!std::isfinite(w) || w < 0) std::abort();
      sum += w;
      if (m.joints[v][static_cast<std::size_t>(k)] >= joints) std::abort();
    }
    if (std::abs(sum - 1) > 1e-3) std::abort();
  }
  for (std::uint32_t i : m.indices)
    if (i >= n) std::abort();
  for (const auto& p : m.primitives)
    if (static_cast<std::size_t>(p.first_index) + p.index_count > m.indices.size() ||
        p.material >= static_cast<int>(m.materials.size()))
      std::abort();
  for (const auto& t : m.textures)
    if (t.width <= 0 || t.height <= 0 || t.rgba.size() != static_cast<std::size_t>(t.width) * static_cast<std::size_t>(t.height) * 4)
      std::abort();
  std::vector<Eigen::Matrix4f> palette(static_cast<std::size_t>(joints));
  kumite::body::rest_palette(m, palette);
  std::vector<Eigen::Vector3f> pos(n), nor(n);
  kumite::body::skin_cpu(m, palette, pos, nor);
  for (std::size_t v = 0; v < n; ++v)
    if (!pos[v].allFinite()) std::abort();
  return 0;
}
