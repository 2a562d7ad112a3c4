// The loader on small hand-written files: normalized u16 weights decoded, and what cannot be
// drawn right refused in one line naming the file.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "kumite/body/model.hpp"
#include "kumite/common/error.hpp"

namespace fs = std::filesystem;
using namespace kumite::body;

namespace {

std::string base64(const std::vector<unsigned char>& in) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  std::size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const unsigned v = (in[i] << 16) | (in[i + 1] << 8) | in[i + 2];
    for (int k = 3; k >= 0; --k) out += t[(v >> (6 * k)) & 63];
  }
  if (i < in.size()) {
    unsigned v = in[i] << 16;
    if (i + 1 < in.size()) v |= in[i + 1] << 8;
    out += t[(v >> 18) & 63];
    out += t[(v >> 12) & 63];
    out += i + 1 < in.size() ? t[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

template <class T>
void put(std::vector<unsigned char>& b, T v) {
  unsigned char x[sizeof(T)];
  std::memcpy(x, &v, sizeof(T));
  b.insert(b.end(), x, x + sizeof(T));
}

/// A two-joint skinned triangle: joint 0 at the origin, joint 1 one metre up (its child).
/// Weights as normalized u16 (`weights_u16`, per vertex two values) or floats.
std::string triangle_gltf(const std::array<std::array<std::uint16_t, 2>, 3>& weights_u16, const std::string& extra = "",
                          float x0 = 0.f) {
  std::vector<unsigned char> b;
  const float pos[9] = {x0, 0, 0, 1, 0, 0, 0, 1, 0};
  for (float f : pos) put(b, f);                       // 0: 36 bytes positions
  for (int v = 0; v < 3; ++v) {                        // 36: joints u16 x4
    put<std::uint16_t>(b, 0); put<std::uint16_t>(b, 1); put<std::uint16_t>(b, 0); put<std::uint16_t>(b, 0);
  }
  for (int v = 0; v < 3; ++v) {                        // 60: weights u16 x4 normalized
    put(b, weights_u16[static_cast<std::size_t>(v)][0]); put(b, weights_u16[static_cast<std::size_t>(v)][1]);
    put<std::uint16_t>(b, 0); put<std::uint16_t>(b, 0);
  }
  const float ibm[32] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1,       // joint 0 at the origin
                         1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -1, 0, 1};     // joint 1 at y = 1
  for (float f : ibm) put(b, f);                       // 84: 128 bytes
  const std::string uri = "data:application/octet-stream;base64," + base64(b);
  return R"({"asset":{"version":"2.0"},)" + extra + R"("scene":0,"scenes":[{"nodes":[0,2]}],
  "nodes":[{"name":"hip","children":[1]},{"name":"top","translation":[0,1,0]},{"name":"mesh","mesh":0,"skin":0}],
  "skins":[{"joints":[0,1],"inverseBindMatrices":3}],
  "meshes":[{"name":"tri","primitives":[{"attributes":{"POSITION":0,"JOINTS_0":1,"WEIGHTS_0":2}}]}],
  "buffers":[{"byteLength":)" + std::to_string(b.size()) + R"(,"uri":")" + uri + R"("}],
  "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":24},
                 {"buffer":0,"byteOffset":60,"byteLength":24},{"buffer":0,"byteOffset":84,"byteLength":128}],
  "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
               {"bufferView":1,"componentType":5123,"count":3,"type":"VEC4"},
               {"bufferView":2,"componentType":5123,"normalized":true,"count":3,"type":"VEC4"},
               {"bufferView":3,"componentType":5126,"count":2,"type":"MAT4"}]})";
}

fs::path write(const std::string& name, const std::string& text) {
  const fs::path p = fs::temp_directory_path() / ("kumite_body_" + name);
  std::ofstream(p, std::ios::binary) << text;
  return p;
}

