/// @file point_maps_avx2.cpp
/// @brief The AVX2 rows of compute_point_maps() (dispatched from point_maps.cpp when the CPU has
/// AVX2): vertices and normals eight pixels at a time.
#include "geometry/point_maps_kernels.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace aoscan::point_maps_detail {

#if defined(AOSCAN_POINTS_AVX2)
namespace {

/// Writes eight (x, y, z) lanes as 24 interleaved floats.
__attribute__((target("avx2"))) inline void store_xyz8(float* out, __m256 x, __m256 y, __m256 z) {
  alignas(32) float fx[8], fy[8], fz[8];
  _mm256_store_ps(fx, x);
  _mm256_store_ps(fy, y);
  _mm256_store_ps(fz, z);
  for (int i = 0; i < 8; ++i) {
    out[3 * i] = fx[i];
    out[3 * i + 1] = fy[i];
    out[3 * i + 2] = fz[i];
  }
}

}  // namespace

/// One row of point_scalar() eight pixels at a time with AVX2 (the same operations lane by lane,
/// so the same bits), the row's last pixels scalar.
__attribute__((target("avx2"))) AOSCAN_NO_CONTRACT void points_row_avx2(
    const float* d, const float* dd, const float* cf, float rf, float rfd, int w, float jump,
    float* vertices, float* normals) {
  int x = 0;
  if (dd != nullptr) {
    const __m256 zero = _mm256_setzero_ps();
    const __m256 sign = _mm256_set1_ps(-0.0f);
    const __m256 jump8 = _mm256_set1_ps(jump);
    const __m256 inf = _mm256_set1_ps(INFINITY);
    const __m256 rf8 = _mm256_set1_ps(rf);
    const __m256 rfd8 = _mm256_set1_ps(rfd);
    for (; x + 8 < w; x += 8) {
      const __m256 z = _mm256_loadu_ps(d + x);
      const __m256 zr = _mm256_loadu_ps(d + x + 1);
      const __m256 zd = _mm256_loadu_ps(dd + x);
      const __m256 c0 = _mm256_loadu_ps(cf + x);
      const __m256 c1 = _mm256_loadu_ps(cf + x + 1);
      const __m256 vx = _mm256_mul_ps(c0, z), vy = _mm256_mul_ps(rf8, z);
      const __m256 z_ok = _mm256_cmp_ps(z, zero, _CMP_GT_OQ);
      store_xyz8(vertices + 3 * x, _mm256_and_ps(z_ok, vx), _mm256_and_ps(z_ok, vy),
                 _mm256_and_ps(z_ok, z));
      __m256 ok = _mm256_and_ps(z_ok, _mm256_and_ps(_mm256_cmp_ps(zr, zero, _CMP_GT_OQ),
                                                    _mm256_cmp_ps(zd, zero, _CMP_GT_OQ)));
      ok = _mm256_and_ps(
          ok, _mm256_cmp_ps(_mm256_andnot_ps(sign, _mm256_sub_ps(zr, z)), jump8, _CMP_LE_OQ));
      ok = _mm256_and_ps(
          ok, _mm256_cmp_ps(_mm256_andnot_ps(sign, _mm256_sub_ps(zd, z)), jump8, _CMP_LE_OQ));
      if (_mm256_movemask_ps(ok) == 0) {
        store_xyz8(normals + 3 * x, zero, zero, zero);
        continue;
      }
      const __m256 ax = _mm256_sub_ps(_mm256_mul_ps(c1, zr), vx);
      const __m256 ay = _mm256_sub_ps(_mm256_mul_ps(rf8, zr), vy);
      const __m256 az = _mm256_sub_ps(zr, z);
      const __m256 bx = _mm256_sub_ps(_mm256_mul_ps(c0, zd), vx);
      const __m256 by = _mm256_sub_ps(_mm256_mul_ps(rfd8, zd), vy);
      const __m256 bz = _mm256_sub_ps(zd, z);
      __m256 cx = _mm256_sub_ps(_mm256_mul_ps(ay, bz), _mm256_mul_ps(az, by));
      __m256 cy = _mm256_sub_ps(_mm256_mul_ps(az, bx), _mm256_mul_ps(ax, bz));
      __m256 cz = _mm256_sub_ps(_mm256_mul_ps(ax, by), _mm256_mul_ps(ay, bx));
      const __m256 len = _mm256_sqrt_ps(_mm256_add_ps(
          _mm256_mul_ps(cx, cx), _mm256_add_ps(_mm256_mul_ps(cy, cy), _mm256_mul_ps(cz, cz))));
      ok = _mm256_and_ps(ok, _mm256_and_ps(_mm256_cmp_ps(len, zero, _CMP_GT_OQ),
                                           _mm256_cmp_ps(len, inf, _CMP_LT_OQ)));
      cx = _mm256_div_ps(cx, len);
      cy = _mm256_div_ps(cy, len);
      cz = _mm256_div_ps(cz, len);
      const __m256 facing = _mm256_add_ps(
          _mm256_mul_ps(cx, vx), _mm256_add_ps(_mm256_mul_ps(cy, vy), _mm256_mul_ps(cz, z)));
      const __m256 flip = _mm256_and_ps(sign, _mm256_cmp_ps(facing, zero, _CMP_GT_OQ));
      store_xyz8(normals + 3 * x, _mm256_and_ps(ok, _mm256_xor_ps(cx, flip)),
                 _mm256_and_ps(ok, _mm256_xor_ps(cy, flip)),
                 _mm256_and_ps(ok, _mm256_xor_ps(cz, flip)));
    }
  }
  points_row_scalar(d, dd, cf, rf, rfd, x, w, w, jump, vertices, normals);
}
#endif

}  // namespace aoscan::point_maps_detail
