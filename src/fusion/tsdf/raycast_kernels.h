/// @file raycast_kernels.h
/// @brief Internal to the raycast: what its portable code (raycast.cpp), its AVX2 hinted-ray
/// search (raycast_avx2.cpp) and the plain reference of the tests (tests/support) share. Not for
/// other code.
#pragma once

#include <algorithm>
#include <cstddef>

#include <Eigen/Core>

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/pose.h"
#include "fusion/tsdf/tsdf_config.h"
#include "fusion/tsdf/tsdf_sampler.h"
#include "fusion/tsdf/tsdf_volume.h"
#include "geometry/point_maps.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define AOSCAN_RAYCAST_AVX2 1
#endif

namespace aoscan {
namespace detail {

/// Pixels per tile edge of the depth-bounds image.
inline constexpr int kTile = 8;
/// Steps of the search around a depth hint before falling back to a march of the window ...
inline constexpr int kHintSteps = 4;
/// ... of this half-width around the hint, in truncation distances.
inline constexpr float kHintWindow = 2.0f;

/// A camera ray in voxel units: g(s) = origin + s * dir, where s is the depth along the optical
/// axis (m).
struct Ray {
  Eigen::Vector3f origin;
  Eigen::Vector3f dir;
  Eigen::Vector3f ray_camera;  ///< (x/z, y/z, 1) of the pixel
  float metres_per_s;          ///< |ray_camera|: metres travelled per unit of s
};

/// Finds the zero crossing between s0 (tsdf f0 >= 0) and s1 (tsdf f1 < 0) on trilinear samples by
/// the Illinois variant of regula falsi; a bracket within one voxel takes a single secant step.
float refine_crossing(TsdfSampler& sampler, const Ray& ray, float voxel_size, float truncation,
                      float s0, float f0, float s1, float f1);
/// Marks pixel (x, y) of `r` as having no surface.
void clear_pixel(RaycastResult& r, int x, int y);
/// Writes depth, vertex and normal of a hit at depth s (normal: TSDF gradient by central
/// differences around the nearest voxel, 7 voxel reads); clears the pixel when it is not
/// available.
void write_hit(TsdfSampler& sampler, const Ray& ray, float s, const Eigen::Matrix3f& R_camera_world,
               RaycastResult& r, int x, int y);
/// Sizes `result` for `intrinsics` and sets its pose; the pixels are the caller's to write.
void prepare(const Intrinsics& intrinsics, const Pose& T_world_camera, RaycastResult& result);
/// Throws usage_error on invalid intrinsics or an empty depth range.
void check_inputs(const Intrinsics& intrinsics, const FusionConfig& config);
/// True when every ray position stays far inside the int range of voxel coordinates.
bool within_grid(const TsdfVolume& volume, const Intrinsics& k, const Pose& T_world_camera,
                 const FusionConfig& config);

/// Everything per frame that the raycasts need.
struct RaySetup {
  Eigen::Matrix3f R_world_camera;
  Eigen::Matrix3f R_camera_world;
  Eigen::Vector3f origin_voxels;
  float inv_voxel;
  float fx_inv, fy_inv, cx, cy;

  RaySetup(const TsdfVolume& volume, const Intrinsics& k, const Pose& T_world_camera) {
    R_world_camera = T_world_camera.rotation().cast<float>();
    R_camera_world = R_world_camera.transpose();
    inv_voxel = 1.0f / volume.voxel_size_m();
    origin_voxels = T_world_camera.translation().cast<float>() * inv_voxel;
    fx_inv = static_cast<float>(1.0 / k.fx);
    fy_inv = static_cast<float>(1.0 / k.fy);
    cx = static_cast<float>(k.cx);
    cy = static_cast<float>(k.cy);
  }
  Ray ray(int x, int y) const {
    Ray r;
    r.ray_camera = Eigen::Vector3f((static_cast<float>(x) - cx) * fx_inv,
                                   (static_cast<float>(y) - cy) * fy_inv, 1.0f);
    r.origin = origin_voxels;
    r.dir = R_world_camera * r.ray_camera * inv_voxel;
    r.metres_per_s = r.ray_camera.norm();
    return r;
  }
};

/// A + to - bracket [s0, s1] of the trilinear field along a ray (tsdf f0 >= 0 at s0, f1 < 0 at s1).
struct Bracket {
  float s0 = 0.0f, f0 = 0.0f, s1 = 0.0f, f1 = 0.0f;
};

/// What the rows of one raycast share: the frame set-up, the per-tile depth bounds, the depth
/// hint and the output.
struct RaycastRows {
  const RaySetup& setup;
  const Image<float>* depth_hint_m;  ///< null: no hint
  bool hinted_only;                  ///< rays without a usable hint are not cast
  const float* zmin;                 ///< per tile: depth bounds of the allocated blocks
  const float* zmax;
  int tiles_x;
  int width;
  float min_depth, max_depth;
  float voxel_size, truncation;
  RaycastResult& result;

  /// The depth range [s_begin, s_end) to search at pixel (x, y) (empty when no block is seen).
  void range(int x, int y, float& s_begin, float& s_end) const {
    const std::size_t ti = static_cast<std::size_t>(y / kTile) * tiles_x + x / kTile;
    s_end = std::min(zmax[ti], max_depth);
    s_begin = std::max(zmin[ti], min_depth);
  }
  /// The hint at pixel (x, y), 0 without a hint.
  float hint(int x, int y) const { return depth_hint_m != nullptr ? (*depth_hint_m)(x, y) : 0.0f; }
  /// Pixel (x, y)'s ray, its depth range [s_begin, s_end) and its hint (0 without one); false
  /// when the range is empty (no block is seen through the pixel).
  bool pixel(int x, int y, Ray& ray, float& s_begin, float& s_end, float& hint_m) const {
    range(x, y, s_begin, s_end);
    if (!(s_begin < s_end)) return false;
    ray = setup.ray(x, y);
    hint_m = hint(x, y);
    return true;
  }
};

/// A depth hint that a ray searches next to.
inline bool usable_hint(float d) {
  return d > 0.0f && d < 1e4f;
}

/// Marches one ray from depth s to s_end; writes the pixel and returns true on a surface hit.
bool march(TsdfSampler& sampler, const Ray& ray, float s, float s_end, float voxel_size,
           float truncation, const Eigen::Matrix3f& R_camera_world, RaycastResult& result, int x,
           int y);

/// Runs a hinted ray to its end: the refined hit of its bracket (`found`), else, or when the hit
/// has no normal, a march of the window around the hint.
void finish_hinted_ray(TsdfSampler& sampler, const Ray& ray, int x, int y, float d, float s_begin,
                       float s_end, bool found, const Bracket& b, float vs, float trunc,
                       const Eigen::Matrix3f& R_camera_world, RaycastResult& result);

#if defined(AOSCAN_RAYCAST_AVX2)
/// Raycasts row y (raycast.cpp's portable row, the same result bit for bit) with the hinted rays
/// searched eight per AVX2 vector. Only on a CPU with AVX2.
void raycast_row_avx2(TsdfSampler& sampler, const RaycastRows& rows, int y);
#endif

}  // namespace detail
}  // namespace aoscan
