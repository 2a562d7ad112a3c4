// glTF 2.0 -> SkinnedModel with Debian's tinygltf (the library decodes the JSON, buffers and
// images; every accessor is decoded and checked here, the `normalized` flag honoured).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <initializer_list>
#include <numeric>
#include <string>

#include <tiny_gltf.h>

#include "kumite/body/model.hpp"
#include "kumite/common/error.hpp"

namespace kumite::body {
namespace {

[[noreturn]] void fail(const std::string& file, std::string_view code, const std::string& message) {
  throw Error("body", std::string(code), file + ": " + message);
}

bool finite(double v) { return std::isfinite(v); }

/// One accessor decoded to doubles, `components` per element, bounds and strides checked.
struct Decoded {
  std::vector<double> values;
  int components = 0;
  std::size_t count = 0;
  int component_type = 0;
  bool normalized = false;
  double at(std::size_t i, int c) const { return values[i * static_cast<std::size_t>(components) + static_cast<std::size_t>(c)]; }
};

int component_count(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    case TINYGLTF_TYPE_MAT4: return 16;
    default: return 0;
  }
}

std::size_t component_size(int ct) {
  switch (ct) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
  }
}

double read_component(const unsigned char* p, int ct, bool normalized) {
  switch (ct) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      std::int8_t v; std::memcpy(&v, p, 1);
      return normalized ? std::max(v / 127.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: {
      std::uint8_t v; std::memcpy(&v, p, 1);
      return normalized ? v / 255.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      std::int16_t v; std::memcpy(&v, p, 2);
      return normalized ? std::max(v / 32767.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      std::uint16_t v; std::memcpy(&v, p, 2);
      return normalized ? v / 65535.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
      std::uint32_t v; std::memcpy(&v, p, 4);
      return normalized ? v / 4294967295.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_FLOAT: {
      float v; std::memcpy(&v, p, 4);
      return v;
    }
    default: return 0;
  }
}

class Reader {
 public:
  Reader(const tinygltf::Model& m, std::string file) : m_(m), file_(std::move(file)) {}

  /// Accessor `index` as `what`, of one of the `types`, with `allowed` component types.
  Decoded decode(int index, const std::string& what, std::initializer_list<int> types,
                 std::initializer_list<int> allowed) const {
    if (index < 0 || static_cast<std::size_t>(index) >= m_.accessors.size())
      fail(file_, "index", what + ": accessor " + std::to_string(index) + " does not exist");
    const tinygltf::Accessor& a = m_.accessors[static_cast<std::size_t>(index)];
    const std::string name = what + " (accessor " + std::to_string(index) + ")";
    if (std::find(types.begin(), types.end(), a.type) == types.end())
      fail(file_, "type", name + ": unexpected element type");
    if (std::find(allowed.begin(), allowed.end(), a.componentType) == allowed.end())
      fail(file_, "type", name + ": unsupported component type " + std::to_string(a.componentType));
    if (a.sparse.isSparse) fail(file_, "sparse", name + ": sparse accessors are not supported");
    Decoded d;
    d.components = component_count(a.type);
    d.count = a.count;
    d.component_type = a.componentType;
    d.normalized = a.normalized;
    const std::size_t csize = component_size(a.componentType);
    const std::size_t elem = csize * static_cast<std::size_t>(d.components);
    if (a.bufferView < 0) {  // all zeros (glTF: no bufferView)
      d.values.assign(d.count * static_cast<std::size_t>(d.components), 0.0);
      return d;
    }
    if (static_cast<std::size_t>(a.bufferView) >= m_.bufferViews.size())
      fail(file_, "index", name + ": bufferView " + std::to_string(a.bufferView) + " does not exist");
    const tinygltf::BufferView& v = m_.bufferViews[static_cast<std::size_t>(a.bufferView)];
    if (v.buffer < 0 || static_cast<std::size_t>(v.buffer) >= m_.buffers.size())
      fail(file_, "index", name + ": buffer " + std::to_string(v.buffer) + " does not exist");
    const auto& buf = m_.buffers[static_cast<std::size_t>(v.buffer)].data;
    const std::size_t stride = v.byteStride ? v.byteStride : elem;
    if (stride < elem) fail(file_, "range", name + ": byteStride smaller than an element");
    if (v.byteOffset > buf.size() || v.byteLength > buf.size() - v.byteOffset)
      fail(file_, "range", name + ": bufferView runs past its buffer (truncated file?)");
    if (d.count > 0) {
      const std::size_t need = a.byteOffset + stride * (d.count - 1) + elem;
      if (a.byteOffset > v.byteLength || need > v.byteLength || (d.count - 1) > v.byteLength / stride)
        fail(file_, "range", name + ": " + std::to_string(d.count) + " elements do not fit its bufferView");
    }
    d.values.resize(d.count * static_cast<std::size_t>(d.components));
    const unsigned char* base = buf.data() + v.byteOffset + a.byteOffset;
    for (std::size_t i = 0; i < d.count; ++i)
      for (int c = 0; c < d.components; ++c) {
        const double x = read_component(base + i * stride + static_cast<std::size_t>(c) * csize,
                                        a.componentType, a.normalized);
        if (!finite(x)) fail(file_, "not_finite", name + ": element " + std::to_string(i) + " is not finite");
        d.values[i * static_cast<std::size_t>(d.components) + static_cast<std::size_t>(c)] = x;
      }
    return d;
  }

 private:
  const tinygltf::Model& m_;
  std::string file_;
};

Eigen::Matrix4d trs(const Eigen::Vector3d& t, const Eigen::Quaterniond& r, const Eigen::Vector3d& s) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = r.toRotationMatrix() * s.asDiagonal();
  m.topRightCorner<3, 1>() = t;
  return m;
}

struct NodeTrs {
  Eigen::Vector3d t{0, 0, 0};
  Eigen::Quaterniond r = Eigen::Quaterniond::Identity();
  Eigen::Vector3d s{1, 1, 1};
};

NodeTrs node_trs(const tinygltf::Node& n, const std::string& file, int index) {
  const std::string name = "node " + std::to_string(index) + (n.name.empty() ? "" : " '" + n.name + "'");
  NodeTrs out;
  auto check = [&](const std::vector<double>& v, std::size_t size, const char* what) {
    if (!v.empty() && v.size() != size) fail(file, "type", name + ": " + what + " must have " + std::to_string(size) + " numbers");
    for (double x : v)
      if (!finite(x)) fail(file, "not_finite", name + ": " + what + " is not finite");
  };
  check(n.matrix, 16, "matrix");
  check(n.translation, 3, "translation");
  check(n.rotation, 4, "rotation");
  check(n.scale, 3, "scale");
  if (n.matrix.size() == 16) {
    Eigen::Matrix4d m;
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) m(r, c) = n.matrix[static_cast<std::size_t>(c * 4 + r)];
    out.t = m.topRightCorner<3, 1>();
    Eigen::Matrix3d l = m.topLeftCorner<3, 3>();
    for (int c = 0; c < 3; ++c) out.s[c] = l.col(c).norm();
    if (out.s.minCoeff() < 1e-12 || l.determinant() <= 0)
      fail(file, "range", name + ": matrix is singular or mirrored");
    Eigen::Matrix3d rot = l * out.s.cwiseInverse().asDiagonal();
    if ((rot.transpose() * rot - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-4)
      fail(file, "range", name + ": matrix has shear");
    out.r = Eigen::Quaterniond(rot).normalized();
    return out;
  }
  if (n.translation.size() == 3) out.t = {n.translation[0], n.translation[1], n.translation[2]};
  if (n.rotation.size() == 4) {
    out.r = Eigen::Quaterniond(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2]);
    if (std::abs(out.r.norm() - 1) > 1e-3) fail(file, "range", name + ": rotation is not a unit quaternion");
    out.r.normalize();
  }
  if (n.scale.size() == 3) out.s = {n.scale[0], n.scale[1], n.scale[2]};
  return out;
}

