/// @file preprocess.cpp
/// @brief Raw depth to metres, border-outlier removal (reference, fast and fused with the
/// conversion), and the whole per-frame preprocessing chain.
#include "fusion/preprocess/preprocess.h"

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "core/status.h"
#include "fusion/preprocess/bilateral.h"
#include "fusion/preprocess/pyramid.h"
#include "geometry/simd.h"

namespace aoscan {
namespace {

/// Raw-to-metres conversion shared by depth_to_metres() and preprocess_depth(), so that both give
/// the same floats.
struct MetresConverter {
  float scale;
  float min_m;
  float max_m;

  MetresConverter(const DepthFrame& frame, const PreprocessConfig& config)
      : scale(static_cast<float>(frame.depth_scale)),
        min_m(static_cast<float>(config.min_depth_m)),
        max_m(static_cast<float>(config.max_depth_m)) {
    if (!(std::isfinite(frame.depth_scale) && frame.depth_scale > 0.0 && scale > 0.0f &&
          std::isfinite(scale))) {
      throw input_error(frame.origin + ": frame " + std::to_string(frame.sequence) +
                        ": depth_scale " + std::to_string(frame.depth_scale) +
                        " is not a positive number");
    }
  }

  /// Converts one row of `width` raw values; branch-free so the compiler vectorises it.
  void row(const std::uint16_t* raw, int width, float* metres) const {
    for (int x = 0; x < width; ++x) {
      const std::uint16_t r = raw[x];
      const float m = static_cast<float>(r) / scale;
      const bool keep = (r != 0) & (r != 0xFFFF) & (m >= min_m) & (m <= max_m);
      metres[x] = keep ? m : 0.0f;
    }
  }
};

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

/// filter_row_body() for the baseline target (SSE2 on x86-64).
void filter_row_portable(const float* up, const float* mid, const float* dn, int width, float t0,
                         float per_m2, float* out) {
  filter_row_body(up, mid, dn, width, t0, per_m2, out);
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define AOSCAN_PREPROCESS_AVX2 1
/// filter_row_body() compiled for AVX2: eight pixels per vector. Comparisons and selects only,
/// and no FMA (the threshold t0 + per_m2 * c * c rounds as in the portable build), so the same
/// bits.
__attribute__((target("avx2"))) AOSCAN_NO_CONTRACT void filter_row_avx2(const float* up,
                                                                        const float* mid,
                                                                        const float* dn, int width,
                                                                        float t0, float per_m2,
                                                                        float* out) {
  filter_row_body(up, mid, dn, width, t0, per_m2, out);
}
#endif

/// One row through the fastest filter_row_*() the CPU runs (`simd` false: the portable one).
void filter_row(const float* up, const float* mid, const float* dn, int width, float t0,
                float per_m2, float* out, bool simd) {
#if defined(AOSCAN_PREPROCESS_AVX2)
  if (simd && cpu_has_avx2()) {
    filter_row_avx2(up, mid, dn, width, t0, per_m2, out);
    return;
  }
#else
  (void)simd;
#endif
  filter_row_portable(up, mid, dn, width, t0, per_m2, out);
}

/// The filter is disabled by a threshold that is not a positive number.
inline bool filter_enabled(float threshold_m) {
  return threshold_m > 0.0f;
}

}  // namespace

void depth_to_metres(const DepthFrame& frame, const PreprocessConfig& config,
                     Image<float>& depth_m) {
  const MetresConverter convert(frame, config);
  const int w = frame.depth.width();
  const int h = frame.depth.height();
  depth_m.resize(w, h);
  for (int y = 0; y < h; ++y) convert.row(frame.depth.row(y), w, depth_m.row(y));
}

void remove_border_outliers_reference(const Image<float>& depth_m, float threshold_m,
                                      float threshold_per_m2, Image<float>& out) {
  out = depth_m;
  if (!filter_enabled(threshold_m)) return;
  for (int y = 0; y < depth_m.height(); ++y) {
    for (int x = 0; x < depth_m.width(); ++x) {
      const float c = depth_m(x, y);
      const float t = threshold_m + threshold_per_m2 * c * c;
      bool remove = !(c > 0.0f);
      for (int dy = -1; dy <= 1 && !remove; ++dy) {
        for (int dx = -1; dx <= 1 && !remove; ++dx) {
          if ((dx == 0 && dy == 0) || !depth_m.contains(x + dx, y + dy)) continue;
          const float n = depth_m(x + dx, y + dy);
          if (n > 0.0f && std::fabs(c - n) > t) remove = true;
        }
      }
      if (remove) out(x, y) = 0.0f;
    }
  }
}

namespace {

void remove_border_outliers_rows(const Image<float>& depth_m, float threshold_m,
                                 float threshold_per_m2, Image<float>& out, bool simd) {
  const int w = depth_m.width();
  const int h = depth_m.height();
  if (!filter_enabled(threshold_m)) {
    out = depth_m;
    return;
  }
  out.resize(w, h);
  for (int y = 0; y < h; ++y) {
    const float* mid = depth_m.row(y);
    const float* up = y > 0 ? depth_m.row(y - 1) : mid;
    const float* dn = y + 1 < h ? depth_m.row(y + 1) : mid;
    filter_row(up, mid, dn, w, threshold_m, threshold_per_m2, out.row(y), simd);
  }
}

}  // namespace

void remove_border_outliers(const Image<float>& depth_m, float threshold_m, float threshold_per_m2,
                            Image<float>& out) {
  remove_border_outliers_rows(depth_m, threshold_m, threshold_per_m2, out, true);
}

void remove_border_outliers_portable(const Image<float>& depth_m, float threshold_m,
                                     float threshold_per_m2, Image<float>& out) {
  remove_border_outliers_rows(depth_m, threshold_m, threshold_per_m2, out, false);
}

void preprocess_depth(const DepthFrame& frame, const PreprocessConfig& config, Image<float>& out,
                      Image<float>* tracking_out) {
  const float t = static_cast<float>(config.outlier_threshold_m);
  const float per_m2 = static_cast<float>(config.outlier_threshold_per_m2);
  const float tracking_per_m2 = static_cast<float>(config.tracking_outlier_threshold_per_m2);
  const bool two = tracking_out != nullptr && tracking_per_m2 != per_m2 && filter_enabled(t);
  if (tracking_out && !two) tracking_out->resize(0, 0);
  if (!filter_enabled(t)) {
    depth_to_metres(frame, config, out);
    return;
  }
  const MetresConverter convert(frame, config);
  const int w = frame.depth.width();
  const int h = frame.depth.height();
  out.resize(w, h);
  if (two) tracking_out->resize(w, h);
  if (w == 0 || h == 0) return;
  // Three converted rows in a ring: row y lives at slot y % 3.
  thread_local std::vector<float> ring;
  ring.resize(static_cast<std::size_t>(3) * static_cast<std::size_t>(w));
  auto slot = [&](int y) { return ring.data() + static_cast<std::size_t>(y % 3) * w; };
  convert.row(frame.depth.row(0), w, slot(0));
  for (int y = 0; y < h; ++y) {
    if (y + 1 < h) convert.row(frame.depth.row(y + 1), w, slot(y + 1));
    const float* mid = slot(y);
    const float* up = y > 0 ? slot(y - 1) : mid;
    const float* dn = y + 1 < h ? slot(y + 1) : mid;
    filter_row(up, mid, dn, w, t, per_m2, out.row(y), true);
    if (two) filter_row(up, mid, dn, w, t, tracking_per_m2, tracking_out->row(y), true);
  }
}

void preprocess_frame(const DepthFrame& frame, const PreprocessConfig& config,
                      PreprocessedFrame& out) {
  const Intrinsics& k = frame.intrinsics;
  if (frame.depth.width() != k.width || frame.depth.height() != k.height) {
    throw input_error(frame.origin + ": frame " + std::to_string(frame.sequence) +
                      ": depth image is " + std::to_string(frame.depth.width()) + "x" +
                      std::to_string(frame.depth.height()) + " but the intrinsics say " +
                      std::to_string(k.width) + "x" + std::to_string(k.height));
  }
  preprocess_depth(frame, config, out.depth_m, &out.tracking_m);
  bilateral_filter(out.tracking_depth(), config, out.filtered_m);
  build_pyramid(out.filtered_m, k, config, out.pyramid);
}

}  // namespace aoscan
