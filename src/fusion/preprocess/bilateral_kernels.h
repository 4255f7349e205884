/// @file bilateral_kernels.h
/// @brief Internal to the preprocess module: what the bilateral filter's portable path
/// (bilateral.cpp) and its AVX2 path (bilateral_avx2.cpp) share: the filter constants, the
/// branch-free exp() and the scalar per-tap / per-pixel arithmetic.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "core/image.h"
#include "fusion/preprocess/preprocess_config.h"

namespace aoscan::bilateral_detail {

/// Largest radius accepted by the configuration (PreprocessConfig::visit).
constexpr int kMaxRadius = 16;
constexpr int kMaxTaps = (2 * kMaxRadius + 1) * (2 * kMaxRadius + 1);

/// Filter constants derived once per call from the configuration.
struct BilateralParams {
  int radius = 0;
  float neg_inv_two_sigma_depth_sq = 0.0f;  ///< -1 / (2 sigma_depth^2), 1/m^2
  float cutoff_m = 0.0f;                    ///< |dz| above this is ignored (3 sigma_depth)
  float spatial[kMaxTaps] = {};             ///< exp(-(dx^2 + dy^2) / (2 sigma_space^2)), row-major
  float log_spatial[kMaxTaps] = {};         ///< -(dx^2 + dy^2) / (2 sigma_space^2), row-major

  explicit BilateralParams(const PreprocessConfig& config) {
    radius = std::clamp(config.bilateral_radius_px, 0, kMaxRadius);
    // Sigmas below the configuration's ranges (possible for a hand-made config) are clamped so
    // that the weights stay finite.
    const double sd = std::max(config.bilateral_sigma_depth_m, 1e-6);
    neg_inv_two_sigma_depth_sq = static_cast<float>(-1.0 / (2.0 * sd * sd));
    cutoff_m = static_cast<float>(3.0 * sd);
    const double ss = std::max(config.bilateral_sigma_space_px, 1e-3);
    const int side = 2 * radius + 1;
    for (int dy = -radius; dy <= radius; ++dy)
      for (int dx = -radius; dx <= radius; ++dx) {
        const double e = -(dx * dx + dy * dy) / (2.0 * ss * ss);
        spatial[(dy + radius) * side + dx + radius] = static_cast<float>(std::exp(e));
        log_spatial[(dy + radius) * side + dx + radius] = static_cast<float>(e);
      }
  }
  float spatial_weight(int dx, int dy) const {
    return spatial[(dy + radius) * (2 * radius + 1) + dx + radius];
  }
};

constexpr float kLog2e = 1.44269504088896341f;
constexpr float kLn2Hi = 0.693359375f;  ///< ln 2 split in two for an exact range reduction
constexpr float kLn2Lo = -2.12194440e-4f;
/// Cephes expf polynomial for (e^r - 1 - r) / r^2, highest degree first.
constexpr float kExpPoly[6] = {1.9875691500e-4f, 1.3981999507e-3f, 8.3334519073e-3f,
                               4.1665795894e-2f, 1.6666665459e-1f, 5.0000001201e-1f};

/// exp(x) for x in [-88, 0] in float, branch-free so loops over it vectorise (Cephes expf: range
/// reduction x = n ln2 + r, degree-6 polynomial for e^r, 2^n by building the exponent bits).
/// Relative error below 2e-7 on that range; arguments below -87 (and NaN) give exp(-87).
inline float exp_nonpositive(float x) {
  x = x > -87.0f ? x : -87.0f;
  // n = round(x * log2(e)); x <= 0, so rounding is a truncation of the positive 0.5 - x log2 e.
  const std::int32_t n = -static_cast<std::int32_t>(0.5f - x * kLog2e);
  const float nf = static_cast<float>(n);
  const float r = (x - nf * kLn2Hi) - nf * kLn2Lo;
  float p = kExpPoly[0];
  for (int i = 1; i < 6; ++i) p = p * r + kExpPoly[i];
  const float er = p * (r * r) + r + 1.0f;
  const std::int32_t bits = (n + 127) << 23;
  float two_n;
  std::memcpy(&two_n, &bits, sizeof two_n);
  return er * two_n;
}

/// One tap for one pixel: adds the tap's weight to `weight` and its weighted offset to `sum`.
/// Scalar twin of the SSE2 lanes of the portable rows (same operations in the same order, so the
/// same bits).
inline void accumulate_tap(float c, float n, float ws, float k, float cutoff, float& sum,
                           float& weight) {
  const float raw_d = n - c;
  const bool use = (n > 0.0f) & (std::fabs(raw_d) <= cutoff);
  const float d = use ? raw_d : 0.0f;  // keeps exp's argument in range
  const float wq = use ? ws * exp_nonpositive(d * d * k) : 0.0f;
  sum += wq * d;
  weight += wq;
}

/// One pixel at any position: taps outside the image are skipped (the scalar path for the image
/// borders of the AVX2 rows; same tap order as the reference). Defined out of line in
/// bilateral.cpp, for the baseline target: the AVX2 rows call it, so its arithmetic is never
/// contracted into fused multiply-adds there.
float filter_pixel(const Image<float>& in, int x, int y, const BilateralParams& p);

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define AOSCAN_BILATERAL_AVX2 1
/// Rows [y0, y1) of the filter with AVX2 + FMA (bilateral_avx2.cpp; only for a CPU that has
/// them, cpu_has_avx2_fma()): eight interior pixels at a time keep their sums in registers over
/// the whole window; the r pixels at each side (and the leftover of a row) go through
/// filter_pixel(). `out` has the input's size.
__attribute__((target("avx2,fma"))) void filter_rows_avx2(const Image<float>& in, int y0, int y1,
                                                          const BilateralParams& p,
                                                          Image<float>& out);
#endif

}  // namespace aoscan::bilateral_detail
