/// @file tsdf_volume.cpp
/// @brief Sparse TSDF: block hash, band allocation along the depth rays, projective voxel update.
#include "fusion/tsdf/tsdf_volume.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/status.h"
#include "fusion/tsdf/grid_traversal.h"
#include "geometry/simd.h"

#if defined(__x86_64__) && defined(__GNUC__)
#define AOSCAN_TSDF_X86 1
#include <immintrin.h>
#else
#define AOSCAN_TSDF_X86 0
#endif

namespace aoscan {
namespace {

/// Image rows handled by one allocation task; fixed so the work split never depends on threads.
constexpr int kRowsPerChunk = 8;
/// Slots of the per-chunk direct-mapped cache that drops repeated block keys of nearby rays.
constexpr int kKeyCacheBits = 9;

Eigen::Vector3i unpack(std::uint64_t key) {
  constexpr std::uint64_t kMask = (1u << 21) - 1;
  return {static_cast<int>(key & kMask) - (1 << 20),
          static_cast<int>((key >> 21) & kMask) - (1 << 20),
          static_cast<int>((key >> 42) & kMask) - (1 << 20)};
}

/// Floor division by kBlockSize for negative coordinates too.
int block_of(int v) {
  return v >= 0 ? v / kBlockSize : -((-v + kBlockSize - 1) / kBlockSize);
}

bool in_key_range(const Eigen::Vector3i& b) {
  return b.cwiseAbs().maxCoeff() <= TsdfVolume::kMaxBlockCoord;
}

/// The grid cell holding q (each coordinate within +-2^31).
inline Eigen::Vector3i floor_cell(const Eigen::Vector3f& q) {
  return {floor_to_int(q.x()), floor_to_int(q.y()), floor_to_int(q.z())};
}

/// Appends the key of block `b` to `out` unless it is out of the packable range or was among the
/// recent keys that `cache` (direct-mapped, kKeyCacheBits slots) remembers.
inline void emit_key(const Eigen::Vector3i& b, std::uint64_t* cache,
                     std::vector<std::uint64_t>& out) {
  if (!in_key_range(b)) return;
  const std::uint64_t key = TsdfVolume::pack(b);
  const std::size_t slot = (key * 0x9E3779B97F4A7C15ULL) >> (64 - kKeyCacheBits);
  if (cache[slot] != key) {
    cache[slot] = key;
    out.push_back(key);
  }
}

/// Block keys of the block-grid cells crossed by the segment a-b (block-grid units, where cell
/// floor(q) is block q; ia, ib = floor(a), floor(b)), appended to `out` unless cached.
inline void traverse_segment(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                             const Eigen::Vector3i& ia, const Eigen::Vector3i& ib,
                             std::uint64_t* cache, std::vector<std::uint64_t>& out) {
  traverse_cells(a, b, ia, ib, [&](const Eigen::Vector3i& cell) { emit_key(cell, cache, out); });
}

bool valid_depth(float d) {
  return d > 0.0f && d < 1e4f;
}

/// One block's projection into the frame for the fast voxel update.
struct BlockProjection {
  Eigen::Vector3f p0;          ///< camera-frame position of the block's voxel (0, 0, 0) (m)
  Eigen::Vector3f dx, dy, dz;  ///< camera-frame steps of one voxel along the block's axes (m)
  float fx, fy, cx, cy;        ///< intrinsics; cx, cy shifted by half a pixel
  int width;                   ///< depth image width (pixels)
  float w_max, h_max;          ///< image size as floats
  const float* depth;          ///< the depth image (m)
  float truncation, inv_trunc, max_weight;
};

/// Camera-frame position of the first voxel of row (y, z) of a block.
inline Eigen::Vector3f row_start(const BlockProjection& b, int y, int z) {
  return b.p0 + static_cast<float>(y) * b.dy + static_cast<float>(z) * b.dz;
}

/// The fast voxel update in plain C++ (positions stepped affinely, one reciprocal per voxel).
void update_block_portable(const BlockProjection& b, Voxel* voxels) {
  for (int z = 0; z < kBlockSize; ++z) {
    for (int y = 0; y < kBlockSize; ++y) {
      const Eigen::Vector3f row = row_start(b, y, z);
      // Pass 1, branch-free so that it vectorises: pixel index (-1 = outside the image or
      // behind the camera) and depth of the row's 8 voxels.
      int pixel[kBlockSize];
      float depth_z[kBlockSize];
      for (int x = 0; x < kBlockSize; ++x) {
        const float px = row.x() + static_cast<float>(x) * b.dx.x();
        const float py = row.y() + static_cast<float>(x) * b.dx.y();
        const float pz = row.z() + static_cast<float>(x) * b.dx.z();
        const float inv_z = 1.0f / pz;
        const float u = b.fx * px * inv_z + b.cx;
        const float v = b.fy * py * inv_z + b.cy;
        const bool inside = pz > 0.0f && u >= 0.0f && v >= 0.0f && u < b.w_max && v < b.h_max;
        const int ui = static_cast<int>(inside ? u : 0.0f);
        const int vi = static_cast<int>(inside ? v : 0.0f);
        pixel[x] = inside ? vi * b.width + ui : -1;
        depth_z[x] = pz;
      }
      // Pass 2: read the depth and update the observed voxels.
      Voxel* out = voxels + voxel_index(0, y, z);
      for (int x = 0; x < kBlockSize; ++x) {
        if (pixel[x] < 0) continue;
        const float d = b.depth[pixel[x]];
        if (!valid_depth(d)) continue;
        const float sdf = d - depth_z[x];
        if (sdf < -b.truncation) continue;
        const float tsdf = std::min(1.0f, sdf * b.inv_trunc);
        out[x].add_observation(tsdf, b.max_weight);
      }
    }
  }
}

#if AOSCAN_TSDF_X86

/// update_block_portable() with one voxel row (8 voxels, 32 bytes) per AVX2 vector and a gather
/// of the 8 depths: the same operations in the same order, so bit for bit the same result (no FMA;
/// the fixed-point TSDF rounds to nearest even like std::lrint, the count truncates).
__attribute__((target("avx2"))) void update_block_avx2(const BlockProjection& b, Voxel* voxels) {
  static_assert(kBlockSize == 8 && sizeof(Voxel) == 4, "one row of voxels = one AVX register");
  const __m256 lane_x = _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256 off_x = _mm256_mul_ps(lane_x, _mm256_set1_ps(b.dx.x()));
  const __m256 off_y = _mm256_mul_ps(lane_x, _mm256_set1_ps(b.dx.y()));
  const __m256 off_z = _mm256_mul_ps(lane_x, _mm256_set1_ps(b.dx.z()));
  const __m256 fx = _mm256_set1_ps(b.fx), fy = _mm256_set1_ps(b.fy);
  const __m256 cx = _mm256_set1_ps(b.cx), cy = _mm256_set1_ps(b.cy);
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  const __m256 w_max = _mm256_set1_ps(b.w_max), h_max = _mm256_set1_ps(b.h_max);
  const __m256 d_max = _mm256_set1_ps(1e4f);
  const __m256 neg_trunc = _mm256_set1_ps(-b.truncation);
  const __m256 inv_trunc = _mm256_set1_ps(b.inv_trunc);
  const __m256 max_weight = _mm256_set1_ps(b.max_weight);
  const __m256 tsdf_scale = _mm256_set1_ps(Voxel::kTsdfScale);
  const __m256 tsdf_step = _mm256_set1_ps(Voxel::kTsdfStep);
  const __m256i low16 = _mm256_set1_epi32(0xFFFF);
  const __m256i width = _mm256_set1_epi32(b.width);
  for (int z = 0; z < kBlockSize; ++z) {
    for (int y = 0; y < kBlockSize; ++y) {
      const Eigen::Vector3f row = row_start(b, y, z);
      const __m256 px = _mm256_add_ps(_mm256_set1_ps(row.x()), off_x);
      const __m256 py = _mm256_add_ps(_mm256_set1_ps(row.y()), off_y);
      const __m256 pz = _mm256_add_ps(_mm256_set1_ps(row.z()), off_z);
      const __m256 inv_z = _mm256_div_ps(one, pz);
      const __m256 u = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(fx, px), inv_z), cx);
      const __m256 v = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(fy, py), inv_z), cy);
      __m256 mask = _mm256_and_ps(
          _mm256_cmp_ps(pz, zero, _CMP_GT_OQ),
          _mm256_and_ps(_mm256_cmp_ps(u, zero, _CMP_GE_OQ), _mm256_cmp_ps(v, zero, _CMP_GE_OQ)));
      mask = _mm256_and_ps(mask, _mm256_and_ps(_mm256_cmp_ps(u, w_max, _CMP_LT_OQ),
                                               _mm256_cmp_ps(v, h_max, _CMP_LT_OQ)));
      if (_mm256_movemask_ps(mask) == 0) continue;
      // Lanes outside the image are masked off before any integer conversion is used.
      const __m256 u_in = _mm256_and_ps(u, mask), v_in = _mm256_and_ps(v, mask);
      const __m256i pixel = _mm256_add_epi32(_mm256_mullo_epi32(_mm256_cvttps_epi32(v_in), width),
                                             _mm256_cvttps_epi32(u_in));
      const __m256 d = _mm256_mask_i32gather_ps(zero, b.depth, pixel, mask, 4);
      const __m256 sdf = _mm256_sub_ps(d, pz);
      mask = _mm256_and_ps(mask, _mm256_and_ps(_mm256_cmp_ps(d, zero, _CMP_GT_OQ),
                                               _mm256_cmp_ps(d, d_max, _CMP_LT_OQ)));
      mask = _mm256_and_ps(mask, _mm256_cmp_ps(sdf, neg_trunc, _CMP_NLT_UQ));
      if (_mm256_movemask_ps(mask) == 0) continue;
      const __m256 tsdf = _mm256_min_ps(_mm256_mul_ps(sdf, inv_trunc), one);
      auto* out = reinterpret_cast<__m256i*>(voxels + voxel_index(0, y, z));
      const __m256i packed = _mm256_loadu_si256(out);  // per lane: tsdf_q | count << 16
      const __m256 t = _mm256_mul_ps(
          _mm256_cvtepi32_ps(_mm256_srai_epi32(_mm256_slli_epi32(packed, 16), 16)), tsdf_step);
      const __m256 w = _mm256_cvtepi32_ps(_mm256_srli_epi32(packed, 16));
      const __m256 w1 = _mm256_add_ps(w, one);
      const __m256 t_new = _mm256_div_ps(_mm256_add_ps(_mm256_mul_ps(t, w), tsdf), w1);
      const __m256 w_new = _mm256_min_ps(w1, max_weight);
      // |t_new| <= 1 (an average of values in [-1, 1]), so no clamp: Voxel::store's is a no-op.
      const __m256i t_q =
          _mm256_and_si256(_mm256_cvtps_epi32(_mm256_mul_ps(t_new, tsdf_scale)), low16);
      const __m256i updated =
          _mm256_or_si256(t_q, _mm256_slli_epi32(_mm256_cvttps_epi32(w_new), 16));
      _mm256_storeu_si256(out, _mm256_blendv_epi8(packed, updated, _mm256_castps_si256(mask)));
    }
  }
}
#endif

