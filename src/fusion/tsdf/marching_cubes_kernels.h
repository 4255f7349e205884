/// @file marching_cubes_kernels.h
/// @brief Internal to marching cubes: the per-cube pieces that the extraction (marching_cubes.cpp)
/// and the plain reference of the tests (tests/support) share. Not for other code.
#pragma once

#include <Eigen/Core>

#include "fusion/tsdf/tsdf_sampler.h"
#include "fusion/tsdf/tsdf_volume.h"

namespace aoscan {
namespace detail {

/// Offset of cube corner `corner` (bit 0: x, bit 1: y, bit 2: z) from the cube's first voxel.
inline Eigen::Vector3i corner_offset(int corner) {
  return {corner & 1, (corner >> 1) & 1, (corner >> 2) & 1};
}

/// Vertex on the grid edge from voxel g along `axis` (world metres) and its unit normal.
inline void edge_vertex(TsdfSampler& sampler, const Eigen::Vector3i& g, int axis, float f0, float f1,
                 float voxel_size, Eigen::Vector3f& position, Eigen::Vector3f& normal) {
  const float t = f0 / (f0 - f1);
  Eigen::Vector3f p = g.cast<float>();
  p[axis] += t;
  position = p * voxel_size;
  Eigen::Vector3f grad;
  if (sampler.gradient(p, grad) && grad.squaredNorm() > 1e-12f) {
    normal = grad.normalized();
  } else {
    normal = Eigen::Vector3f::Zero();
    normal[axis] = f1 > f0 ? 1.0f : -1.0f;
  }
}

/// True when the voxel exists and is observed with at least `min_weight`.
inline bool usable(const Voxel* v, float min_weight) {
  return v != nullptr && v->weight() >= min_weight && v->count > 0;
}

}  // namespace detail
}  // namespace aoscan
