/// @file intrinsics.h
/// @brief Pinhole intrinsics of a depth camera: projection, back-projection, pyramid scaling.
#pragma once

#include <string>

#include <Eigen/Core>

namespace aoscan {

/// Pinhole model in pixels; pixel centres are at integer coordinates (OpenCV convention).
/// Camera frame: x right, y down, z forward (metres).
struct Intrinsics {
  int width = 640;
  int height = 480;
  double fx = 525.0;
  double fy = 525.0;
  double cx = 319.5;
  double cy = 239.5;

  /// Pixel coordinates of a point in the camera frame (z > 0 expected).
  Eigen::Vector2d project(const Eigen::Vector3d& p_camera) const {
    return {fx * p_camera.x() / p_camera.z() + cx, fy * p_camera.y() / p_camera.z() + cy};
  }
  /// Camera-frame point at pixel (u, v) with depth z metres along the optical axis.
  Eigen::Vector3d unproject(double u, double v, double z) const {
    return {(u - cx) / fx * z, (v - cy) / fy * z, z};
  }
  /// Float variants for per-pixel kernels.
  Eigen::Vector3f unproject(float u, float v, float z) const {
    return {static_cast<float>((u - cx) / fx) * z, static_cast<float>((v - cy) / fy) * z, z};
  }
  /// Intrinsics of pyramid level `level` (each level halves the resolution; level 0 is this).
  /// The half-pixel shift keeps pixel centres aligned with 2x2 block averaging.
  Intrinsics scaled(int level) const {
    Intrinsics k = *this;
    for (int i = 0; i < level; ++i) {
      k.width /= 2;
      k.height /= 2;
      k.fx *= 0.5;
      k.fy *= 0.5;
      k.cx = (k.cx + 0.5) * 0.5 - 0.5;
      k.cy = (k.cy + 0.5) * 0.5 - 0.5;
    }
    return k;
  }
  /// True when every value is finite and positive where it must be.
  bool valid() const;
  /// Why these intrinsics cannot be a real camera's, or empty: a principal point outside the
  /// image, or a field of view beyond 170 degrees. Such a calibration sends the rays of the model
  /// raycast kilometres sideways (minutes per frame) and fuses nothing useful.
  std::string implausible() const;

  bool operator==(const Intrinsics& o) const {
    return width == o.width && height == o.height && fx == o.fx && fy == o.fy && cx == o.cx &&
           cy == o.cy;
  }
};

}  // namespace aoscan
