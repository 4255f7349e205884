/// @file tsdf_volume.h
/// @brief The sparse truncated signed distance field: 8^3 voxel blocks in a hash of block
/// coordinates, allocated only near observed surfaces, updated by projective TSDF integration.
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

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "core/block_hash_map.h"
#include "core/config.h"
#include "core/image.h"
#include "core/intrinsics.h"
#include "core/pose.h"

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

/// What one integrate() call did.
struct IntegrateStats {
  int rays = 0;              ///< valid depth pixels cast
  int blocks_allocated = 0;  ///< blocks newly allocated by this frame
  int blocks_updated = 0;    ///< blocks whose voxels were updated (the band of this frame)
  int blocks_dropped = 0;    ///< blocks the band needed that the capacity did not allow
  bool skipped = false;      ///< true when the pose was not finite: nothing was done
};

/// The sparse TSDF. World coordinates are metres; the centre of voxel g (integer global voxel
/// coordinates) is at g * voxel_size_m; block b holds voxels 8b .. 8b+7 on each axis. The only
/// stateful object of fusion: one writer (integrate, allocate_block, reset), any number of
/// concurrent readers between writes.
class TsdfVolume {
 public:
  /// Throws usage_error when voxel size, truncation, weight cap or capacity are not usable.
  explicit TsdfVolume(const FusionConfig& config);

  /// Fuses one depth image (metres, 0 = invalid, size = intrinsics) seen from T_world_camera:
  /// allocates the blocks that the truncation band [d - truncation, d + truncation] of every
  /// valid pixel's ray passes through, then updates every voxel of those blocks by projective
  /// TSDF (sdf = depth(pixel) - z_voxel along the optical axis, running average, weight capped).
  /// Multi-threaded over blocks through TBB; the result does not depend on the thread count.
  /// The voxel update runs one voxel row per AVX2 vector when the CPU has AVX2.
  /// Throws usage_error when the depth size differs from the intrinsics.
  IntegrateStats integrate(const Image<float>& depth_m, const Intrinsics& intrinsics,
                           const Pose& T_world_camera);
  /// integrate() without SIMD (the portable C++ voxel update): bit for bit the same volume as
  /// integrate() on any CPU (the AVX2 update performs the same float operations in the same
  /// order). For tests and CPUs without AVX2.
  IntegrateStats integrate_portable(const Image<float>& depth_m, const Intrinsics& intrinsics,
                                    const Pose& T_world_camera);
  /// Plain single-threaded reference of integrate(): the same allocation and blocks, each voxel
  /// projected by a full matrix product and two divisions. Agrees with integrate() up to the float
  /// rounding of the projection: a voxel projecting within rounding of a pixel border may read
  /// the neighbouring pixel (a few voxels in a million).
  IntegrateStats integrate_reference(const Image<float>& depth_m, const Intrinsics& intrinsics,
                                     const Pose& T_world_camera);

  /// Drops every block (keeps the configuration).
  void reset();

  /// Index of the block with coordinates `block`, or -1 when it is not allocated.
  int find_block(const Eigen::Vector3i& block) const { return map_.find(pack(block)); }
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
  /// Largest |block coordinate| that pack() represents.
  static constexpr int kMaxBlockCoord = (1 << 20) - 1;

 private:
  static constexpr int kChunkBits = 10;
  static constexpr int kChunkMask = (1 << kChunkBits) - 1;

