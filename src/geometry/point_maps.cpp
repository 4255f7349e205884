/// @file point_maps.cpp
/// @brief 2x2 depth downsampling, vertex maps and normal maps (TBB over rows; every pixel is
/// computed on its own, so any thread count gives the same bits).
#include "geometry/point_maps.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "geometry/simd.h"

namespace aoscan {
namespace {

// The fast paths read vertex and normal maps as packed x, y, z floats.
static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "Vector3f must be three packed floats");

/// Gives `image` the size w x h; its pixels are left as they are when it has that size already
/// (for outputs whose every pixel is written next).
template <class T>
void size_for_overwrite(Image<T>& image, int w, int h, const T& fill) {
  if (image.width() != w || image.height() != h) image.resize(w, h, fill);
}

/// Ray factor (x - cx) / fx of every column, as Intrinsics::unproject(float, float, float) and
/// compute_vertex_map() compute it.
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

/// Unit normal of the pixel with vertex v, right neighbour vr and lower neighbour vd (all valid
/// and within the jump), or zero: the operations of compute_normal_map() in its order (Eigen's
/// cross product, norm = sqrt(x^2 + (y^2 + z^2)), per-component division, dot with v).
AOSCAN_NO_CONTRACT inline void normal_scalar(const float* v, const float* vr, const float* vd,
                                             float* n) {
  const float ax = vr[0] - v[0], ay = vr[1] - v[1], az = vr[2] - v[2];
  const float bx = vd[0] - v[0], by = vd[1] - v[1], bz = vd[2] - v[2];
  float cx = ay * bz - az * by;
  float cy = az * bx - ax * bz;
  float cz = ax * by - ay * bx;
  const float len = std::sqrt(cx * cx + (cy * cy + cz * cz));
  if (!(len > 0.0f) || !std::isfinite(len)) {
    n[0] = n[1] = n[2] = 0.0f;
    return;
  }
  cx /= len;
  cy /= len;
  cz /= len;
  if (cx * v[0] + (cy * v[1] + cz * v[2]) > 0.0f) {
    cx = -cx;
    cy = -cy;
    cz = -cz;
  }
  n[0] = cx;
  n[1] = cy;
  n[2] = cz;
}

/// Vertex and normal of pixel x of a row from the depths of this row (d) and the next (dd, null
/// on the last row); cf = column factors, rf / rfd = this and the next row's factor.
AOSCAN_NO_CONTRACT inline void point_scalar(const float* d, const float* dd, const float* cf,
                                            float rf, float rfd, int x, int w, float jump,
                                            float* vertex, float* normal) {
  const float z = d[x];
  const float v[3] = {cf[x] * z, rf * z, z};
  if (z > 0.0f) {
    vertex[0] = v[0];
    vertex[1] = v[1];
    vertex[2] = v[2];
  } else {
    vertex[0] = vertex[1] = vertex[2] = 0.0f;
  }
  normal[0] = normal[1] = normal[2] = 0.0f;
  if (dd == nullptr || x + 1 >= w) return;
  const float zr = d[x + 1];
  const float zd = dd[x];
  if (!(z > 0.0f) || !(zr > 0.0f) || !(zd > 0.0f) || std::fabs(zr - z) > jump ||
      std::fabs(zd - z) > jump)
    return;
  const float vr[3] = {cf[x + 1] * zr, rf * zr, zr};
  const float vd[3] = {cf[x] * zd, rfd * zd, zd};
  normal_scalar(v, vr, vd, normal);
}

/// Pixels [x0, x1) of a row through point_scalar().
void points_row_scalar(const float* d, const float* dd, const float* cf, float rf, float rfd,
                       int x0, int x1, int w, float jump, float* vertices, float* normals) {
  for (int x = x0; x < x1; ++x)
    point_scalar(d, dd, cf, rf, rfd, x, w, jump, vertices + 3 * x, normals + 3 * x);
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define AOSCAN_POINTS_AVX2 1

/// Writes eight (x, y, z) lanes as 24 interleaved floats.
__attribute__((target("avx2"))) inline void store_xyz8(float* out, __m256 x, __m256 y, __m256 z) {
  alignas(32) float fx[8], fy[8], fz[8];
  _mm256_store_ps(fx, x);
  _mm256_store_ps(fy, y);
  _mm256_store_ps(fz, z);
  for (int i = 0; i < 8; ++i) {
    out[3 * i] = fx[i];
    out[3 * i + 1] = fy[i];
    out[3 * i + 2] = fz[i];
  }
}

/// One row of point_scalar() eight pixels at a time with AVX2 (the same operations lane by lane,
/// so the same bits), the row's last pixels scalar.
__attribute__((target("avx2"))) AOSCAN_NO_CONTRACT void points_row_avx2(
    const float* d, const float* dd, const float* cf, float rf, float rfd, int w, float jump,
    float* vertices, float* normals) {
  int x = 0;
  if (dd != nullptr) {
    const __m256 zero = _mm256_setzero_ps();
    const __m256 sign = _mm256_set1_ps(-0.0f);
    const __m256 jump8 = _mm256_set1_ps(jump);
    const __m256 inf = _mm256_set1_ps(INFINITY);
    const __m256 rf8 = _mm256_set1_ps(rf);
    const __m256 rfd8 = _mm256_set1_ps(rfd);
    for (; x + 8 < w; x += 8) {
      const __m256 z = _mm256_loadu_ps(d + x);
      const __m256 zr = _mm256_loadu_ps(d + x + 1);
      const __m256 zd = _mm256_loadu_ps(dd + x);
      const __m256 c0 = _mm256_loadu_ps(cf + x);
      const __m256 c1 = _mm256_loadu_ps(cf + x + 1);
      const __m256 vx = _mm256_mul_ps(c0, z), vy = _mm256_mul_ps(rf8, z);
      const __m256 z_ok = _mm256_cmp_ps(z, zero, _CMP_GT_OQ);
      store_xyz8(vertices + 3 * x, _mm256_and_ps(z_ok, vx), _mm256_and_ps(z_ok, vy),
                 _mm256_and_ps(z_ok, z));
      __m256 ok = _mm256_and_ps(z_ok, _mm256_and_ps(_mm256_cmp_ps(zr, zero, _CMP_GT_OQ),
                                                    _mm256_cmp_ps(zd, zero, _CMP_GT_OQ)));
      ok = _mm256_and_ps(
          ok, _mm256_cmp_ps(_mm256_andnot_ps(sign, _mm256_sub_ps(zr, z)), jump8, _CMP_LE_OQ));
      ok = _mm256_and_ps(
          ok, _mm256_cmp_ps(_mm256_andnot_ps(sign, _mm256_sub_ps(zd, z)), jump8, _CMP_LE_OQ));
      if (_mm256_movemask_ps(ok) == 0) {
        store_xyz8(normals + 3 * x, zero, zero, zero);
        continue;
      }
      const __m256 ax = _mm256_sub_ps(_mm256_mul_ps(c1, zr), vx);
      const __m256 ay = _mm256_sub_ps(_mm256_mul_ps(rf8, zr), vy);
      const __m256 az = _mm256_sub_ps(zr, z);
      const __m256 bx = _mm256_sub_ps(_mm256_mul_ps(c0, zd), vx);
      const __m256 by = _mm256_sub_ps(_mm256_mul_ps(rfd8, zd), vy);
      const __m256 bz = _mm256_sub_ps(zd, z);
      __m256 cx = _mm256_sub_ps(_mm256_mul_ps(ay, bz), _mm256_mul_ps(az, by));
      __m256 cy = _mm256_sub_ps(_mm256_mul_ps(az, bx), _mm256_mul_ps(ax, bz));
      __m256 cz = _mm256_sub_ps(_mm256_mul_ps(ax, by), _mm256_mul_ps(ay, bx));
      const __m256 len = _mm256_sqrt_ps(_mm256_add_ps(
          _mm256_mul_ps(cx, cx), _mm256_add_ps(_mm256_mul_ps(cy, cy), _mm256_mul_ps(cz, cz))));
      ok = _mm256_and_ps(ok, _mm256_and_ps(_mm256_cmp_ps(len, zero, _CMP_GT_OQ),
                                           _mm256_cmp_ps(len, inf, _CMP_LT_OQ)));
      cx = _mm256_div_ps(cx, len);
      cy = _mm256_div_ps(cy, len);
      cz = _mm256_div_ps(cz, len);
      const __m256 facing = _mm256_add_ps(
          _mm256_mul_ps(cx, vx), _mm256_add_ps(_mm256_mul_ps(cy, vy), _mm256_mul_ps(cz, z)));
      const __m256 flip = _mm256_and_ps(sign, _mm256_cmp_ps(facing, zero, _CMP_GT_OQ));
      store_xyz8(normals + 3 * x, _mm256_and_ps(ok, _mm256_xor_ps(cx, flip)),
                 _mm256_and_ps(ok, _mm256_xor_ps(cy, flip)),
                 _mm256_and_ps(ok, _mm256_xor_ps(cz, flip)));
    }
  }
  points_row_scalar(d, dd, cf, rf, rfd, x, w, w, jump, vertices, normals);
}
#endif

}  // namespace

void downsample_depth(const Image<float>& depth_m, float max_depth_diff_m, Image<float>& out) {
  const int w = depth_m.width() / 2;
  const int h = depth_m.height() / 2;
  size_for_overwrite(out, w, h, 0.0f);
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

void compute_point_maps(const Image<float>& depth_m, const Intrinsics& intrinsics,
                        float max_depth_jump_m, PointMaps& maps) {
  const int w = depth_m.width();
  const int h = depth_m.height();
  maps.intrinsics = intrinsics;
  size_for_overwrite(maps.vertices, w, h, Eigen::Vector3f::Zero().eval());
  size_for_overwrite(maps.normals, w, h, Eigen::Vector3f::Zero().eval());
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