/// What the band allocation needs per pixel ray, in block-grid units (cell floor(q) is block q):
/// the ray of pixel (x, y) at depth z is z * (row_dir + rx(x) * x_dir) + origin.
struct BandRays {
  Eigen::Vector3f row_dir, x_dir, origin;
  float cx, fx_inv, trunc;
};

/// The band segments of eight pixels of a row: ends a = ray(z0), b = ray(z1) and their cells.
struct BandSegments8 {
  float a[3][8], b[3][8];
  int ia[3][8], ib[3][8];
};

#if AOSCAN_TSDF_X86
/// floor() of eight floats within the int range, as floor_to_int() computes it.
__attribute__((target("avx2"))) inline __m256i floor8(__m256 v) {
  const __m256i i = _mm256_cvttps_epi32(v);
  const __m256 above = _mm256_cmp_ps(_mm256_cvtepi32_ps(i), v, _CMP_GT_OQ);
  return _mm256_add_epi32(i, _mm256_castps_si256(above));  // true lanes are -1
}

/// The band segment set-up of pixels x0 .. x0 + 7 of one row with AVX2: the float operations
/// of the per-pixel code in the same order (no FMA), so the same ends and cells. Returns the
/// lanes with a valid depth (bit i = pixel x0 + i) in the low byte and, among them, those whose
/// ends are inside the packable block range in the high byte.
__attribute__((target("avx2"))) int band_segments_avx2(const float* depth, int x0,
                                                       const BandRays& r, BandSegments8& out) {
  const __m256 d = _mm256_loadu_ps(depth + x0);
  const __m256 valid = _mm256_and_ps(_mm256_cmp_ps(d, _mm256_setzero_ps(), _CMP_GT_OQ),
                                     _mm256_cmp_ps(d, _mm256_set1_ps(1e4f), _CMP_LT_OQ));
  const int valid_bits = _mm256_movemask_ps(valid);
  if (valid_bits == 0) return 0;
  const __m256 xs =
      _mm256_add_ps(_mm256_set1_ps(static_cast<float>(x0)), _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7));
  const __m256 rx =
      _mm256_mul_ps(_mm256_sub_ps(xs, _mm256_set1_ps(r.cx)), _mm256_set1_ps(r.fx_inv));
  const __m256 trunc = _mm256_set1_ps(r.trunc);
  const __m256 z0 = _mm256_max_ps(_mm256_sub_ps(d, trunc), _mm256_mul_ps(_mm256_set1_ps(0.5f), d));
  const __m256 z1 = _mm256_add_ps(d, trunc);
  const __m256 limit = _mm256_set1_ps(static_cast<float>(TsdfVolume::kMaxBlockCoord));
  const __m256 neg_limit = _mm256_set1_ps(-static_cast<float>(TsdfVolume::kMaxBlockCoord));
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7FFFFFFF));
  __m256 inside = valid;
  for (int c = 0; c < 3; ++c) {
    const __m256 dir =
        _mm256_add_ps(_mm256_set1_ps(r.row_dir[c]), _mm256_mul_ps(rx, _mm256_set1_ps(r.x_dir[c])));
    const __m256 origin = _mm256_set1_ps(r.origin[c]);
    const __m256 a = _mm256_add_ps(_mm256_mul_ps(dir, z0), origin);
    const __m256 b = _mm256_add_ps(_mm256_mul_ps(dir, z1), origin);
    inside = _mm256_and_ps(inside, _mm256_cmp_ps(_mm256_and_ps(a, abs_mask), limit, _CMP_LT_OQ));
    inside = _mm256_and_ps(inside, _mm256_cmp_ps(_mm256_and_ps(b, abs_mask), limit, _CMP_LT_OQ));
    _mm256_storeu_ps(out.a[c], a);
    _mm256_storeu_ps(out.b[c], b);
    // Lanes outside the range are never read; clamp them so the conversion stays defined.
    const __m256i ia = floor8(_mm256_min_ps(_mm256_max_ps(a, neg_limit), limit));
    const __m256i ib = floor8(_mm256_min_ps(_mm256_max_ps(b, neg_limit), limit));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out.ia[c]), ia);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out.ib[c]), ib);
  }
  return valid_bits | (_mm256_movemask_ps(inside) << 8);
}
#endif

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
  last_frame_.clear();
  last_frame_.shrink_to_fit();
  visible_.clear();
  capacity_reached_ = false;
  frame_counter_ = 0;
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
  last_frame_.push_back(0);
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
         coords_.capacity() * sizeof(Eigen::Vector3i) +
         last_frame_.capacity() * sizeof(std::uint32_t);
}

