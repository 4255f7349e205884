/// @file pyramid.cpp
/// @brief The tracking pyramid: 2x2 depth downsampling, vertex maps and normal maps per level
/// (TBB over rows; every pixel is computed on its own, so any thread count gives the same bits).
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/status.h"
#include "fusion/preprocess.h"

namespace aoscan {

void downsample_depth(const Image<float>& depth_m, float max_depth_diff_m, Image<float>& out) {
  const int w = depth_m.width() / 2;
  const int h = depth_m.height() / 2;
  out.resize(w, h);
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
  vertices.resize(w, h, Eigen::Vector3f::Zero());
  // The same per-pixel ray factors as Intrinsics::unproject(float, float, float).
  thread_local std::vector<float> column_factor;
  column_factor.resize(static_cast<std::size_t>(w));
  for (int x = 0; x < w; ++x)
    column_factor[x] = static_cast<float>(
        (static_cast<double>(static_cast<float>(x)) - intrinsics.cx) / intrinsics.fx);
  const float* cf = column_factor.data();
  tbb::parallel_for(tbb::blocked_range<int>(0, h, 16), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y) {
      const float row_factor = static_cast<float>(
          (static_cast<double>(static_cast<float>(y)) - intrinsics.cy) / intrinsics.fy);
      const float* d = depth_m.row(y);
      Eigen::Vector3f* v = vertices.row(y);
      for (int x = 0; x < w; ++x) {
        const float z = d[x];
        v[x] = z > 0.0f ? Eigen::Vector3f(cf[x] * z, row_factor * z, z) : Eigen::Vector3f::Zero();
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

void build_pyramid(const Image<float>& filtered_m, const Intrinsics& intrinsics,
                   const PreprocessConfig& config, DepthPyramid& out) {
  if (filtered_m.width() != intrinsics.width || filtered_m.height() != intrinsics.height) {
    throw input_error("build_pyramid: depth image is " + std::to_string(filtered_m.width()) + "x" +
                      std::to_string(filtered_m.height()) + " but the intrinsics say " +
                      std::to_string(intrinsics.width) + "x" + std::to_string(intrinsics.height));
  }
  const float max_diff = static_cast<float>(config.pyramid_max_depth_diff_m);
  float jump = static_cast<float>(config.normal_max_depth_jump_m);
  out.depth_m[0] = filtered_m;
  for (int level = 0; level < kPyramidLevels; ++level) {
    if (level > 0) downsample_depth(out.depth_m[level - 1], max_diff, out.depth_m[level]);
    PointMaps& maps = out.maps[level];
    maps.intrinsics = intrinsics.scaled(level);
    compute_vertex_map(out.depth_m[level], maps.intrinsics, maps.vertices);
    compute_normal_map(maps.vertices, jump, maps.normals);
    jump *= 2.0f;
  }
}

void build_pyramid(const Image<float>& filtered_m, const Intrinsics& intrinsics,
                   DepthPyramid& out) {
  build_pyramid(filtered_m, intrinsics, PreprocessConfig{}, out);
}

}  // namespace aoscan
