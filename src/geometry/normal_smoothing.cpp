/// @file normal_smoothing.cpp
/// @brief Whole-image normal smoothing of model maps (tracking's and SSAO's normals): the rows
/// whose windows lie inside the image through the AVX2 kernel (normal_smoothing_avx2.cpp) when
/// the CPU has it, every other row pixel by pixel through smoothed_normal().
#include "geometry/normal_smoothing.h"

#include <algorithm>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "geometry/normal_smoothing_kernels.h"

namespace aoscan {

// The AVX2 path reads vertex and normal maps as packed x, y, z floats.
static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "Vector3f must be three packed floats");

namespace {

/// What the smoothing writes besides the normals: the intrinsics and the vertices, as they are.
void copy_model_but_normals(const PointMaps& in, PointMaps& out) {
  out.intrinsics = in.intrinsics;
  out.vertices = in.vertices;
  // Every pixel's normal is written by smooth_model_normals().
  out.normals.resize_for_overwrite(in.vertices.width(), in.vertices.height(),
                                   Eigen::Vector3f::Zero());
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
#if defined(AOSCAN_SMOOTHING_AVX2)
      if (simd && y >= r && y + r < h) {
        smoothing_detail::smooth_row_avx2(in, scratch.data(), y, r, max_distance_sq, row);
        continue;
      }
#endif
      for (int x = 0; x < w; ++x) row[x] = smoothed_normal(in, x, y, r, max_distance_sq);
    }
  });
}

}  // namespace aoscan