  /// Allocation pass of integrate() and integrate_reference(): fills visible_. `fast` runs the
  /// chunks in parallel and skips the traversal of segments whose cells are known (the same
  /// blocks in the same order as the plain per-pixel traversal); `simd` (with `fast`, the
  /// caller checked the CPU) sets up eight pixels' segments per AVX2 vector, the same floats.
  IntegrateStats allocate_band(const Image<float>& depth_m, const Intrinsics& intrinsics,
                               const Pose& T_world_camera, bool fast, bool simd);
  /// integrate() with the AVX2 voxel update (`simd`) or the portable one.
  IntegrateStats integrate_fast(const Image<float>& depth_m, const Intrinsics& intrinsics,
                                const Pose& T_world_camera, bool simd);
  /// update_block() with the voxel positions stepped affinely and one reciprocal per voxel:
  /// the same update up to float rounding of the projection (a voxel whose projection lies
  /// within rounding of a pixel border may read the neighbouring pixel). `simd`: one voxel row
  /// per AVX2 vector (the caller checked the CPU), bit for bit the same result.
  void update_block_fast(int index, const Image<float>& depth_m, const Intrinsics& intrinsics,
                         const Eigen::Matrix3f& R_camera_world,
                         const Eigen::Vector3f& t_camera_world, bool simd);
  /// Updates the voxels of one block from the frame (the plain reference arithmetic).
  void update_block(int index, const Image<float>& depth_m, const Intrinsics& intrinsics,
                    const Eigen::Matrix3f& R_camera_world, const Eigen::Vector3f& t_camera_world);

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
  std::vector<std::uint32_t> last_frame_;  ///< per block: integrate() call that last listed it
  std::uint32_t frame_counter_ = 0;

  // Per-frame scratch, reused across calls.
  std::vector<std::vector<std::uint64_t>> chunk_keys_;
  std::vector<int> chunk_rays_;
  std::vector<int> visible_;
};

/// Read access for kernels (raycast, meshing) that remembers the last block it looked up. Not
/// thread-safe: one per task. Positions are in voxel units (world metres / voxel size), so voxel
/// g sits at integer position g.
class TsdfSampler {
 public:
  explicit TsdfSampler(const TsdfVolume& volume) : volume_(volume) {}

  /// The voxel at global voxel coordinates (x, y, z), or nullptr when its block is not allocated.
  const Voxel* voxel(int x, int y, int z) {
    const VoxelBlock* block = find(x >> 3, y >> 3, z >> 3);  // arithmetic shift = floor(v / 8)
    return block ? &block->voxels[voxel_index(x & 7, y & 7, z & 7)] : nullptr;
  }

  /// The block at block coordinates (bx, by, bz) or nullptr. Cached in 8 slots chosen by the
  /// parity of the coordinates, so the 2x2x2 blocks around any point are all cached at once.
  const VoxelBlock* find(int bx, int by, int bz) {
    const int slot = (bx & 1) | ((by & 1) << 1) | ((bz & 1) << 2);
    Cached<const VoxelBlock*>& c = cache_[slot];
    if (!c.holds(bx, by, bz)) {
      const Eigen::Vector3i b(bx, by, bz);
      const int index =
          b.cwiseAbs().maxCoeff() <= TsdfVolume::kMaxBlockCoord ? volume_.find_block(b) : -1;
      c.value = index >= 0 ? &volume_.block(index) : nullptr;
    }
    return c.value;
  }

  /// True when no block of region (rx, ry, rz) is allocated (see TsdfVolume::region_allocated).
  /// The last answer is cached.
  bool region_empty(int rx, int ry, int rz) {
    if (!region_.holds(rx, ry, rz)) {
      const Eigen::Vector3i r(rx, ry, rz);
      region_.value =
          !(r.cwiseAbs().maxCoeff() <= TsdfVolume::kMaxBlockCoord && volume_.region_allocated(r));
    }
    return region_.value;
  }

  /// Trilinear TSDF at position g (voxel units); false when any of the 8 voxels around g is
  /// unallocated or has a weight below `min_weight` (at least "observed once" when 0 < it).
  bool trilinear(const Eigen::Vector3f& g, float& tsdf, float min_weight = 1e-6f) {
#if defined(__SSE2__)
    // Counts are integers: for a threshold in (0, 1] "observed" is count != 0, which the
    // vector read tests for all eight corners at once. It needs the cell's x pairs in one block.
    if (min_weight > 0.0f && min_weight <= 1.0f) {
      const int x = floor_to_int(g.x()), y = floor_to_int(g.y()), z = floor_to_int(g.z());
      if ((x & 7) != 7) {
        const Voxel* pairs[4];
        if (!x_pairs(x, y, z, pairs)) return false;
        return pairs_trilinear(pairs, g, x, y, z, tsdf);
      }
    }
#endif
    float c[8], a[3];
    if (!cell(g, c, a, min_weight)) return false;
    tsdf = interpolate(c, a);
    return true;
  }

