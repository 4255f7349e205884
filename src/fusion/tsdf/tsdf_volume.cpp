/// @file tsdf_volume.cpp
/// @brief Sparse TSDF storage: block hash, regions, chunked block storage.
#include "fusion/tsdf/tsdf_volume.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <type_traits>
#include <utility>

#include "core/status.h"

namespace aoscan {
namespace {

/// Floor division by kBlockSize for negative coordinates too.
int block_of(int v) {
  return v >= 0 ? v / kBlockSize : -((-v + kBlockSize - 1) / kBlockSize);
}

bool in_key_range(const Eigen::Vector3i& b) {
  return b.cwiseAbs().maxCoeff() <= TsdfVolume::kMaxBlockCoord;
}

}  // namespace

TsdfVolume::TsdfVolume(const FusionConfig& config)
    : voxel_size_(static_cast<float>(config.voxel_size_m)),
      truncation_(static_cast<float>(config.truncation_m)),
      max_weight_(static_cast<float>(config.max_weight)),
      max_blocks_(config.max_blocks) {
  if (!(config.voxel_size_m > 0.0) || !std::isfinite(config.voxel_size_m))
    throw usage_error("fusion.voxel_size_m must be positive, got " +
                      std::to_string(config.voxel_size_m));
  if (!(config.truncation_m >= config.voxel_size_m) || !std::isfinite(config.truncation_m))
    throw usage_error("fusion.truncation_m must be at least fusion.voxel_size_m");
  if (!(config.max_weight >= 1.0 && config.max_weight <= Voxel::kMaxWeight))
    throw usage_error("fusion.max_weight must be between 1 and 65535");
  if (config.max_blocks < 1) throw usage_error("fusion.max_blocks must be positive");
}

void TsdfVolume::reset() {
  map_.clear();
  regions_.clear();
  chunks_.clear();
  coords_.clear();
  coords_.shrink_to_fit();
  capacity_reached_ = false;
}

int TsdfVolume::allocate_block(const Eigen::Vector3i& coord) {
  if (!in_key_range(coord)) return -1;
  const std::uint64_t key = pack(coord);
  const int found = map_.find(key);
  if (found >= 0) return found;
  if (block_count() >= max_blocks_) {
    capacity_reached_ = true;
    return -1;
  }
  const int index = block_count();
  if ((index >> kChunkBits) >= static_cast<int>(chunks_.size())) {
    static_assert(std::is_trivially_destructible_v<VoxelBlock>, "ChunkFree destroys nothing");
    // Owned before the vector grows, so a failing push_back frees it.
    std::unique_ptr<VoxelBlock[], ChunkFree> chunk(
        static_cast<VoxelBlock*>(::operator new(sizeof(VoxelBlock) << kChunkBits)));
    chunks_.push_back(std::move(chunk));
  }
  ::new (static_cast<void*>(&block(index))) VoxelBlock{};
  coords_.push_back(coord);
  map_.insert(key, index);
  const std::uint64_t region_key = pack(coord.unaryExpr([](int b) { return b >> 2; }));
  static_assert(kRegionBlocks == 4, "the region shift above is log2(kRegionBlocks)");
  if (regions_.find(region_key) < 0) regions_.insert(region_key, index);
  return index;
}

const Voxel* TsdfVolume::find_voxel(const Eigen::Vector3i& voxel) const {
  const Eigen::Vector3i b(block_of(voxel.x()), block_of(voxel.y()), block_of(voxel.z()));
  if (!in_key_range(b)) return nullptr;
  const int index = find_block(b);
  if (index < 0) return nullptr;
  const Eigen::Vector3i local = voxel - kBlockSize * b;
  return &block(index).voxels[voxel_index(local.x(), local.y(), local.z())];
}

std::vector<int> TsdfVolume::sorted_block_indices() const {
  std::vector<int> order(coords_.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(), [this](int a, int b) {
    const Eigen::Vector3i& p = coords_[a];
    const Eigen::Vector3i& q = coords_[b];
    if (p.z() != q.z()) return p.z() < q.z();
    if (p.y() != q.y()) return p.y() < q.y();
    return p.x() < q.x();
  });
  return order;
}

std::size_t TsdfVolume::memory_bytes() const {
  return chunks_.size() * (std::size_t{1} << kChunkBits) * sizeof(VoxelBlock) +
         map_.memory_bytes() + regions_.memory_bytes() +
         coords_.capacity() * sizeof(Eigen::Vector3i);
}

}  // namespace aoscan
