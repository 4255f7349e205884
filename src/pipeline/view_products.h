/// @file view_products.h
/// @brief What the view consumers need beyond the fusion products: the per-pixel MVAO image of a
/// frame (read from the grid by the mvao stage) and the sparse AO point cloud of the orbit view.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <unordered_map>

#include "ao/mvao_grid.h"
#include "core/image.h"
#include "core/mesh.h"
#include "core/pose.h"
#include "geometry/point_maps.h"
#include "render/composite.h"

namespace aoscan {

/// AO of the MVAO grid cell holding each pixel's world point T_world_camera * maps.vertices(x, y)
/// (metres), in [0, 1]; NaN where the pixel has no surface (zero vertex) or its cell was never
/// observed. `out` is resized to the maps' size (its buffer reused). Read-only on `grid`: call it
/// on the grid's writer thread (the mvao stage). Parallel over rows; equal to the plain serial
/// lookup of every pixel.
/// `slots` (optional): what MvaoGrid::integrate() just returned for these very maps and pose;
/// its pixels read their cell from it without a table lookup (the cells are still in the cache),
/// the others (not integrated: no SSAO weight) look theirs up.
void mvao_image(const MvaoGrid& grid, const PointMaps& maps, const Pose& T_world_camera,
                Image<float>& out, const Image<std::uint32_t>* slots = nullptr);

/// The view's MVAO image as `read` says (ao.view_read): mvao_image() (cells, through `slots`
/// when given) or, coarse, MvaoGrid::lookup_ao_coarse() of every pixel (the grid's brick sums
/// brought up to date first, which makes this a writer's call), parallel over rows.
void mvao_image(MvaoGrid& grid, AoViewRead read, const PointMaps& maps, const Pose& T_world_camera,
                Image<float>& out, const Image<std::uint32_t>* slots = nullptr);

struct SurfaceCloudOptions {
  double voxel_m = kSurfaceCloudSpacingM;  ///< one point per voxel of this side (metres)
  int pixel_step = 4;               ///< sample every pixel_step-th pixel in x and y
  std::size_t max_points = 400000;  ///< points beyond this are not added (memory bound)
};

/// The orbit view's surface: raycast points in the world frame with their MVAO, one per voxel,
/// accumulated frame by frame (the first point seen in a voxel keeps its position; its normal and
/// AO follow the newest frame with an observed AO). Cheap (a hash insert per sampled pixel) and
/// off the fusion path: the view stage owns it. Deterministic for a given frame order.
class SurfaceCloud {
 public:
  explicit SurfaceCloud(SurfaceCloudOptions options = {});

  /// Adds the sampled pixels of one frame: camera-frame vertices and normals (zero = invalid),
  /// `mvao` the frame's per-pixel AO (NaN = unknown; may be empty), T_world_camera its pose.
  void add(const PointMaps& maps, const Image<float>& mvao, const Pose& T_world_camera);
  void clear();

  /// A snapshot as a face-less mesh (vertices, normals, quality = AO; NaN AO = never observed).
  std::shared_ptr<const TriangleMesh> to_mesh() const;
  std::size_t size() const { return mesh_.vertices.size(); }
  /// Points not added because max_points was reached.
  std::uint64_t points_refused() const { return refused_; }

 private:
  SurfaceCloudOptions options_;
  TriangleMesh mesh_;
  std::unordered_map<std::uint64_t, std::uint32_t> index_;  ///< voxel key → vertex
  std::uint64_t refused_ = 0;
};

}  // namespace aoscan