  /// The first voxels of the four x pairs (corners 0-1, 2-3, 4-5, 6-7) of the cell at (x, y, z),
  /// whose pairs each lie in one block ((x & 7) != 7): one block, or two or four when the cell
  /// straddles y or z block borders, each found once. False when one of them is missing. For
  /// kernels that read many cells' voxels at once (trilinear() reads them through this).
  __attribute__((always_inline)) bool x_pairs(int x, int y, int z, const Voxel** pairs) {
    const int ly = y & 7, lz = z & 7;
    if (ly != 7 && lz != 7) {
      const Voxel* v0 = voxel(x, y, z);
      if (v0 == nullptr) return false;
      pairs[0] = v0;
      pairs[1] = v0 + kBlockSize;
      pairs[2] = v0 + kBlockSize * kBlockSize;
      pairs[3] = v0 + kBlockSize + kBlockSize * kBlockSize;
      return true;
    }
    const VoxelBlock* blocks[4];
    if (!yz_blocks(x >> 3, y >> 3, z >> 3, ly == 7, lz == 7, blocks)) return false;
    for (int k = 0; k < 4; ++k) pairs[k] = &blocks[k]->voxels[(x & 7) + yz_offset(ly, lz, k)];
    return true;
  }

  /// TSDF gradient (per voxel) at the voxel nearest to g by central differences of its six
  /// neighbours: 7 voxel reads, for kernels that cannot afford trilinear differences. False when
  /// a neighbour is unallocated or unobserved.
  bool nearest_gradient(const Eigen::Vector3f& g, Eigen::Vector3f& grad) {
    const int x = floor_to_int(g.x() + 0.5f);
    const int y = floor_to_int(g.y() + 0.5f);
    const int z = floor_to_int(g.z() + 0.5f);
    if (((x + 1) & 7) >= 2 && ((y + 1) & 7) >= 2 && ((z + 1) & 7) >= 2) {
      // All six neighbours in the voxel's own block (local coordinates 1..6).
      const Voxel* c = voxel(x, y, z);
      if (c == nullptr) return false;
      constexpr int kStride[3] = {1, kBlockSize, kBlockSize * kBlockSize};
      for (int axis = 0; axis < 3; ++axis) {
        const Voxel& p = c[kStride[axis]];
        const Voxel& m = c[-kStride[axis]];
        if (p.count == 0 || m.count == 0) return false;
        grad[axis] = 0.5f * (p.tsdf() - m.tsdf());
      }
      return true;
    }
    // A neighbour across a block border: every axis has one neighbour in the voxel's own block,
    // so without that block there is no gradient; the blocks across are found once each.
    const VoxelBlock* own = find(x >> 3, y >> 3, z >> 3);
    if (own == nullptr) return false;
    const int b[3] = {x >> 3, y >> 3, z >> 3};
    const int l[3] = {x & 7, y & 7, z & 7};
    const int local = voxel_index(l[0], l[1], l[2]);
    constexpr int kStride[3] = {1, kBlockSize, kBlockSize * kBlockSize};
    for (int axis = 0; axis < 3; ++axis) {
      const int step = kStride[axis];
      const Voxel* p = l[axis] == 7 ? nullptr : &own->voxels[local + step];
      const Voxel* m = l[axis] == 0 ? nullptr : &own->voxels[local - step];
      if (p == nullptr || m == nullptr) {
        int n[3] = {b[0], b[1], b[2]};
        n[axis] += p == nullptr ? 1 : -1;
        const VoxelBlock* across = find(n[0], n[1], n[2]);
        if (across == nullptr) return false;
        // The neighbour's local coordinate on this axis wraps to 0 (from 7) or 7 (from 0).
        if (p == nullptr)
          p = &across->voxels[local - (kBlockSize - 1) * step];
        else
          m = &across->voxels[local + (kBlockSize - 1) * step];
      }
      if (p->count == 0 || m->count == 0) return false;
      grad[axis] = 0.5f * (p->tsdf() - m->tsdf());
    }
    return true;
  }

