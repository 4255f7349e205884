/// @file scan_mesh.h
/// @brief `aoscan scans --mesh`: the scans fused into the TSDF of the real-time path, meshed by
/// marching cubes, and each vertex given the AO of the nearest scan point.
#pragma once

#include <functional>
#include <memory>
#include <vector>

#include "ao/multiscan.h"
#include "core/image.h"
#include "core/intrinsics.h"
#include "core/mesh.h"
#include "core/pose.h"
#include "fusion/tsdf/tsdf_config.h"
#include "geometry/range_map.h"

namespace aoscan {

/// A depth image a scan contributes to the TSDF: metres along the optical axis, 0 = none.
struct DepthView {
  Image<float> depth_m;
  Intrinsics intrinsics;
  Pose T_world_camera;
};

/// The depth images of `map` for a TSDF: a pinhole scan is one already; an equirectangular scan
/// becomes the six 90-degree faces of a cube around its scanner (width / 4 pixels across, each
/// point in the face pixel it projects to, the nearest kept), whose empty pixels with at least
/// four neighbours on one surface (depths within 5 % of each other) take their mean, since the
/// faces sample the sphere more finely than the map towards their corners.
std::vector<DepthView> scan_depth_views(const RangeMap& map);

/// What mesh_scans() did.
struct ScanMeshStats {
  long long vertices = 0;
  long long faces = 0;
  long long vertices_without_ao = 0;  ///< no scan point within the distance: quality 1
  int tsdf_blocks = 0;
  bool capacity_reached = false;  ///< tsdf.max_blocks was reached: parts are missing
  double fuse_s = 0.0, extract_s = 0.0, shade_s = 0.0;
};

/// Fuses `count` scans (`scan(i)` gives scan i, loaded one at a time) into a TSDF with `fusion`
/// (tsdf.* keys), extracts its mesh (mesh_min_weight), and gives each vertex the value (`values(i,
/// scan, out)`: the scan's MVAO or SSAO, its map's size) of the scan point nearest to it among the
/// 3 x 3 pixels around its projection into each scan (the first scan's on a tie), if that point
/// lies within the truncation distance or two of its point radii (point_radius()); else quality 1
/// (counted). Vertices run in parallel; the result
/// does not depend on the thread count.
TriangleMesh mesh_scans(int count, const std::function<std::shared_ptr<const ScanAo>(int)>& scan,
                        const std::function<void(int, const ScanAo&, Image<float>&)>& values,
                        const FusionConfig& fusion, ScanMeshStats& stats);

}  // namespace aoscan
