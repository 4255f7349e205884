/// @file volume_export.cpp
/// @brief TsdfVolume blocks to volume.vdb bricks and back.
#include "pipeline/volume_export.h"

#include <cmath>
#include <memory>
#include <vector>

#include "core/status.h"

namespace aoscan {

static_assert(kBrickSize == kBlockSize && kBrickVoxels == kBlockVoxels,
              "a TSDF block must be exactly one volume.vdb brick");

VolumeView volume_view(const TsdfVolume& volume, const FusionConfig* config,
                       const ColourVolume* colour) {
  auto order = std::make_shared<const std::vector<int>>(volume.sorted_block_indices());
  VolumeView view;
  const bool same = config != nullptr &&
                    static_cast<float>(config->voxel_size_m) == volume.voxel_size_m() &&
                    static_cast<float>(config->truncation_m) == volume.truncation_m();
  view.voxel_size_m = same ? config->voxel_size_m : volume.voxel_size_m();
  view.truncation_m = same ? config->truncation_m : volume.truncation_m();
  view.brick_count = order->size();
  if (colour != nullptr && colour->block_count() == 0) colour = nullptr;
  view.has_colour = colour != nullptr;
  const float truncation = volume.truncation_m();
  view.brick = [&volume, order, truncation, colour](std::size_t i, VolumeBrick& brick) {
    const int index = (*order)[i];
    brick.origin = volume.block_coord(index) * kBlockSize;
    const VoxelBlock& block = volume.block(index);
    for (int v = 0; v < kBlockVoxels; ++v) {  // both layouts are x + 8 (y + 8 z)
      brick.sdf_m[v] = block.voxels[v].tsdf() * truncation;
      brick.weight[v] = block.voxels[v].weight();
    }
    if (colour == nullptr) return;
    const ColourBlock* cb = colour->block(index);
    for (int v = 0; v < kBlockVoxels; ++v) {
      const ColourVoxel c = cb != nullptr ? cb->voxels[v] : ColourVoxel{};
      brick.colour[v] = Rgb8{c.r, c.g, c.b};
      brick.colour_weight[v] = c.weight;
    }
  };
  return view;
}

VdbWriteStats write_volume(const std::string& path, const TsdfVolume& volume,
                           const FusionConfig* config, const ColourVolume* colour) {
  return write_volume_vdb(path, volume_view(volume, config, colour));
}

void load_volume(const VolumeData& data, TsdfVolume& volume, ColourVolume* colour) {
  const double voxel = volume.voxel_size_m();
  if (!(std::abs(data.voxel_size_m - voxel) <= 1e-6 * voxel))
    throw usage_error("volume of voxel size " + std::to_string(data.voxel_size_m) +
                      " m loaded into a TSDF of voxel size " + std::to_string(voxel) + " m");
  volume.reset();
  if (colour != nullptr) colour->reset();
  const float truncation = volume.truncation_m();
  for (const VolumeBrick& brick : data.bricks) {
    const int index = volume.allocate_block(brick.origin / kBlockSize);
    if (index < 0)
      throw usage_error(
          "volume of " + std::to_string(data.bricks.size()) +
          " bricks exceeds fusion.max_blocks = " + std::to_string(volume.max_blocks()));
    VoxelBlock& block = volume.block(index);
    for (int v = 0; v < kBlockVoxels; ++v)
      block.voxels[v].store(brick.sdf_m[v] / truncation, brick.weight[v]);
    if (colour == nullptr || !data.has_colour) continue;
    ColourBlock* cb = nullptr;
    for (int v = 0; v < kBlockVoxels; ++v) {
      if (brick.colour_weight[v] == 0 || block.voxels[v].count == 0) continue;
      if (cb == nullptr) cb = &colour->allocate(index);
      const Rgb8& c = brick.colour[v];
      cb->voxels[v] = ColourVoxel{c.r, c.g, c.b, brick.colour_weight[v]};
    }
  }
}

}  // namespace aoscan
