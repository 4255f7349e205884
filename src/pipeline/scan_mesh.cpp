/// @file scan_mesh.cpp
/// @brief The mesh of a scan set: cube-face depth views, TSDF fusion, marching cubes, vertex AO.
#include "pipeline/scan_mesh.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "fusion/tsdf/marching_cubes.h"
#include "fusion/tsdf/tsdf_integrator.h"
#include "fusion/tsdf/tsdf_volume.h"

namespace aoscan {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

/// A point's tangent plane gives the depth at its face pixel's centre unless the plane is seen
/// nearly edge-on (|cos| of the angle between the ray and the normal below this) ...
constexpr float kMinFacing = 0.1f;
/// ... or that depth lies farther than this share of the point's own depth from it.
constexpr float kMaxPlaneShift = 0.1f;
/// Empty pixels with at least this many of their 8 neighbours on one surface are filled.
constexpr int kFillNeighbours = 4;
/// Neighbours are on one surface when their depths lie within this share of their mean.
constexpr float kFillSpread = 0.05f;

/// The camera-to-scanner rotation of cube face f (0..5: +x, -x, +y, -y, +z, -z forward).
Eigen::Matrix3d face_rotation(int f) {
  Eigen::Vector3d z = Eigen::Vector3d::Zero();
  z[f / 2] = f % 2 == 0 ? 1.0 : -1.0;
  // Image down is the scanner's -z for the side faces, and any perpendicular for the top and
  // bottom ones.
  const Eigen::Vector3d y = f / 2 == 2 ? Eigen::Vector3d(0, 1, 0) : Eigen::Vector3d(0, 0, -1);
  Eigen::Matrix3d R;
  R.col(0) = y.cross(z);
  R.col(1) = y;
  R.col(2) = z;
  return R;
}

/// Fills the empty pixels of `depth` that sit among enough neighbours on one surface.
void fill_small_holes(Image<float>& depth) {
  const Image<float> in = depth;
  for (int y = 1; y + 1 < in.height(); ++y)
    for (int x = 1; x + 1 < in.width(); ++x) {
      if (in(x, y) > 0.0f) continue;
      float lo = std::numeric_limits<float>::max(), hi = 0.0f, sum = 0.0f;
      int n = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const float d = in(x + dx, y + dy);
          if (!(d > 0.0f)) continue;
          lo = std::min(lo, d);
          hi = std::max(hi, d);
          sum += d;
          ++n;
        }
      if (n >= kFillNeighbours && hi - lo <= kFillSpread * sum / static_cast<float>(n))
        depth(x, y) = sum / static_cast<float>(n);
    }
}

}  // namespace

std::vector<DepthView> scan_depth_views(const RangeMap& map) {
  std::vector<DepthView> views;
  if (map.camera.projection == ScanProjection::kPinhole) {
    DepthView v;
    v.intrinsics = map.camera.pinhole;
    v.T_world_camera = map.T_world_scanner;
    v.depth_m.resize(map.camera.width, map.camera.height, 0.0f);
    for (int y = 0; y < map.camera.height; ++y)
      for (int x = 0; x < map.camera.width; ++x)
        if (map.has_point(x, y)) v.depth_m(x, y) = map.points(x, y).z();
    views.push_back(std::move(v));
    return views;
  }
  const int s = std::max(8, map.camera.width / 4);
  Intrinsics k;
  k.width = k.height = s;
  k.fx = k.fy = 0.5 * s;
  k.cx = k.cy = 0.5 * (s - 1);
  for (int f = 0; f < 6; ++f) {
    DepthView v;
    v.intrinsics = k;
    const Eigen::Matrix3d R = face_rotation(f);
    v.T_world_camera = map.T_world_scanner * Pose(R, Eigen::Vector3d::Zero());
    v.depth_m.resize(s, s, 0.0f);
    const Eigen::Matrix3f R_cs = R.transpose().cast<float>();
    for (int y = 0; y < map.camera.height; ++y)
      for (int x = 0; x < map.camera.width; ++x) {
        if (!map.has_point(x, y)) continue;
        const Eigen::Vector3f q = R_cs * map.points(x, y);
        if (!(q.z() > 0.0f)) continue;
        const long u = std::lround(k.fx * q.x() / q.z() + k.cx);
        const long w = std::lround(k.fy * q.y() / q.z() + k.cy);
        if (u < 0 || w < 0 || u >= s || w >= s) continue;
        // The depth at the pixel's centre on the point's tangent plane (the point's own depth
        // where it has no normal or the plane is seen edge-on).
        float z = q.z();
        const Eigen::Vector3f n = R_cs * map.normals(x, y);
        const Eigen::Vector3f ray(static_cast<float>((u - k.cx) / k.fx),
                                  static_cast<float>((w - k.cy) / k.fy), 1.0f);
        const float facing = n.dot(ray);
        if (n.squaredNorm() > 0.5f) {
          if (std::abs(facing) < kMinFacing * ray.norm()) continue;  // seen edge-on
          const float along = n.dot(q) / facing;
          if (along > 0.0f && std::abs(along - z) < kMaxPlaneShift * z) z = along;
        }
        float& d = v.depth_m(static_cast<int>(u), static_cast<int>(w));
        if (d == 0.0f || z < d) d = z;
      }
    fill_small_holes(v.depth_m);
    views.push_back(std::move(v));
  }
  return views;
}

