/// @file normal_smoothing_avx2.cpp
/// @brief The AVX2 + FMA rows of smooth_model_normals() (dispatched from normal_smoothing.cpp
/// when the CPU has them): the window sums of eight pixels at a time.
#include "geometry/normal_smoothing_kernels.h"

#include <cmath>
#include <cstddef>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace aoscan::smoothing_detail {

#if defined(AOSCAN_SMOOTHING_AVX2)
namespace {

/// smoothed_normal() for the eight pixels x0..x0 + 7 of row y, whose windows lie inside the
/// image, from `planes` (the maps as six float planes vx, vy, vz, nx, ny, nz of w * h each): the
/// window sums on eight lanes in the reference's order, the normalisation per pixel as there.
__attribute__((target("avx2,fma"))) AOSCAN_NO_CONTRACT void smoothed_normals8(
    const PointMaps& in, const float* planes, int x0, int y, int radius_px, float max_distance_sq,
    Eigen::Vector3f* out) {
  const int w = in.vertices.width();
  const std::size_t plane = static_cast<std::size_t>(w) * in.vertices.height();
  const std::size_t centre = static_cast<std::size_t>(y) * w + x0;
  const __m256 vx = _mm256_loadu_ps(planes + centre);
  const __m256 vy = _mm256_loadu_ps(planes + plane + centre);
  const __m256 vz = _mm256_loadu_ps(planes + 2 * plane + centre);
  const __m256 zero = _mm256_setzero_ps();
  const __m256 max_d2 = _mm256_set1_ps(max_distance_sq);
  __m256 sx = zero, sy = zero, sz = zero;
  for (int yy = y - radius_px; yy <= y + radius_px; ++yy) {
    for (int xx = x0 - radius_px; xx <= x0 + radius_px; ++xx) {
      const float* q = planes + static_cast<std::size_t>(yy) * w + xx;
      const __m256 qz = _mm256_loadu_ps(q + 2 * plane);
      const __m256 dx = _mm256_sub_ps(_mm256_loadu_ps(q), vx);
      const __m256 dy = _mm256_sub_ps(_mm256_loadu_ps(q + plane), vy);
      const __m256 dz = _mm256_sub_ps(qz, vz);
      const __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)),
                                      _mm256_mul_ps(dz, dz));
      const __m256 use =
          _mm256_and_ps(_mm256_cmp_ps(qz, zero, _CMP_GT_OQ), _mm256_cmp_ps(d2, max_d2, _CMP_LE_OQ));
      sx = _mm256_add_ps(sx, _mm256_and_ps(use, _mm256_loadu_ps(q + 3 * plane)));
      sy = _mm256_add_ps(sy, _mm256_and_ps(use, _mm256_loadu_ps(q + 4 * plane)));
      sz = _mm256_add_ps(sz, _mm256_and_ps(use, _mm256_loadu_ps(q + 5 * plane)));
    }
  }
  alignas(32) float fx[8], fy[8], fz[8];
  _mm256_store_ps(fx, sx);
  _mm256_store_ps(fy, sy);
  _mm256_store_ps(fz, sz);
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3f& v = in.vertices(x0 + i, y);
    const Eigen::Vector3f& n = in.normals(x0 + i, y);
    if (!(v.z() > 0.0f) || (n.x() == 0.0f && n.y() == 0.0f && n.z() == 0.0f)) {
      out[i].setZero();
      continue;
    }
    const float length = std::sqrt(fx[i] * fx[i] + fy[i] * fy[i] + fz[i] * fz[i]);
    out[i] = length > 0.0f ? Eigen::Vector3f(fx[i] / length, fy[i] / length, fz[i] / length) : n;
  }
}
}  // namespace

__attribute__((target("avx2,fma"))) AOSCAN_NO_CONTRACT void smooth_row_avx2(
    const PointMaps& in, const float* planes, int y, int radius_px, float max_distance_sq,
    Eigen::Vector3f* row) {
  const int w = in.vertices.width();
  int x = 0;
  for (; x < radius_px; ++x) row[x] = smoothed_normal(in, x, y, radius_px, max_distance_sq);
  for (; x + 7 + radius_px < w; x += 8)
    smoothed_normals8(in, planes, x, y, radius_px, max_distance_sq, row + x);
  for (; x < w; ++x) row[x] = smoothed_normal(in, x, y, radius_px, max_distance_sq);
}
#endif

}  // namespace aoscan::smoothing_detail
