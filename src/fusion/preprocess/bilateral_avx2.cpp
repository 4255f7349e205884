/// @file bilateral_avx2.cpp
/// @brief The bilateral filter's AVX2 + FMA rows (dispatched from bilateral.cpp when the CPU has
/// AVX2 and FMA): eight pixels at a time with the window's sums in registers.
#include "fusion/preprocess/bilateral_kernels.h"

#include <algorithm>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace aoscan::bilateral_detail {

#if defined(AOSCAN_BILATERAL_AVX2)
namespace {

/// exp(x) for x in [-87, 0] on eight lanes with AVX2 + FMA (the Cephes reduction and polynomial
/// of exp_nonpositive(), fused multiply-adds; relative error below 3e-7).
__attribute__((target("avx2,fma"))) inline __m256 exp_nonpositive8(__m256 x) {
  x = _mm256_max_ps(x, _mm256_set1_ps(-87.0f));
  const __m256 nf = _mm256_round_ps(_mm256_mul_ps(x, _mm256_set1_ps(kLog2e)),
                                    _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  const __m256 r =
      _mm256_fnmadd_ps(nf, _mm256_set1_ps(kLn2Lo), _mm256_fnmadd_ps(nf, _mm256_set1_ps(kLn2Hi), x));
  __m256 poly = _mm256_set1_ps(kExpPoly[0]);
  for (int i = 1; i < 6; ++i) poly = _mm256_fmadd_ps(poly, r, _mm256_set1_ps(kExpPoly[i]));
  const __m256 er =
      _mm256_add_ps(_mm256_fmadd_ps(poly, _mm256_mul_ps(r, r), r), _mm256_set1_ps(1.0f));
  const __m256i n = _mm256_cvtps_epi32(nf);
  const __m256 two_n =
      _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_add_epi32(n, _mm256_set1_epi32(127)), 23));
  return _mm256_mul_ps(er, two_n);
}

}  // namespace

/// Rows [y0, y1) with AVX2: eight interior pixels at a time keep their sums in registers over the
/// whole window; the r pixels at each side (and the leftover of a row) go through filter_pixel().
/// The spatial weight is folded into the exponent (exp(ln w_s + k d^2)).
__attribute__((target("avx2,fma"))) void filter_rows_avx2(const Image<float>& in, int y0, int y1,
                                                          const BilateralParams& p,
                                                          Image<float>& out) {
  const int w = in.width();
  const int h = in.height();
  const int r = p.radius;
  const int side = 2 * r + 1;
  const __m256 k8 = _mm256_set1_ps(p.neg_inv_two_sigma_depth_sq);
  const __m256 cutoff8 = _mm256_set1_ps(p.cutoff_m);
  const __m256 sign = _mm256_set1_ps(-0.0f);
  const __m256 zero = _mm256_setzero_ps();
  const __m256 tiny = _mm256_set1_ps(1e-30f);
  for (int y = y0; y < y1; ++y) {
    const float* centre = in.row(y);
    float* o = out.row(y);
    const int dy0 = std::max(-r, -y);
    const int dy1 = std::min(r, h - 1 - y);
    int x = 0;
    for (; x < std::min(r, w); ++x) o[x] = filter_pixel(in, x, y, p);
    for (; x + 8 + r <= w; x += 8) {
      const __m256 c = _mm256_loadu_ps(centre + x);
      const __m256 c_valid = _mm256_cmp_ps(c, zero, _CMP_GT_OQ);
      if (_mm256_movemask_ps(c_valid) == 0) {  // eight holes stay holes
        _mm256_storeu_ps(o + x, zero);
        continue;
      }
      __m256 sum = zero;
      __m256 weight = zero;
      for (int dy = dy0; dy <= dy1; ++dy) {
        const float* n = in.row(y + dy) + x;
        const float* ls = p.log_spatial + (dy + r) * side + r;
        for (int dx = -r; dx <= r; ++dx) {
          const __m256 nv = _mm256_loadu_ps(n + dx);
          const __m256 raw_d = _mm256_sub_ps(nv, c);
          const __m256 use =
              _mm256_and_ps(_mm256_cmp_ps(nv, zero, _CMP_GT_OQ),
                            _mm256_cmp_ps(_mm256_andnot_ps(sign, raw_d), cutoff8, _CMP_LE_OQ));
          const __m256 d = _mm256_and_ps(use, raw_d);
          const __m256 e = exp_nonpositive8(
              _mm256_fmadd_ps(_mm256_mul_ps(d, d), k8, _mm256_broadcast_ss(ls + dx)));
          const __m256 wq = _mm256_and_ps(use, e);
          sum = _mm256_fmadd_ps(wq, d, sum);
          weight = _mm256_add_ps(weight, wq);
        }
      }
      const __m256 res = _mm256_add_ps(c, _mm256_div_ps(sum, _mm256_max_ps(weight, tiny)));
      _mm256_storeu_ps(o + x, _mm256_and_ps(c_valid, res));
    }
    for (; x < w; ++x) o[x] = filter_pixel(in, x, y, p);
  }
}

#endif

}  // namespace aoscan::bilateral_detail