  /// TSDF gradient at g (per voxel) by central differences of trilinear samples one voxel apart;
  /// false when a sample is unavailable.
  bool gradient(const Eigen::Vector3f& g, Eigen::Vector3f& grad) {
    float p = 0, m = 0;
    for (int axis = 0; axis < 3; ++axis) {
      Eigen::Vector3f q = g;
      q[axis] += 1.0f;
      if (!trilinear(q, p)) return false;
      q[axis] -= 2.0f;
      if (!trilinear(q, m)) return false;
      grad[axis] = 0.5f * (p - m);
    }
    return true;
  }

 private:
  /// Reads the 8 voxels of the cell around g (corner i at offset (i & 1, (i >> 1) & 1, i >> 2))
  /// and the fractional position in it.
  bool cell(const Eigen::Vector3f& g, float* c, float* a, float min_weight) {
    const int x = floor_to_int(g.x()), y = floor_to_int(g.y()), z = floor_to_int(g.z());
    const float fx = static_cast<float>(x), fy = static_cast<float>(y), fz = static_cast<float>(z);
    a[0] = g.x() - fx;
    a[1] = g.y() - fy;
    a[2] = g.z() - fz;
    if ((x & 7) != 7) {
      const Voxel* pairs[4];
      if (!x_pairs(x, y, z, pairs)) return false;
      for (int i = 0; i < 8; ++i) {
        const Voxel& v = pairs[i >> 1][i & 1];
        if (!(v.weight() >= min_weight)) return false;
        c[i] = v.tsdf();
      }
      return true;
    }
    // The cell straddles an x block border: its even corners lie at local x 7 of the block
    // column bx, its odd ones at local x 0 of column bx + 1.
    const int ly = y & 7, lz = z & 7;
    const bool sy = ly == 7, sz = lz == 7;
    const VoxelBlock* left[4];
    const VoxelBlock* right[4];
    if (!yz_blocks(x >> 3, y >> 3, z >> 3, sy, sz, left) ||
        !yz_blocks((x >> 3) + 1, y >> 3, z >> 3, sy, sz, right))
      return false;
    for (int k = 0; k < 4; ++k) {
      const int yz = yz_offset(ly, lz, k);
      const Voxel& v0 = left[k]->voxels[kBlockSize - 1 + yz];
      const Voxel& v1 = right[k]->voxels[yz];
      if (!(v0.weight() >= min_weight) || !(v1.weight() >= min_weight)) return false;
      c[2 * k] = v0.tsdf();
      c[2 * k + 1] = v1.tsdf();
    }
    return true;
  }

  /// The blocks of a cell's four x pairs in the block column bx (pair k lies at dy = k & 1 and
  /// dz = k >> 1): block (bx, by + dy, bz + dz) on the axes that straddle (sy, sz), else
  /// (bx, by, bz), each found once. False when one of them is missing.
  bool yz_blocks(int bx, int by, int bz, bool sy, bool sz, const VoxelBlock** out) {
    out[0] = find(bx, by, bz);
    if (out[0] == nullptr) return false;
    out[1] = sy ? find(bx, by + 1, bz) : out[0];
    out[2] = sz ? find(bx, by, bz + 1) : out[0];
    if (out[1] == nullptr || out[2] == nullptr) return false;
    out[3] = sy ? (sz ? find(bx, by + 1, bz + 1) : out[1]) : out[2];
    return out[3] != nullptr;
  }

