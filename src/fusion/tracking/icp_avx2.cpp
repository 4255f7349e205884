/// @file icp_avx2.cpp
/// @brief The AVX2 + FMA rows of icp_system() (dispatched from icp.cpp when the CPU has them):
/// association and normal equations eight frame pixels at a time.
#include "fusion/tracking/icp_kernels.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace aoscan::icp_detail {

#if defined(AOSCAN_ICP_AVX2)
namespace {

/// Horizontal sum of eight float lanes in double, lane 0 first.
__attribute__((target("avx2,fma"))) inline double lane_sum(__m256 v) {
  alignas(32) float f[8];
  _mm256_store_ps(f, v);
  double s = 0.0;
  for (float x : f) s += static_cast<double>(x);
  return s;
}

/// Eight copies of f.
__attribute__((target("avx2,fma"))) AOSCAN_NO_CONTRACT inline __m256 bc(float f) {
  return _mm256_set1_ps(f);
}

/// Row i of the row-major 3x3 `m` times (x, y, z) on eight lanes, as m0 x + m1 y + m2 z left to
/// right without fused multiply-adds (the scalar association's operations).
__attribute__((target("avx2,fma"))) AOSCAN_NO_CONTRACT inline __m256 rotate_row(const float* m,
                                                                                int i, __m256 x,
                                                                                __m256 y,
                                                                                __m256 z) {
  return _mm256_add_ps(
      _mm256_add_ps(_mm256_mul_ps(bc(m[3 * i]), x), _mm256_mul_ps(bc(m[3 * i + 1]), y)),
      _mm256_mul_ps(bc(m[3 * i + 2]), z));
}

/// Eight points base + offset[i] (x, y, z floats each) as x, y, z lanes; reads the float after
/// each point too.
__attribute__((target("avx2,fma"))) inline void load_xyz8(const float* base, const int* offset,
                                                          __m256& x, __m256& y, __m256& z) {
  __m256 r[4];
  for (int i = 0; i < 4; ++i)
    r[i] = _mm256_set_m128(_mm_loadu_ps(base + offset[i + 4]), _mm_loadu_ps(base + offset[i]));
  // 4x4 transposes within each 128-bit half: lanes 0-3 are points 0-3, lanes 4-7 points 4-7.
  const __m256 t0 = _mm256_unpacklo_ps(r[0], r[1]);  // x0 x1 y0 y1
  const __m256 t1 = _mm256_unpackhi_ps(r[0], r[1]);  // z0 z1 . .
  const __m256 t2 = _mm256_unpacklo_ps(r[2], r[3]);  // x2 x3 y2 y3
  const __m256 t3 = _mm256_unpackhi_ps(r[2], r[3]);  // z2 z3 . .
  x = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0));
  y = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2));
  z = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(1, 0, 1, 0));
}

/// Adds the eight correspondences of the lanes in `ok` (frame point p in the model camera frame,
/// model normal m, difference d = p - q) to the per-lane sums of the normal equations: the
/// residual r = m . d, its Jacobian and Huber weight, summed with FMAs.
__attribute__((target("avx2,fma"))) AOSCAN_NO_CONTRACT __attribute__((always_inline)) inline void
accumulate8(const Associator& a, __m256 ok, __m256 px, __m256 py, __m256 pz, __m256 mx, __m256 my,
            __m256 mz, __m256 dx, __m256 dy, __m256 dz, __m256* sa, __m256* sb, __m256& sr) {
  const __m256 one = _mm256_set1_ps(1.0f);
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7FFFFFFF));
  const __m256 r =
      _mm256_and_ps(ok, _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(mx, dx), _mm256_mul_ps(my, dy)),
                                      _mm256_mul_ps(mz, dz)));
  const __m256 j[6] = {
      _mm256_and_ps(ok, _mm256_sub_ps(_mm256_mul_ps(py, mz), _mm256_mul_ps(pz, my))),
      _mm256_and_ps(ok, _mm256_sub_ps(_mm256_mul_ps(pz, mx), _mm256_mul_ps(px, mz))),
      _mm256_and_ps(ok, _mm256_sub_ps(_mm256_mul_ps(px, my), _mm256_mul_ps(py, mx))),
      _mm256_and_ps(ok, mx),
      _mm256_and_ps(ok, my),
      _mm256_and_ps(ok, mz)};
  // Huber weight on r / s with the depth noise scale s = max(1, (z / z_ref)^2): 1 up to the
  // threshold, huber s / |r| above (rejected lanes have r = 0), then divided by s^2.
  const __m256 abs_r = _mm256_and_ps(abs_mask, r);
  const __m256 noise =
      _mm256_max_ps(one, _mm256_mul_ps(_mm256_mul_ps(pz, pz), bc(a.inv_noise_depth_sq)));
  const __m256 huber_scaled = _mm256_mul_ps(bc(a.huber), noise);
  const __m256 weight = _mm256_and_ps(
      ok, _mm256_div_ps(_mm256_blendv_ps(_mm256_div_ps(huber_scaled, abs_r), one,
                                         _mm256_cmp_ps(abs_r, huber_scaled, _CMP_LE_OQ)),
                        _mm256_mul_ps(noise, noise)));
  int k = 0;
  for (int i = 0; i < 6; ++i) {
    const __m256 wj = _mm256_mul_ps(weight, j[i]);
    for (int c = i; c < 6; ++c, ++k) sa[k] = _mm256_fmadd_ps(wj, j[c], sa[k]);
    sb[i] = _mm256_fmadd_ps(wj, r, sb[i]);
  }
  sr = _mm256_fmadd_ps(r, r, sr);
}

}  // namespace

