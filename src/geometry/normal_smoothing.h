/// @file normal_smoothing.h
/// @brief The smoothed normal of one pixel of a vertex and normal map: the normalised sum of the
/// normals around it on the same surface. Tracking reads the model raycast's normals smoothed
/// (smooth_model_normals() below, whole images with AVX2), and so does the SSAO stage at the
/// pixels it evaluates.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Core>

#include "geometry/point_maps.h"
#include "geometry/simd.h"

namespace aoscan {

/// The model maps `in` with every normal replaced by the normalised sum of the normals within
/// radius_px pixels (a (2 radius_px + 1)^2 window clipped at the image border) whose vertices lie
/// within max_distance_m of the pixel's own (metres, camera frame): the same surface, not the one
/// behind a depth jump. Pixels without a vertex or a normal keep a zero normal; vertices and
/// intrinsics are copied. The result does not depend on the thread count. Multi-threaded over
/// rows, eight pixels at a time with AVX2 where the window lies inside the image; bit for bit
/// smoothed_normal() at every pixel (the test oracle smooth_model_normals_reference() in
/// tests/support). `scratch` (the maps as float planes) is reused between calls.
void smooth_model_normals(const PointMaps& in, int radius_px, float max_distance_m, PointMaps& out,
                          std::vector<float>& scratch);

/// The normalised sum of the normals of the pixels within radius_px of (x, y) (a (2 radius_px +
/// 1)^2 window clipped at the image border, rows then columns) whose vertices lie within
/// sqrt(max_distance_sq) metres of the pixel's own (the same surface, not the one behind a depth
/// jump). Zero when the pixel has no vertex or no normal; the pixel's own normal when the sum
/// vanishes or is not finite (a NaN neighbour). The reference arithmetic: the AVX2 path of
/// smooth_model_normals() repeats it lane by lane (differences summed x, y, z left to right, no
/// fused multiply-adds).
AOSCAN_NO_CONTRACT inline Eigen::Vector3f smoothed_normal(const PointMaps& in, int x, int y,
                                                          int radius_px, float max_distance_sq) {
  const int w = in.vertices.width();
  const int h = in.vertices.height();
  const Eigen::Vector3f& v = in.vertices(x, y);
  const Eigen::Vector3f& n = in.normals(x, y);
  if (!(v.z() > 0.0f) || (n.x() == 0.0f && n.y() == 0.0f && n.z() == 0.0f))
    return Eigen::Vector3f::Zero();
  float sx = 0.0f, sy = 0.0f, sz = 0.0f;
  for (int yy = std::max(0, y - radius_px); yy <= std::min(h - 1, y + radius_px); ++yy) {
    for (int xx = std::max(0, x - radius_px); xx <= std::min(w - 1, x + radius_px); ++xx) {
      const Eigen::Vector3f& q = in.vertices(xx, yy);
      const float dx = q.x() - v.x(), dy = q.y() - v.y(), dz = q.z() - v.z();
      if (!(q.z() > 0.0f) || !(dx * dx + dy * dy + dz * dz <= max_distance_sq)) continue;
      const Eigen::Vector3f& m = in.normals(xx, yy);  // a zero normal adds nothing
      sx += m.x();
      sy += m.y();
      sz += m.z();
    }
  }
  const float length = std::sqrt(sx * sx + sy * sy + sz * sz);
  return length > 0.0f ? Eigen::Vector3f(sx / length, sy / length, sz / length) : n;
}

}  // namespace aoscan
