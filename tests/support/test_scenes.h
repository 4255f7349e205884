/// @file test_scenes.h
/// @brief Analytic depth frames for fusion tests: planes, spheres and axis-aligned boxes (in a
/// y-down world like a camera's) ray-cast by sim's AnalyticScene into float depth images, point
/// maps and pyramids with exact normals and optional seeded Gaussian depth noise.
#pragma once

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/pose.h"
#include "geometry/point_maps.h"
#include "sim/synth_camera.h"
#include "sim/synth_scene.h"

namespace aoscan {
namespace test {

/// Points p with normal.dot(p) == offset (world frame, metres).
struct Plane {
  Eigen::Vector3d normal;
  double offset;
};
struct Sphere {
  Eigen::Vector3d centre;
  double radius;
};
/// Axis-aligned box; seen from inside it is a room.
struct Box {
  Eigen::Vector3d lo, hi;
};

/// Extent (metres) of the box that stands for a plane in to_analytic(): depth of the half-space
/// and half-width along the plane, far beyond any depth the tests render.
inline constexpr double kPlaneBoxM = 1000.0;

struct Scene {
  std::vector<Plane> planes;  ///< axis-aligned: each normal is +-1 along one axis
  std::vector<Sphere> spheres;
  std::vector<Box> boxes;

  /// The scene as a sim scene for a camera at `eye`: spheres and boxes as they are, each plane as a
  /// box filling the half-space beyond it seen from `eye` (kPlaneBoxM deep and wide), so that the
  /// plane is the face the camera sees. Throws std::logic_error for a plane that is not
  /// axis-aligned or an eye on a plane.
  AnalyticScene to_analytic(const Eigen::Vector3d& eye) const {
    AnalyticScene out("test");
    for (const Plane& p : planes) {
      int axis = -1;
      for (int a = 0; a < 3; ++a)
        if (std::abs(p.normal[a]) == 1.0) axis = a;
      if (axis < 0 || p.normal.cwiseAbs().sum() != 1.0 || eye[axis] == p.offset * p.normal[axis])
        throw std::logic_error("test::Scene: planes must be axis-aligned, off the eye");
      const double at = p.offset * p.normal[axis];  // the plane is x_axis = at
      Eigen::Vector3d lo = eye.array() - kPlaneBoxM, hi = eye.array() + kPlaneBoxM;
      lo[axis] = eye[axis] < at ? at : at - kPlaneBoxM;
      hi[axis] = eye[axis] < at ? at + kPlaneBoxM : at;
      out.add_box(lo, hi);
    }
    for (const Box& b : boxes) out.add_box(b.lo, b.hi);
    for (const Sphere& sp : spheres) out.add_sphere(sp.centre, sp.radius);
    return out;
  }
};

/// Renders depth (m along the optical axis, 0 = no hit or outside [min, max]) and, if asked,
/// camera-frame point maps with exact normals. `noise_m` adds Gaussian depth noise (seeded).
inline void render(const Scene& scene, const Intrinsics& k, const Pose& T_world_camera,
                   Image<float>& depth, PointMaps* maps = nullptr, double noise_m = 0.0,
                   unsigned seed = 1, double max_depth_m = 6.0) {
  depth.resize(k.width, k.height, 0.0f);
  if (maps) {
    maps->intrinsics = k;
    maps->vertices.resize(k.width, k.height, Eigen::Vector3f::Zero());
    maps->normals.resize(k.width, k.height, Eigen::Vector3f::Zero());
  }
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const Eigen::Matrix3d& R = T_world_camera.rotation();
  const AnalyticScene analytic = scene.to_analytic(T_world_camera.translation());
  for (int y = 0; y < k.height; ++y) {
    for (int x = 0; x < k.width; ++x) {
      const Eigen::Vector3d ray_c = k.unproject(double(x), double(y), 1.0);
      const Eigen::Vector3d d = (R * ray_c).normalized();
      const double e = noise_m > 0 ? noise_m * gauss(rng) : 0.0;
      Hit hit;
      if (!analytic.intersect(Ray{T_world_camera.translation(), d}, 1e-9,
                              std::numeric_limits<double>::infinity(), &hit))
        continue;
      const Eigen::Vector3d n = hit.normal.dot(d) > 0 ? Eigen::Vector3d(-hit.normal) : hit.normal;
      const double z = hit.t / ray_c.norm() + e;
      if (z <= 0.05 || z > max_depth_m) continue;
      depth(x, y) = static_cast<float>(z);
      if (maps) {
        maps->vertices(x, y) = (ray_c * z).cast<float>();
        maps->normals(x, y) = (R.transpose() * n).cast<float>();
      }
    }
  }
}

/// The tracking pyramid of a rendered frame (each level rendered at its own intrinsics).
inline DepthPyramid render_pyramid(const Scene& scene, const Intrinsics& k,
                                   const Pose& T_world_camera, double noise_m = 0.0,
                                   unsigned seed = 1) {
  DepthPyramid pyramid;
  for (int level = 0; level < kPyramidLevels; ++level)
    render(scene, k.scaled(level), T_world_camera, pyramid.depth_m[level], &pyramid.maps[level],
           noise_m, seed + level);
  return pyramid;
}

/// A camera at `eye` looking at `target` in these scenes' y-down world (world up is -y).
inline Pose look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  return aoscan::look_at(eye, target, -Eigen::Vector3d::UnitY());
}

/// A small rigid motion: rotation by `angle_deg` about `axis`, then translation `t`.
inline Pose motion(const Eigen::Vector3d& axis, double angle_deg, const Eigen::Vector3d& t) {
  return Pose(Eigen::AngleAxisd(angle_deg * M_PI / 180.0, axis.normalized()).toRotationMatrix(), t);
}

/// A 6-DoF-constraining scene: floor, two walls, a sphere and a box in the corner. The world is
/// y-down like a camera: floor at y = 1, walls at x = -1 and z = 3.
inline Scene corner_scene() {
  Scene s;
  s.planes.push_back({Eigen::Vector3d(0, 1, 0), 1.0});
  s.planes.push_back({Eigen::Vector3d(1, 0, 0), -1.0});
  s.planes.push_back({Eigen::Vector3d(0, 0, 1), 3.0});
  s.spheres.push_back({Eigen::Vector3d(0.3, 0.6, 2.2), 0.3});
  s.boxes.push_back({Eigen::Vector3d(-1.0, 0.5, 2.3), Eigen::Vector3d(-0.5, 1.0, 3.0)});
  return s;
}

}  // namespace test
}  // namespace aoscan