IntegrateStats TsdfVolume::allocate_band(const Image<float>& depth_m, const Intrinsics& intrinsics,
                                         const Pose& T_world_camera, bool fast, bool simd) {
  IntegrateStats stats;
  visible_.clear();
  if (depth_m.width() != intrinsics.width || depth_m.height() != intrinsics.height)
    throw usage_error("integrate: depth image is " + std::to_string(depth_m.width()) + "x" +
                      std::to_string(depth_m.height()) + " but the intrinsics are " +
                      std::to_string(intrinsics.width) + "x" + std::to_string(intrinsics.height));
  if (!T_world_camera.finite()) {
    stats.skipped = true;
    return stats;
  }
  ++frame_counter_;
  const int chunks = (depth_m.height() + kRowsPerChunk - 1) / kRowsPerChunk;
  chunk_keys_.resize(chunks);
  chunk_rays_.assign(chunks, 0);

  const Eigen::Matrix3f R = T_world_camera.rotation().cast<float>();
  const Eigen::Vector3f t = T_world_camera.translation().cast<float>();
  // Block-grid coordinates q = (p_world / voxel + 0.5) / 8: block floor(q) holds the voxel
  // nearest to p_world.
  const float to_grid = 1.0f / (voxel_size_ * kBlockSize);
  const Eigen::Vector3f grid_offset = Eigen::Vector3f::Constant(0.5f / kBlockSize);
  const float fx_inv = static_cast<float>(1.0 / intrinsics.fx);
  const float fy_inv = static_cast<float>(1.0 / intrinsics.fy);
  const float cx = static_cast<float>(intrinsics.cx);
  const float cy = static_cast<float>(intrinsics.cy);
  const float trunc = truncation_;
  const Eigen::Vector3f x_dir = R.col(0) * to_grid;
  const Eigen::Vector3f origin = t * to_grid + grid_offset;

  auto run_chunk = [&](int c) {
    std::vector<std::uint64_t>& keys = chunk_keys_[c];
    keys.clear();
    std::uint64_t cache[1 << kKeyCacheBits];
    std::fill(std::begin(cache), std::end(cache), BlockHashMap::kEmpty);
    int rays = 0;
    const int y_end = std::min(depth_m.height(), (c + 1) * kRowsPerChunk);
    Eigen::Vector3i last_a = Eigen::Vector3i::Zero(), last_b = Eigen::Vector3i::Zero();
    int last_rank[3] = {0, 0, 0};
    bool have_last = false;
    // The blocks of one pixel's band segment a-b (block-grid units, ends within the packable
    // range, ia and ib their cells).
    auto segment = [&](const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                       const Eigen::Vector3i& ia, const Eigen::Vector3i& ib) {
      if (!fast) {
        traverse_segment(a, b, ia, ib, cache, keys);
        return;
      }
      // Fast path, the same blocks: a segment at most one cell from its first cell per axis
      // crosses the cells its crossing order (ranks) gives; when the end cells and the order
      // equal the previous such pixel's, every key was just emitted.
      if ((ib - ia).cwiseAbs().maxCoeff() > 1) {
        traverse_segment(a, b, ia, ib, cache, keys);
        have_last = false;
        return;
      }
      int rank[3];
      short_path_ranks(a, b, ia, ib, rank);
      if (have_last && ia == last_a && ib == last_b && rank[0] == last_rank[0] &&
          rank[1] == last_rank[1] && rank[2] == last_rank[2])
        return;
      emit_key(ia, cache, keys);
      emit_short_path(ia, ib, rank,
                      [&](const Eigen::Vector3i& cell) { emit_key(cell, cache, keys); });
      last_a = ia;
      last_b = ib;
      std::copy(rank, rank + 3, last_rank);
      have_last = true;
    };
    for (int y = c * kRowsPerChunk; y < y_end; ++y) {
      const float* row = depth_m.row(y);
      const float ry = (static_cast<float>(y) - cy) * fy_inv;
      // The pixel's ray direction in block-grid units per metre of depth: row_dir + rx * x_dir.
      const BandRays rays_of_row{
          (R.col(1) * ry + R.col(2)) * to_grid, x_dir, origin, cx, fx_inv, trunc};
      int x = 0;
#if AOSCAN_TSDF_X86
      if (simd) {
        BandSegments8 batch;
        for (; x + 8 <= depth_m.width(); x += 8) {
          const int bits = band_segments_avx2(row, x, rays_of_row, batch);
          rays += __builtin_popcount(bits & 0xFF);
          for (int inside = bits >> 8; inside != 0; inside &= inside - 1) {
            const int l = __builtin_ctz(inside);
            segment({batch.a[0][l], batch.a[1][l], batch.a[2][l]},
                    {batch.b[0][l], batch.b[1][l], batch.b[2][l]},
                    {batch.ia[0][l], batch.ia[1][l], batch.ia[2][l]},
                    {batch.ib[0][l], batch.ib[1][l], batch.ib[2][l]});
          }
        }
      }
#else
      (void)simd;
#endif
      for (; x < depth_m.width(); ++x) {
        const float d = row[x];
        if (!valid_depth(d)) continue;
        ++rays;
        const float rx = (static_cast<float>(x) - cx) * fx_inv;
        const Eigen::Vector3f dir = rays_of_row.row_dir + rx * x_dir;
        const float z0 = std::max(d - trunc, 0.5f * d);
        const float z1 = d + trunc;
        const Eigen::Vector3f a = dir * z0 + origin;
        const Eigen::Vector3f b = dir * z1 + origin;
        constexpr float kLimit = static_cast<float>(kMaxBlockCoord);
        if (!(a.cwiseAbs().maxCoeff() < kLimit && b.cwiseAbs().maxCoeff() < kLimit)) continue;
        segment(a, b, floor_cell(a), floor_cell(b));
      }
    }
    chunk_rays_[c] = rays;
  };
  if (fast) {
    tbb::parallel_for(0, chunks, run_chunk);
  } else {
    for (int c = 0; c < chunks; ++c) run_chunk(c);
  }

  // Serial merge in chunk order: block indices and the visible list are deterministic.
  for (int c = 0; c < chunks; ++c) {
    stats.rays += chunk_rays_[c];
    for (const std::uint64_t key : chunk_keys_[c]) {
      int index = map_.find(key);
      if (index < 0) {
        index = allocate_block(unpack(key));
        if (index < 0) {
          ++stats.blocks_dropped;
          continue;
        }
        ++stats.blocks_allocated;
      }
      if (last_frame_[index] != frame_counter_) {
        last_frame_[index] = frame_counter_;
        visible_.push_back(index);
      }
    }
  }
  stats.blocks_updated = static_cast<int>(visible_.size());
  return stats;
}

