/// @file tsdf_integrator_avx2.cpp
/// @brief The TSDF integrator's AVX2 kernels: the voxel update one voxel row per vector, and the
/// band segment set-up eight pixels per vector. Compiled for any x86-64 CPU (each function
/// carries its target attribute); tsdf_integrator.cpp calls them only when the CPU has AVX2.
#include "fusion/tsdf/tsdf_integrator_kernels.h"

#if AOSCAN_TSDF_X86
#include <immintrin.h>
#endif

namespace aoscan {
namespace detail {

#if AOSCAN_TSDF_X86

namespace {

/// floor() of eight floats within the int range, as floor_to_int() computes it.
__attribute__((target("avx2"))) inline __m256i floor8(__m256 v) {
  const __m256i i = _mm256_cvttps_epi32(v);
  const __m256 above = _mm256_cmp_ps(_mm256_cvtepi32_ps(i), v, _CMP_GT_OQ);
  return _mm256_add_epi32(i, _mm256_castps_si256(above));  // true lanes are -1
}

}  // namespace

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

#endif  // AOSCAN_TSDF_X86

}  // namespace detail
}  // namespace aoscan
