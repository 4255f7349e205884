/// @file geometry_reference.cpp
/// @brief Plain serial reference of the normal smoothing; noisy planes seen by a depth camera.
#include "support/geometry_reference.h"

#include <algorithm>
#include <random>

#include "geometry/normal_smoothing.h"

namespace aoscan {

void smooth_model_normals_reference(const PointMaps& in, int radius_px, float max_distance_m,
                                    PointMaps& out) {
  out.intrinsics = in.intrinsics;
  out.vertices = in.vertices;
  out.normals.resize(in.vertices.width(), in.vertices.height(), Eigen::Vector3f::Zero());
  const float max_distance_sq = max_distance_m * max_distance_m;
  for (int y = 0; y < in.vertices.height(); ++y)
    for (int x = 0; x < in.vertices.width(); ++x)
      out.normals(x, y) = smoothed_normal(in, x, y, std::max(radius_px, 0), max_distance_sq);
}

RangeMap noisy_depth_scan(const std::function<float(const Eigen::Vector3f&)>& depth_of_ray,
                          const std::function<float(float)>& sigma_of_z, unsigned seed) {
  const Intrinsics k{640, 480, 585.0, 585.0, 319.5, 239.5};
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 1.0f);
  Image<float> depth(k.width, k.height, 0.0f);
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const Eigen::Vector3f ray(static_cast<float>((x - k.cx) / k.fx),
                                static_cast<float>((y - k.cy) / k.fy), 1.0f);
      const float z = depth_of_ray(ray);
      depth(x, y) = z + sigma_of_z(z) * noise(rng);
    }
  RangeMap map;
  range_map_from_depth(depth, k, map);
  return map;
}

RangeMap noisy_plane_scan(const Eigen::Vector3f& normal, float offset,
                          const std::function<float(float)>& sigma_of_z, unsigned seed) {
  return noisy_depth_scan(
      [&normal, offset](const Eigen::Vector3f& ray) { return -offset / normal.dot(ray); },
      sigma_of_z, seed);
}

}  // namespace aoscan
