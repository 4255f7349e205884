/// @file tsdf_reference.h
/// @brief Plain reference versions of the TSDF kernels (integration so far), written on the
/// volume's public API: slow, single-threaded, obviously correct; the oracles the
/// tests compare the fast library paths with.
#pragma once

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/pose.h"
#include "fusion/tsdf/tsdf_integrator.h"
#include "fusion/tsdf/tsdf_volume.h"

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

}  // namespace test
}  // namespace aoscan
