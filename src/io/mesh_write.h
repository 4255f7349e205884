/// @file mesh_write.h
/// @brief What the mesh writers (mesh.ply: io/ply.h, mesh.glb: io/gltf.h) share: their options,
/// the colour they write for a vertex, and the check of a mesh before it is written.
#pragma once

#include <cstddef>
#include <string>

#include "core/colour.h"
#include "core/mesh.h"

namespace aoscan {

/// Options of the mesh writers.
struct MeshWriteOptions {
  /// `--bake-ao`: multiplies the colour by the AO, for viewers that ignore the AO attribute: each
  /// channel becomes round(colour * clamp(quality, 0, 1)). A mesh without colours is written as
  /// the AO grey either way, so this changes nothing for it.
  bool bake_ao = false;
};

/// The AO `quality` clamped to [0, 1], NaN as 0.
float clamped_ao(float quality);

/// The AO as a grey: red = green = blue = round(255 * clamped_ao(quality)), halves rounded up.
Rgb8 ao_grey(float quality);

/// `colour` multiplied by the AO: each channel round(channel * clamped_ao(quality)), halves
/// rounded up.
Rgb8 baked_colour(const Rgb8& colour, float quality);

/// The colour the writers give vertex `i` of `mesh` (which passed check_mesh_for_writing()): its
/// colour (baked_colour() of it with `options.bake_ao`) when the mesh has colours, else the AO
/// grey of its quality (of 1, white, when the mesh has no quality).
Rgb8 written_colour(const TriangleMesh& mesh, std::size_t i, const MeshWriteOptions& options);

/// Throws usage_error naming `path` when `mesh` cannot be written as it is: normals, quality or
/// colours neither empty nor one per vertex, more vertices than an int index reaches, or a face
/// index out of range.
void check_mesh_for_writing(const std::string& path, const TriangleMesh& mesh);

}  // namespace aoscan
