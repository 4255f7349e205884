/// @file tsdf_reference.cpp
/// @brief Plain reference integration, raycast and marching cubes over the public TsdfVolume API.
#include "support/tsdf_reference.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <tuple>
#include <unordered_set>
#include <vector>

#include <Eigen/Core>

#include "core/status.h"
#include "fusion/tsdf/grid_traversal.h"
#include "fusion/tsdf/marching_cubes.h"
#include "fusion/tsdf/marching_cubes_kernels.h"
#include "fusion/tsdf/raycast.h"
#include "fusion/tsdf/raycast_kernels.h"
#include "fusion/tsdf/tsdf_integrator_kernels.h"
#include "fusion/tsdf/tsdf_sampler.h"

namespace aoscan {
namespace test {

using detail::check_inputs;
using detail::corner_offset;
using detail::edge_vertex;
using detail::prepare;
using detail::Ray;
using detail::RaySetup;
using detail::refine_crossing;
using detail::usable;
using detail::within_grid;
using detail::write_hit;

namespace {

// ---- Integration ------------------------------------------------------------------------------

bool valid_depth(float d) {
  return d > 0.0f && d < 1e4f;
}

Eigen::Vector3i floor_cell(const Eigen::Vector3f& q) {
  return {floor_to_int(q.x()), floor_to_int(q.y()), floor_to_int(q.z())};
}

/// The blocks that the truncation band of the valid pixels' rays crosses, each once, in the order
/// the pixels (raster order) first reach them; allocates those that are new. Fills the stats'
/// rays and block counts.
std::vector<int> allocate_band(TsdfVolume& volume, const Image<float>& depth_m,
                               const Intrinsics& intrinsics, const Pose& T_world_camera,
                               IntegrateStats& stats) {
  const Eigen::Matrix3f R = T_world_camera.rotation().cast<float>();
  const Eigen::Vector3f t = T_world_camera.translation().cast<float>();
  // Block-grid coordinates q = (p_world / voxel + 0.5) / 8: block floor(q) holds the voxel
  // nearest to p_world.
  const float to_grid = 1.0f / (volume.voxel_size_m() * kBlockSize);
  const Eigen::Vector3f grid_offset = Eigen::Vector3f::Constant(0.5f / kBlockSize);
  const float fx_inv = static_cast<float>(1.0 / intrinsics.fx);
  const float fy_inv = static_cast<float>(1.0 / intrinsics.fy);
  const float cx = static_cast<float>(intrinsics.cx);
  const float cy = static_cast<float>(intrinsics.cy);
  const float trunc = volume.truncation_m();
  const Eigen::Vector3f x_dir = R.col(0) * to_grid;
  const Eigen::Vector3f origin = t * to_grid + grid_offset;
  std::vector<int> visible;
  std::unordered_set<std::uint64_t> seen;
  auto add = [&](const Eigen::Vector3i& block) {
    if (block.cwiseAbs().maxCoeff() > TsdfVolume::kMaxBlockCoord) return;
    if (!seen.insert(TsdfVolume::pack(block)).second) return;
    const int blocks_before = volume.block_count();
    const int index = volume.allocate_block(block);
    if (index < 0) {
      ++stats.blocks_dropped;
      return;
    }
    if (volume.block_count() > blocks_before) ++stats.blocks_allocated;
    visible.push_back(index);
  };
  for (int y = 0; y < depth_m.height(); ++y) {
    const float ry = (static_cast<float>(y) - cy) * fy_inv;
    // The pixel's ray direction in block-grid units per metre of depth: row_dir + rx * x_dir.
    const Eigen::Vector3f row_dir = (R.col(1) * ry + R.col(2)) * to_grid;
    for (int x = 0; x < depth_m.width(); ++x) {
      const float d = depth_m(x, y);
      if (!valid_depth(d)) continue;
      ++stats.rays;
      const float rx = (static_cast<float>(x) - cx) * fx_inv;
      const Eigen::Vector3f dir = row_dir + rx * x_dir;
      Eigen::Vector3f a, b;
      if (!detail::band_segment(dir, origin, d, trunc, a, b)) continue;
      traverse_cells(a, b, floor_cell(a), floor_cell(b), add);
    }
  }
  stats.blocks_updated = static_cast<int>(visible.size());
  return visible;
}

/// Updates the voxels of one block from the frame (projective TSDF, running average).
void update_block(TsdfVolume& volume, int index, const Image<float>& depth_m,
                  const Intrinsics& intrinsics, const Eigen::Matrix3f& R_camera_world,
                  const Eigen::Vector3f& t_camera_world) {
  VoxelBlock& blk = volume.block(index);
  const Eigen::Vector3i base = volume.block_coord(index) * kBlockSize;
  const float voxel_size = volume.voxel_size_m();
  const float truncation = volume.truncation_m();
  const float fx = static_cast<float>(intrinsics.fx);
  const float fy = static_cast<float>(intrinsics.fy);
  const float cx = static_cast<float>(intrinsics.cx);
  const float cy = static_cast<float>(intrinsics.cy);
  const float max_u = static_cast<float>(depth_m.width()) - 0.5f;
  const float max_v = static_cast<float>(depth_m.height()) - 0.5f;
  const float inv_trunc = 1.0f / truncation;
  for (int z = 0; z < kBlockSize; ++z) {
    for (int y = 0; y < kBlockSize; ++y) {
      for (int x = 0; x < kBlockSize; ++x) {
        const Eigen::Vector3f p_world(static_cast<float>(base.x() + x) * voxel_size,
                                      static_cast<float>(base.y() + y) * voxel_size,
                                      static_cast<float>(base.z() + z) * voxel_size);
        const Eigen::Vector3f p = R_camera_world * p_world + t_camera_world;
        if (!(p.z() > 0.0f)) continue;
        const float u = fx * p.x() / p.z() + cx;
        const float v = fy * p.y() / p.z() + cy;
        if (!(u >= -0.5f && v >= -0.5f && u < max_u && v < max_v)) continue;
        const int ui = static_cast<int>(u + 0.5f);
        const int vi = static_cast<int>(v + 0.5f);
        const float d = depth_m(ui, vi);
        if (!valid_depth(d)) continue;
        const float sdf = d - p.z();
        if (sdf < -truncation) continue;
        const float tsdf = std::min(1.0f, sdf * inv_trunc);
        blk.voxels[voxel_index(x, y, z)].add_observation(tsdf, volume.max_weight());
      }
    }
  }
}

// ---- Raycast ----------------------------------------------------------------------------------

}  // namespace

IntegrateStats integrate_reference(TsdfVolume& volume, const Image<float>& depth_m,
                                   const Intrinsics& intrinsics, const Pose& T_world_camera) {
  IntegrateStats stats;
  if (!detail::integration_input_usable(depth_m, intrinsics, T_world_camera)) {
    stats.skipped = true;
    return stats;
  }
  const std::vector<int> visible =
      allocate_band(volume, depth_m, intrinsics, T_world_camera, stats);
  const Pose T_camera_world = T_world_camera.inverse();
  const Eigen::Matrix3f R = T_camera_world.rotation().cast<float>();
  const Eigen::Vector3f t = T_camera_world.translation().cast<float>();
  for (const int index : visible) update_block(volume, index, depth_m, intrinsics, R, t);
  return stats;
}

void raycast_reference(const TsdfVolume& volume, const Intrinsics& intrinsics,
                       const Pose& T_world_camera, const FusionConfig& config, float step_voxels,
                       RaycastResult& result) {
  check_inputs(intrinsics, config);
  prepare(intrinsics, T_world_camera, result);
  if (!T_world_camera.finite() || !(step_voxels > 0.0f) ||
      !within_grid(volume, intrinsics, T_world_camera, config))
    return;
  const RaySetup setup(volume, intrinsics, T_world_camera);
  const float min_depth = static_cast<float>(config.raycast_min_depth_m);
  const float max_depth = static_cast<float>(config.raycast_max_depth_m);
  TsdfSampler sampler(volume);
  for (int y = 0; y < intrinsics.height; ++y) {
    for (int x = 0; x < intrinsics.width; ++x) {
      const Ray ray = setup.ray(x, y);
      const float step = step_voxels * volume.voxel_size_m() / ray.metres_per_s;
      float prev_s = 0.0f, prev_f = 0.0f;
      bool prev_valid = false;
      for (float s = min_depth; s < max_depth; s += step) {
        float f = 0.0f;
        if (!sampler.trilinear(ray.origin + s * ray.dir, f)) {
          prev_valid = false;
          continue;
        }
        if (prev_valid && prev_f >= 0.0f && f < 0.0f) {
          write_hit(sampler, ray,
                    refine_crossing(sampler, ray, volume.voxel_size_m(), volume.truncation_m(),
                                    prev_s, prev_f, s, f),
                    setup.R_camera_world, result, x, y);
          break;
        }
        prev_s = s;
        prev_f = f;
        prev_valid = true;
      }
    }
  }
  result.hits = count_hits(result.depth_m);
}

TriangleMesh extract_mesh_reference(const TsdfVolume& volume, float min_weight) {
  const MarchingCubesTable& table = marching_cubes_table();
  TriangleMesh mesh;
  std::map<std::tuple<int, int, int, int>, int> vertex_of_edge;
  TsdfSampler sampler(volume);
  const float vs = volume.voxel_size_m();
  for (const int index : volume.sorted_block_indices()) {
    const Eigen::Vector3i base = volume.block_coord(index) * kBlockSize;
    for (int z = 0; z < kBlockSize; ++z) {
      for (int y = 0; y < kBlockSize; ++y) {
        for (int x = 0; x < kBlockSize; ++x) {
          const Eigen::Vector3i g = base + Eigen::Vector3i(x, y, z);
          float f[8];
          int mask = 0;
          bool ok = true;
          for (int c = 0; c < 8 && ok; ++c) {
            const Eigen::Vector3i h = g + corner_offset(c);
            const Voxel* v = volume.find_voxel(h);
            ok = usable(v, min_weight);
            if (ok) {
              f[c] = v->tsdf();
              if (f[c] < 0.0f) mask |= 1 << c;
            }
          }
          if (!ok) continue;
          for (const auto& tri : table.triangles[mask]) {
            Eigen::Vector3i face;
            for (int k = 0; k < 3; ++k) {
              const int e = tri[k];
              const int a = kCubeEdges[e][0], b = kCubeEdges[e][1];
              const Eigen::Vector3i owner = g + corner_offset(a);
              const auto key = std::make_tuple(owner.x(), owner.y(), owner.z(), e / 4);
              auto it = vertex_of_edge.find(key);
              if (it == vertex_of_edge.end()) {
                Eigen::Vector3f p, nrm;
                edge_vertex(sampler, owner, e / 4, f[a], f[b], vs, p, nrm);
                it = vertex_of_edge.emplace(key, static_cast<int>(mesh.vertices.size())).first;
                mesh.vertices.push_back(p);
                mesh.normals.push_back(nrm);
              }
              face[k] = it->second;
            }
            mesh.faces.push_back(face);
          }
        }
      }
    }
  }
  return mesh;
}

ColourIntegrateStats colour_pass_after(ColourVolume& colour, const TsdfVolume& volume,
                                       const std::vector<int>& blocks,
                                       const ColourFrameInput& input) {
  ColourIntegration pass(colour, input);
  if (!input.T_world_camera.finite() || blocks.empty() || input.colour->empty()) return {};
  pass.begin(volume, blocks);
  for (std::size_t k = 0; k < blocks.size(); ++k) pass.visit(volume, k);
  return pass.finish();
}

}  // namespace test
}  // namespace aoscan
