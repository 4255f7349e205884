/// @file normal_smoothing.cpp
/// @brief Whole-image normal smoothing of model maps (tracking's and SSAO's normals): AVX2 eight
/// pixels at a time, and the plain reference.
#include "geometry/normal_smoothing.h"

#include <algorithm>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace aoscan {

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define AOSCAN_SMOOTHING_AVX2 1
#endif

// The AVX2 path reads vertex and normal maps as packed x, y, z floats.
static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "Vector3f must be three packed floats");

namespace {

#if defined(AOSCAN_SMOOTHING_AVX2)
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
#endif

/// What both smoothings write besides the normals: the intrinsics and the vertices, as they are.
void copy_model_but_normals(const PointMaps& in, PointMaps& out) {
  out.intrinsics = in.intrinsics;
  out.vertices = in.vertices;
  out.normals.resize(in.vertices.width(), in.vertices.height(), Eigen::Vector3f::Zero());
}

}  // namespace

void smooth_model_normals(const PointMaps& in, int radius_px, float max_distance_m, PointMaps& out,
                          std::vector<float>& scratch) {
  const int w = in.vertices.width();
  const int h = in.vertices.height();
  copy_model_but_normals(in, out);
  const float max_distance_sq = max_distance_m * max_distance_m;
  const int r = std::max(radius_px, 0);
  bool simd = false;
#if defined(AOSCAN_SMOOTHING_AVX2)
  // Six float planes, so that eight neighbours along a row are one load each.
  simd = cpu_has_avx2_fma() && w >= 2 * r + 8 && h >= 2 * r + 1;
  if (simd) {
    const std::size_t plane = static_cast<std::size_t>(w) * h;
    scratch.resize(6 * plane);
    const float* v = in.vertices.data()->data();
    const float* n = in.normals.data()->data();
    for (std::size_t i = 0; i < plane; ++i)
      for (int c = 0; c < 3; ++c) {
        scratch[c * plane + i] = v[3 * i + c];
        scratch[(3 + c) * plane + i] = n[3 * i + c];
      }
  }
#else
  (void)scratch;
#endif
  tbb::parallel_for(tbb::blocked_range<int>(0, h, 8), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y) {
      Eigen::Vector3f* row = out.normals.row(y);
      int x = 0;
#if defined(AOSCAN_SMOOTHING_AVX2)
      if (simd && y >= r && y + r < h) {
        for (; x < r; ++x) row[x] = smoothed_normal(in, x, y, r, max_distance_sq);
        for (; x + 7 + r < w; x += 8)
          smoothed_normals8(in, scratch.data(), x, y, r, max_distance_sq, row + x);
      }
#endif
      for (; x < w; ++x) row[x] = smoothed_normal(in, x, y, r, max_distance_sq);
    }
  });
}

void smooth_model_normals_reference(const PointMaps& in, int radius_px, float max_distance_m,
                                    PointMaps& out) {
  copy_model_but_normals(in, out);
  const float max_distance_sq = max_distance_m * max_distance_m;
  for (int y = 0; y < in.vertices.height(); ++y)
    for (int x = 0; x < in.vertices.width(); ++x)
      out.normals(x, y) = smoothed_normal(in, x, y, std::max(radius_px, 0), max_distance_sq);
}

}  // namespace aoscan
