/// @file marching_cubes.cpp
/// @brief Marching cubes over the sparse TSDF: generated case table, per-block vertex pass,
/// prefix sums, per-block triangle pass, removal of unused vertices.
#include "fusion/tsdf/marching_cubes.h"

#include <algorithm>
#include <cstdint>

#include <tbb/parallel_for.h>

#include "fusion/tsdf/marching_cubes_kernels.h"
#include "fusion/tsdf/tsdf_sampler.h"

namespace aoscan {

using detail::corner_offset;
using detail::edge_vertex;
using detail::usable;

const std::array<std::array<int, 2>, 12> kCubeEdges = {{{0, 1},
                                                        {2, 3},
                                                        {4, 5},
                                                        {6, 7},  // along x
                                                        {0, 2},
                                                        {1, 3},
                                                        {4, 6},
                                                        {5, 7},  // along y
                                                        {0, 4},
                                                        {1, 5},
                                                        {2, 6},
                                                        {3, 7}}};  // along z

namespace {

MarchingCubesTable build_table() {
  int edge_of[8][8];
  for (auto& row : edge_of) std::fill(std::begin(row), std::end(row), -1);
  for (int e = 0; e < 12; ++e) {
    edge_of[kCubeEdges[e][0]][kCubeEdges[e][1]] = e;
    edge_of[kCubeEdges[e][1]][kCubeEdges[e][0]] = e;
  }
  // Faces as corner cycles, counter-clockwise seen from outside the cube.
  std::vector<std::array<int, 4>> faces;
  for (int a = 0; a < 3; ++a) {
    const int u = (a + 1) % 3, v = (a + 2) % 3;
    for (int s = 0; s < 2; ++s) {
      std::array<int, 4> cycle;
      const int du[4] = {0, 1, 1, 0}, dv[4] = {0, 0, 1, 1};
      for (int k = 0; k < 4; ++k) cycle[k] = (s << a) | (du[k] << u) | (dv[k] << v);
      if (s == 0) std::reverse(cycle.begin(), cycle.end());  // outward normal is -e_a
      faces.push_back(cycle);
    }
  }
  MarchingCubesTable table;
  for (int mask = 0; mask < 256; ++mask) {
    auto inside = [mask](int corner) { return ((mask >> corner) & 1) != 0; };
    // next[e]: the boundary of the inside region on the cube surface, traversed with the region
    // on the left, goes from edge e to edge next[e] across one face.
    int next[12];
    std::fill(std::begin(next), std::end(next), -1);
    for (const auto& c : faces) {
      int out_pos[4], in_pos[4], outs = 0, ins = 0;
      for (int k = 0; k < 4; ++k) {
        const bool a = inside(c[k]), b = inside(c[(k + 1) % 4]);
        if (a && !b) out_pos[outs++] = k;
        if (!a && b) in_pos[ins++] = k;
      }
      if (outs == 1) {
        next[edge_of[c[out_pos[0]]][c[(out_pos[0] + 1) % 4]]] =
            edge_of[c[in_pos[0]]][c[(in_pos[0] + 1) % 4]];
      } else if (outs == 2) {
        // Ambiguous face: cut off each inside corner on its own.
        for (int k = 0; k < 4; ++k) {
          if (!inside(c[k])) continue;
          next[edge_of[c[k]][c[(k + 1) % 4]]] = edge_of[c[(k + 3) % 4]][c[k]];
        }
      }
    }
    bool visited[12] = {};
    for (int start = 0; start < 12; ++start) {
      if (next[start] < 0 || visited[start]) continue;
      std::vector<int> loop;
      for (int e = start; !visited[e]; e = next[e]) {
        visited[e] = true;
        loop.push_back(e);
      }
      // The loop runs counter-clockwise around the inside seen from outside the cube, so its
      // right-hand normal points inside; wind the fan the other way.
      for (std::size_t i = 1; i + 1 < loop.size(); ++i)
        table.triangles[mask].push_back({loop[0], loop[i + 1], loop[i]});
    }
  }
  return table;
}

/// Per-block output of the vertex pass.
struct BlockVertices {
  std::vector<std::uint16_t> codes;  ///< local voxel index * 3 + axis, ascending
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;
  std::vector<Eigen::Vector3i> faces;  ///< global vertex indices
};

/// Drops vertices no face uses (their edges belonged only to cubes that were not meshed).
void remove_unused_vertices(TriangleMesh& mesh) {
  std::vector<int> remap(mesh.vertices.size(), -1);
  for (const Eigen::Vector3i& f : mesh.faces)
    for (int k = 0; k < 3; ++k) remap[f[k]] = 0;
  int count = 0;
  for (std::size_t i = 0; i < remap.size(); ++i) {
    if (remap[i] < 0) continue;
    remap[i] = count;
    mesh.vertices[count] = mesh.vertices[i];
    mesh.normals[count] = mesh.normals[i];
    ++count;
  }
  mesh.vertices.resize(count);
  mesh.normals.resize(count);
  for (Eigen::Vector3i& f : mesh.faces)
    for (int k = 0; k < 3; ++k) f[k] = remap[f[k]];
}

}  // namespace

const MarchingCubesTable& marching_cubes_table() {
  static const MarchingCubesTable table = build_table();
  return table;
}

TriangleMesh extract_mesh(const TsdfVolume& volume, float min_weight) {
  const MarchingCubesTable& table = marching_cubes_table();
  const std::vector<int> order = volume.sorted_block_indices();
  const int n = static_cast<int>(order.size());
  std::vector<int> position_of(volume.block_count(), -1);
  for (int i = 0; i < n; ++i) position_of[order[i]] = i;
  // neighbours[i][k]: sorted position of the block at offset corner_offset(k) from block i.
  std::vector<std::array<int, 8>> neighbours(n);
  std::vector<BlockVertices> out(n);
  const float vs = volume.voxel_size_m();

  // Pass 1: the vertices on the three grid edges leaving each voxel in +x, +y, +z.
  tbb::parallel_for(0, n, [&](int i) {
    const Eigen::Vector3i b = volume.block_coord(order[i]);
    for (int k = 0; k < 8; ++k) {
      const int index = k == 0 ? order[i] : volume.find_block(b + corner_offset(k));
      neighbours[i][k] = index >= 0 ? position_of[index] : -1;
    }
    TsdfSampler sampler(volume);
    BlockVertices& bv = out[i];
    const VoxelBlock& blk = volume.block(order[i]);
    const Eigen::Vector3i base = b * kBlockSize;
    for (int z = 0; z < kBlockSize; ++z) {
      for (int y = 0; y < kBlockSize; ++y) {
        for (int x = 0; x < kBlockSize; ++x) {
          const int local = voxel_index(x, y, z);
          const Voxel& v0 = blk.voxels[local];
          if (!usable(&v0, min_weight)) continue;
          const Eigen::Vector3i g = base + Eigen::Vector3i(x, y, z);
          for (int axis = 0; axis < 3; ++axis) {
            Eigen::Vector3i h = g;
            h[axis] += 1;
            const Voxel* v1 = sampler.voxel(h.x(), h.y(), h.z());
            if (!usable(v1, min_weight) || (v0.tsdf_q < 0) == (v1->tsdf_q < 0)) continue;
            Eigen::Vector3f p, nrm;
            edge_vertex(sampler, g, axis, v0.tsdf(), v1->tsdf(), vs, p, nrm);
            bv.codes.push_back(static_cast<std::uint16_t>(local * 3 + axis));
            bv.positions.push_back(p);
            bv.normals.push_back(nrm);
          }
        }
      }
    }
  });

  std::vector<int> first_vertex(n + 1, 0);
  for (int i = 0; i < n; ++i)
    first_vertex[i + 1] = first_vertex[i] + static_cast<int>(out[i].codes.size());

  // Pass 2: the triangles of each cube whose lowest corner is in the block.
  tbb::parallel_for(0, n, [&](int i) {
    const Voxel* corner[8];
    for (int z = 0; z < kBlockSize; ++z) {
      for (int y = 0; y < kBlockSize; ++y) {
        for (int x = 0; x < kBlockSize; ++x) {
          int mask = 0;
          bool ok = true;
          for (int c = 0; c < 8 && ok; ++c) {
            const int cx = x + (c & 1), cy = y + ((c >> 1) & 1), cz = z + (c >> 2);
            const int nb = neighbours[i][(cx >> 3) | ((cy >> 3) << 1) | ((cz >> 3) << 2)];
            if (nb < 0) {
              ok = false;
              break;
            }
            corner[c] = &volume.block(order[nb]).voxels[voxel_index(cx & 7, cy & 7, cz & 7)];
            ok = usable(corner[c], min_weight);
            if (corner[c]->tsdf_q < 0) mask |= 1 << c;
          }
          if (!ok || mask == 0 || mask == 255) continue;
          for (const auto& tri : table.triangles[mask]) {
            Eigen::Vector3i face;
            bool found = true;
            for (int k = 0; k < 3 && found; ++k) {
              const int e = tri[k];
              const int lower = kCubeEdges[e][0];
              const int axis = e / 4;
              const int ox = x + (lower & 1), oy = y + ((lower >> 1) & 1), oz = z + (lower >> 2);
              const int nb = neighbours[i][(ox >> 3) | ((oy >> 3) << 1) | ((oz >> 3) << 2)];
              const std::vector<std::uint16_t>& codes = out[nb].codes;
              const auto code =
                  static_cast<std::uint16_t>(voxel_index(ox & 7, oy & 7, oz & 7) * 3 + axis);
              const auto it = std::lower_bound(codes.begin(), codes.end(), code);
              found = it != codes.end() && *it == code;
              if (found) face[k] = first_vertex[nb] + static_cast<int>(it - codes.begin());
            }
            if (found) out[i].faces.push_back(face);
          }
        }
      }
    }
  });

  TriangleMesh mesh;
  mesh.vertices.reserve(first_vertex[n]);
  mesh.normals.reserve(first_vertex[n]);
  std::size_t faces = 0;
  for (const BlockVertices& bv : out) faces += bv.faces.size();
  mesh.faces.reserve(faces);
  for (const BlockVertices& bv : out) {
    mesh.vertices.insert(mesh.vertices.end(), bv.positions.begin(), bv.positions.end());
    mesh.normals.insert(mesh.normals.end(), bv.normals.begin(), bv.normals.end());
    mesh.faces.insert(mesh.faces.end(), bv.faces.begin(), bv.faces.end());
  }
  remove_unused_vertices(mesh);
  return mesh;
}

}  // namespace aoscan
