/// @file ply.h
/// @brief PLY meshes: the contract's binary little-endian mesh.ply writer and a reader for binary
/// little-endian and ASCII PLY (evaluation tools, tests).
#pragma once

#include <cstddef>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/colour.h"
#include "core/mesh.h"
#include "io/mesh_write.h"

namespace aoscan {

/// The exact header write_ply emits before the vertex and face counts are filled in; the data
/// follows `end_header\n` directly.
///   ply / format binary_little_endian 1.0 / element vertex N / property float x, y, z,
///   nx, ny, nz, quality / property uchar red, green, blue / element face M /
///   property list uchar int vertex_indices / end_header
/// With `face_element` false the `element face` lines are left out (a point cloud).
std::string ply_header(std::size_t vertex_count, std::size_t face_count, bool face_element = true);

/// Bytes of one vertex after that header: seven floats and three uchars.
constexpr std::size_t kPlyVertexBytes = 7 * 4 + 3;

/// Writes `mesh` (metres) as binary little-endian PLY with the header of ply_header(): per vertex
/// float x y z, float nx ny nz (zeros when the mesh has no normals), float quality (the AO; 1 when
/// the mesh has none), uchar red green blue: the mesh's colour when it has colours (with
/// `options.bake_ao`, `--bake-ao`, the colour multiplied by the AO: round(colour * clamp(quality,
/// 0, 1)) per channel), else the AO as grey, red = green = blue = round(255 * clamp(quality, 0, 1))
/// (written_colour(), io/mesh_write.h); per face a uchar 3 and three int indices. Identical meshes
/// give identical bytes. Throws usage_error for an inconsistent mesh (normals/quality/colours
/// count, face index out of range) and Error (exit code 1) when the file cannot be written.
void write_ply(const std::string& path, const TriangleMesh& mesh,
               const MeshWriteOptions& options = {});

/// The vertices of `mesh` as a point cloud (points.ply): write_ply()'s vertex layout and values,
/// and a header without the face element.
void write_points_ply(const std::string& path, const TriangleMesh& mesh,
                      const MeshWriteOptions& options = {});

/// Writes a PLY of write_ply()'s layout one vertex (then one face) at a time, for outputs too
/// large to hold as one TriangleMesh: the counts are fixed up front and finish() checks that
/// exactly that many were given. Writes `path` itself (wrap it in write_atomically()). Throws
/// Error (exit code 1) naming the file when it cannot be written, usage_error on a wrong count.
class PlyWriter {
 public:
  /// `face_element` false: a point cloud, whose header has no face element (face_count 0).
  PlyWriter(const std::string& path, std::size_t vertex_count, std::size_t face_count,
            bool face_element = true);
  ~PlyWriter();
  PlyWriter(const PlyWriter&) = delete;
  PlyWriter& operator=(const PlyWriter&) = delete;
  /// One vertex: position, normal, quality (grey colour from it: ao_grey()).
  void vertex(const Eigen::Vector3f& p, const Eigen::Vector3f& n, float quality);
  /// One vertex: position, normal, quality, and `colour` as red, green, blue (written as given).
  void vertex(const Eigen::Vector3f& p, const Eigen::Vector3f& n, float quality,
              const Rgb8& colour);
  /// One triangle (after the last vertex).
  void face(const Eigen::Vector3i& f);
  /// Flushes and closes the file.
  void finish();

 private:
  void flush();
  static constexpr std::size_t kChunk = 1 << 20;
  std::string path_;
  std::FILE* file_ = nullptr;
  std::vector<unsigned char> buffer_;
  std::size_t vertices_left_;
  std::size_t faces_left_;
  bool ok_ = true;
};

/// Reads a binary little-endian or ASCII PLY: vertices (x y z; nx ny nz, quality and red green
/// blue (rounded, clamped to 0-255) when present), faces from the `vertex_indices` (or `vertex_index`) list, polygons fan-triangulated;
/// other elements and properties are skipped. Throws input_error naming the file on a missing file,
/// a bad header, an unsupported format (big-endian), truncated data or an out-of-range face index.
TriangleMesh read_ply(const std::string& path);

}  // namespace aoscan