TriangleMesh mesh_scans(int count, const std::function<std::shared_ptr<const ScanAo>(int)>& scan,
                        const std::function<void(int, const ScanAo&, Image<float>&)>& values,
                        const FusionConfig& fusion, ScanMeshStats& stats) {
  Clock::time_point start = Clock::now();
  TriangleMesh mesh;
  {  // the volume's memory is given back before the shading
    TsdfVolume volume(fusion);
    TsdfIntegrator integrator;
    for (int i = 0; i < count; ++i) {
      const std::shared_ptr<const ScanAo> s = scan(i);
      for (const DepthView& v : scan_depth_views(s->map))
        integrator.integrate(volume, v.depth_m, v.intrinsics, v.T_world_camera);
    }
    stats.tsdf_blocks = volume.block_count();
    stats.capacity_reached = volume.capacity_reached();
    stats.fuse_s = seconds_since(start);
    start = Clock::now();
    mesh = extract_mesh(volume, static_cast<float>(fusion.mesh_min_weight));
    stats.extract_s = seconds_since(start);
  }

  start = Clock::now();
  const std::size_t n = mesh.vertices.size();
  std::vector<float> best(n, std::numeric_limits<float>::infinity());
  mesh.quality.assign(n, 1.0f);
  const float max_distance = static_cast<float>(fusion.truncation_m);
  Image<float> ao;
  for (int i = 0; i < count; ++i) {
    const std::shared_ptr<const ScanAo> s = scan(i);
    values(i, *s, ao);
    const RangeMap& map = s->map;
    const Eigen::Matrix3f R = map.T_world_scanner.rotation().transpose().cast<float>();
    const Eigen::Vector3f t = map.T_world_scanner.translation().cast<float>();
    const bool wrap = map.camera.wraps();
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, n), [&](const tbb::blocked_range<std::size_t>& r) {
          for (std::size_t v = r.begin(); v < r.end(); ++v) {
            const Eigen::Vector3f p = R * (mesh.vertices[v] - t);
            int px = 0, py = 0;
            if (!map.camera.pixel_of(p, px, py)) continue;
            // The nearest point of the 3 x 3 pixels around the projection, if it lies within
            // the truncation distance or two point radii (coarse scans) of the vertex.
            for (int dy = -1; dy <= 1; ++dy)
              for (int dx = -1; dx <= 1; ++dx) {
                int x = px + dx;
                int y = py + dy;
                if (!onto_map(x, y, map.camera.width, map.camera.height, wrap) ||
                    !map.has_point(x, y))
                  continue;
                const Eigen::Vector3f& q = map.points(x, y);
                const float d = (p - q).norm();
                const float reach = std::max(
                    max_distance, 2.0f * point_radius(map.camera, map.camera.depth(q)));
                if (!(d < best[v]) || !(d <= reach)) continue;
                best[v] = d;
                mesh.quality[v] = ao(x, y);
              }
          }
        });
  }
  for (std::size_t v = 0; v < n; ++v) stats.vertices_without_ao += std::isinf(best[v]) ? 1 : 0;
  stats.vertices = static_cast<long long>(n);
  stats.faces = static_cast<long long>(mesh.faces.size());
  stats.shade_s = seconds_since(start);
  return mesh;
}

}  // namespace aoscan
