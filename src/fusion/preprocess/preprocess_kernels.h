/// @file preprocess_kernels.h
/// @brief Internal to the preprocess module: the per-row border-outlier kernel that
/// preprocess.cpp (baseline target) and preprocess_avx2.cpp (AVX2) both compile, so the two
/// paths share one copy of the arithmetic.
#pragma once

#include <cmath>

#include "geometry/simd.h"

namespace aoscan::outlier_detail {

/// 1 when neighbour depth `n` is valid and differs from `c` by more than `t`.
inline int differs(float c, float n, float t) {
  return (n > 0.0f) & (std::fabs(c - n) > t);
}

/// Outlier decision for one pixel given its three rows and clamped column indices. Clamping a
/// missing neighbour onto the pixel itself (or onto a neighbour already compared) never changes
/// the decision, because |c - c| = 0 is never above a positive threshold.
inline float filter_pixel(const float* up, const float* mid, const float* dn, int xl, int x, int xr,
                          float t0, float per_m2) {
  const float c = mid[x];
  const float t = t0 + per_m2 * c * c;
  const int bad = differs(c, up[xl], t) | differs(c, up[x], t) | differs(c, up[xr], t) |
                  differs(c, mid[xl], t) | differs(c, mid[xr], t) | differs(c, dn[xl], t) |
                  differs(c, dn[x], t) | differs(c, dn[xr], t) | !(c > 0.0f);
  return bad ? 0.0f : c;
}

/// Filters one row. `up` / `dn` are the rows above and below, or `mid` itself at the image border
/// (see filter_pixel() for why that is exact). Requires t0 > 0 and per_m2 >= 0. Branch-free, so
/// the compiler vectorises the interior at the width of the target it is compiled for.
__attribute__((always_inline)) inline void filter_row_body(const float* up, const float* mid,
                                                           const float* dn, int width, float t0,
                                                           float per_m2, float* out) {
  if (width <= 0) return;
  if (width == 1) {
    out[0] = filter_pixel(up, mid, dn, 0, 0, 0, t0, per_m2);
    return;
  }
  out[0] = filter_pixel(up, mid, dn, 0, 0, 1, t0, per_m2);
  for (int x = 1; x < width - 1; ++x)
    out[x] = filter_pixel(up, mid, dn, x - 1, x, x + 1, t0, per_m2);
  out[width - 1] = filter_pixel(up, mid, dn, width - 2, width - 1, width - 1, t0, per_m2);
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define AOSCAN_PREPROCESS_AVX2 1
/// filter_row_body() compiled for AVX2 (preprocess_avx2.cpp): eight pixels per vector.
/// Comparisons and selects only, and no FMA (the threshold t0 + per_m2 * c * c rounds as in the
/// portable build), so the same bits. Only for a CPU with AVX2 (cpu_has_avx2()).
__attribute__((target("avx2"))) AOSCAN_NO_CONTRACT void filter_row_avx2(const float* up,
                                                                        const float* mid,
                                                                        const float* dn, int width,
                                                                        float t0, float per_m2,
                                                                        float* out);
#endif

}  // namespace aoscan::outlier_detail