std::string refusal(const fs::path& p) {
  try {
    load_model(p);
  } catch (const kumite::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(ModelBadInput, NormalizedU16WeightsAreDecodedAndRenormalised) {
  // 65535 = 1.0; 16384 + 16384 = 0.25 + 0.25, renormalised to 0.5 + 0.5; 49151/16384 = 0.75/0.25.
  const fs::path p = write("u16.gltf", triangle_gltf({{{65535, 0}, {16384, 16384}, {49151, 16384}}}));
  const SkinnedModel m = load_model(p);
  ASSERT_EQ(m.vertex_count(), 3u);
  EXPECT_EQ(m.skeleton.names, (std::vector<std::string>{"hip", "top"}));
  EXPECT_EQ(m.skeleton.parents, (std::vector<int>{-1, 0}));
  EXPECT_FLOAT_EQ(m.weights[0][0], 1.f);
  EXPECT_EQ(m.joints[0][0], 0);
  EXPECT_NEAR(m.weights[1][0], 0.5, 1e-6);
  EXPECT_NEAR(m.weights[1][1], 0.5, 1e-6);
  EXPECT_NEAR(m.weights[2][0], 49151.0 / 65535 / (49151.0 / 65535 + 16384.0 / 65535), 1e-6);
  EXPECT_EQ(m.joints[2][0], 0);
  EXPECT_EQ(m.joints[2][1], 1);
  for (const auto& w : m.weights) EXPECT_NEAR(w[0] + w[1] + w[2] + w[3], 1.0, 1e-6);
  // Rest skinning gives the bind vertices.
  std::vector<Eigen::Matrix4f> pal(2);
  rest_palette(m, pal);
  std::vector<Eigen::Vector3f> v(3), n(3);
  skin_cpu(m, pal, v, n);
  for (int i = 0; i < 3; ++i) EXPECT_LT((v[static_cast<std::size_t>(i)] - m.positions[static_cast<std::size_t>(i)]).norm(), 1e-6);
  fs::remove(p);
}

TEST(ModelBadInput, ExtensionsRequiredIsRefusedNamingTheFile) {
  const fs::path p = write("draco.gltf", triangle_gltf({{{65535, 0}, {65535, 0}, {65535, 0}}},
                                                       R"("extensionsUsed":["KHR_draco_mesh_compression"],"extensionsRequired":["KHR_draco_mesh_compression"],)"));
  const std::string why = refusal(p);
  EXPECT_NE(why.find(p.string()), std::string::npos) << why;
  EXPECT_NE(why.find("KHR_draco_mesh_compression"), std::string::npos) << why;
  EXPECT_EQ(why.find('\n'), std::string::npos) << why;
  fs::remove(p);
}

TEST(ModelBadInput, TruncatedFilesAreRefusedNamingTheFile) {
  // A shipped .glb cut at several places, and the .gltf cut in its JSON.
  std::ifstream in(fs::path(KUMITE_SOURCE_DIR) / "body" / "assets" / "male_base_mesh.glb", std::ios::binary);
  const std::string glb((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(glb.size(), 90000u);
  for (std::size_t cut : {std::size_t{10}, std::size_t{100}, glb.size() / 2, glb.size() - 1}) {
    SCOPED_TRACE(cut);
    const fs::path p = write("cut.glb", glb.substr(0, cut));
    const std::string why = refusal(p);
    EXPECT_NE(why.find(p.string() + ": "), std::string::npos) << why;
    EXPECT_EQ(why.find('\n'), std::string::npos) << why;
    fs::remove(p);
  }
  const std::string text = triangle_gltf({{{65535, 0}, {65535, 0}, {65535, 0}}});
  const fs::path p = write("cut.gltf", text.substr(0, text.size() / 2));
  EXPECT_NE(refusal(p).find(p.string() + ": "), std::string::npos);
  fs::remove(p);
}

TEST(ModelBadInput, NonFinitePositionsNoSkinAndBadIndicesAreRefused) {
  {
    const fs::path p = write("nan.gltf", triangle_gltf({{{65535, 0}, {65535, 0}, {65535, 0}}}, "", std::nanf("")));
    EXPECT_NE(refusal(p).find("not finite"), std::string::npos) << refusal(p);
    fs::remove(p);
  }
  {
    std::string t = triangle_gltf({{{65535, 0}, {65535, 0}, {65535, 0}}});
    t.replace(t.find(R"("mesh":0,"skin":0)"), 17, R"("mesh":0)");
    const fs::path p = write("noskin.gltf", t);
    EXPECT_NE(refusal(p).find("no skinned mesh"), std::string::npos) << refusal(p);
    fs::remove(p);
  }
  {
    std::string t = triangle_gltf({{{65535, 0}, {65535, 0}, {65535, 0}}});
    t.replace(t.find(R"("count":2,"type":"MAT4")"), 9, R"("count":9)");
    const fs::path p = write("ibm.gltf", t);
    EXPECT_NE(refusal(p).find(p.string() + ": "), std::string::npos) << refusal(p);
    fs::remove(p);
  }
}

TEST(ModelBadInput, AMissingTextureIsRefusedNamingTheFileAndTheImage) {
  // A base-colour texture whose image file is not there: one line naming the model and the
  // image (the app then draws the capsule figure: BodyRender.ABodyThatCannotBeWorn...).
  const std::string extra = R"("materials":[{"name":"skin","pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}],
  "textures":[{"source":0}],"images":[{"uri":"missing_texture.png"}],)";
  const fs::path p = write("missing_texture.gltf", triangle_gltf({{{65535, 0}, {65535, 0}, {65535, 0}}}, extra));
  const std::string why = refusal(p);
  std::printf("%s\n", why.c_str());
  EXPECT_NE(why.find(p.string()), std::string::npos) << why;
  EXPECT_NE(why.find("missing_texture.png"), std::string::npos) << why;
  EXPECT_EQ(why.find('\n'), std::string::npos) << why;
  fs::remove(p);
}

namespace {
/// A 1 x 1 RGBA PNG (a standard test image; its chunks' CRCs checked when this was written).
const char* kPixelPng = "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNk+M9QDwADhgGAWjR9awAAAABJRU5ErkJggg==";
std::string textured(const std::string& sampler) {
  return R"("materials":[{"name":"skin","pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}],
  "textures":[{"source":0)" + std::string(sampler.empty() ? "" : R"(,"sampler":0)") + R"(}],
  "images":[{"uri":"data:image/png;base64,)" + kPixelPng + R"("}],)" +
         (sampler.empty() ? std::string() : R"("samplers":[)" + sampler + "],");
}
}  // namespace

