/// @file test_scenes.h
/// @brief Tiny analytic depth renderer for fusion tests: planes, spheres and axis-aligned boxes
/// ray-cast into depth images, point maps and pyramids with exact normals.
#pragma once

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/pose.h"
#include "geometry/point_maps.h"
#include "sim/synth_camera.h"

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

struct Scene {
  std::vector<Plane> planes;
  std::vector<Sphere> spheres;
  std::vector<Box> boxes;

  /// Nearest hit t > 0 along the unit ray o + t d, with the world normal facing the ray origin.
  bool intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double& t_hit,
                 Eigen::Vector3d& n_hit) const {
    t_hit = std::numeric_limits<double>::infinity();
    auto take = [&](double t, const Eigen::Vector3d& n) {
      if (t > 1e-9 && t < t_hit) {
        t_hit = t;
        n_hit = n.dot(d) > 0 ? Eigen::Vector3d(-n) : n;
      }
    };
    for (const Plane& p : planes) {
      const double nd = p.normal.dot(d);
      if (std::abs(nd) > 1e-12) take((p.offset - p.normal.dot(o)) / nd, p.normal);
    }
    for (const Sphere& s : spheres) {
      const Eigen::Vector3d oc = o - s.centre;
      const double b = oc.dot(d), c = oc.squaredNorm() - s.radius * s.radius;
      const double disc = b * b - c;
      if (disc < 0) continue;
      const double r = std::sqrt(disc);
      for (double t : {-b - r, -b + r}) {
        if (t > 1e-9) {
          take(t, (o + t * d - s.centre).normalized());
          break;
        }
      }
    }
    for (const Box& box : boxes) {
      double t_near = -std::numeric_limits<double>::infinity();
      double t_far = std::numeric_limits<double>::infinity();
      int axis_near = 0, axis_far = 0;
      bool miss = false;
      for (int a = 0; a < 3; ++a) {
        if (std::abs(d[a]) < 1e-15) {
          if (o[a] < box.lo[a] || o[a] > box.hi[a]) miss = true;
          continue;
        }
        double t0 = (box.lo[a] - o[a]) / d[a], t1 = (box.hi[a] - o[a]) / d[a];
        if (t0 > t1) std::swap(t0, t1);
        if (t0 > t_near) t_near = t0, axis_near = a;
        if (t1 < t_far) t_far = t1, axis_far = a;
      }
      if (miss || t_near > t_far) continue;
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      if (t_near > 1e-9) {
        n[axis_near] = 1;
        take(t_near, n);
      } else if (t_far > 1e-9) {
        n[axis_far] = 1;
        take(t_far, n);
      }
    }
    return std::isfinite(t_hit);
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
  for (int y = 0; y < k.height; ++y) {
    for (int x = 0; x < k.width; ++x) {
      const Eigen::Vector3d ray_c = k.unproject(double(x), double(y), 1.0);
      const Eigen::Vector3d d = (R * ray_c).normalized();
      double t = 0;
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      const double e = noise_m > 0 ? noise_m * gauss(rng) : 0.0;
      if (!scene.intersect(T_world_camera.translation(), d, t, n)) continue;
      const double z = t / ray_c.norm() + e;
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
