/// @file scan_camera.cpp
/// @brief Pinhole and equirectangular scan cameras: projection and pixel footprint.
#include "geometry/scan_camera.h"

#include <algorithm>
#include <cmath>

namespace aoscan {
namespace {

constexpr double kPi = M_PI;  // as pixels_per_metre_at_1m() in the header

}  // namespace

ScanCamera ScanCamera::make_pinhole(const Intrinsics& intrinsics) {
  ScanCamera camera;
  camera.projection = ScanProjection::kPinhole;
  camera.width = intrinsics.width;
  camera.height = intrinsics.height;
  camera.pinhole = intrinsics;
  return camera;
}

ScanCamera ScanCamera::make_equirectangular(int h) {
  ScanCamera camera;
  camera.projection = ScanProjection::kEquirectangular;
  camera.width = 2 * h;
  camera.height = h;
  return camera;
}

ScanCamera ScanCamera::equirectangular_for_points(long long points) {
  const double h = std::sqrt(kPi * static_cast<double>(std::max(points, 0LL)) / 3.0);
  return make_equirectangular(std::max(1, static_cast<int>(std::lround(h))));
}

bool ScanCamera::project(const Eigen::Vector3f& p, float& u, float& v) const {
  if (!p.allFinite()) return false;
  if (projection == ScanProjection::kPinhole) {
    if (!(p.z() > 0.0f)) return false;
    u = static_cast<float>(pinhole.fx * p.x() / p.z() + pinhole.cx);
    v = static_cast<float>(pinhole.fy * p.y() / p.z() + pinhole.cy);
    return true;
  }
  const double x = p.x(), y = p.y(), z = p.z();
  const double horizontal = std::sqrt(x * x + y * y);
  if (horizontal == 0.0 && z == 0.0) return false;
  const double phi = std::atan2(y, x);             // [-pi, pi]
  const double theta = std::atan2(horizontal, z);  // [0, pi]
  u = static_cast<float>((phi + kPi) / (2.0 * kPi) * width);
  v = static_cast<float>(theta / kPi * height);
  return true;
}

Eigen::Vector3d ScanCamera::ray(double u, double v) const {
  if (projection == ScanProjection::kPinhole) return pinhole.unproject(u, v, 1.0).normalized();
  const double phi = u / width * 2.0 * kPi - kPi;
  const double theta = v / height * kPi;
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

bool ScanCamera::pixel_of(const Eigen::Vector3f& p, int& x, int& y) const {
  float u = 0.0f, v = 0.0f;
  if (!project(p, u, v)) return false;
  if (projection == ScanProjection::kPinhole) {
    u += 0.5f;  // pixel centres at integers: pixel x covers [x - 0.5, x + 0.5)
    v += 0.5f;
  }
  // Compare as floats before converting: a point far off a pinhole camera's axis projects beyond
  // any int.
  if (!(u >= 0.0f && v >= 0.0f && u <= static_cast<float>(width) &&
        v <= static_cast<float>(height)))
    return false;
  x = static_cast<int>(u);
  y = static_cast<int>(v);
  if (projection == ScanProjection::kEquirectangular) {
    x = std::min(x, width - 1);  // phi = pi and theta = pi land on the last column / row
    y = std::min(y, height - 1);
  }
  return x < width && y < height;
}

bool ScanCamera::valid() const {
  if (width <= 0 || height <= 0) return false;
  if (projection == ScanProjection::kEquirectangular) return width == 2 * height;
  return pinhole.valid() && pinhole.width == width && pinhole.height == height;
}

}  // namespace aoscan
