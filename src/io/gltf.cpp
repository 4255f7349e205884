/// @file gltf.cpp
/// @brief mesh.glb through tinygltf: the model is built here, tinygltf serialises it.
#include "io/gltf.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <vector>

#include <tiny_gltf.h>

#include "core/status.h"
#include "io/atomic_write.h"

namespace aoscan {
namespace {

// The buffer takes the arrays' bytes as they are in memory; glTF's are little-endian.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "glTF buffers are little-endian");
static_assert(sizeof(Eigen::Vector3f) == 12 && sizeof(Eigen::Vector3i) == 12,
              "Eigen 3-vectors are three packed 32-bit values");

/// A normal within this of unit length (squared) is written as it is.
constexpr double kUnitTolerance = 1e-5;

/// Appends `bytes` bytes from `data` to buffer 0 as a new buffer view; its index.
int add_view(tinygltf::Model& model, const void* data, std::size_t bytes, int target) {
  std::vector<unsigned char>& buffer = model.buffers[0].data;
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = buffer.size();
  view.byteLength = bytes;
  view.target = target;
  const auto* first = static_cast<const unsigned char*>(data);
  buffer.insert(buffer.end(), first, first + bytes);
  model.bufferViews.push_back(std::move(view));
  return static_cast<int>(model.bufferViews.size()) - 1;
}

/// Adds an accessor of all of buffer view `view`; its index.
int add_accessor(tinygltf::Model& model, int view, int component_type, int type,
                 std::size_t count) {
  tinygltf::Accessor accessor;
  accessor.bufferView = view;
  accessor.componentType = component_type;
  accessor.type = type;
  accessor.count = count;
  model.accessors.push_back(std::move(accessor));
  return static_cast<int>(model.accessors.size()) - 1;
}

/// The mesh's normals made unit length (see write_glb()).
std::vector<Eigen::Vector3f> unit_normals(const TriangleMesh& mesh) {
  std::vector<Eigen::Vector3f> out(mesh.normals.size());
  std::vector<std::size_t> degenerate;
  for (std::size_t i = 0; i < mesh.normals.size(); ++i) {
    const Eigen::Vector3d n = mesh.normals[i].cast<double>();
    const double sq = n.squaredNorm();
    if (!(sq > 1e-30) || !std::isfinite(sq)) {
      degenerate.push_back(i);
    } else if (std::abs(sq - 1.0) <= kUnitTolerance) {
      out[i] = mesh.normals[i];
    } else {
      out[i] = (n / std::sqrt(sq)).cast<float>();
    }
  }
  if (degenerate.empty()) return out;
  std::vector<Eigen::Vector3d> sum(mesh.vertices.size(), Eigen::Vector3d::Zero());
  for (const Eigen::Vector3i& f : mesh.faces) {
    const Eigen::Vector3d a = mesh.vertices[f[0]].cast<double>();
    const Eigen::Vector3d area =
        (mesh.vertices[f[1]].cast<double>() - a).cross(mesh.vertices[f[2]].cast<double>() - a);
    for (int k = 0; k < 3; ++k) sum[f[k]] += area;
  }
  for (const std::size_t i : degenerate) {
    const double sq = sum[i].squaredNorm();
    out[i] = sq > 0.0 && std::isfinite(sq) ? (sum[i] / std::sqrt(sq)).cast<float>()
                                           : Eigen::Vector3f(0.0f, 0.0f, -1.0f);
  }
  return out;
}

/// The glTF model of `mesh` (which passed the checks of write_glb()).
tinygltf::Model gltf_model(const TriangleMesh& mesh, const MeshWriteOptions& options) {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "aoscan";
  tinygltf::Node node;
  node.name = "aoscan";
  node.rotation = {1.0, 0.0, 0.0, 0.0};  // 180 degrees about x: y down, z forward -> y up
  tinygltf::Scene scene;
  scene.nodes = {0};
  model.scenes.push_back(std::move(scene));
  model.defaultScene = 0;
  if (mesh.faces.empty()) {
    model.nodes.push_back(std::move(node));
    return model;
  }

  const std::size_t n = mesh.vertices.size();
  const bool normals = !mesh.normals.empty();
  const bool ao = !mesh.quality.empty();
  const bool colours = !mesh.colours.empty() || ao;
  model.buffers.emplace_back();
  model.buffers[0].data.reserve(12 * n * (1 + normals + colours) + 4 * n * ao +
                                12 * mesh.faces.size());
  tinygltf::Primitive primitive;
  primitive.mode = TINYGLTF_MODE_TRIANGLES;
  primitive.material = 0;

  const int position = add_accessor(
      model, add_view(model, mesh.vertices.data(), 12 * n, TINYGLTF_TARGET_ARRAY_BUFFER),
      TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);
  Eigen::Vector3f lo = mesh.vertices[0], hi = mesh.vertices[0];
  for (const Eigen::Vector3f& v : mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  model.accessors[position].minValues = {lo.x(), lo.y(), lo.z()};
  model.accessors[position].maxValues = {hi.x(), hi.y(), hi.z()};
  primitive.attributes["POSITION"] = position;

  if (normals) {
    const std::vector<Eigen::Vector3f> unit = unit_normals(mesh);
    primitive.attributes["NORMAL"] =
        add_accessor(model, add_view(model, unit.data(), 12 * n, TINYGLTF_TARGET_ARRAY_BUFFER),
                     TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);
  }
  if (colours) {
    std::array<float, 256> linear;
    for (int c = 0; c < 256; ++c) linear[c] = srgb_to_linear(static_cast<unsigned char>(c));
    std::vector<float> rgb(3 * n);
    for (std::size_t i = 0; i < n; ++i) {
      const Rgb8 c = written_colour(mesh, i, options);
      rgb[3 * i] = linear[c.r];
      rgb[3 * i + 1] = linear[c.g];
      rgb[3 * i + 2] = linear[c.b];
    }
    primitive.attributes["COLOR_0"] =
        add_accessor(model, add_view(model, rgb.data(), 12 * n, TINYGLTF_TARGET_ARRAY_BUFFER),
                     TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);
  }
  if (ao) {
    std::vector<float> values(n);
    for (std::size_t i = 0; i < n; ++i) values[i] = clamped_ao(mesh.quality[i]);
    primitive.attributes["_AO"] =
        add_accessor(model, add_view(model, values.data(), 4 * n, TINYGLTF_TARGET_ARRAY_BUFFER),
                     TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_SCALAR, n);
  }
  // Face indices are checked to lie in [0, n): their int bits are the unsigned values.
  primitive.indices = add_accessor(model,
                                   add_view(model, mesh.faces.data(), 12 * mesh.faces.size(),
                                            TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER),
                                   TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR,
                                   3 * mesh.faces.size());

  tinygltf::Material material;
  material.name = "aoscan";
  material.pbrMetallicRoughness.metallicFactor = 0.0;
  material.pbrMetallicRoughness.roughnessFactor = 1.0;
  material.doubleSided = true;
  model.materials.push_back(std::move(material));
  tinygltf::Mesh gltf_mesh;
  gltf_mesh.name = "aoscan";
  gltf_mesh.primitives.push_back(std::move(primitive));
  model.meshes.push_back(std::move(gltf_mesh));
  node.mesh = 0;
  model.nodes.push_back(std::move(node));
  return model;
}

}  // namespace

float srgb_to_linear(unsigned char srgb) {
  const double c = srgb / 255.0;
  return static_cast<float>(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
}

void write_glb(const std::string& path, const TriangleMesh& mesh, const MeshWriteOptions& options) {
  check_mesh_for_writing(path, mesh);
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    if (!mesh.vertices[i].allFinite())
      throw usage_error(path + ": vertex " + std::to_string(i) +
                        " has a non-finite position, which glTF does not allow");
  // The glb's length is a 32-bit field: the buffer (at most 40 bytes a vertex and 12 a face) and
  // the JSON (well under a megabyte) must fit it.
  const double bytes = 40.0 * static_cast<double>(mesh.vertices.size()) +
                       12.0 * static_cast<double>(mesh.faces.size());
  if (bytes > static_cast<double>(std::numeric_limits<std::uint32_t>::max() - (1u << 20)))
    throw Error(ExitCode::kFailure, path + ": mesh too large for a glb (4 GiB at most)");

  const tinygltf::Model model = gltf_model(mesh, options);
  write_atomically(path, [&model](const std::string& partial) {
    std::ofstream out(partial, std::ios::binary | std::ios::trunc);
    if (!out) throw_write_failed(partial);
    tinygltf::TinyGLTF gltf;
    // Not WriteGltfSceneToFile: it reports success also when the file cannot be written.
    const bool serialised = gltf.WriteGltfSceneToStream(&model, out, false, true);
    out.close();
    if (!serialised || !out) throw_write_failed(partial);
  });
}

}  // namespace aoscan
