/// @file tsdf_integrator_kernels.h
/// @brief Internal to the TSDF integrator: what its portable code (tsdf_integrator.cpp) and its
/// AVX2 kernels (tsdf_integrator_avx2.cpp) share. Not for use outside src/fusion/tsdf/.
#pragma once

#include <algorithm>

#include <Eigen/Core>

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/pose.h"
#include "fusion/tsdf/tsdf_volume.h"

#if defined(__x86_64__) && defined(__GNUC__)
#define AOSCAN_TSDF_X86 1
#else
#define AOSCAN_TSDF_X86 0
#endif

namespace aoscan {
namespace detail {

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

/// What the band allocation needs per pixel ray, in block-grid units (cell floor(q) is block q):
/// the ray of pixel (x, y) at depth z is z * (row_dir + rx(x) * x_dir) + origin.
struct BandRays {
  Eigen::Vector3f row_dir, x_dir, origin;
  float cx, fx_inv, trunc;
};

/// The band segments of eight pixels of a row: ends a = ray(z0), b = ray(z1) and their cells.
/// A pixel *repeats* the pixel to its left when both are inside the block range, their ends lie
/// in the same cells, and either the segments are short (at most one cell along every axis) and
/// cross the cell walls in the same order, or they change cell along one axis only: such a segment
/// crosses exactly the cells of its left neighbour, in the same order, so the band allocation
/// skips it.
struct BandSegments8 {
  float a[3][8], b[3][8];
  int ia[3][8], ib[3][8];
};

/// The last pixel of the previous eight of a row, for the first of the next eight.
struct BandLeft {
  int ia[3] = {0, 0, 0}, ib[3] = {0, 0, 0}, rank[3] = {0, 0, 0};
  bool inside = false;  ///< false at the start of a row
};

#if AOSCAN_TSDF_X86
/// The fast voxel update (update_block_portable() in tsdf_integrator.cpp) with one voxel row
/// (8 voxels, 32 bytes) per AVX2 vector and a gather of the 8 depths: the same operations in the
/// same order, so bit for bit the same result. Only on a CPU with AVX2.
void update_block_avx2(const BlockProjection& b, Voxel* voxels);

/// The band segment set-up of pixels x0 .. x0 + 7 of one row with AVX2: the float operations of
/// the per-pixel code in the same order (no FMA), so the same ends, cells and crossing order.
/// Returns the lanes with a valid depth (bit i = pixel x0 + i) in bits 0-7, among them those whose
/// ends are inside the packable block range in bits 8-15, and among those the lanes that repeat
/// the pixel to their left (BandSegments8) in bits 16-23. `left`: the row's pixel before x0 (reset
/// at the start of a row), updated to pixel x0 + 7. Only on a CPU with AVX2.
int band_segments_avx2(const float* depth, int x0, const BandRays& r, BandSegments8& out,
                       BandLeft& left);
#endif

/// The truncation band of a pixel's ray with depth d, in voxel units: from max(d - trunc, d / 2)
/// to d + trunc along `dir` (voxels per metre of depth) from `origin`. False when the band leaves
/// the range of block coordinates.
inline bool band_segment(const Eigen::Vector3f& dir, const Eigen::Vector3f& origin, float d,
                         float trunc, Eigen::Vector3f& a, Eigen::Vector3f& b) {
  const float z0 = std::max(d - trunc, 0.5f * d);
  const float z1 = d + trunc;
  a = dir * z0 + origin;
  b = dir * z1 + origin;
  constexpr float kLimit = static_cast<float>(TsdfVolume::kMaxBlockCoord);
  return a.cwiseAbs().maxCoeff() < kLimit && b.cwiseAbs().maxCoeff() < kLimit;
}

/// The integration's input check, shared with the plain reference of the tests: throws
/// usage_error when the depth's size differs from the intrinsics; false (nothing to do) when the
/// pose is not finite.
bool integration_input_usable(const Image<float>& depth_m, const Intrinsics& intrinsics,
                              const Pose& T_world_camera);

}  // namespace detail
}  // namespace aoscan
