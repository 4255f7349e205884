/// @file volume_export.h
/// @brief The TSDF volume as volume.vdb and back: the adapter between fusion's TsdfVolume and
/// io's neutral brick view (io must not depend on fusion).
#pragma once

#include <string>

#include "fusion/tsdf/colour_volume.h"
#include "fusion/tsdf/tsdf_volume.h"
#include "io/vdb.h"

namespace aoscan {

/// A view of `volume`'s allocated blocks in block-coordinate order: brick origin = 8 * block
/// coordinates, sdf_m = voxel tsdf * truncation (m), weight as stored. Valid while `volume`
/// lives and is not written. The view's voxel size and truncation are `config`'s (in double
/// precision; the volume holds them as float) when `config` is the volume's configuration, else
/// the volume's. With `colour` (the volume's colour, when it has any colour block) the bricks carry
/// its voxels' colour and weight.
VolumeView volume_view(const TsdfVolume& volume, const FusionConfig* config = nullptr,
                       const ColourVolume* colour = nullptr);

/// Writes `volume` to `path` (usually OUT/volume.vdb) with write_volume_vdb(): grids `tsdf` and
/// `weight`, voxel size (fusion.voxel_size_m of `config`, see volume_view()) and world frame of the
/// volume (= trajectory.txt's), and `colour`'s grids when given and not empty. Throws like
/// write_volume_vdb().
VdbWriteStats write_volume(const std::string& path, const TsdfVolume& volume,
                           const FusionConfig* config = nullptr,
                           const ColourVolume* colour = nullptr);

/// Replaces the content of `volume` by `data` (read_volume_vdb()): one block per brick, voxel
/// tsdf = sdf_m / truncation of `volume` stored in the voxel's fixed point (Voxel::store: equal
/// to the written voxel when the truncations agree), weight as read (truncated to an integer).
/// Throws usage_error when the voxel sizes differ by more than 1e-6 relative or the capacity
/// (fusion.max_blocks) is too small. With `colour`, it is reset and given the bricks' colour.
void load_volume(const VolumeData& data, TsdfVolume& volume, ColourVolume* colour = nullptr);

}  // namespace aoscan