/// An image as a message names it: its name, else its file (a uri that is not inline data),
/// else "#index".
std::string image_label(const tinygltf::Image& img, int index) {
  if (!img.name.empty()) return img.name;
  if (!img.uri.empty() && img.uri.rfind("data:", 0) != 0) return img.uri;
  return "#" + std::to_string(index);
}

/// A sampler's wrap modes and filters onto `out` (left at glTF's defaults where unset, -1);
/// a value glTF does not allow is refused naming the sampler.
void read_sampler(const tinygltf::Sampler& s, int index, Texture& out, const std::string& file) {
  const auto check = [&](int v, std::initializer_list<int> allowed, const char* what, int& to) {
    if (v < 0) return;
    if (std::find(allowed.begin(), allowed.end(), v) == allowed.end())
      fail(file, "sampler", "sampler " + std::to_string(index) + ": " + what + " " + std::to_string(v) + " is not one glTF allows");
    to = v;
  };
  check(s.wrapS, {33071, 33648, 10497}, "wrapS", out.wrap_s);
  check(s.wrapT, {33071, 33648, 10497}, "wrapT", out.wrap_t);
  check(s.magFilter, {9728, 9729}, "magFilter", out.mag_filter);
  check(s.minFilter, {9728, 9729, 9984, 9985, 9986, 9987}, "minFilter", out.min_filter);
}

