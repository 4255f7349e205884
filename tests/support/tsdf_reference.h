/// @file tsdf_reference.h
/// @brief Plain reference versions of the TSDF kernels (integration, raycast, marching cubes),
/// written on the volume's public API: slow, single-threaded, obviously correct; the oracles the
/// tests compare the fast library paths with.
#pragma once

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/mesh.h"
#include "core/pose.h"
#include "fusion/tsdf/colour_volume.h"
#include "fusion/tsdf/tsdf_config.h"
#include "fusion/tsdf/tsdf_integrator.h"
#include "fusion/tsdf/tsdf_volume.h"
#include "geometry/point_maps.h"

namespace aoscan {
namespace test {

/// Plain single-threaded reference of TsdfIntegrator::integrate(): the same allocation (every
/// block the band segment of a valid pixel crosses, allocated in the same order) and blocks, each
/// voxel projected by a full matrix product and two divisions. Agrees with integrate() up to the
/// float rounding of the projection: a voxel projecting within rounding of a pixel border may read
/// the neighbouring pixel (a few voxels in a million). blocks_dropped counts each refused block
/// once. Throws usage_error when the depth size differs from the intrinsics.
IntegrateStats integrate_reference(TsdfVolume& volume, const Image<float>& depth_m,
                                   const Intrinsics& intrinsics, const Pose& T_world_camera);

/// Plain reference of raycast(): single-threaded, a fixed step of `step_voxels` voxels through
/// the whole depth range, trilinear samples only, no block skipping. Slow.
void raycast_reference(const TsdfVolume& volume, const Intrinsics& intrinsics,
                       const Pose& T_world_camera, const FusionConfig& config, float step_voxels,
                       RaycastResult& result);

/// Plain reference of extract_mesh(): one serial pass over all cubes, vertices shared through a
/// map keyed by grid edge. Same vertices and triangles, in a different order.
TriangleMesh extract_mesh_reference(const TsdfVolume& volume, float min_weight);

/// Plain reference of the colour fused inside TsdfIntegrator::integrate() (ColourIntegration as
/// its block visitor): the same per-block pass run after the depth integration, over `blocks`
/// (the blocks it updated) one after another. Throws like ColourIntegration's constructor; a
/// pose that is not finite, no block or no colour image colours nothing.
ColourIntegrateStats colour_pass_after(ColourVolume& colour, const TsdfVolume& volume,
                                       const std::vector<int>& blocks,
                                       const ColourFrameInput& input);

}  // namespace test
}  // namespace aoscan
