/// @file icp_kernels.h
/// @brief Internal to the tracking module: the per-pixel ICP association and the partial sums of
/// the normal equations that the portable path (icp.cpp) and the AVX2 path (icp_avx2.cpp) share,
/// and the AVX2 row kernel's declaration. The test oracle icp_system_reference()
/// (tests/support) sums Associator::pixel() too, so that it picks the same correspondences.
#pragma once

#include <algorithm>
#include <cmath>

#include <Eigen/Core>

#include "core/pose.h"
#include "fusion/tracking/icp.h"
#include "fusion/tracking/tracking_config.h"
#include "geometry/point_maps.h"
#include "geometry/simd.h"

namespace aoscan::icp_detail {

// The fast paths read vertex and normal maps as packed x, y, z floats.
static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "Vector3f must be three packed floats");

/// Partial sums of the normal equations (upper triangle of A row by row, b, residuals) in
/// scalar type T: float for one image row (a few hundred terms; twice the SIMD width), double
/// for everything summed from rows.
template <typename T>
struct Accumulator {
  T a[21] = {};
  T b[6] = {};
  T residual_sq = 0;
  int inliers = 0;
  int valid = 0;

  void add(const T j[6], T r, T w) {
    int k = 0;
    for (int i = 0; i < 6; ++i) {
      const T wj = w * j[i];
      for (int c = i; c < 6; ++c) a[k++] += wj * j[c];
      b[i] += wj * r;
    }
    residual_sq += r * r;
    ++inliers;
  }
  template <typename U>
  void add(const Accumulator<U>& o) {
    for (int i = 0; i < 21; ++i) a[i] += static_cast<T>(o.a[i]);
    for (int i = 0; i < 6; ++i) b[i] += static_cast<T>(o.b[i]);
    residual_sq += static_cast<T>(o.residual_sq);
    inliers += o.inliers;
    valid += o.valid;
  }
  IcpSystem system() const {
    IcpSystem s;
    int k = 0;
    for (int i = 0; i < 6; ++i) {
      for (int c = i; c < 6; ++c) {
        s.A(i, c) = static_cast<double>(a[k]);
        s.A(c, i) = static_cast<double>(a[k]);
        ++k;
      }
      s.b[i] = static_cast<double>(b[i]);
    }
    s.residual_sq = static_cast<double>(residual_sq);
    s.inliers = inliers;
    s.valid = valid;
    return s;
  }
};

/// Everything the per-pixel association needs, in float, with the arithmetic spelled out so the
/// scalar and the AVX2 paths perform the same IEEE operations in the same order (no fused
/// multiply-adds in the association): both pick exactly the same correspondences.
struct Associator {
  float rot[9];  ///< R_model_camera, row-major
  float t[3];    ///< t_model_camera (m)
  float fx, fy, cx, cy;
  float max_u, max_v;
  float max_distance_sq;
  float min_normal_cos;
  float huber;
  float inv_noise_depth_sq;  ///< 1 / noise_reference_depth_m^2 (1/m^2), 0 without depth weighting
  const float* model_vertices;  ///< model vertex map as x, y, z floats, row-major
  const float* model_normals;
  int model_width;
  int model_last;  ///< float index of the model's last pixel

