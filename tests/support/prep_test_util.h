/// @file prep_test_util.h
/// @brief Helpers for the preprocessing tests: analytic depth images (plane, sphere), random depth
/// with holes, and where the shared real recording's frames are (read them with io/png_read.h).
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "core/intrinsics.h"

namespace aoscan::test {

/// Depth (metres, float) of the plane n . p = d seen through `k`: z = d / (n . K^-1 (u, v, 1)),
/// 0 where the ray misses the plane in front of the camera.
inline Image<float> render_plane(const Intrinsics& k, const Eigen::Vector3d& n, double d) {
  Image<float> depth(k.width, k.height);
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const Eigen::Vector3d ray((x - k.cx) / k.fx, (y - k.cy) / k.fy, 1.0);
      const double denom = n.dot(ray);
      const double z = denom != 0.0 ? d / denom : -1.0;
      depth(x, y) = z > 0.0 ? static_cast<float>(z) : 0.0f;
    }
  return depth;
}

/// Depth (metres) of the front side of the sphere |p - c| = r seen through `k`; 0 off the sphere.
inline Image<float> render_sphere(const Intrinsics& k, const Eigen::Vector3d& c, double r) {
  Image<float> depth(k.width, k.height);
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const Eigen::Vector3d ray((x - k.cx) / k.fx, (y - k.cy) / k.fy, 1.0);
      // |t ray - c|^2 = r^2, nearest t > 0; z = t because ray.z = 1.
      const double a = ray.squaredNorm();
      const double b = -2.0 * ray.dot(c);
      const double cc = c.squaredNorm() - r * r;
      const double disc = b * b - 4 * a * cc;
      if (disc < 0) continue;
      const double t = (-b - std::sqrt(disc)) / (2 * a);
      if (t > 0) depth(x, y) = static_cast<float>(t);
    }
  return depth;
}

/// Random depth with structure: patches of different surfaces (steps well above and near the
/// 2 cm threshold), per-pixel noise of a few mm, and holes.
inline Image<float> random_depth(int w, int h, std::uint32_t seed, double hole_fraction = 0.1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> base(0.5f, 4.0f);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::normal_distribution<float> noise(0.0f, 0.008f);
  Image<float> depth(w, h);
  const int patch = 1 + static_cast<int>(rng() % 9);
  std::vector<float> patch_depth(static_cast<std::size_t>((w / patch + 1) * (h / patch + 1)));
  for (float& p : patch_depth) p = base(rng);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float z =
          patch_depth[static_cast<std::size_t>((y / patch) * (w / patch + 1) + x / patch)] +
          noise(rng);
      depth(x, y) = unit(rng) < hole_fraction ? 0.0f : z;
    }
  return depth;
}

/// The shared 7-Scenes recording folder (may be absent).
inline std::string redkitchen_dir() {
  return std::string(AOSCAN_SHARED_DATA_DIR) + "/7scenes-redkitchen";
}

/// Path of frame `i` of the 7-Scenes recording.
inline std::string redkitchen_frame(int i) {
  char name[64];
  std::snprintf(name, sizeof name, "/depth/frame-%06d.png", i);
  return redkitchen_dir() + name;
}

/// The 7-Scenes depth camera (camera.json of the recording).
inline Intrinsics redkitchen_intrinsics() {
  return Intrinsics{640, 480, 585.0, 585.0, 320.0, 240.0};
}

/// Angle between two vectors (radians).
inline double angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

/// The plane n . p = d facing the camera.
struct Plane {
  Eigen::Vector3d n;
  double d;
};

/// Planes of the point-map and pyramid tests.
inline const Plane kPlanes[] = {
    {Eigen::Vector3d(0, 0, -1), -2.0},                      // fronto-parallel at 2 m
    {Eigen::Vector3d(0.3, -0.2, -1).normalized(), -1.5},    // tilted
    {Eigen::Vector3d(-0.8, 0.1, -0.6).normalized(), -1.2},  // strongly slanted (53 degrees)
};

}  // namespace aoscan::test
