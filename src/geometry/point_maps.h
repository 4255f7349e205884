/// @file point_maps.h
/// @brief Per-pixel vertex and normal maps (of a depth frame or of a model raycast), the depth
/// pyramid that tracking consumes, and the functions that compute them from metric depth.
///
/// Depth images hold metres along the optical axis as float, and 0.0f marks an invalid pixel.
/// Every function writes into a caller-owned output that is resized (without reallocating when it
/// is large enough); outputs must not alias inputs; results do not depend on the thread count.
#pragma once

#include <array>

#include <Eigen/Core>

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/pose.h"

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


/// The model seen from one pose. Published by the pipeline as an immutable product.
struct RaycastResult {
  Pose T_world_camera;   ///< pose the model was raycast from
  Image<float> depth_m;  ///< depth along the optical axis (m), 0 = no surface
  PointMaps maps;        ///< camera-frame vertices (m) and unit normals facing the camera
  int hits = 0;          ///< pixels with a surface
};

/// Halves a metric depth image: output pixel (x, y) averages the valid depths of the 2x2 block
/// (2x..2x+1, 2y..2y+1) that lie within `max_depth_diff_m` of the block's first valid depth in
/// raster order (KinectFusion-style: only depths of the same surface are averaged); 0 when the
/// block has no valid depth. Output size is (width / 2, height / 2), matching
/// Intrinsics::scaled(1); an odd last row or column is dropped.
void downsample_depth(const Image<float>& depth_m, float max_depth_diff_m, Image<float>& out);

/// Vertex map: the camera-frame point (metres) of every pixel, Intrinsics::unproject(x, y, z) with
/// `intrinsics` of this image's resolution; the zero vector where the depth is invalid.
void compute_vertex_map(const Image<float>& depth_m, const Intrinsics& intrinsics,
                        Image<Eigen::Vector3f>& vertices);

/// Normal map of a camera-frame vertex map: n = normalise((v(x+1,y) - v) x (v(x,y+1) - v)),
/// flipped so that it faces the camera (n . v < 0). The zero vector where the pixel or its right
/// or down neighbour is invalid (zero vertex), where either neighbour's z differs from the pixel's
/// by more than `max_depth_jump_m`, in the last column and last row, and where the cross product
/// vanishes.
void compute_normal_map(const Image<Eigen::Vector3f>& vertices, float max_depth_jump_m,
                        Image<Eigen::Vector3f>& normals);

/// compute_vertex_map() and compute_normal_map() in one pass over the depth image (the normal map
/// with `max_depth_jump_m`), `maps.intrinsics` = `intrinsics`. This is the fast version (AVX2 over
/// eight pixels when the CPU has it, TBB over rows); it performs the reference functions'
/// operations in their order without fused multiply-adds and equals them bit for bit in the
/// default build (within 1e-6 when the whole build uses FMA contraction, e.g. -march=native).
void compute_point_maps(const Image<float>& depth_m, const Intrinsics& intrinsics,
                        float max_depth_jump_m, PointMaps& maps);

}  // namespace aoscan
