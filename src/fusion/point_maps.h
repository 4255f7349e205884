/// @file point_maps.h
/// @brief Per-pixel vertex and normal maps (of a depth frame or of a model raycast) and the depth
/// pyramid that tracking consumes.
#pragma once

#include <array>

#include <Eigen/Core>

#include "core/image.h"
#include "core/intrinsics.h"

namespace aoscan {

/// Number of pyramid levels used by tracking (level 0 = full resolution).
inline constexpr int kPyramidLevels = 3;

/// Vertex and normal of every pixel in the camera frame of the image (metres, unit normals facing
/// the camera). An invalid pixel has an all-zero vertex and an all-zero normal.
struct PointMaps {
  Intrinsics intrinsics;
  Image<Eigen::Vector3f> vertices;
  Image<Eigen::Vector3f> normals;
};

/// Depth in metres (0 = invalid) and point maps at every level of the tracking pyramid.
struct DepthPyramid {
  std::array<Image<float>, kPyramidLevels> depth_m;
  std::array<PointMaps, kPyramidLevels> maps;
};

}  // namespace aoscan
