/// @file mesh_write.cpp
/// @brief The mesh writers' colour and consistency check.
#include "io/mesh_write.h"

#include <cmath>
#include <cstdint>

#include "core/status.h"

namespace aoscan {
namespace {

std::uint8_t scaled(std::uint8_t channel, float ao) {
  return static_cast<std::uint8_t>(std::lround(static_cast<double>(channel) * ao));
}

void check_count(const std::string& path, std::size_t count, std::size_t vertices,
                 const char* what) {
  if (count != 0 && count != vertices)
    throw usage_error(path + ": mesh has " + std::to_string(count) + " " + what + " for " +
                      std::to_string(vertices) + " vertices");
}

}  // namespace

float clamped_ao(float quality) {
  if (!(quality > 0.0f)) return 0.0f;  // also NaN
  return quality >= 1.0f ? 1.0f : quality;
}

Rgb8 ao_grey(float quality) {
  const std::uint8_t g = scaled(255, clamped_ao(quality));
  return {g, g, g};
}

Rgb8 baked_colour(const Rgb8& colour, float quality) {
  const float ao = clamped_ao(quality);
  return {scaled(colour.r, ao), scaled(colour.g, ao), scaled(colour.b, ao)};
}

Rgb8 written_colour(const TriangleMesh& mesh, std::size_t i, const MeshWriteOptions& options) {
  const float quality = mesh.quality.empty() ? 1.0f : mesh.quality[i];
  if (mesh.colours.empty()) return ao_grey(quality);
  return options.bake_ao ? baked_colour(mesh.colours[i], quality) : mesh.colours[i];
}

void check_mesh_for_writing(const std::string& path, const TriangleMesh& mesh) {
  const std::size_t n = mesh.vertices.size();
  check_count(path, mesh.normals.size(), n, "normals");
  check_count(path, mesh.quality.size(), n, "quality values");
  check_count(path, mesh.colours.size(), n, "colours");
  if (n > static_cast<std::size_t>(INT32_MAX))
    throw usage_error(path + ": too many vertices for int face indices");
  for (std::size_t f = 0; f < mesh.faces.size(); ++f)
    for (int k = 0; k < 3; ++k)
      if (mesh.faces[f][k] < 0 || static_cast<std::size_t>(mesh.faces[f][k]) >= n)
        throw usage_error(path + ": face " + std::to_string(f) + " has vertex index " +
                          std::to_string(mesh.faces[f][k]) + " out of range");
}

}  // namespace aoscan
