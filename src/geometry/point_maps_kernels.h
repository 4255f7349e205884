/// @file point_maps_kernels.h
/// @brief Internal to the geometry module: the per-pixel vertex and normal arithmetic of
/// compute_point_maps() that its portable rows (point_maps.cpp) and its AVX2 rows
/// (point_maps_avx2.cpp) share, and the AVX2 row kernel's declaration.
#pragma once

#include <cmath>

#include "geometry/simd.h"

namespace aoscan::point_maps_detail {

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

/// Pixels [x0, x1) of a row through point_scalar() (the portable rows, and the last pixels of
/// the AVX2 rows).
inline void points_row_scalar(const float* d, const float* dd, const float* cf, float rf, float rfd,
                       int x0, int x1, int w, float jump, float* vertices, float* normals) {
  for (int x = x0; x < x1; ++x)
    point_scalar(d, dd, cf, rf, rfd, x, w, jump, vertices + 3 * x, normals + 3 * x);
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define AOSCAN_POINTS_AVX2 1
/// One row of point_scalar() eight pixels at a time with AVX2 (point_maps_avx2.cpp; only for a
/// CPU that has it, cpu_has_avx2()): the same operations lane by lane, so the same bits; the
/// row's last pixels through points_row_scalar(). `dd` is null on the last row.
__attribute__((target("avx2"))) AOSCAN_NO_CONTRACT void points_row_avx2(
    const float* d, const float* dd, const float* cf, float rf, float rfd, int w, float jump,
    float* vertices, float* normals);
#endif

}  // namespace aoscan::point_maps_detail
