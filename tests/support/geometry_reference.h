/// @file geometry_reference.h
/// @brief Test oracle of the geometry module: the plain serial normal smoothing that
/// smooth_model_normals() is checked against; noisy planes seen by a depth camera.
#pragma once

#include <functional>

#include <Eigen/Core>

#include "geometry/point_maps.h"
#include "geometry/range_map.h"

namespace aoscan {

/// Plain serial reference of smooth_model_normals(): smoothed_normal() at every pixel, the
/// vertices and intrinsics copied.
void smooth_model_normals_reference(const PointMaps& in, int radius_px, float max_distance_m,
                                    PointMaps& out);

/// The range map of a 640 x 480 depth camera (fx = fy = 585, centred) at the origin looking
/// along +z at a surface whose depth along the ray (x, y, 1) of each pixel is depth_of_ray(ray),
/// each pixel's depth z given noise of sigma sigma_of_z(z): one standard normal draw a pixel in
/// row order from std::mt19937(seed).
RangeMap noisy_depth_scan(const std::function<float(const Eigen::Vector3f&)>& depth_of_ray,
                          const std::function<float(float)>& sigma_of_z, unsigned seed);

/// noisy_depth_scan() of the plane n . p = -offset (n facing the camera).
RangeMap noisy_plane_scan(const Eigen::Vector3f& normal, float offset,
                          const std::function<float(float)>& sigma_of_z, unsigned seed);

}  // namespace aoscan
