/// @file gltf_test.cpp
/// @brief Tests for src/io/gltf.h: mesh.glb read back with tinygltf, every attribute checked
/// exactly; colours, baked AO, the AO grey, unit normals, empty meshes and write errors.
#include "io/gltf.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include "core/status.h"
#include "support/error_message.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

using testing::error_message;
using testing::read_bytes;
using testing::ScratchDir;

/// Two triangles: normals unit, unit but not exactly in float, too long and zero; colours; AO
/// in and out of [0, 1].
TriangleMesh known_mesh() {
  TriangleMesh m;
  m.vertices = {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 0.5f}};
  m.normals = {{0, 0, -1}, {0.6f, 0, -0.8f}, {0, 0, -2}, {0, 0, 0}};
  m.quality = {1.0f, 0.5f, 1.5f, -0.25f};
  m.colours = {{255, 0, 128}, {10, 20, 30}, {0, 0, 0}, {200, 100, 50}};
  m.faces = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

/// glTF's linear value of an sRGB byte, from the definition.
float linear(int srgb) {
  const double c = srgb / 255.0;
  return static_cast<float>(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
}

std::vector<float> linear(const std::vector<Rgb8>& colours) {
  std::vector<float> out;
  for (const Rgb8& c : colours) out.insert(out.end(), {linear(c.r), linear(c.g), linear(c.b)});
  return out;
}

tinygltf::Model load(const std::string& path) {
  tinygltf::Model model;
  tinygltf::TinyGLTF gltf;
  std::string err, warn;
  EXPECT_TRUE(gltf.LoadBinaryFromFile(&model, &err, &warn, path)) << err;
  EXPECT_EQ(err, "");
  EXPECT_EQ(warn, "");
  return model;
}

/// The values of accessor `index` (component type `component`, `components` per element), read
/// through its buffer view's offset and stride.
template <typename T>
std::vector<T> values(const tinygltf::Model& model, int index, int component, int type) {
  const tinygltf::Accessor& a = model.accessors.at(index);
  EXPECT_EQ(a.componentType, component);
  EXPECT_EQ(a.type, type);
  EXPECT_FALSE(a.normalized);
  EXPECT_FALSE(a.sparse.isSparse);
  const tinygltf::BufferView& view = model.bufferViews.at(a.bufferView);
  const std::vector<unsigned char>& data = model.buffers.at(view.buffer).data;
  const int components = tinygltf::GetNumComponentsInType(type);
  const std::size_t stride = a.ByteStride(view);
  EXPECT_EQ(stride, components * sizeof(T));
  EXPECT_EQ(view.byteLength, a.count * stride);  // no view holds more than its accessor
  EXPECT_LE(view.byteOffset + view.byteLength, data.size());
  EXPECT_EQ((view.byteOffset + a.byteOffset) % 4, 0u);
  std::vector<T> out(a.count * components);
  for (std::size_t i = 0; i < a.count; ++i)
    std::memcpy(&out[i * components], data.data() + view.byteOffset + a.byteOffset + i * stride,
                components * sizeof(T));
  return out;
}

std::vector<float> floats(const tinygltf::Model& model, const tinygltf::Primitive& p,
                          const std::string& name, int type) {
  return values<float>(model, p.attributes.at(name), TINYGLTF_COMPONENT_TYPE_FLOAT, type);
}

std::vector<float> flat(const std::vector<Eigen::Vector3f>& v) {
  std::vector<float> out;
  for (const Eigen::Vector3f& x : v) out.insert(out.end(), {x.x(), x.y(), x.z()});
  return out;
}

TEST(Gltf, EveryAttributeReadsBackExactly) {
  ScratchDir dir;
  const TriangleMesh m = known_mesh();
  write_glb(dir.file("mesh.glb"), m);
  const tinygltf::Model model = load(dir.file("mesh.glb"));

  EXPECT_EQ(model.asset.version, "2.0");
  EXPECT_EQ(model.asset.generator, "aoscan");
  ASSERT_EQ(model.scenes.size(), 1u);
  EXPECT_EQ(model.defaultScene, 0);
  EXPECT_EQ(model.scenes[0].nodes, std::vector<int>{0});
  ASSERT_EQ(model.nodes.size(), 1u);
  EXPECT_EQ(model.nodes[0].mesh, 0);
  EXPECT_EQ(model.nodes[0].rotation, (std::vector<double>{1, 0, 0, 0}));
  EXPECT_TRUE(model.nodes[0].translation.empty());
  EXPECT_TRUE(model.nodes[0].matrix.empty());
  ASSERT_EQ(model.buffers.size(), 1u);
  EXPECT_TRUE(model.buffers[0].uri.empty());  // the GLB's BIN chunk
  ASSERT_EQ(model.meshes.size(), 1u);
  ASSERT_EQ(model.meshes[0].primitives.size(), 1u);
  const tinygltf::Primitive& p = model.meshes[0].primitives[0];
  EXPECT_EQ(p.mode, TINYGLTF_MODE_TRIANGLES);
  std::vector<std::string> names;
  for (const auto& [name, accessor] : p.attributes) names.push_back(name);
  EXPECT_EQ(names, (std::vector<std::string>{"COLOR_0", "NORMAL", "POSITION", "_AO"}));
  ASSERT_EQ(p.material, 0);
  const tinygltf::Material& material = model.materials.at(0);
  EXPECT_TRUE(material.doubleSided);
  EXPECT_EQ(material.pbrMetallicRoughness.metallicFactor, 0.0);
  EXPECT_EQ(material.pbrMetallicRoughness.roughnessFactor, 1.0);
  EXPECT_EQ(material.pbrMetallicRoughness.baseColorFactor, (std::vector<double>{1, 1, 1, 1}));

  EXPECT_EQ(floats(model, p, "POSITION", TINYGLTF_TYPE_VEC3), flat(m.vertices));
  const tinygltf::Accessor& position = model.accessors[p.attributes.at("POSITION")];
  EXPECT_EQ(position.count, 4u);
  EXPECT_EQ(position.minValues, (std::vector<double>{0, 0, 0.5}));
  EXPECT_EQ(position.maxValues, (std::vector<double>{1, 1, 1}));
  // Unit normals are kept bit for bit, (0, 0, -2) is normalised, and the zero normal of vertex 3
  // becomes that of its face (0, 2, 3): (1, 1, 0) x (0, 1, -0.5) = (-0.5, 0.5, 1), normalised.
  const Eigen::Vector3f face = (Eigen::Vector3d(-0.5, 0.5, 1.0) / std::sqrt(1.5)).cast<float>();
  EXPECT_EQ(floats(model, p, "NORMAL", TINYGLTF_TYPE_VEC3),
            flat({{0, 0, -1}, {0.6f, 0, -0.8f}, {0, 0, -1}, face}));
  EXPECT_EQ(floats(model, p, "COLOR_0", TINYGLTF_TYPE_VEC3), linear(m.colours));
  EXPECT_EQ(floats(model, p, "_AO", TINYGLTF_TYPE_SCALAR),
            (std::vector<float>{1.0f, 0.5f, 1.0f, 0.0f}));
  for (const auto& [name, accessor] : p.attributes) {
    EXPECT_EQ(model.accessors[accessor].count, 4u) << name;
    EXPECT_EQ(model.bufferViews[model.accessors[accessor].bufferView].target,
              TINYGLTF_TARGET_ARRAY_BUFFER)
        << name;
  }
  EXPECT_EQ(values<std::uint32_t>(model, p.indices, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                                  TINYGLTF_TYPE_SCALAR),
            (std::vector<std::uint32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_EQ(model.bufferViews[model.accessors[p.indices].bufferView].target,
            TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
  // 4 x (12 + 12 + 12 + 4) bytes of vertices and 2 x 12 of faces, nothing else.
  EXPECT_EQ(model.buffers[0].data.size(), 4u * 40 + 24);
}

TEST(Gltf, LinearColoursFromSrgb) {
  EXPECT_EQ(srgb_to_linear(0), 0.0f);
  EXPECT_EQ(srgb_to_linear(255), 1.0f);
  EXPECT_EQ(srgb_to_linear(10), static_cast<float>(10 / 255.0 / 12.92));  // the linear segment
  EXPECT_EQ(srgb_to_linear(11), static_cast<float>(std::pow((11 / 255.0 + 0.055) / 1.055, 2.4)));
  EXPECT_NEAR(srgb_to_linear(128), 0.2158605f, 1e-7f);
  for (int c = 0; c < 256; ++c) EXPECT_EQ(srgb_to_linear(static_cast<unsigned char>(c)), linear(c));
}

TEST(Gltf, BakeAoMultipliesTheColourByTheAo) {
  ScratchDir dir;
  write_glb(dir.file("mesh.glb"), known_mesh(), MeshWriteOptions{true});
  const tinygltf::Model model = load(dir.file("mesh.glb"));
  const tinygltf::Primitive& p = model.meshes.at(0).primitives.at(0);
  // AO 1, 0.5, 1 (1.5 clamped), 0 (-0.25 clamped) times the sRGB bytes, then linear.
  EXPECT_EQ(floats(model, p, "COLOR_0", TINYGLTF_TYPE_VEC3),
            linear({{255, 0, 128}, {5, 10, 15}, {0, 0, 0}, {0, 0, 0}}));
  EXPECT_EQ(floats(model, p, "_AO", TINYGLTF_TYPE_SCALAR),
            (std::vector<float>{1.0f, 0.5f, 1.0f, 0.0f}));
}

TEST(Gltf, WithoutColoursTheAoIsTheGreyColour) {
  ScratchDir dir;
  TriangleMesh m = known_mesh();
  m.colours.clear();
  m.quality = {1.0f, 0.5f, 0.25f, 0.0f};
  for (const bool bake : {false, true}) {
    write_glb(dir.file("mesh.glb"), m, MeshWriteOptions{bake});
    const tinygltf::Model model = load(dir.file("mesh.glb"));
    const tinygltf::Primitive& p = model.meshes.at(0).primitives.at(0);
    // Grey bytes 255, round(127.5) = 128, round(63.75) = 64, 0, as mesh.ply's.
    EXPECT_EQ(floats(model, p, "COLOR_0", TINYGLTF_TYPE_VEC3),
              linear({{255, 255, 255}, {128, 128, 128}, {64, 64, 64}, {0, 0, 0}}));
    EXPECT_EQ(floats(model, p, "_AO", TINYGLTF_TYPE_SCALAR), m.quality);
  }
}

TEST(Gltf, OptionalAttributesAreLeftOut) {
  ScratchDir dir;
  TriangleMesh m = known_mesh();
  m.normals.clear();
  m.quality.clear();
  write_glb(dir.file("colours.glb"), m);
  tinygltf::Model model = load(dir.file("colours.glb"));
  const tinygltf::Primitive* p = &model.meshes.at(0).primitives.at(0);
  EXPECT_EQ(p->attributes.size(), 2u);
  EXPECT_EQ(floats(model, *p, "COLOR_0", TINYGLTF_TYPE_VEC3), linear(m.colours));

  m.colours.clear();
  write_glb(dir.file("plain.glb"), m);
  model = load(dir.file("plain.glb"));
  p = &model.meshes.at(0).primitives.at(0);
  EXPECT_EQ(p->attributes.size(), 1u);
  EXPECT_EQ(floats(model, *p, "POSITION", TINYGLTF_TYPE_VEC3), flat(m.vertices));
  EXPECT_EQ(model.buffers.at(0).data.size(), 4u * 12 + 24);
}

TEST(Gltf, FileIsAGlbAndTheSameMeshGivesTheSameBytes) {
  ScratchDir dir;
  write_glb(dir.file("a.glb"), known_mesh());
  write_glb(dir.file("b.glb"), known_mesh());
  const std::string bytes = read_bytes(dir.file("a.glb"));
  EXPECT_EQ(bytes, read_bytes(dir.file("b.glb")));
  ASSERT_GE(bytes.size(), 20u);
  std::uint32_t version, length;
  std::memcpy(&version, bytes.data() + 4, 4);
  std::memcpy(&length, bytes.data() + 8, 4);
  EXPECT_EQ(bytes.substr(0, 4), "glTF");
  EXPECT_EQ(version, 2u);
  EXPECT_EQ(length, bytes.size());
  EXPECT_EQ(bytes.size() % 4, 0u);
  EXPECT_FALSE(std::filesystem::exists(dir.file("a.glb.partial")));
}

TEST(Gltf, MeshWithoutFacesGivesAnEmptyScene) {
  ScratchDir dir;
  TriangleMesh points = known_mesh();
  points.faces.clear();
  for (const TriangleMesh& m : {TriangleMesh{}, points}) {
    write_glb(dir.file("empty.glb"), m);
    const tinygltf::Model model = load(dir.file("empty.glb"));
    ASSERT_EQ(model.scenes.size(), 1u);
    EXPECT_EQ(model.scenes[0].nodes, std::vector<int>{0});
    ASSERT_EQ(model.nodes.size(), 1u);
    EXPECT_EQ(model.nodes[0].mesh, -1);
    EXPECT_EQ(model.nodes[0].rotation, (std::vector<double>{1, 0, 0, 0}));
    EXPECT_TRUE(model.meshes.empty());
    EXPECT_TRUE(model.accessors.empty());
    EXPECT_TRUE(model.buffers.empty());
  }
}

TEST(Gltf, RejectsInconsistentMeshesAndUnwritablePaths) {
  ScratchDir dir;
  const std::string path = dir.file("mesh.glb");
  TriangleMesh m = known_mesh();
  m.colours.pop_back();
  EXPECT_EQ(error_message([&] { write_glb(path, m); }, ExitCode::kUsage),
            path + ": mesh has 3 colours for 4 vertices");
  m = known_mesh();
  m.quality.push_back(1.0f);
  EXPECT_EQ(error_message([&] { write_glb(path, m); }, ExitCode::kUsage),
            path + ": mesh has 5 quality values for 4 vertices");
  m = known_mesh();
  m.faces.emplace_back(0, 1, 4);
  EXPECT_EQ(error_message([&] { write_glb(path, m); }, ExitCode::kUsage),
            path + ": face 2 has vertex index 4 out of range");
  m = known_mesh();
  m.vertices[2].y() = std::nanf("");
  EXPECT_EQ(error_message([&] { write_glb(path, m); }, ExitCode::kUsage),
            path + ": vertex 2 has a non-finite position, which glTF does not allow");
  EXPECT_FALSE(std::filesystem::exists(path));

  const std::string unwritable = dir.file("no/such/dir/mesh.glb");
  EXPECT_EQ(error_message([&] { write_glb(unwritable, known_mesh()); }, ExitCode::kFailure),
            unwritable + ": cannot write: No such file or directory");
}

}  // namespace
}  // namespace aoscan
