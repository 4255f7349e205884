/// @file bilateral.cpp
/// @brief Bilateral filter of metric depth (KinectFusion Sec. 3.2): scalar reference and the fast
/// fast versions: AVX2 + FMA with registers over the whole window (chosen at run time when the CPU
/// has them) and the row-wise portable one (SSE2 on x86-64, scalar elsewhere, the same bits).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "fusion/preprocess/bilateral.h"
#include "geometry/simd.h"

namespace aoscan {
namespace {

/// Gives `image` the size w x h; its pixels are left as they are when it has that size already
/// (for outputs whose every pixel is written next).
template <class T>
void size_for_overwrite(Image<T>& image, int w, int h, const T& fill) {
  if (image.width() != w || image.height() != h) image.resize(w, h, fill);
}

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
/// Scalar twin of the SSE2 lanes below (same operations in the same order, so the same bits).
inline void accumulate_tap(float c, float n, float ws, float k, float cutoff, float& sum,
                           float& weight) {
  const float raw_d = n - c;
  const bool use = (n > 0.0f) & (std::fabs(raw_d) <= cutoff);
  const float d = use ? raw_d : 0.0f;  // keeps exp's argument in range
  const float wq = use ? ws * exp_nonpositive(d * d * k) : 0.0f;
  sum += wq * d;
  weight += wq;
}

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

/// One pixel at any position: taps outside the image are skipped (scalar path for the image
/// borders of the AVX2 kernel; same tap order as the reference).
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

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define AOSCAN_BILATERAL_AVX2 1

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

}  // namespace

void bilateral_filter_reference(const Image<float>& depth_m, const PreprocessConfig& config,
                                Image<float>& out) {
  const BilateralParams p(config);
  if (p.radius == 0) {
    out = depth_m;
    return;
  }
  const int w = depth_m.width();
  const int h = depth_m.height();
  out.resize(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float c = depth_m(x, y);
      if (!(c > 0.0f)) {
        out(x, y) = 0.0f;
        continue;
      }
      float sum = 0.0f;
      float weight = 0.0f;
      for (int dy = -p.radius; dy <= p.radius; ++dy) {
        for (int dx = -p.radius; dx <= p.radius; ++dx) {
          if (!depth_m.contains(x + dx, y + dy)) continue;
          const float n = depth_m(x + dx, y + dy);
          const float d = n - c;
          if (!(n > 0.0f) || std::fabs(d) > p.cutoff_m) continue;
          const float wq =
              p.spatial_weight(dx, dy) * std::exp(d * d * p.neg_inv_two_sigma_depth_sq);
          sum += wq * d;
          weight += wq;
        }
      }
      out(x, y) = c + sum / weight;
    }
  }
}

void bilateral_filter(const Image<float>& depth_m, const PreprocessConfig& config,
                      Image<float>& out) {
#if defined(AOSCAN_BILATERAL_AVX2)
  if (cpu_has_avx2_fma()) {
    const BilateralParams p(config);
    if (p.radius == 0) {
      out = depth_m;
      return;
    }
    size_for_overwrite(out, depth_m.width(), depth_m.height(), 0.0f);
    tbb::parallel_for(tbb::blocked_range<int>(0, depth_m.height(), 8),
                      [&](const tbb::blocked_range<int>& rows) {
                        filter_rows_avx2(depth_m, rows.begin(), rows.end(), p, out);
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
