/// @file ply.h
/// @brief PLY meshes: the contract's binary little-endian mesh.ply writer and a reader for binary
/// little-endian and ASCII PLY (evaluation tools, tests).
#pragma once

#include <cstddef>
#include <string>

#include "core/mesh.h"

namespace aoscan {

/// The exact header write_ply emits before the vertex and face counts are filled in; the data
/// follows `end_header\n` directly.
///   ply / format binary_little_endian 1.0 / element vertex N / property float x, y, z,
///   nx, ny, nz, quality / property uchar red, green, blue / element face M /
///   property list uchar int vertex_indices / end_header
std::string ply_header(std::size_t vertex_count, std::size_t face_count);

/// Writes `mesh` (metres) as binary little-endian PLY with the header of ply_header(): per vertex
/// float x y z, float nx ny nz (zeros when the mesh has no normals), float quality (the AO; 1 when
/// the mesh has none), uchar red = green = blue = round(255 * clamp(quality, 0, 1)); per face a
/// uchar 3 and three int indices. Identical meshes give identical bytes. Throws usage_error for an
/// inconsistent mesh (normals/quality count, face index out of range) and Error (exit code 1) when
/// the file cannot be written.
void write_ply(const std::string& path, const TriangleMesh& mesh);

/// Reads a binary little-endian or ASCII PLY: vertices (x y z; nx ny nz and quality when all
/// present), faces from the `vertex_indices` (or `vertex_index`) list, polygons fan-triangulated;
/// other elements and properties are skipped. Throws input_error naming the file on a missing file,
/// a bad header, an unsupported format (big-endian), truncated data or an out-of-range face index.
TriangleMesh read_ply(const std::string& path);

}  // namespace aoscan