void to_rgba8(const tinygltf::Image& img, int index, Texture& out, const std::string& file) {
  const int comp = img.component, bits = img.bits;
  // (an external image file that is missing or unreadable is left empty by the library)
  if (img.width <= 0 || img.height <= 0 || comp < 1 || comp > 4 || (bits != 8 && bits != 16))
    fail(file, "image", "image '" + image_label(img, index) + "' could not be read or decoded");
  const std::size_t px = static_cast<std::size_t>(img.width) * static_cast<std::size_t>(img.height);
  const std::size_t bpc = static_cast<std::size_t>(bits / 8);
  if (img.image.size() < px * static_cast<std::size_t>(comp) * bpc)
    fail(file, "image", "image '" + image_label(img, index) + "' is shorter than its size");
  out.width = img.width;
  out.height = img.height;
  out.rgba.assign(px * 4, 255);
  for (std::size_t i = 0; i < px; ++i)
    for (int c = 0; c < comp; ++c) {
      const std::size_t at = (i * static_cast<std::size_t>(comp) + static_cast<std::size_t>(c)) * bpc;
      const std::uint8_t v = bpc == 1 ? img.image[at] : img.image[at + 1];  // 16-bit little-endian: high byte
      if (comp <= 2 && c == 0) {
        out.rgba[i * 4 + 0] = out.rgba[i * 4 + 1] = out.rgba[i * 4 + 2] = v;
      } else if (comp == 2 && c == 1) {
        out.rgba[i * 4 + 3] = v;
      } else {
        out.rgba[i * 4 + static_cast<std::size_t>(c)] = v;
      }
    }
}

}  // namespace

int ModelSkeleton::find(std::string_view name) const {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<int>(i);
  return -1;
}