void TsdfVolume::update_block(int index, const Image<float>& depth_m, const Intrinsics& intrinsics,
                              const Eigen::Matrix3f& R_camera_world,
                              const Eigen::Vector3f& t_camera_world) {
  VoxelBlock& blk = block(index);
  const Eigen::Vector3i base = coords_[index] * kBlockSize;
  const float fx = static_cast<float>(intrinsics.fx);
  const float fy = static_cast<float>(intrinsics.fy);
  const float cx = static_cast<float>(intrinsics.cx);
  const float cy = static_cast<float>(intrinsics.cy);
  const float max_u = static_cast<float>(depth_m.width()) - 0.5f;
  const float max_v = static_cast<float>(depth_m.height()) - 0.5f;
  const float inv_trunc = 1.0f / truncation_;
  for (int z = 0; z < kBlockSize; ++z) {
    for (int y = 0; y < kBlockSize; ++y) {
      for (int x = 0; x < kBlockSize; ++x) {
        const Eigen::Vector3f p_world(static_cast<float>(base.x() + x) * voxel_size_,
                                      static_cast<float>(base.y() + y) * voxel_size_,
                                      static_cast<float>(base.z() + z) * voxel_size_);
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
        if (sdf < -truncation_) continue;
        const float tsdf = std::min(1.0f, sdf * inv_trunc);
        blk.voxels[voxel_index(x, y, z)].add_observation(tsdf, max_weight_);
      }
    }
  }
}