  Associator(const PointMaps& model_maps, const Pose& T_model_camera, const TrackingConfig& config)
      : fx(static_cast<float>(model_maps.intrinsics.fx)),
        fy(static_cast<float>(model_maps.intrinsics.fy)),
        cx(static_cast<float>(model_maps.intrinsics.cx)),
        cy(static_cast<float>(model_maps.intrinsics.cy)),
        max_u(static_cast<float>(model_maps.vertices.width()) - 0.5f),
        max_v(static_cast<float>(model_maps.vertices.height()) - 0.5f),
        max_distance_sq(static_cast<float>(config.max_distance_m * config.max_distance_m)),
        min_normal_cos(static_cast<float>(std::cos(config.max_normal_angle_deg * M_PI / 180.0))),
        huber(static_cast<float>(config.huber_delta_m)),
        inv_noise_depth_sq(config.noise_reference_depth_m > 0.0
                               ? static_cast<float>(1.0 / (config.noise_reference_depth_m *
                                                           config.noise_reference_depth_m))
                               : 0.0f),
        model_vertices(reinterpret_cast<const float*>(model_maps.vertices.data())),
        model_normals(reinterpret_cast<const float*>(model_maps.normals.data())),
        model_width(model_maps.vertices.width()),
        model_last(3 * (model_maps.vertices.width() * model_maps.vertices.height() - 1)) {
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j)
        rot[3 * i + j] = static_cast<float>(T_model_camera.rotation()(i, j));
      t[i] = static_cast<float>(T_model_camera.translation()[i]);
    }
  }

  /// Adds the correspondence of the frame pixel with vertex `v` and normal `n` (x, y, z floats),
  /// if any, in T arithmetic.
  template <typename T>
  AOSCAN_NO_CONTRACT void pixel(const float* v, const float* n, Accumulator<T>& acc) const {
    if (!(v[2] > 0.0f) || (n[0] == 0.0f && n[1] == 0.0f && n[2] == 0.0f)) return;
    ++acc.valid;
    const float px = rot[0] * v[0] + rot[1] * v[1] + rot[2] * v[2] + t[0];
    const float py = rot[3] * v[0] + rot[4] * v[1] + rot[5] * v[2] + t[1];
    const float pz = rot[6] * v[0] + rot[7] * v[1] + rot[8] * v[2] + t[2];
    if (!(pz > 0.0f)) return;
    const float u = fx * px / pz + cx;
    const float w = fy * py / pz + cy;
    if (!(u >= -0.5f && w >= -0.5f && u < max_u && w < max_v)) return;
    const int index = 3 * (static_cast<int>(w + 0.5f) * model_width + static_cast<int>(u + 0.5f));
    const float* q = model_vertices + index;
    const float* nm = model_normals + index;
    if (!(q[2] > 0.0f) || (nm[0] == 0.0f && nm[1] == 0.0f && nm[2] == 0.0f)) return;
    const float dx = px - q[0];
    const float dy = py - q[1];
    const float dz = pz - q[2];
    if (!(dx * dx + dy * dy + dz * dz <= max_distance_sq)) return;
    const float rnx = rot[0] * n[0] + rot[1] * n[1] + rot[2] * n[2];
    const float rny = rot[3] * n[0] + rot[4] * n[1] + rot[5] * n[2];
    const float rnz = rot[6] * n[0] + rot[7] * n[1] + rot[8] * n[2];
    if (!(rnx * nm[0] + rny * nm[1] + rnz * nm[2] >= min_normal_cos)) return;
    const float r = nm[0] * dx + nm[1] * dy + nm[2] * dz;
    const T j[6] = {py * nm[2] - pz * nm[1],
                    pz * nm[0] - px * nm[2],
                    px * nm[1] - py * nm[0],
                    nm[0],
                    nm[1],
                    nm[2]};
    // Depth noise scale s = max(1, (z / z_ref)^2): Huber on r / s, weight 1 / s^2 on top.
    const float abs_r = std::abs(r);
    const float noise = std::max(1.0f, pz * pz * inv_noise_depth_sq);
    const float huber_scaled = huber * noise;
    const T weight =
        (abs_r <= huber_scaled ? T(1) : static_cast<T>(huber_scaled) / static_cast<T>(abs_r)) /
        static_cast<T>(noise * noise);
    acc.add(j, static_cast<T>(r), weight);
  }

  /// Frame pixels x0, x0 + step, ... < width of one row (x, y, z floats per pixel).
  AOSCAN_NO_CONTRACT void row_portable(const float* vertices, const float* normals, int x0,
                                       int width, int step, Accumulator<float>& acc) const {
    for (int x = x0; x < width; x += step) pixel(vertices + 3 * x, normals + 3 * x, acc);
  }
};

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define AOSCAN_ICP_AVX2 1
/// Associator::row_portable() on eight pixels at a time with AVX2 + FMA (icp_avx2.cpp; only for a
/// CPU that has them, cpu_has_avx2_fma()): the same correspondences (the association repeats the
/// scalar operations lane by lane, without fused multiply-adds); the normal equations are summed
/// per lane in float with FMAs and the lanes added in double, then the scalar tail of the row.
/// Adds the row to `acc`.
__attribute__((target("avx2,fma"))) AOSCAN_NO_CONTRACT void row_avx2(const Associator& a,
                                                                     const float* vertices,
                                                                     const float* normals, int x0,
                                                                     int width, int step,
                                                                     Accumulator<double>& acc);
#endif

}  // namespace aoscan::icp_detail
