/// @file raycast.h
/// @brief Raycasting the sparse TSDF into depth, vertex and normal maps at a camera pose: the ICP
/// reference of the next frame and the input of the SSAO stage.
#pragma once

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/pose.h"
#include "fusion/tsdf/tsdf_config.h"
#include "fusion/tsdf/tsdf_volume.h"
#include "geometry/point_maps.h"

namespace aoscan {

/// Which rays a hinted raycast casts.
enum class RaycastRays {
  kAll,         ///< every pixel: rays without a hint march their whole range
  kHintedOnly,  ///< only pixels with a hint (the others stay empty): checking a frame's own
                ///< pixels against the model, where a pixel without depth has nothing to check
};

/// Raycasts `volume` from T_world_camera through every pixel of `intrinsics`, between
/// fusion.raycast_min_depth_m and raycast_max_depth_m (depth along the optical axis). Each ray
/// starts at the nearest allocated block seen through its 8x8-pixel tile, jumps over unallocated
/// blocks, steps by the TSDF value inside blocks, and takes the first + to - zero crossing,
/// refined by interpolating trilinear samples (scanned in half-voxel steps when a trilinear cell
/// reaches past the observed band). Normals come from the TSDF gradient (central
/// differences around the voxel nearest to the hit). `result`'s
/// buffers are reused. Multi-threaded over rows; the result does not depend on the thread count.
/// `depth_hint_m` (optional, metres, same size): a depth image taken at this very pose, normally
/// the frame just integrated. A ray with a hint looks for the zero crossing next to it (a few
/// trilinear samples stepping by the TSDF value, then a march of +-2 truncations around it) and
/// nowhere else: the frame saw free space in front of its depth, so this is the first crossing
/// unless the model disagrees with the frame. Rays without a hint march their whole range. Pass a
/// hint only for a frame that was fused at this pose (never after a lost frame). On a CPU with
/// AVX2 the hinted rays of a row are searched eight per vector (raycast_portable() is the same
/// search one ray at a time, bit for bit the same result). With a hint and
/// RaycastRays::kHintedOnly, pixels without a usable hint are left empty.
/// Throws usage_error on invalid intrinsics, an empty depth range or a hint of the wrong size.
void raycast(const TsdfVolume& volume, const Intrinsics& intrinsics, const Pose& T_world_camera,
             const FusionConfig& config, RaycastResult& result,
             const Image<float>* depth_hint_m = nullptr, RaycastRays rays = RaycastRays::kAll);

/// raycast() without SIMD, the hinted rays searched one at a time: bit for bit the same result
/// on any CPU. For tests and CPUs without AVX2.
void raycast_portable(const TsdfVolume& volume, const Intrinsics& intrinsics,
                      const Pose& T_world_camera, const FusionConfig& config, RaycastResult& result,
                      const Image<float>* depth_hint_m = nullptr,
                      RaycastRays rays = RaycastRays::kAll);

/// Pixels of a depth image with a surface (depth > 0): RaycastResult::hits of that depth.
int count_hits(const Image<float>& depth);

}  // namespace aoscan
