/// @file tsdf_volume.h
/// @brief The sparse truncated signed distance field: 8^3 voxel blocks in a hash of block
/// coordinates, allocated only near observed surfaces (TsdfIntegrator, tsdf_integrator.h, fills
/// them).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <vector>

#include <Eigen/Core>

#include "core/block_hash_map.h"
#include "core/image.h"
#include "core/intrinsics.h"
#include "core/pose.h"
#include "fusion/tsdf/tsdf_config.h"

namespace aoscan {

/// Voxels per block edge; a block holds kBlockSize^3 voxels.
inline constexpr int kBlockSize = 8;
inline constexpr int kBlockVoxels = kBlockSize * kBlockSize * kBlockSize;

/// One voxel in 4 bytes: the TSDF (signed distance divided by the truncation, in [-1, 1], positive
/// in front of the surface) as a 16-bit fixed-point number in steps of 1/32767, and the number of
/// observations (capped; 0 = never observed). Half the size of two floats: integration streams
/// every voxel of the visible blocks each frame and the raycast's samples are cache misses, so the
/// volume's bytes are what fusion's time is made of. A step is 1/32767 of the truncation (about
/// one micrometre at the default 3.5 cm).
struct Voxel {
  static constexpr float kTsdfScale = 32767.0f;
  static constexpr float kTsdfStep = 1.0f / kTsdfScale;
  static constexpr float kMaxWeight = 65535.0f;

  std::int16_t tsdf_q = 32767;  ///< tsdf * 32767, rounded to nearest (even)
  std::uint16_t count = 0;      ///< observations, capped

  float tsdf() const { return static_cast<float>(tsdf_q) * kTsdfStep; }
  float weight() const { return static_cast<float>(count); }

  /// Stores a TSDF (clamped to [-1, 1], NaN read as 1 = free) and a weight (clamped to
  /// [0, 65535] and truncated to an integer, NaN read as 0 = unobserved).
  void store(float tsdf, float weight) {
    float t = 1.0f;
    if (tsdf >= -1.0f && tsdf <= 1.0f)
      t = tsdf;
    else if (tsdf < -1.0f)
      t = -1.0f;
    tsdf_q = static_cast<std::int16_t>(std::lrint(t * kTsdfScale));
    const float w = weight > 0.0f ? (weight < kMaxWeight ? weight : kMaxWeight) : 0.0f;
    count = static_cast<std::uint16_t>(w);
  }
  /// Adds one observation `tsdf` (in [-1, 1]) to the running average; the count stops at
  /// `max_weight`. The AVX2 integration performs these float operations in this order.
  void add_observation(float tsdf, float max_weight) {
    const float w = weight();
    store((this->tsdf() * w + tsdf) / (w + 1.0f), std::min(w + 1.0f, max_weight));
  }
};
static_assert(sizeof(Voxel) == 4, "a voxel is 4 bytes");

/// kBlockSize^3 voxels; voxel (x, y, z) of the block is `voxels[x + 8 * (y + 8 * z)]`.
struct VoxelBlock {
  std::array<Voxel, kBlockVoxels> voxels;
};

/// Index of a voxel inside its block from its local coordinates (0..7 each).
inline int voxel_index(int x, int y, int z) {
  return x + kBlockSize * (y + kBlockSize * z);
}

/// floor(v) as an int for |v| < 2^31, without a library call or rounding-mode change.
inline int floor_to_int(float v) {
  const int i = static_cast<int>(v);
  return i - (static_cast<float>(i) > v ? 1 : 0);
}

/// The sparse TSDF. World coordinates are metres; the centre of voxel g (integer global voxel
/// coordinates) is at g * voxel_size_m; block b holds voxels 8b .. 8b+7 on each axis. The block
/// storage only; TsdfIntegrator fuses depth frames into it. The only stateful object of fusion:
/// one writer (an integrator's integrate(), allocate_block, reset), any number of concurrent
/// readers between writes.
class TsdfVolume {
 public:
  /// Throws usage_error when voxel size, truncation, weight cap or capacity are not usable.
  explicit TsdfVolume(const FusionConfig& config);

  /// Drops every block (keeps the configuration).
  void reset();

