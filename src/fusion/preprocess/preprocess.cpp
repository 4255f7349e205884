/// @file preprocess.cpp
/// @brief Raw depth to metres, border-outlier removal (the row dispatch between the portable and
/// the AVX2 kernel, and the removal fused with the conversion), and the whole per-frame
/// preprocessing chain.
#include "fusion/preprocess/preprocess.h"

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "core/status.h"
#include "fusion/preprocess/bilateral.h"
#include "fusion/preprocess/preprocess_kernels.h"
#include "fusion/preprocess/pyramid.h"
#include "geometry/simd.h"

namespace aoscan {
namespace {

using outlier_detail::filter_row_body;
#if defined(AOSCAN_PREPROCESS_AVX2)
using outlier_detail::filter_row_avx2;
#endif

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

/// filter_row_body() for the baseline target (SSE2 on x86-64).
void filter_row_portable(const float* up, const float* mid, const float* dn, int width, float t0,
                         float per_m2, float* out) {
  filter_row_body(up, mid, dn, width, t0, per_m2, out);
}

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
  depth_m.resize_for_overwrite(w, h);
  for (int y = 0; y < h; ++y) convert.row(frame.depth.row(y), w, depth_m.row(y));
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
  out.resize_for_overwrite(w, h);
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
  out.resize_for_overwrite(w, h);
  if (two) tracking_out->resize_for_overwrite(w, h);
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
