/// @file colour.h
/// @brief Colour as the sources deliver it and the outputs write it: 8-bit RGB pixels and the
/// calibration of a colour camera beside a depth camera.
#pragma once

#include <cstdint>

#include "core/intrinsics.h"
#include "core/pose.h"

namespace aoscan {

/// Whether frame `sequence` of a source takes part in colour fusion when every `every`-th frame
/// does (fusion.colour_every): the frames whose sequence is a multiple of it. The one rule the
/// sources (which skip decoding the others' colour where they can) and fusion share.
inline bool colour_frame(std::uint64_t sequence, int every) {
  return every <= 1 || sequence % static_cast<std::uint64_t>(every) == 0;
}

/// One 8-bit sRGB colour.
struct Rgb8 {
  std::uint8_t r = 0, g = 0, b = 0;
  friend bool operator==(const Rgb8& a, const Rgb8& b) {
    return a.r == b.r && a.g == b.g && a.b == b.b;
  }
  friend bool operator!=(const Rgb8& a, const Rgb8& b) { return !(a == b); }
};

/// The colour camera of a depth camera: where a depth-camera point appears in the colour image.
/// A point p in the depth camera's frame (metres) is at T_colour_depth * p in the colour camera's
/// frame and projects with `intrinsics` (the colour image's own size). `registered` says the source
/// has already resampled colour onto the depth pixels (hardware registration, or a recording made
/// that way): then the colour image has the depth image's size and pixel (x, y) of one is pixel
/// (x, y) of the other; `intrinsics` are the depth's and T_colour_depth is the identity.
struct ColourCamera {
  Intrinsics intrinsics;
  Pose T_colour_depth;
  bool registered = false;

  /// The colour pixel (u, v) of a depth-camera point p; false when p is behind the colour camera.
  bool project(const Eigen::Vector3d& p_depth, double& u, double& v) const {
    const Eigen::Vector3d q = T_colour_depth.rotation() * p_depth + T_colour_depth.translation();
    if (!(q.z() > 0.0)) return false;
    u = intrinsics.fx * q.x() / q.z() + intrinsics.cx;
    v = intrinsics.fy * q.y() / q.z() + intrinsics.cy;
    return true;
  }

  /// A colour camera with nominal Kinect v1 intrinsics for colour images of width x height
  /// (fx = fy = 525 * width / 640, principal point at the centre ((width - 1) / 2,
  /// (height - 1) / 2)) at `depth_to_colour_x_m` along the depth camera's x axis (no rotation):
  /// what a Kinect-class camera's colour camera is when nothing better is known.
  static ColourCamera nominal(int width, int height, double depth_to_colour_x_m = 0.0) {
    ColourCamera c;
    c.intrinsics.width = width;
    c.intrinsics.height = height;
    c.intrinsics.fx = c.intrinsics.fy = 525.0 * width / 640.0;
    c.intrinsics.cx = (width - 1) * 0.5;
    c.intrinsics.cy = (height - 1) * 0.5;
    c.T_colour_depth =
        Pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(depth_to_colour_x_m, 0.0, 0.0));
    return c;
  }

  /// A registered colour camera of a depth camera with `depth_intrinsics`.
  static ColourCamera registered_to(const Intrinsics& depth_intrinsics) {
    ColourCamera c;
    c.intrinsics = depth_intrinsics;
    c.registered = true;
    return c;
  }
};

}  // namespace aoscan
