/// @file range_map.cpp
/// @brief Range maps from depth images and point clouds, and their normals.
#include "geometry/range_map.h"

#include <cmath>
#include <string>

#include "core/status.h"

namespace aoscan {

long long RangeMap::count_points() const {
  long long n = 0;
  for (int y = 0; y < points.height(); ++y)
    for (int x = 0; x < points.width(); ++x) n += has_point(x, y) ? 1 : 0;
  return n;
}

void range_map_from_depth(const Image<float>& depth_m, const Intrinsics& intrinsics,
                          RangeMap& map) {
  if (depth_m.width() != intrinsics.width || depth_m.height() != intrinsics.height)
    throw input_error(map.name + ": depth image is " + std::to_string(depth_m.width()) + "x" +
                      std::to_string(depth_m.height()) + " but its intrinsics say " +
                      std::to_string(intrinsics.width) + "x" + std::to_string(intrinsics.height));
  map.camera = ScanCamera::make_pinhole(intrinsics);
  map.points.resize(intrinsics.width, intrinsics.height, Eigen::Vector3f::Zero());
  map.normals.resize(intrinsics.width, intrinsics.height, Eigen::Vector3f::Zero());
  for (int y = 0; y < intrinsics.height; ++y)
    for (int x = 0; x < intrinsics.width; ++x) {
      const float z = depth_m(x, y);
      map.points(x, y) = z > 0.0f && std::isfinite(z)
                             ? intrinsics.unproject(static_cast<float>(x), static_cast<float>(y), z)
                             : Eigen::Vector3f::Zero();
      map.normals(x, y).setZero();
    }
}

long long rasterize_points(const std::vector<Eigen::Vector3f>& points,
                           const std::vector<Eigen::Vector3f>& normals, RangeMap& map) {
  if (!map.camera.valid()) throw usage_error(map.name + ": the scan's camera is not usable");
  const bool with_normals = !normals.empty();
  if (with_normals && normals.size() != points.size())
    throw input_error(map.name + ": " + std::to_string(points.size()) + " points but " +
                      std::to_string(normals.size()) + " normals");
  map.points.resize(map.camera.width, map.camera.height, Eigen::Vector3f::Zero());
  map.normals.resize(map.camera.width, map.camera.height, Eigen::Vector3f::Zero());
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < map.camera.width; ++x) {
      map.points(x, y).setZero();
      map.normals(x, y).setZero();
    }
  long long skipped = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& p = points[i];
    int x = 0, y = 0;
    if (!map.camera.pixel_of(p, x, y)) {
      ++skipped;
      continue;
    }
    if (map.has_point(x, y) && !(map.camera.depth(p) < map.camera.depth(map.points(x, y))))
      continue;
    map.points(x, y) = p;
    if (with_normals) {
      Eigen::Vector3f n = normals[i];
      const float length = n.norm();
      n = length > 0.0f && std::isfinite(length) ? Eigen::Vector3f(n / length)
                                                 : Eigen::Vector3f::Zero();
      if (n.dot(p) > 0.0f) n = -n;  // face the scanner
      map.normals(x, y) = n;
    }
  }
  return skipped;
}

namespace {

/// The neighbour of (x, y) at offset (dx, dy) on the map's grid (wrapping around in azimuth for
/// an equirectangular map), or false when there is none or it has no point.
bool neighbour(const RangeMap& map, int x, int y, int dx, int dy, int& nx, int& ny) {
  nx = x + dx;
  ny = y + dy;
  if (map.camera.projection == ScanProjection::kEquirectangular)
    nx = (nx + map.camera.width) % map.camera.width;
  if (nx < 0 || ny < 0 || nx >= map.camera.width || ny >= map.camera.height) return false;
  return map.has_point(nx, ny);
}

/// The difference vector to the neighbour along one axis: the forward one, else the backward
/// one negated (so the cross product keeps its orientation); false when neither is usable.
bool axis_difference(const RangeMap& map, int x, int y, int dx, int dy, float max_jump,
                     Eigen::Vector3f& d) {
  const Eigen::Vector3f& p = map.points(x, y);
  const float depth = map.camera.depth(p);
  for (const int sign : {1, -1}) {
    int nx = 0, ny = 0;
    if (!neighbour(map, x, y, sign * dx, sign * dy, nx, ny)) continue;
    const Eigen::Vector3f& q = map.points(nx, ny);
    if (std::abs(map.camera.depth(q) - depth) > max_jump * depth) continue;
    d = static_cast<float>(sign) * (q - p);
    return true;
  }
  return false;
}

}  // namespace

void compute_range_map_normals(RangeMap& map, float max_jump_ratio) {
  for (int y = 0; y < map.points.height(); ++y)
    for (int x = 0; x < map.points.width(); ++x) {
      Eigen::Vector3f& n = map.normals(x, y);
      if (!(n.x() == 0.0f && n.y() == 0.0f && n.z() == 0.0f)) continue;
      if (!map.has_point(x, y)) continue;
      Eigen::Vector3f du, dv;
      if (!axis_difference(map, x, y, 1, 0, max_jump_ratio, du) ||
          !axis_difference(map, x, y, 0, 1, max_jump_ratio, dv))
        continue;
      Eigen::Vector3f c = du.cross(dv);
      const float length = c.norm();
      if (!(length > 0.0f) || !std::isfinite(length)) continue;
      c /= length;
      if (c.dot(map.points(x, y)) > 0.0f) c = -c;
      n = c;
    }
}

float point_radius(const ScanCamera& camera, float depth_m) {
  return depth_m / camera.pixels_per_metre_at_1m();
}

}  // namespace aoscan