  /// The y and z parts of the voxel index of pair k's voxels (local coordinates ly, lz of the
  /// cell's first corner; the next one wraps to 0 in the next block).
  static int yz_offset(int ly, int lz, int k) {
    return ((ly + (k & 1)) & 7) * kBlockSize + ((lz + (k >> 1)) & 7) * kBlockSize * kBlockSize;
  }

#if defined(__SSE2__)
  /// trilinear() of the cell at (x, y, z) from its four x pairs with SSE2: each voxel a 32-bit
  /// lane (tsdf_q low, count high). The same float operations as interpolate(), so the same bits
  /// as the scalar read.
  static bool pairs_trilinear(const Voxel* const* pairs, const Eigen::Vector3f& g, int x, int y,
                              int z, float& tsdf) {
    auto pair = [pairs](int k) {
      return _mm_loadl_epi64(reinterpret_cast<const __m128i*>(pairs[k]));
    };
    const __m128i lo = _mm_unpacklo_epi64(pair(0), pair(1));  // corners 0 1 2 3
    const __m128i hi = _mm_unpacklo_epi64(pair(2), pair(3));  // corners 4 5 6 7
    const __m128i zero = _mm_setzero_si128();
    const __m128i unobserved = _mm_or_si128(_mm_cmpeq_epi32(_mm_srli_epi32(lo, 16), zero),
                                            _mm_cmpeq_epi32(_mm_srli_epi32(hi, 16), zero));
    if (_mm_movemask_epi8(unobserved) != 0) return false;
    const __m128 step = _mm_set1_ps(Voxel::kTsdfStep);
    const __m128 f_lo =
        _mm_mul_ps(_mm_cvtepi32_ps(_mm_srai_epi32(_mm_slli_epi32(lo, 16), 16)), step);
    const __m128 f_hi =
        _mm_mul_ps(_mm_cvtepi32_ps(_mm_srai_epi32(_mm_slli_epi32(hi, 16), 16)), step);
    const __m128 even = _mm_shuffle_ps(f_lo, f_hi, _MM_SHUFFLE(2, 0, 2, 0));  // c0 c2 c4 c6
    const __m128 odd = _mm_shuffle_ps(f_lo, f_hi, _MM_SHUFFLE(3, 1, 3, 1));   // c1 c3 c5 c7
    const float ax = g.x() - static_cast<float>(x);
    const float ay = g.y() - static_cast<float>(y);
    const float az = g.z() - static_cast<float>(z);
    float l[4];  // c00 c10 c01 c11
    _mm_storeu_ps(l, _mm_add_ps(even, _mm_mul_ps(_mm_set1_ps(ax), _mm_sub_ps(odd, even))));
    const float c0 = l[0] + ay * (l[1] - l[0]);
    const float c1 = l[2] + ay * (l[3] - l[2]);
    tsdf = c0 + az * (c1 - c0);
    return true;
  }
#endif
  static float interpolate(const float* c, const float* a) {
    const float c00 = c[0] + a[0] * (c[1] - c[0]);
    const float c10 = c[2] + a[0] * (c[3] - c[2]);
    const float c01 = c[4] + a[0] * (c[5] - c[4]);
    const float c11 = c[6] + a[0] * (c[7] - c[6]);
    const float c0 = c00 + a[1] * (c10 - c00);
    const float c1 = c01 + a[1] * (c11 - c01);
    return c0 + a[2] * (c1 - c0);
  }

  /// One cached answer for integer coordinates (x, y, z).
  template <typename T>
  struct Cached {
    bool valid = false;
    int x = 0, y = 0, z = 0;
    T value{};
    /// True when the answer for (cx, cy, cz) is cached; otherwise takes those coordinates and
    /// false (the caller then stores the answer in `value`).
    bool holds(int cx, int cy, int cz) {
      if (valid && x == cx && y == cy && z == cz) return true;
      valid = true;
      x = cx;
      y = cy;
      z = cz;
      return false;
    }
  };
  const TsdfVolume& volume_;
  Cached<const VoxelBlock*> cache_[8];
  Cached<bool> region_;  ///< value: the region is empty
};

}  // namespace aoscan