SkinnedModel load_model(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) fail(file, "io", "cannot open the file");
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });

  tinygltf::TinyGLTF loader;
  tinygltf::Model m;
  std::string err, warn;
  bool ok = false;
  if (ext == ".glb") {
    ok = loader.LoadBinaryFromFile(&m, &err, &warn, file);
  } else if (ext == ".gltf") {
    ok = loader.LoadASCIIFromFile(&m, &err, &warn, file);
  } else {
    fail(file, "format", "not a glTF file (.glb or .gltf)");
  }
  if (!ok) {
    std::string why = err.empty() ? warn : err;
    std::replace(why.begin(), why.end(), '\n', ' ');
    while (!why.empty() && why.back() == ' ') why.pop_back();
    fail(file, "parse", "cannot be read as glTF: " + (why.empty() ? std::string("malformed") : why));
  }
  if (!m.extensionsRequired.empty()) {
    std::string list;
    for (const auto& e : m.extensionsRequired) list += (list.empty() ? "" : ", ") + e;
    fail(file, "extension", "extensionsRequired (" + list + ") is not supported: export without compression or extensions");
  }
  for (const auto& e : m.extensionsUsed)
    if (e == "KHR_draco_mesh_compression" || e == "EXT_meshopt_compression" || e == "KHR_meshopt_compression")
      fail(file, "extension", e + " is not supported: export without mesh compression");

  const Reader reader(m, file);
  const std::size_t node_count = m.nodes.size();
  // Node parents, checked: indices in range, one parent each, no cycle.
  std::vector<int> node_parent(node_count, -1);
  for (std::size_t i = 0; i < node_count; ++i)
    for (int c : m.nodes[i].children) {
      if (c < 0 || static_cast<std::size_t>(c) >= node_count)
        fail(file, "index", "node " + std::to_string(i) + ": child " + std::to_string(c) + " does not exist");
      if (node_parent[static_cast<std::size_t>(c)] != -1 || static_cast<std::size_t>(c) == i)
        fail(file, "index", "node " + std::to_string(c) + " has more than one parent");
      node_parent[static_cast<std::size_t>(c)] = static_cast<int>(i);
    }
  std::vector<int> depth(node_count, -1);
  for (std::size_t i = 0; i < node_count; ++i) {
    int d = 0;
    for (int p = node_parent[i]; p != -1; p = node_parent[static_cast<std::size_t>(p)])
      if (++d > static_cast<int>(node_count)) fail(file, "index", "the node hierarchy has a cycle");
    depth[i] = d;
  }
  std::vector<NodeTrs> local(node_count);
  for (std::size_t i = 0; i < node_count; ++i) local[i] = node_trs(m.nodes[i], file, static_cast<int>(i));
  auto node_global = [&](int n) {
    Eigen::Matrix4d g = Eigen::Matrix4d::Identity();
    for (int k = n; k != -1; k = node_parent[static_cast<std::size_t>(k)]) {
      const NodeTrs& t = local[static_cast<std::size_t>(k)];
      g = trs(t.t, t.r, t.s) * g;
    }
    return g;
  };

  // The skin: the first skinned mesh node's. Other meshes may have skins of their own on the
  // same joints (FBX2glTF writes one per mesh): their vertices are carried into this skin's
  // bind space below.
  int skin = -1;
  for (const auto& n : m.nodes)
    if (n.mesh >= 0 && n.skin >= 0) {
      if (static_cast<std::size_t>(n.skin) >= m.skins.size()) fail(file, "index", "skin " + std::to_string(n.skin) + " does not exist");
      if (skin == -1) skin = n.skin;
    }
  if (skin < 0) fail(file, "skin", "no skinned mesh (a mesh node with a skin) in the file");
  const tinygltf::Skin& sk = m.skins[static_cast<std::size_t>(skin)];
  const std::size_t jn = sk.joints.size();
  if (jn == 0) fail(file, "skin", "the skin has no joints");
  if (jn > static_cast<std::size_t>(kMaxJoints))
    fail(file, "joints", "the skin has " + std::to_string(jn) + " joints, more than the " + std::to_string(kMaxJoints) + " the renderer takes");
  std::vector<int> joint_of_node(node_count, -1);
  for (std::size_t j = 0; j < jn; ++j) {
    const int n = sk.joints[j];
    if (n < 0 || static_cast<std::size_t>(n) >= node_count) fail(file, "index", "skin joint " + std::to_string(j) + " names no node");
    if (joint_of_node[static_cast<std::size_t>(n)] != -1) fail(file, "index", "node " + std::to_string(n) + " is a joint twice");
    joint_of_node[static_cast<std::size_t>(n)] = static_cast<int>(j);
  }
  // Parents first: order the skin's joints by depth (stable).
  std::vector<std::size_t> order(jn);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return depth[static_cast<std::size_t>(sk.joints[a])] < depth[static_cast<std::size_t>(sk.joints[b])];
  });
  std::vector<int> new_index(jn);
  for (std::size_t k = 0; k < jn; ++k) new_index[order[k]] = static_cast<int>(k);

  Decoded ibm;
  if (sk.inverseBindMatrices >= 0) {
    ibm = reader.decode(sk.inverseBindMatrices, "inverseBindMatrices", {TINYGLTF_TYPE_MAT4}, {TINYGLTF_COMPONENT_TYPE_FLOAT});
    if (ibm.count < jn) fail(file, "range", "inverseBindMatrices has " + std::to_string(ibm.count) + " matrices for " + std::to_string(jn) + " joints");
  }

  SkinnedModel out;
  out.source = file;
  ModelSkeleton& s = out.skeleton;
  for (std::size_t k = 0; k < jn; ++k) {
    const std::size_t j = order[k];
    const int n = sk.joints[j];
    const tinygltf::Node& node = m.nodes[static_cast<std::size_t>(n)];
    s.names.push_back(node.name.empty() ? "joint" + std::to_string(j) : node.name);
    const int pn = node_parent[static_cast<std::size_t>(n)];
    int parent = -1;
    Eigen::Matrix4d top = Eigen::Matrix4d::Identity();
    if (pn != -1) {
      const int pj = joint_of_node[static_cast<std::size_t>(pn)];
      if (pj != -1) {
        parent = new_index[static_cast<std::size_t>(pj)];
      } else {
        // A node between two joints that is no joint itself would move them unseen.
        for (int a = node_parent[static_cast<std::size_t>(pn)]; a != -1; a = node_parent[static_cast<std::size_t>(a)])
          if (joint_of_node[static_cast<std::size_t>(a)] != -1)
            fail(file, "skin", "joint '" + s.names.back() + "' hangs under node " + std::to_string(pn) + ", which is not a joint of the skin");
        top = node_global(pn);
      }
    }
    s.parents.push_back(parent);
    const NodeTrs& t = local[static_cast<std::size_t>(n)];
    s.rest_translations.push_back(t.t);
    s.rest_rotations.push_back(t.r);
    s.rest_scales.push_back(t.s);
    s.top_parent_globals.push_back(top);
    Eigen::Matrix4d ib = Eigen::Matrix4d::Identity();
    if (!ibm.values.empty())
      for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) ib(r, c) = ibm.at(j, c * 4 + r);
    if (std::abs(ib.determinant()) < 1e-20) fail(file, "range", "inverse bind matrix of joint '" + s.names.back() + "' is singular");
    s.inverse_bind.push_back(ib);
  }

  // Materials and their base-colour textures (one per glTF texture: an image and a sampler).
  std::vector<int> texture_of(m.textures.size(), -1);
  for (const auto& mat : m.materials) {
    Material mm;
    mm.name = mat.name;
    const auto& f = mat.pbrMetallicRoughness.baseColorFactor;
    if (f.size() == 4)
      for (int c = 0; c < 4; ++c) {
        if (!finite(f[static_cast<std::size_t>(c)])) fail(file, "not_finite", "material '" + mat.name + "': baseColorFactor is not finite");
        mm.base_color[static_cast<std::size_t>(c)] = static_cast<float>(std::clamp(f[static_cast<std::size_t>(c)], 0.0, 1.0));
      }
    const int ti = mat.pbrMetallicRoughness.baseColorTexture.index;
    if (ti >= 0) {
      if (static_cast<std::size_t>(ti) >= m.textures.size()) fail(file, "index", "material '" + mat.name + "': texture " + std::to_string(ti) + " does not exist");
      const int src = m.textures[static_cast<std::size_t>(ti)].source;
      if (src < 0 || static_cast<std::size_t>(src) >= m.images.size())
        fail(file, "index", "material '" + mat.name + "': its texture has no image");
      if (texture_of[static_cast<std::size_t>(ti)] == -1) {
        Texture tex;
        tex.name = image_label(m.images[static_cast<std::size_t>(src)], src);
        to_rgba8(m.images[static_cast<std::size_t>(src)], src, tex, file);
        const int si = m.textures[static_cast<std::size_t>(ti)].sampler;
        if (si >= 0) {
          if (static_cast<std::size_t>(si) >= m.samplers.size()) fail(file, "index", "texture " + std::to_string(ti) + ": sampler " + std::to_string(si) + " does not exist");
          read_sampler(m.samplers[static_cast<std::size_t>(si)], si, tex, file);
        }
        texture_of[static_cast<std::size_t>(ti)] = static_cast<int>(out.textures.size());
        out.textures.push_back(std::move(tex));
      }
      mm.base_color_texture = texture_of[static_cast<std::size_t>(ti)];
    }
    out.materials.push_back(std::move(mm));
  }

  // Every primitive of every mesh node bound to the skin.
  const std::initializer_list<int> any_float = {TINYGLTF_COMPONENT_TYPE_FLOAT};
  for (std::size_t ni = 0; ni < node_count; ++ni) {
    const tinygltf::Node& node = m.nodes[ni];
    if (node.mesh < 0 || node.skin < 0) continue;
    // This mesh's skin: its joints as the primary skin's (new) indices, and the matrix taking
    // its bind vertices into the primary skin's bind space (IBM_0j^-1 * IBM_kj, one for all j).
    const tinygltf::Skin& mine = m.skins[static_cast<std::size_t>(node.skin)];
    if (mine.joints.size() != jn) fail(file, "skin", "mesh node " + std::to_string(ni) + " is bound to a skin on other joints");
    std::vector<int> remap(jn);
    for (std::size_t j = 0; j < jn; ++j) {
      const int n = mine.joints[j];
      const int pj = n >= 0 && static_cast<std::size_t>(n) < node_count ? joint_of_node[static_cast<std::size_t>(n)] : -1;
      if (pj < 0) fail(file, "skin", "mesh node " + std::to_string(ni) + " is bound to a skin on other joints");
      remap[j] = new_index[static_cast<std::size_t>(pj)];
    }
    Eigen::Matrix4d carry = Eigen::Matrix4d::Identity();
    if (node.skin != skin) {
      std::vector<Eigen::Matrix4d> mine_ibm(jn, Eigen::Matrix4d::Identity());
      if (mine.inverseBindMatrices >= 0) {
        const Decoded d = reader.decode(mine.inverseBindMatrices, "inverseBindMatrices", {TINYGLTF_TYPE_MAT4}, {TINYGLTF_COMPONENT_TYPE_FLOAT});
        if (d.count < jn) fail(file, "range", "inverseBindMatrices of skin " + std::to_string(node.skin) + " is short");
        for (std::size_t j = 0; j < jn; ++j)
          for (int c = 0; c < 4; ++c)
            for (int r = 0; r < 4; ++r) mine_ibm[static_cast<std::size_t>(remap[j])](r, c) = d.at(j, c * 4 + r);
      }
      std::vector<Eigen::Matrix4d> g(jn);
      rest_globals(s, g);
      carry = s.inverse_bind[0].inverse() * mine_ibm[0];
      for (std::size_t j = 0; j < jn; ++j) {
        const Eigen::Matrix4d a = g[j] * s.inverse_bind[j] * carry, b = g[j] * mine_ibm[j];
        if ((a - b).cwiseAbs().maxCoeff() > 1e-4 * (1 + b.cwiseAbs().maxCoeff()))
          fail(file, "skin", "mesh node " + std::to_string(ni) + ": its skin's bind pose differs from the first skin's");
      }
    }
    const Eigen::Matrix3d carry_normal = carry.topLeftCorner<3, 3>().inverse().transpose();
    if (static_cast<std::size_t>(node.mesh) >= m.meshes.size()) fail(file, "index", "node " + std::to_string(ni) + ": mesh does not exist");
    const tinygltf::Mesh& mesh = m.meshes[static_cast<std::size_t>(node.mesh)];
    for (std::size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
      const tinygltf::Primitive& p = mesh.primitives[pi];
      const std::string what = "mesh '" + mesh.name + "' primitive " + std::to_string(pi);
      if (p.mode != TINYGLTF_MODE_TRIANGLES && p.mode != -1) fail(file, "mode", what + ": only triangle lists are supported");
      if (p.extensions.count("KHR_draco_mesh_compression")) fail(file, "extension", what + ": Draco compression is not supported");
      auto attr = [&](const char* key) { auto it = p.attributes.find(key); return it == p.attributes.end() ? -1 : it->second; };
      if (attr("POSITION") < 0) fail(file, "attribute", what + ": no POSITION");
      if (attr("JOINTS_0") < 0 || attr("WEIGHTS_0") < 0) fail(file, "attribute", what + ": no JOINTS_0/WEIGHTS_0: not skinned");
      const Decoded pos = reader.decode(attr("POSITION"), what + " POSITION", {TINYGLTF_TYPE_VEC3}, any_float);
      const std::size_t vn = pos.count;
      auto same_count = [&](const Decoded& d, const char* key) {
        if (d.count != vn) fail(file, "range", what + " " + key + ": " + std::to_string(d.count) + " elements for " + std::to_string(vn) + " vertices");
      };
      Decoded nrm, uv;
      if (attr("NORMAL") >= 0) { nrm = reader.decode(attr("NORMAL"), what + " NORMAL", {TINYGLTF_TYPE_VEC3}, any_float); same_count(nrm, "NORMAL"); }
      if (attr("TEXCOORD_0") >= 0) {
        uv = reader.decode(attr("TEXCOORD_0"), what + " TEXCOORD_0", {TINYGLTF_TYPE_VEC2},
                           {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT});
        same_count(uv, "TEXCOORD_0");
      }
      std::vector<Decoded> js, ws;
      for (int set = 0; set < 2; ++set) {
        const std::string jk = "JOINTS_" + std::to_string(set), wk = "WEIGHTS_" + std::to_string(set);
        if (attr(jk.c_str()) < 0 && attr(wk.c_str()) < 0) continue;
        if (attr(jk.c_str()) < 0 || attr(wk.c_str()) < 0) fail(file, "attribute", what + ": " + jk + " and " + wk + " must come together");
        js.push_back(reader.decode(attr(jk.c_str()), what + " " + jk, {TINYGLTF_TYPE_VEC4},
                                   {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT}));
        ws.push_back(reader.decode(attr(wk.c_str()), what + " " + wk, {TINYGLTF_TYPE_VEC4},
                                   {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT}));
        same_count(js.back(), jk.c_str());
        same_count(ws.back(), wk.c_str());
        if (ws.back().component_type != TINYGLTF_COMPONENT_TYPE_FLOAT && !ws.back().normalized)
          fail(file, "type", what + " " + wk + ": integer weights must be normalized");
      }
      const std::size_t base = out.positions.size();
      if (base + vn > std::numeric_limits<std::uint32_t>::max()) fail(file, "range", "too many vertices");
      for (std::size_t v = 0; v < vn; ++v) {
        const Eigen::Vector3d pv = carry.topLeftCorner<3, 3>() * Eigen::Vector3d(pos.at(v, 0), pos.at(v, 1), pos.at(v, 2)) + carry.topRightCorner<3, 1>();
        out.positions.push_back(pv.cast<float>());
        Eigen::Vector3f nv = Eigen::Vector3f::Zero();
        if (nrm.count) {
          nv = (carry_normal * Eigen::Vector3d(nrm.at(v, 0), nrm.at(v, 1), nrm.at(v, 2))).cast<float>();
          if (nv.norm() > 1e-6f) nv.normalize();
        }
        out.normals.push_back(nv);
        out.uvs.emplace_back(uv.count ? static_cast<float>(uv.at(v, 0)) : 0.f, uv.count ? static_cast<float>(uv.at(v, 1)) : 0.f);
        // Up to eight influences: merge duplicates, keep the four largest, renormalise.
        std::array<std::pair<double, int>, 8> inf{};
        int k = 0;
        for (std::size_t set = 0; set < js.size(); ++set)
          for (int c = 0; c < 4; ++c) {
            const double w = ws[set].at(v, c);
            const double jd = js[set].at(v, c);
            if (w < 0) fail(file, "range", what + ": vertex " + std::to_string(v) + " has a negative weight");
            if (w == 0) continue;
            if (jd >= static_cast<double>(jn))
              fail(file, "index", what + ": vertex " + std::to_string(v) + " names joint " + std::to_string(static_cast<long>(jd)) + " of " + std::to_string(jn));
            const int j = remap[static_cast<std::size_t>(jd)];
            bool merged = false;
            for (int q = 0; q < k; ++q)
              if (inf[static_cast<std::size_t>(q)].second == j) { inf[static_cast<std::size_t>(q)].first += w; merged = true; }
            if (!merged) inf[static_cast<std::size_t>(k++)] = {w, j};
          }
        for (int a = 1; a < k; ++a)  // largest first (ties: lower joint first)
          for (int b = a; b > 0; --b) {
            auto& x = inf[static_cast<std::size_t>(b - 1)];
            auto& y = inf[static_cast<std::size_t>(b)];
            if (y.first > x.first || (y.first == x.first && y.second < x.second)) std::swap(x, y); else break;
          }
        const int keep = std::min(k, 4);
        double sum = 0;
        for (int q = 0; q < keep; ++q) sum += inf[static_cast<std::size_t>(q)].first;
        if (!(sum > 1e-8)) fail(file, "range", what + ": vertex " + std::to_string(v) + " has no weight");
        std::array<std::uint16_t, 4> jj{};
        std::array<float, 4> ww{};
        for (int q = 0; q < keep; ++q) {
          jj[static_cast<std::size_t>(q)] = static_cast<std::uint16_t>(inf[static_cast<std::size_t>(q)].second);
          ww[static_cast<std::size_t>(q)] = static_cast<float>(inf[static_cast<std::size_t>(q)].first / sum);
        }
        out.joints.push_back(jj);
        out.weights.push_back(ww);
      }
      Primitive prim;
      prim.mesh = mesh.name;
      prim.first_index = static_cast<std::uint32_t>(out.indices.size());
      if (p.material >= 0) {
        if (static_cast<std::size_t>(p.material) >= m.materials.size()) fail(file, "index", what + ": material does not exist");
        prim.material = p.material;
      }
      if (p.indices >= 0) {
        const Decoded idx = reader.decode(p.indices, what + " indices", {TINYGLTF_TYPE_SCALAR},
                                          {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT});
        if (idx.normalized) fail(file, "type", what + " indices must not be normalized");
        if (idx.count % 3) fail(file, "range", what + ": index count is not a multiple of 3");
        for (std::size_t i = 0; i < idx.count; ++i) {
          const double x = idx.values[i];
          if (x >= static_cast<double>(vn)) fail(file, "index", what + ": index " + std::to_string(static_cast<long long>(x)) + " past its " + std::to_string(vn) + " vertices");
          out.indices.push_back(static_cast<std::uint32_t>(base + static_cast<std::size_t>(x)));
        }
      } else {
        if (vn % 3) fail(file, "range", what + ": vertex count is not a multiple of 3");
        for (std::size_t i = 0; i < vn; ++i) out.indices.push_back(static_cast<std::uint32_t>(base + i));
      }
      prim.index_count = static_cast<std::uint32_t>(out.indices.size()) - prim.first_index;
      out.primitives.push_back(std::move(prim));
    }
  }
  if (out.positions.empty()) fail(file, "skin", "the skinned meshes have no vertices");
  // The rest pose must be drawable: finite globals and palette.
  std::vector<Eigen::Matrix4f> palette(jn);
  rest_palette(out, palette);
  for (std::size_t j = 0; j < jn; ++j)
    if (!palette[j].allFinite()) fail(file, "not_finite", "joint '" + s.names[j] + "': its rest transform is not finite");
  // ...and so must its vertices skinned there: finite numbers whose products overflow (a
  // float near 3e38 in a translation or a position) drew an exploded mesh (fuzz_gltf).
  std::vector<Eigen::Vector3f> rest(out.vertex_count()), rest_normals(out.vertex_count());
  skin_cpu(out, palette, rest, rest_normals);
  for (std::size_t v = 0; v < rest.size(); ++v)
    if (!rest[v].allFinite())
      fail(file, "not_finite", "vertex " + std::to_string(v) + ": skinned at the rest pose it is not finite (numbers too large to draw)");
  return out;
}

}  // namespace kumite::body
