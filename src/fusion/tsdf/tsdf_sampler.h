/// @file tsdf_sampler.h
/// @brief Read access to the TSDF for kernels (raycast, meshing): cached block lookups, voxel
/// reads, trilinear samples and gradients, inline because they run per ray step.
#pragma once

#include <Eigen/Core>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "fusion/tsdf/tsdf_volume.h"

namespace aoscan {

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
