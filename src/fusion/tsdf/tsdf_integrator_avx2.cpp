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

/// Lane i - 1 of v moved to lane i, and lane 0 given `carried` (the last lane of the eight before).
__attribute__((target("avx2"))) inline __m256i from_left(__m256i v, int carried) {
  const __m256i to_left = _mm256_setr_epi32(7, 0, 1, 2, 3, 4, 5, 6);
  return _mm256_blend_epi32(_mm256_permutevar8x32_epi32(v, to_left), _mm256_set1_epi32(carried),
                            0x01);
}

/// short_path_ranks()'s "axis i crosses before axis j" of eight segments, -1 where it does.
__attribute__((target("avx2"))) inline __m256i crosses_before(const __m256* num, const __m256* den,
                                                              const __m256i* moves, int i, int j) {
  const __m256 ti = _mm256_mul_ps(num[i], den[j]), tj = _mm256_mul_ps(num[j], den[i]);
  const __m256i earlier = _mm256_castps_si256(i < j ? _mm256_cmp_ps(ti, tj, _CMP_LE_OQ)
                                                    : _mm256_cmp_ps(ti, tj, _CMP_LT_OQ));
  const __m256i j_still = _mm256_cmpeq_epi32(moves[j], _mm256_setzero_si256());
  return _mm256_and_si256(moves[i], _mm256_or_si256(j_still, earlier));
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
/// of the per-pixel code in the same order (no FMA), so the same ends, cells and crossing order.
/// Returns the lanes with a valid depth (bit i = pixel x0 + i) in bits 0-7, among them those whose
/// ends are inside the packable block range in bits 8-15, and among those the lanes that repeat
/// the pixel to their left (BandSegments8) in bits 16-23; `left` carries the row's last lane from
/// one call to the next.
__attribute__((target("avx2"))) int band_segments_avx2(const float* depth, int x0,
                                                       const BandRays& r, BandSegments8& out,
                                                       BandLeft& left) {
  const __m256 d = _mm256_loadu_ps(depth + x0);
  const __m256 valid = _mm256_and_ps(_mm256_cmp_ps(d, _mm256_setzero_ps(), _CMP_GT_OQ),
                                     _mm256_cmp_ps(d, _mm256_set1_ps(1e4f), _CMP_LT_OQ));
  const int valid_bits = _mm256_movemask_ps(valid);
  if (valid_bits == 0) {
    left.inside = false;
    return 0;
  }
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
  const __m256i zero = _mm256_setzero_si256();
  __m256 inside = valid;
  __m256 av[3], bv[3];
  __m256i ia[3], ib[3], delta[3], moves[3];
  __m256i same = _mm256_set1_epi32(-1);        // ends in the cells of the pixel to the left
  __m256i moving = zero;                       // the number of axes along which the cell changes
  __m256i within_one = _mm256_set1_epi32(-1);  // at most one cell along every axis
  for (int c = 0; c < 3; ++c) {
    const __m256 dir =
        _mm256_add_ps(_mm256_set1_ps(r.row_dir[c]), _mm256_mul_ps(rx, _mm256_set1_ps(r.x_dir[c])));
    const __m256 origin = _mm256_set1_ps(r.origin[c]);
    av[c] = _mm256_add_ps(_mm256_mul_ps(dir, z0), origin);
    bv[c] = _mm256_add_ps(_mm256_mul_ps(dir, z1), origin);
    inside =
        _mm256_and_ps(inside, _mm256_cmp_ps(_mm256_and_ps(av[c], abs_mask), limit, _CMP_LT_OQ));
    inside =
        _mm256_and_ps(inside, _mm256_cmp_ps(_mm256_and_ps(bv[c], abs_mask), limit, _CMP_LT_OQ));
    _mm256_storeu_ps(out.a[c], av[c]);
    _mm256_storeu_ps(out.b[c], bv[c]);
    // Lanes outside the range are never read; clamp them so the conversion stays defined.
    ia[c] = floor8(_mm256_min_ps(_mm256_max_ps(av[c], neg_limit), limit));
    ib[c] = floor8(_mm256_min_ps(_mm256_max_ps(bv[c], neg_limit), limit));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out.ia[c]), ia[c]);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out.ib[c]), ib[c]);
    same = _mm256_and_si256(
        same, _mm256_and_si256(_mm256_cmpeq_epi32(ia[c], from_left(ia[c], left.ia[c])),
                               _mm256_cmpeq_epi32(ib[c], from_left(ib[c], left.ib[c]))));
    delta[c] = _mm256_sub_epi32(ib[c], ia[c]);
    moves[c] = _mm256_xor_si256(_mm256_cmpeq_epi32(delta[c], zero), _mm256_set1_epi32(-1));
    moving = _mm256_sub_epi32(moving, moves[c]);
    within_one = _mm256_andnot_si256(
        _mm256_cmpgt_epi32(_mm256_abs_epi32(delta[c]), _mm256_set1_epi32(1)), within_one);
  }
  // The crossing order of short segments, as short_path_ranks() finds it (lanes with a longer
  // segment get a meaningless order, never compared: their cells alone decide below).
  __m256 num[3], den[3];
  for (int c = 0; c < 3; ++c) {
    const __m256 sign = _mm256_cvtepi32_ps(delta[c]);
    const __m256 plane =
        _mm256_cvtepi32_ps(_mm256_blendv_epi8(ia[c], ib[c], _mm256_cmpgt_epi32(delta[c], zero)));
    num[c] = _mm256_mul_ps(_mm256_sub_ps(plane, av[c]), sign);
    den[c] =
        _mm256_blendv_ps(_mm256_set1_ps(1.0f), _mm256_mul_ps(_mm256_sub_ps(bv[c], av[c]), sign),
                         _mm256_castsi256_ps(moves[c]));
  }
  __m256i rank[3];
  rank[0] = _mm256_sub_epi32(zero, _mm256_add_epi32(crosses_before(num, den, moves, 1, 0),
                                                    crosses_before(num, den, moves, 2, 0)));
  rank[1] = _mm256_sub_epi32(zero, _mm256_add_epi32(crosses_before(num, den, moves, 0, 1),
                                                    crosses_before(num, den, moves, 2, 1)));
  rank[2] = _mm256_sub_epi32(zero, _mm256_add_epi32(crosses_before(num, den, moves, 0, 2),
                                                    crosses_before(num, den, moves, 1, 2)));
  __m256i same_order = _mm256_set1_epi32(-1);
  for (int c = 0; c < 3; ++c)
    same_order =
        _mm256_and_si256(same_order, _mm256_cmpeq_epi32(rank[c], from_left(rank[c], left.rank[c])));
  // A short segment with the cells and order of the pixel before crosses what it just crossed;
  // a longer one along one axis only crosses the cells between its ends, whatever its ends.
  const __m256i one_axis = _mm256_cmpgt_epi32(_mm256_set1_epi32(2), moving);
  const __m256i repeats =
      _mm256_and_si256(same, _mm256_or_si256(_mm256_and_si256(within_one, same_order),
                                             _mm256_andnot_si256(within_one, one_axis)));
  const int inside_bits = _mm256_movemask_ps(inside);
  const int left_inside = (inside_bits << 1) | (left.inside ? 1 : 0);
  const int repeat_bits =
      _mm256_movemask_ps(_mm256_castsi256_ps(repeats)) & inside_bits & left_inside & 0xFF;
  for (int c = 0; c < 3; ++c) {
    left.ia[c] = _mm256_extract_epi32(ia[c], 7);
    left.ib[c] = _mm256_extract_epi32(ib[c], 7);
    left.rank[c] = _mm256_extract_epi32(rank[c], 7);
  }
  left.inside = (inside_bits & 0x80) != 0;
  return valid_bits | (inside_bits << 8) | (repeat_bits << 16);
}

#endif  // AOSCAN_TSDF_X86

}  // namespace detail
}  // namespace aoscan