TEST(ModelBadInput, ATexturesSamplerIsReadAndOneGltfDoesNotAllowIsRefused) {
  // No sampler: glTF's defaults (repeat, linear, trilinear).
  {
    const fs::path p = write("default_sampler.gltf", triangle_gltf({{{65535, 0}, {65535, 0}, {65535, 0}}}, textured("")));
    const SkinnedModel m = load_model(p);
    ASSERT_EQ(m.textures.size(), 1u);
    EXPECT_EQ(m.textures[0].width, 1);
    EXPECT_EQ(m.textures[0].wrap_s, 10497);
    EXPECT_EQ(m.textures[0].mag_filter, 9729);
    EXPECT_EQ(m.textures[0].min_filter, 9987);
    fs::remove(p);
  }
  // The file's own: clamped and mirrored, nearest.
  {
    const fs::path p = write("own_sampler.gltf", triangle_gltf({{{65535, 0}, {65535, 0}, {65535, 0}}},
                                                               textured(R"({"magFilter":9728,"minFilter":9984,"wrapS":33071,"wrapT":33648})")));
    const SkinnedModel m = load_model(p);
    ASSERT_EQ(m.textures.size(), 1u);
    EXPECT_EQ(m.textures[0].wrap_s, 33071);
    EXPECT_EQ(m.textures[0].wrap_t, 33648);
    EXPECT_EQ(m.textures[0].mag_filter, 9728);
    EXPECT_EQ(m.textures[0].min_filter, 9984);
    fs::remove(p);
  }
  // A value glTF does not allow (a mipmap filter for magnification): one line naming the file.
  {
    const fs::path p = write("bad_sampler.gltf", triangle_gltf({{{65535, 0}, {65535, 0}, {65535, 0}}}, textured(R"({"magFilter":9987})")));
    const std::string why = refusal(p);
    std::printf("%s\n", why.c_str());
    EXPECT_NE(why.find(p.string()), std::string::npos) << why;
    EXPECT_NE(why.find("magFilter 9987"), std::string::npos) << why;
    EXPECT_EQ(why.find('\n'), std::string::npos) << why;
    fs::remove(p);
  }
}

TEST(ModelBadInput, TheGltfFuzzersSeedsAreModelsItCanDraw) {
  // tests/body/fuzz/corpus_fuzz_gltf: a textured two-joint triangle as .gltf (inline data) and
  // as .glb (buffer and PNG in the binary chunk): the fuzzer starts from files that load.
  for (const char* name : {"triangle_textured.gltf", "triangle_textured.glb"}) {
    const SkinnedModel m = load_model(fs::path(KUMITE_SOURCE_DIR) / "tests/body/fuzz/corpus_fuzz_gltf" / name);
    EXPECT_EQ(m.vertex_count(), 3u) << name;
    EXPECT_EQ(m.skeleton.joint_count(), 2) << name;
    ASSERT_EQ(m.textures.size(), 1u) << name;
    EXPECT_EQ(m.textures[0].wrap_t, 33071) << name;
    EXPECT_FLOAT_EQ(m.uvs[1].x(), 1.0f) << name;
  }
}

TEST(ModelBadInput, AModelWhoseRestPoseSkinsToInfinityIsRefused) {
  // fuzz_gltf's first finding: the textured triangle with a few bytes changed into a float near
  // 3e38; every number finite, the rest palette finite, the vertices skinned there not.
  const fs::path p = fs::path(KUMITE_SOURCE_DIR) / "tests/body/fuzz/corpus_fuzz_gltf/regression-rest-skinning-overflow.glb";
  const std::string why = refusal(p);
  std::printf("%s\n", why.c_str());
  EXPECT_NE(why.find(p.string()), std::string::npos) << why;
  EXPECT_NE(why.find("not finite"), std::string::npos) << why;
}
