/// @file point_maps.cpp
/// @brief 2x2 depth downsampling, vertex maps and normal maps (TBB over rows; every pixel is
/// computed on its own, so any thread count gives the same bits); compute_point_maps() picks the
/// AVX2 rows (point_maps_avx2.cpp) or the portable ones here.
#include "geometry/point_maps.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "geometry/point_maps_kernels.h"
#include "geometry/simd.h"

namespace aoscan {
namespace {

using point_maps_detail::points_row_scalar;
#if defined(AOSCAN_POINTS_AVX2)
using point_maps_detail::points_row_avx2;
#endif

// The fast paths read vertex and normal maps as packed x, y, z floats.
static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "Vector3f must be three packed floats");

/// Ray factor (x - cx) / fx of every column, as Intrinsics::unproject(float, float, float)
/// computes it.
void column_factors(const Intrinsics& intrinsics, int width, std::vector<float>& out) {
  out.resize(static_cast<std::size_t>(width));
  for (int x = 0; x < width; ++x)
    out[x] = static_cast<float>((static_cast<double>(static_cast<float>(x)) - intrinsics.cx) /
                                intrinsics.fx);
}

/// Ray factor (y - cy) / fy of row y.
float row_factor(const Intrinsics& intrinsics, int y) {
  return static_cast<float>((static_cast<double>(static_cast<float>(y)) - intrinsics.cy) /
                            intrinsics.fy);
}

}  // namespace

void downsample_depth(const Image<float>& depth_m, float max_depth_diff_m, Image<float>& out) {
  const int w = depth_m.width() / 2;
  const int h = depth_m.height() / 2;
  out.resize_for_overwrite(w, h, 0.0f);
  // The reference depth always counts itself, so the average below never divides by zero.
  max_depth_diff_m = std::max(max_depth_diff_m, 0.0f);
  tbb::parallel_for(tbb::blocked_range<int>(0, h, 16), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y) {
      const float* r0 = depth_m.row(2 * y);
      const float* r1 = depth_m.row(2 * y + 1);
      float* o = out.row(y);
      for (int x = 0; x < w; ++x) {
        const float block[4] = {r0[2 * x], r0[2 * x + 1], r1[2 * x], r1[2 * x + 1]};
        float ref = 0.0f;
        for (float v : block) {
          if (v > 0.0f) {
            ref = v;
            break;
          }
        }
        if (ref == 0.0f) {
          o[x] = 0.0f;
          continue;
        }
        // Mean as an offset from the reference depth, so a constant block stays exactly constant.
        float offset_sum = 0.0f;
        int count = 0;
        for (float v : block) {
          if (v > 0.0f && std::fabs(v - ref) <= max_depth_diff_m) {
            offset_sum += v - ref;
            ++count;
          }
        }
        o[x] = ref + offset_sum / static_cast<float>(count);
      }
    }
  });
}

void compute_vertex_map(const Image<float>& depth_m, const Intrinsics& intrinsics,
                        Image<Eigen::Vector3f>& vertices) {
  const int w = depth_m.width();
  const int h = depth_m.height();
  vertices.resize_for_overwrite(w, h, Eigen::Vector3f::Zero());  // every pixel is written
  thread_local std::vector<float> column_factor;
  column_factors(intrinsics, w, column_factor);
  const float* cf = column_factor.data();
  tbb::parallel_for(tbb::blocked_range<int>(0, h, 16), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y) {
      const float ry = row_factor(intrinsics, y);
      const float* d = depth_m.row(y);
      Eigen::Vector3f* v = vertices.row(y);
      for (int x = 0; x < w; ++x) {
        const float z = d[x];
        v[x] = z > 0.0f ? Eigen::Vector3f(cf[x] * z, ry * z, z) : Eigen::Vector3f::Zero();
      }
    }
  });
}

void compute_normal_map(const Image<Eigen::Vector3f>& vertices, float max_depth_jump_m,
                        Image<Eigen::Vector3f>& normals) {
  const int w = vertices.width();
  const int h = vertices.height();
  normals.resize(w, h, Eigen::Vector3f::Zero());
  if (w < 2 || h < 2) return;
  tbb::parallel_for(
      tbb::blocked_range<int>(0, h - 1, 16), [&](const tbb::blocked_range<int>& rows) {
        for (int y = rows.begin(); y < rows.end(); ++y) {
          const Eigen::Vector3f* v = vertices.row(y);
          const Eigen::Vector3f* vd = vertices.row(y + 1);
          Eigen::Vector3f* n = normals.row(y);
          for (int x = 0; x + 1 < w; ++x) {
            const float z = v[x].z();
            const float zr = v[x + 1].z();
            const float zd = vd[x].z();
            if (!(z > 0.0f) || !(zr > 0.0f) || !(zd > 0.0f) ||
                std::fabs(zr - z) > max_depth_jump_m || std::fabs(zd - z) > max_depth_jump_m)
              continue;
            Eigen::Vector3f c = (v[x + 1] - v[x]).cross(vd[x] - v[x]);
            const float len = c.norm();
            if (!(len > 0.0f) || !std::isfinite(len)) continue;
            c /= len;
            if (c.dot(v[x]) > 0.0f) c = -c;
            n[x] = c;
          }
        }
      });
}

void compute_point_maps(const Image<float>& depth_m, const Intrinsics& intrinsics,
                        float max_depth_jump_m, PointMaps& maps) {
  const int w = depth_m.width();
  const int h = depth_m.height();
  maps.intrinsics = intrinsics;
  maps.vertices.resize_for_overwrite(w, h, Eigen::Vector3f::Zero().eval());
  maps.normals.resize_for_overwrite(w, h, Eigen::Vector3f::Zero().eval());
  thread_local std::vector<float> column_factor;
  column_factors(intrinsics, w, column_factor);
  const float* cf = column_factor.data();
#if defined(AOSCAN_POINTS_AVX2)
  const bool avx2 = cpu_has_avx2();
#endif
  tbb::parallel_for(tbb::blocked_range<int>(0, h, 16), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y) {
      const float* d = depth_m.row(y);
      const float* dd = y + 1 < h ? depth_m.row(y + 1) : nullptr;
      const float rf = row_factor(intrinsics, y);
      const float rfd = row_factor(intrinsics, y + 1);
      float* v = reinterpret_cast<float*>(maps.vertices.row(y));
      float* n = reinterpret_cast<float*>(maps.normals.row(y));
#if defined(AOSCAN_POINTS_AVX2)
      if (avx2) {
        points_row_avx2(d, dd, cf, rf, rfd, w, max_depth_jump_m, v, n);
        continue;
      }
#endif
      points_row_scalar(d, dd, cf, rf, rfd, 0, w, w, max_depth_jump_m, v, n);
    }
  });
}

}  // namespace aoscan