void TsdfVolume::update_block_fast(int index, const Image<float>& depth_m,
                                   const Intrinsics& intrinsics,
                                   const Eigen::Matrix3f& R_camera_world,
                                   const Eigen::Vector3f& t_camera_world, bool simd) {
  // The camera-frame position is affine in the voxel's local coordinates: p = p0 + x dx + y dy +
  // z dz, so a voxel costs three multiply-adds and one reciprocal instead of a matrix product and
  // two divisions.
  BlockProjection b;
  b.p0 =
      R_camera_world * ((coords_[index] * kBlockSize).cast<float>() * voxel_size_) + t_camera_world;
  b.dx = R_camera_world.col(0) * voxel_size_;
  b.dy = R_camera_world.col(1) * voxel_size_;
  b.dz = R_camera_world.col(2) * voxel_size_;
  b.fx = static_cast<float>(intrinsics.fx);
  b.fy = static_cast<float>(intrinsics.fy);
  // Shifted by half a pixel: the nearest pixel is the integer part.
  b.cx = static_cast<float>(intrinsics.cx) + 0.5f;
  b.cy = static_cast<float>(intrinsics.cy) + 0.5f;
  b.width = depth_m.width();
  b.w_max = static_cast<float>(depth_m.width());
  b.h_max = static_cast<float>(depth_m.height());
  b.depth = depth_m.data();
  b.truncation = truncation_;
  b.inv_trunc = 1.0f / truncation_;
  b.max_weight = max_weight_;
  Voxel* voxels = block(index).voxels.data();
#if AOSCAN_TSDF_X86
  if (simd) {
    update_block_avx2(b, voxels);
    return;
  }
#else
  (void)simd;
#endif
  update_block_portable(b, voxels);
}

