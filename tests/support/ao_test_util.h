/// @file ao_test_util.h
/// @brief Test helpers for src/ao: exact point maps of a camera inside a convex set of planes
/// (open plane, inner corners of rooms), rendered analytically, and the reference's ray caster
/// over an analytic scene.
#pragma once

#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "core/intrinsics.h"
#include "core/pose.h"
#include "geometry/point_maps.h"
#include "sim/reference_ao.h"
#include "sim/synth_scene.h"

namespace aoscan::test {

/// The reference's ray caster over an analytic scene (the scene must outlive it).
inline RayCaster caster(const AnalyticScene& scene) {
  return [&scene](const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                  double t_max) -> std::optional<double> {
    Hit hit;
    if (!scene.intersect(Ray{o, d}, 0.0, t_max, &hit)) return std::nullopt;
    return hit.t;
  };
}

/// A plane n . x = offset in the world frame, seen from the side its unit normal n points into.
struct Plane {
  Eigen::Vector3d n;  ///< unit normal facing the camera (world frame)
  double offset;      ///< n . x = offset on the plane
};

/// Camera-frame point maps of the camera T_world_camera inside the convex region
/// {x : n_i . x > offset_i for all planes}: each pixel sees the nearest plane its ray leaves the
/// region through. Normals face the camera. Pixels whose ray leaves through no plane are invalid.
inline PointMaps render_planes(const Intrinsics& k, const Pose& T_world_camera,
                               const std::vector<Plane>& planes) {
  PointMaps maps;
  maps.intrinsics = k;
  maps.vertices.resize(k.width, k.height, Eigen::Vector3f::Zero());
  maps.normals.resize(k.width, k.height, Eigen::Vector3f::Zero());
  const Pose T_camera_world = T_world_camera.inverse();
  const Eigen::Vector3d o = T_world_camera.translation();
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const Eigen::Vector3d ray_c =
          k.unproject(static_cast<double>(x), static_cast<double>(y), 1.0);
      const Eigen::Vector3d d = T_world_camera.rotation() * ray_c;  // z = 1 in camera frame
      double best = std::numeric_limits<double>::infinity();
      int which = -1;
      for (int i = 0; i < static_cast<int>(planes.size()); ++i) {
        const double nd = planes[i].n.dot(d);
        if (nd >= 0.0) continue;  // ray moves away from this plane
        const double t = (planes[i].offset - planes[i].n.dot(o)) / nd;
        if (t > 0.0 && t < best) best = t, which = i;
      }
      if (which < 0) continue;
      maps.vertices(x, y) = (ray_c * best).cast<float>();
      maps.normals(x, y) = (T_camera_world.rotation() * planes[which].n).cast<float>();
    }
  return maps;
}

/// A 320x240 camera (half VGA, fx = fy = 292.5) used by the SSAO tests.
inline Intrinsics small_camera() {
  Intrinsics k;
  k.width = 320;
  k.height = 240;
  k.fx = k.fy = 292.5;
  k.cx = 159.5;
  k.cy = 119.5;
  return k;
}

}  // namespace aoscan::test