  /// Index of the block with coordinates `block`, or -1 when it is not allocated.
  int find_block(const Eigen::Vector3i& block) const { return map_.find(pack(block)); }
  /// find_block() by the block's pack()ed key (the integrator's allocation pass works on keys).
  int find_block_key(std::uint64_t key) const { return map_.find(key); }
  /// Index of the block, allocating it (all voxels unobserved) when needed; -1 when the capacity
  /// is exhausted (then capacity_reached() becomes true).
  int allocate_block(const Eigen::Vector3i& block);
  /// The voxel at global voxel coordinates, or nullptr when its block is not allocated.
  const Voxel* find_voxel(const Eigen::Vector3i& voxel) const;
  /// True when any block of the region (kRegionBlocks^3 blocks: region r holds blocks
  /// kRegionBlocks * r .. kRegionBlocks * r + kRegionBlocks - 1 per axis) is allocated. Lets rays
  /// cross empty space a region, not a block, at a time.
  bool region_allocated(const Eigen::Vector3i& region) const {
    return regions_.find(pack(region)) >= 0;
  }
  /// Blocks per region edge (a power of two).
  static constexpr int kRegionBlocks = 4;

  VoxelBlock& block(int index) { return chunks_[index >> kChunkBits][index & kChunkMask]; }
  const VoxelBlock& block(int index) const {
    return chunks_[index >> kChunkBits][index & kChunkMask];
  }
  /// Block coordinates of the block stored at `index`.
  const Eigen::Vector3i& block_coord(int index) const { return coords_[index]; }
  /// Indices of all allocated blocks ordered by (z, y, x) block coordinates: a deterministic order.
  std::vector<int> sorted_block_indices() const;

  int block_count() const { return static_cast<int>(coords_.size()); }
  int max_blocks() const { return max_blocks_; }
  /// True once an allocation was refused because the capacity was exhausted (sticky until reset).
  bool capacity_reached() const { return capacity_reached_; }
  /// Bytes held by blocks and the hash map.
  std::size_t memory_bytes() const;

  float voxel_size_m() const { return voxel_size_; }
  float block_size_m() const { return voxel_size_ * kBlockSize; }
  float truncation_m() const { return truncation_; }
  float max_weight() const { return max_weight_; }

  /// Packs block coordinates (each within +-2^20) into a hash key.
  static std::uint64_t pack(const Eigen::Vector3i& b) {
    constexpr std::uint64_t kMask = (1u << 21) - 1;
    return (static_cast<std::uint64_t>(b.x() + (1 << 20)) & kMask) |
           ((static_cast<std::uint64_t>(b.y() + (1 << 20)) & kMask) << 21) |
           ((static_cast<std::uint64_t>(b.z() + (1 << 20)) & kMask) << 42);
  }
  /// The block coordinates of a pack()ed key.
  static Eigen::Vector3i unpack(std::uint64_t key) {
    constexpr std::uint64_t kMask = (1u << 21) - 1;
    return {static_cast<int>(key & kMask) - (1 << 20),
            static_cast<int>((key >> 21) & kMask) - (1 << 20),
            static_cast<int>((key >> 42) & kMask) - (1 << 20)};
  }
  /// Largest |block coordinate| that pack() represents.
  static constexpr int kMaxBlockCoord = (1 << 20) - 1;

 private:
  static constexpr int kChunkBits = 10;
  static constexpr int kChunkMask = (1 << kChunkBits) - 1;

  float voxel_size_;
  float truncation_;
  float max_weight_;
  int max_blocks_;
  bool capacity_reached_ = false;

  BlockHashMap map_;
  BlockHashMap regions_;  ///< the regions holding a block (value: the first block's index)
  /// Frees a chunk's storage (blocks are trivially destructible: nothing to destroy).
  struct ChunkFree {
    void operator()(VoxelBlock* chunk) const { ::operator delete(chunk); }
  };
  /// Storage of 2^kChunkBits blocks each, which never moves; a block is constructed only when
  /// allocate_block() hands it out, so a new chunk costs no write (and no page touched) at once.
  std::vector<std::unique_ptr<VoxelBlock[], ChunkFree>> chunks_;
  std::vector<Eigen::Vector3i> coords_;
};

}  // namespace aoscan
