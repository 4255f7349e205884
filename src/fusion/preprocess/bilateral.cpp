/// @file bilateral.cpp
/// @brief Bilateral filter of metric depth (KinectFusion Sec. 3.2): the run-time choice between
/// the AVX2 + FMA rows (bilateral_avx2.cpp, registers over the whole window) and the row-wise
/// portable path defined here (SSE2 on x86-64, scalar elsewhere, the same bits).
#include <algorithm>
#include <cmath>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "fusion/preprocess/bilateral.h"
#include "fusion/preprocess/bilateral_kernels.h"
#include "geometry/simd.h"

namespace aoscan {
namespace {

using bilateral_detail::accumulate_tap;
using bilateral_detail::BilateralParams;
using bilateral_detail::kExpPoly;
using bilateral_detail::kLn2Hi;
using bilateral_detail::kLn2Lo;
using bilateral_detail::kLog2e;

#if defined(__SSE2__)
/// exp_nonpositive() on four lanes with SSE2 (bit-identical to the scalar function).
inline __m128 exp_nonpositive4(__m128 x) {
  x = _mm_max_ps(x, _mm_set1_ps(-87.0f));  // NaN lanes give -87, as in the scalar version
  const __m128i n = _mm_sub_epi32(
      _mm_setzero_si128(),
      _mm_cvttps_epi32(_mm_sub_ps(_mm_set1_ps(0.5f), _mm_mul_ps(x, _mm_set1_ps(kLog2e)))));
  const __m128 nf = _mm_cvtepi32_ps(n);
  const __m128 r = _mm_sub_ps(_mm_sub_ps(x, _mm_mul_ps(nf, _mm_set1_ps(kLn2Hi))),
                              _mm_mul_ps(nf, _mm_set1_ps(kLn2Lo)));
  __m128 p = _mm_set1_ps(kExpPoly[0]);
  for (int i = 1; i < 6; ++i) p = _mm_add_ps(_mm_mul_ps(p, r), _mm_set1_ps(kExpPoly[i]));
  const __m128 er = _mm_add_ps(_mm_add_ps(_mm_mul_ps(p, _mm_mul_ps(r, r)), r), _mm_set1_ps(1.0f));
  const __m128 two_n = _mm_castsi128_ps(_mm_slli_epi32(_mm_add_epi32(n, _mm_set1_epi32(127)), 23));
  return _mm_mul_ps(er, two_n);
}
#endif

/// Filters row `y` of `in` into `out_row` with the accumulators `sum` and `weight` (width each).
/// Taps are accumulated in the same order as the reference (dy, then dx) for every pixel.
void filter_row(const Image<float>& in, int y, const BilateralParams& p, float* sum, float* weight,
                float* out_row) {
  const int w = in.width();
  const int h = in.height();
  const int r = p.radius;
  const float* centre = in.row(y);
  std::fill(sum, sum + w, 0.0f);
  std::fill(weight, weight + w, 0.0f);
  const float k = p.neg_inv_two_sigma_depth_sq;
  const float cutoff = p.cutoff_m;
  for (int dy = -r; dy <= r; ++dy) {
    const int yy = y + dy;
    if (yy < 0 || yy >= h) continue;
    const float* nrow = in.row(yy);
    for (int dx = -r; dx <= r; ++dx) {
      const float ws = p.spatial_weight(dx, dy);
      const int x0 = std::max(0, -dx);
      const int x1 = std::min(w, w - dx);
      const float* n = nrow + dx;
      int x = x0;
#if defined(__SSE2__)
      const __m128 ws4 = _mm_set1_ps(ws);
      const __m128 k4 = _mm_set1_ps(k);
      const __m128 cutoff4 = _mm_set1_ps(cutoff);
      const __m128 sign = _mm_set1_ps(-0.0f);
      const __m128 zero = _mm_setzero_ps();
      for (; x + 4 <= x1; x += 4) {
        const __m128 nv = _mm_loadu_ps(n + x);
        const __m128 raw_d = _mm_sub_ps(nv, _mm_loadu_ps(centre + x));
        const __m128 use =
            _mm_and_ps(_mm_cmpgt_ps(nv, zero), _mm_cmple_ps(_mm_andnot_ps(sign, raw_d), cutoff4));
        const __m128 d = _mm_and_ps(use, raw_d);
        const __m128 e = exp_nonpositive4(_mm_mul_ps(_mm_mul_ps(d, d), k4));
        const __m128 wq = _mm_and_ps(use, _mm_mul_ps(ws4, e));
        _mm_storeu_ps(sum + x, _mm_add_ps(_mm_loadu_ps(sum + x), _mm_mul_ps(wq, d)));
        _mm_storeu_ps(weight + x, _mm_add_ps(_mm_loadu_ps(weight + x), wq));
      }
#endif
      for (; x < x1; ++x) accumulate_tap(centre[x], n[x], ws, k, cutoff, sum[x], weight[x]);
    }
  }
  for (int x = 0; x < w; ++x) {
    const float c = centre[x];
    const float wt = std::max(weight[x], 1e-30f);
    out_row[x] = c > 0.0f ? c + sum[x] / wt : 0.0f;
  }
}

}  // namespace

namespace bilateral_detail {

float filter_pixel(const Image<float>& in, int x, int y, const BilateralParams& p) {
  const float c = in(x, y);
  if (!(c > 0.0f)) return 0.0f;
  const int r = p.radius;
  const int w = in.width();
  const int h = in.height();
  float sum = 0.0f;
  float weight = 0.0f;
  for (int dy = -r; dy <= r; ++dy) {
    const int yy = y + dy;
    if (yy < 0 || yy >= h) continue;
    const float* nrow = in.row(yy);
    for (int dx = -r; dx <= r; ++dx) {
      const int xx = x + dx;
      if (xx < 0 || xx >= w) continue;
      accumulate_tap(c, nrow[xx], p.spatial_weight(dx, dy), p.neg_inv_two_sigma_depth_sq,
                     p.cutoff_m, sum, weight);
    }
  }
  return c + sum / std::max(weight, 1e-30f);
}

}  // namespace bilateral_detail

void bilateral_filter(const Image<float>& depth_m, const PreprocessConfig& config,
                      Image<float>& out) {
#if defined(AOSCAN_BILATERAL_AVX2)
  if (cpu_has_avx2_fma()) {
    const BilateralParams p(config);
    if (p.radius == 0) {
      out = depth_m;
      return;
    }
    out.resize_for_overwrite(depth_m.width(), depth_m.height(), 0.0f);
    tbb::parallel_for(tbb::blocked_range<int>(0, depth_m.height(), 8),
                      [&](const tbb::blocked_range<int>& rows) {
                        bilateral_detail::filter_rows_avx2(depth_m, rows.begin(), rows.end(), p,
                                                           out);
                      });
    return;
  }
#endif
  bilateral_filter_portable(depth_m, config, out);
}

void bilateral_filter_portable(const Image<float>& depth_m, const PreprocessConfig& config,
                               Image<float>& out) {
  const BilateralParams p(config);
  if (p.radius == 0) {
    out = depth_m;
    return;
  }
  const int w = depth_m.width();
  const int h = depth_m.height();
  out.resize(w, h);
  tbb::parallel_for(tbb::blocked_range<int>(0, h, 8), [&](const tbb::blocked_range<int>& rows) {
    thread_local std::vector<float> scratch;
    scratch.resize(2 * static_cast<std::size_t>(w));
    for (int y = rows.begin(); y < rows.end(); ++y)
      filter_row(depth_m, y, p, scratch.data(), scratch.data() + w, out.row(y));
  });
}

}  // namespace aoscan
