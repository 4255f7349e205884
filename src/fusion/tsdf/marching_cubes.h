/// @file marching_cubes.h
/// @brief Mesh extraction from the sparse TSDF: marching cubes over the allocated blocks, shared
/// vertices, normals from the TSDF gradient, deterministic output.
#pragma once

#include <array>
#include <vector>

#include "core/mesh.h"
#include "fusion/tsdf/tsdf_volume.h"

namespace aoscan {

/// Marching-cubes case table. Corner i of a cube sits at offset (i & 1, (i >> 1) & 1, i >> 2);
/// edge e joins corners kCubeEdges[e]; a corner is inside when its TSDF is negative. Generated
/// (not typed in) by walking the sign changes around the cube faces; on an ambiguous face the
/// inside corners are kept apart, a rule that only reads the face, so two cubes sharing a face
/// always cut it the same way and the mesh has no cracks.
struct MarchingCubesTable {
  /// Triangles per case as edge indices, wound counter-clockwise seen from outside (positive
  /// TSDF): the right-hand normal points along the TSDF gradient.
  std::array<std::vector<std::array<int, 3>>, 256> triangles;
};
extern const std::array<std::array<int, 2>, 12> kCubeEdges;
const MarchingCubesTable& marching_cubes_table();

/// Extracts the zero level set of `volume` as a triangle mesh in the world frame (metres), with
/// unit vertex normals from the TSDF gradient (pointing to the observed free space). A cube is
/// meshed only when its 8 corner voxels are allocated and have weight >= min_weight. Vertices on
/// cube edges are shared between cubes (one per grid edge), so a surface seen completely gives a
/// closed mesh. Blocks are processed in parallel and emitted in block-coordinate order: the bytes
/// of the result depend neither on the thread count nor on the allocation order.
TriangleMesh extract_mesh(const TsdfVolume& volume, float min_weight);

}  // namespace aoscan
