/// @file tsdf_integrator.cpp
/// @brief Projective TSDF integration: band allocation along the depth rays, the portable voxel
/// update, and the one dispatch to the AVX2 kernels (tsdf_integrator_avx2.cpp).
#include "fusion/tsdf/tsdf_integrator.h"

#include <algorithm>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/status.h"
#include "fusion/tsdf/grid_traversal.h"
#include "fusion/tsdf/tsdf_integrator_kernels.h"
#include "geometry/simd.h"

namespace aoscan {

bool detail::integration_input_usable(const Image<float>& depth_m, const Intrinsics& intrinsics,
                                      const Pose& T_world_camera) {
  if (depth_m.width() != intrinsics.width || depth_m.height() != intrinsics.height)
    throw usage_error("integrate: depth image is " + std::to_string(depth_m.width()) + "x" +
                      std::to_string(depth_m.height()) + " but the intrinsics are " +
                      std::to_string(intrinsics.width) + "x" + std::to_string(intrinsics.height));
  return T_world_camera.finite();
}
namespace {

using detail::BandLeft;
using detail::BandRays;
using detail::BandSegments8;
using detail::BlockProjection;

/// Image rows handled by one allocation task; fixed so the work split never depends on threads.
constexpr int kRowsPerChunk = 8;
/// Slots of the per-chunk direct-mapped cache that drops repeated block keys of nearby rays.
constexpr int kKeyCacheBits = 9;

/// The set bits among the low 8 of `bits`, without a library call (the build's baseline CPU has
/// no popcnt instruction, and __builtin_popcount then calls libgcc).
inline int popcount8(unsigned bits) {
  bits &= 0xFFu;
  bits -= (bits >> 1) & 0x55u;
  bits = (bits & 0x33u) + ((bits >> 2) & 0x33u);
  return static_cast<int>((bits + (bits >> 4)) & 0x0Fu);
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

/// The block keys of the band segments of rows y_begin .. y_end - 1, appended to `keys`; returns
/// the number of valid depth pixels. Skips the traversal of segments whose cells are known: a
/// segment at most one cell from its first cell per axis crosses the cells its crossing order
/// (ranks) gives, and when the end cells and the order equal the previous such pixel's, every key
/// was just emitted. `simd` (the caller checked the CPU): eight pixels' segments per AVX2 vector,
/// which also finds the pixels that repeat the pixel to their left (their segments never reach
/// the per-pixel code: most pixels of a row, since a block spans many pixels).
int band_keys(const Image<float>& depth_m, int y_begin, int y_end, const Eigen::Matrix3f& R,
              const BandRays& rays_of_image, float cy, float fy_inv, float to_grid, bool simd,
              std::vector<std::uint64_t>& keys) {
  keys.clear();
  std::uint64_t cache[1 << kKeyCacheBits];
  std::fill(std::begin(cache), std::end(cache), BlockHashMap::kEmpty);
  int rays = 0;
  Eigen::Vector3i last_a = Eigen::Vector3i::Zero(), last_b = Eigen::Vector3i::Zero();
  int last_rank[3] = {0, 0, 0};
  bool have_last = false;
  const Eigen::Vector3f& x_dir = rays_of_image.x_dir;
  const Eigen::Vector3f& origin = rays_of_image.origin;
  const float cx = rays_of_image.cx, fx_inv = rays_of_image.fx_inv, trunc = rays_of_image.trunc;
  // The blocks of one pixel's band segment a-b (block-grid units, ends within the packable
  // range, ia and ib their cells).
  auto segment = [&](const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3i& ia,
                     const Eigen::Vector3i& ib) {
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
  for (int y = y_begin; y < y_end; ++y) {
    const float* row = depth_m.row(y);
    const float ry = (static_cast<float>(y) - cy) * fy_inv;
    // The pixel's ray direction in block-grid units per metre of depth: row_dir + rx * x_dir.
    const BandRays rays_of_row{
        (R.col(1) * ry + R.col(2)) * to_grid, x_dir, origin, cx, fx_inv, trunc};
    int x = 0;
#if AOSCAN_TSDF_X86
    if (simd) {
      BandSegments8 batch;
      BandLeft left;
      for (; x + 8 <= depth_m.width(); x += 8) {
        const int bits = detail::band_segments_avx2(row, x, rays_of_row, batch, left);
        rays += popcount8(static_cast<unsigned>(bits));
        // A repeating lane crosses the cells just emitted for the lane to its left, in the same
        // order: segment() would add no key that is not already in `keys`.
        for (int inside = (bits >> 8) & ~(bits >> 16) & 0xFF; inside != 0; inside &= inside - 1) {
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
      Eigen::Vector3f a, b;
      if (!detail::band_segment(dir, origin, d, trunc, a, b)) continue;
      segment(a, b, floor_cell(a), floor_cell(b));
    }
  }
  return rays;
}

/// The fast voxel update of block `index` of `volume`: the camera-frame position is affine in
/// the voxel's local coordinates, p = p0 + x dx + y dy + z dz, so a voxel costs three
/// multiply-adds and one reciprocal instead of a matrix product and two divisions (the same update
/// as the plain one up to float rounding of the projection: a voxel whose projection lies within
/// rounding of a pixel border may read the neighbouring pixel). `simd`: one voxel row per AVX2
/// vector (the caller checked the CPU), bit for bit the same result.
void update_block_fast(TsdfVolume& volume, int index, const Image<float>& depth_m,
                       const Intrinsics& intrinsics, const Eigen::Matrix3f& R_camera_world,
                       const Eigen::Vector3f& t_camera_world, bool simd) {
  const float voxel_size = volume.voxel_size_m();
  BlockProjection b;
  b.p0 = R_camera_world * ((volume.block_coord(index) * kBlockSize).cast<float>() * voxel_size) +
         t_camera_world;
  b.dx = R_camera_world.col(0) * voxel_size;
  b.dy = R_camera_world.col(1) * voxel_size;
  b.dz = R_camera_world.col(2) * voxel_size;
  b.fx = static_cast<float>(intrinsics.fx);
  b.fy = static_cast<float>(intrinsics.fy);
  // Shifted by half a pixel: the nearest pixel is the integer part.
  b.cx = static_cast<float>(intrinsics.cx) + 0.5f;
  b.cy = static_cast<float>(intrinsics.cy) + 0.5f;
  b.width = depth_m.width();
  b.w_max = static_cast<float>(depth_m.width());
  b.h_max = static_cast<float>(depth_m.height());
  b.depth = depth_m.data();
  b.truncation = volume.truncation_m();
  b.inv_trunc = 1.0f / volume.truncation_m();
  b.max_weight = volume.max_weight();
  Voxel* voxels = volume.block(index).voxels.data();
#if AOSCAN_TSDF_X86
  if (simd) {
    detail::update_block_avx2(b, voxels);
    return;
  }
#else
  (void)simd;
#endif
  update_block_portable(b, voxels);
}

}  // namespace

void TsdfIntegrator::reset() {
  last_frame_.clear();
  last_frame_.shrink_to_fit();
  visible_.clear();
  frame_counter_ = 0;
}

IntegrateStats TsdfIntegrator::allocate_band(TsdfVolume& volume, const Image<float>& depth_m,
                                             const Intrinsics& intrinsics,
                                             const Pose& T_world_camera, bool simd) {
  IntegrateStats stats;
  visible_.clear();
  if (!detail::integration_input_usable(depth_m, intrinsics, T_world_camera)) {
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
  const float to_grid = 1.0f / (volume.voxel_size_m() * kBlockSize);
  const Eigen::Vector3f grid_offset = Eigen::Vector3f::Constant(0.5f / kBlockSize);
  const float fy_inv = static_cast<float>(1.0 / intrinsics.fy);
  const float cy = static_cast<float>(intrinsics.cy);
  // Everything of the pixel rays but the row direction (filled per row).
  const BandRays rays_of_image{Eigen::Vector3f::Zero(),
                               R.col(0) * to_grid,
                               t * to_grid + grid_offset,
                               static_cast<float>(intrinsics.cx),
                               static_cast<float>(1.0 / intrinsics.fx),
                               volume.truncation_m()};
  tbb::parallel_for(0, chunks, [&](int c) {
    const int y_end = std::min(depth_m.height(), (c + 1) * kRowsPerChunk);
    chunk_rays_[c] = band_keys(depth_m, c * kRowsPerChunk, y_end, R, rays_of_image, cy, fy_inv,
                               to_grid, simd, chunk_keys_[c]);
  });
  merge_chunks(volume, stats);
  return stats;
}

void TsdfIntegrator::merge_chunks(TsdfVolume& volume, IntegrateStats& stats) {
  // A volume with fewer blocks than listed here was reset (its blocks are new); blocks allocated
  // since the last frame by others get their entry.
  const auto blocks = static_cast<std::size_t>(volume.block_count());
  if (last_frame_.size() > blocks) last_frame_.clear();
  if (last_frame_.size() < blocks) last_frame_.resize(blocks, 0);
  // Serial merge in chunk order: block indices and the visible list are deterministic.
  for (std::size_t c = 0; c < chunk_keys_.size(); ++c) {
    stats.rays += chunk_rays_[c];
    for (const std::uint64_t key : chunk_keys_[c]) {
      int index = volume.find_block_key(key);
      if (index < 0) {
        index = volume.allocate_block(TsdfVolume::unpack(key));
        if (index < 0) {
          ++stats.blocks_dropped;
          continue;
        }
        ++stats.blocks_allocated;
        last_frame_.push_back(0);
      }
      if (last_frame_[index] != frame_counter_) {
        last_frame_[index] = frame_counter_;
        visible_.push_back(index);
      }
    }
  }
  stats.blocks_updated = static_cast<int>(visible_.size());
}

IntegrateStats TsdfIntegrator::integrate(TsdfVolume& volume, const Image<float>& depth_m,
                                         const Intrinsics& intrinsics,
                                         const Pose& T_world_camera, BlockVisitor* visitor) {
  // The one dispatch of the AVX2 kernels: the band set-up and the voxel update.
#if AOSCAN_TSDF_X86
  return integrate_fast(volume, depth_m, intrinsics, T_world_camera, cpu_has_avx2(), visitor);
#else
  return integrate_fast(volume, depth_m, intrinsics, T_world_camera, false, visitor);
#endif
}

IntegrateStats TsdfIntegrator::integrate_portable(TsdfVolume& volume, const Image<float>& depth_m,
                                                  const Intrinsics& intrinsics,
                                                  const Pose& T_world_camera) {
  return integrate_fast(volume, depth_m, intrinsics, T_world_camera, false, nullptr);
}

IntegrateStats TsdfIntegrator::integrate_fast(TsdfVolume& volume, const Image<float>& depth_m,
                                              const Intrinsics& intrinsics,
                                              const Pose& T_world_camera, bool simd,
                                              BlockVisitor* visitor) {
  IntegrateStats stats = allocate_band(volume, depth_m, intrinsics, T_world_camera, simd);
  if (stats.skipped) return stats;
  if (visitor != nullptr) visitor->begin(volume, visible_);
  const Pose T_camera_world = T_world_camera.inverse();
  const Eigen::Matrix3f R = T_camera_world.rotation().cast<float>();
  const Eigen::Vector3f t = T_camera_world.translation().cast<float>();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, visible_.size(), 16),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        update_block_fast(volume, visible_[i], depth_m, intrinsics, R, t, simd);
                        if (visitor != nullptr) visitor->visit(volume, i);
                      }
                    });
  return stats;
}

}  // namespace aoscan