__attribute__((target("avx2,fma"))) AOSCAN_NO_CONTRACT void row_avx2(const Associator& a,
                                                                     const float* vertices,
                                                                     const float* normals, int x0,
                                                                     int width, int step,
                                                                     Accumulator<double>& acc) {
  const int count = x0 < width ? (width - x0 + step - 1) / step : 0;
  // Each pixel is read as four floats (x, y, z and the next pixel's x): a block never ends on
  // the row's last pixel, so those reads stay inside the row.
  int blocks = count / 8;
  if (blocks > 0 && x0 + (8 * blocks - 1) * step >= width - 1) --blocks;
  int frame_offset[8];
  for (int i = 0; i < 8; ++i) frame_offset[i] = 3 * step * i;
  // Model points are read the same way, except the image's last pixel (its extra float would lie
  // past the end): a block that needs it gathers.
  const __m256i model_last = _mm256_set1_epi32(a.model_last);
  const __m256 zero = _mm256_setzero_ps();
  const __m256 half = _mm256_set1_ps(0.5f);
  __m256 sa[21], sb[6], sr = zero;
  for (__m256& s : sa) s = zero;
  for (__m256& s : sb) s = zero;
  int inliers = 0, valid = 0;
  for (int b = 0; b < blocks; ++b) {
    const int x = x0 + 8 * b * step;
    const float* fv = vertices + 3 * x;
    const float* fn = normals + 3 * x;
    __m256 vx, vy, vz, nx, ny, nz;
    load_xyz8(fv, frame_offset, vx, vy, vz);
    __m256 ok = _mm256_cmp_ps(vz, zero, _CMP_GT_OQ);
    if (_mm256_movemask_ps(ok) == 0) continue;
    load_xyz8(fn, frame_offset, nx, ny, nz);
    const __m256 n_zero = _mm256_and_ps(
        _mm256_and_ps(_mm256_cmp_ps(nx, zero, _CMP_EQ_OQ), _mm256_cmp_ps(ny, zero, _CMP_EQ_OQ)),
        _mm256_cmp_ps(nz, zero, _CMP_EQ_OQ));
    ok = _mm256_andnot_ps(n_zero, ok);
    const int valid_bits = _mm256_movemask_ps(ok);
    if (valid_bits == 0) continue;
    valid += __builtin_popcount(static_cast<unsigned>(valid_bits));
    // p = R v + t, summed left to right as in the scalar code.
    const __m256 px = _mm256_add_ps(rotate_row(a.rot, 0, vx, vy, vz), bc(a.t[0]));
    const __m256 py = _mm256_add_ps(rotate_row(a.rot, 1, vx, vy, vz), bc(a.t[1]));
    const __m256 pz = _mm256_add_ps(rotate_row(a.rot, 2, vx, vy, vz), bc(a.t[2]));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(pz, zero, _CMP_GT_OQ));
    const __m256 u = _mm256_add_ps(_mm256_div_ps(_mm256_mul_ps(bc(a.fx), px), pz), bc(a.cx));
    const __m256 w = _mm256_add_ps(_mm256_div_ps(_mm256_mul_ps(bc(a.fy), py), pz), bc(a.cy));
    const __m256 lo = bc(-0.5f);
    ok = _mm256_and_ps(
        ok, _mm256_and_ps(_mm256_cmp_ps(u, lo, _CMP_GE_OQ), _mm256_cmp_ps(w, lo, _CMP_GE_OQ)));
    ok = _mm256_and_ps(ok, _mm256_and_ps(_mm256_cmp_ps(u, bc(a.max_u), _CMP_LT_OQ),
                                         _mm256_cmp_ps(w, bc(a.max_v), _CMP_LT_OQ)));
    if (_mm256_movemask_ps(ok) == 0) continue;
    // static_cast<int>(u + 0.5f) truncates toward zero: u + 0.5 >= 0 on the kept lanes.
    const __m256i ui = _mm256_cvttps_epi32(_mm256_add_ps(u, half));
    const __m256i vi = _mm256_cvttps_epi32(_mm256_add_ps(w, half));
    __m256i index = _mm256_mullo_epi32(
        _mm256_add_epi32(_mm256_mullo_epi32(vi, _mm256_set1_epi32(a.model_width)), ui),
        _mm256_set1_epi32(3));
    index = _mm256_and_si256(index, _mm256_castps_si256(ok));  // rejected lanes read pixel 0
    __m256 qx, qy, qz, mx, my, mz;
    if (_mm256_movemask_epi8(_mm256_cmpeq_epi32(index, model_last)) == 0) {
      alignas(32) int model_offset[8];
      _mm256_store_si256(reinterpret_cast<__m256i*>(model_offset), index);
      load_xyz8(a.model_vertices, model_offset, qx, qy, qz);
      load_xyz8(a.model_normals, model_offset, mx, my, mz);
    } else {
      qx = _mm256_i32gather_ps(a.model_vertices, index, 4);
      qy = _mm256_i32gather_ps(a.model_vertices + 1, index, 4);
      qz = _mm256_i32gather_ps(a.model_vertices + 2, index, 4);
      mx = _mm256_i32gather_ps(a.model_normals, index, 4);
      my = _mm256_i32gather_ps(a.model_normals + 1, index, 4);
      mz = _mm256_i32gather_ps(a.model_normals + 2, index, 4);
    }
    const __m256 m_zero = _mm256_and_ps(
        _mm256_and_ps(_mm256_cmp_ps(mx, zero, _CMP_EQ_OQ), _mm256_cmp_ps(my, zero, _CMP_EQ_OQ)),
        _mm256_cmp_ps(mz, zero, _CMP_EQ_OQ));
    ok = _mm256_and_ps(ok, _mm256_andnot_ps(m_zero, _mm256_cmp_ps(qz, zero, _CMP_GT_OQ)));
    const __m256 dx = _mm256_sub_ps(px, qx);
    const __m256 dy = _mm256_sub_ps(py, qy);
    const __m256 dz = _mm256_sub_ps(pz, qz);
    const __m256 dist_sq = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(dist_sq, bc(a.max_distance_sq), _CMP_LE_OQ));
    const __m256 rnx = rotate_row(a.rot, 0, nx, ny, nz);
    const __m256 rny = rotate_row(a.rot, 1, nx, ny, nz);
    const __m256 rnz = rotate_row(a.rot, 2, nx, ny, nz);
    const __m256 cos_angle = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(rnx, mx), _mm256_mul_ps(rny, my)), _mm256_mul_ps(rnz, mz));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(cos_angle, bc(a.min_normal_cos), _CMP_GE_OQ));
    const int inlier_bits = _mm256_movemask_ps(ok);
    if (inlier_bits == 0) continue;
    inliers += __builtin_popcount(static_cast<unsigned>(inlier_bits));
    accumulate8(a, ok, px, py, pz, mx, my, mz, dx, dy, dz, sa, sb, sr);
  }
  Accumulator<double> row;
  for (int k = 0; k < 21; ++k) row.a[k] = lane_sum(sa[k]);
  for (int i = 0; i < 6; ++i) row.b[i] = lane_sum(sb[i]);
  row.residual_sq = lane_sum(sr);
  row.inliers = inliers;
  row.valid = valid;
  acc.add(row);
  Accumulator<float> tail;
  a.row_portable(vertices, normals, x0 + 8 * blocks * step, width, step, tail);
  acc.add(tail);
}
#endif

}  // namespace aoscan::icp_detail