IntegrateStats TsdfVolume::integrate(const Image<float>& depth_m, const Intrinsics& intrinsics,
                                     const Pose& T_world_camera) {
#if AOSCAN_TSDF_X86
  return integrate_fast(depth_m, intrinsics, T_world_camera, cpu_has_avx2());
#else
  return integrate_fast(depth_m, intrinsics, T_world_camera, false);
#endif
}

IntegrateStats TsdfVolume::integrate_portable(const Image<float>& depth_m,
                                              const Intrinsics& intrinsics,
                                              const Pose& T_world_camera) {
  return integrate_fast(depth_m, intrinsics, T_world_camera, false);
}

IntegrateStats TsdfVolume::integrate_fast(const Image<float>& depth_m, const Intrinsics& intrinsics,
                                          const Pose& T_world_camera, bool simd) {
  IntegrateStats stats = allocate_band(depth_m, intrinsics, T_world_camera, true, simd);
  if (stats.skipped) return stats;
  const Pose T_camera_world = T_world_camera.inverse();
  const Eigen::Matrix3f R = T_camera_world.rotation().cast<float>();
  const Eigen::Vector3f t = T_camera_world.translation().cast<float>();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, visible_.size(), 16),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i)
                        update_block_fast(visible_[i], depth_m, intrinsics, R, t, simd);
                    });
  return stats;
}

IntegrateStats TsdfVolume::integrate_reference(const Image<float>& depth_m,
                                               const Intrinsics& intrinsics,
                                               const Pose& T_world_camera) {
  IntegrateStats stats = allocate_band(depth_m, intrinsics, T_world_camera, false, false);
  if (stats.skipped) return stats;
  const Pose T_camera_world = T_world_camera.inverse();
  const Eigen::Matrix3f R = T_camera_world.rotation().cast<float>();
  const Eigen::Vector3f t = T_camera_world.translation().cast<float>();
  for (const int index : visible_) update_block(index, depth_m, intrinsics, R, t);
  return stats;
}

}  // namespace aoscan
