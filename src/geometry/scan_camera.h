/// @file scan_camera.h
/// @brief The camera model of one scan's range map (Sabbadin et al. 2016 Sec. 4-5): a pinhole
/// camera (a depth image) or an equirectangular map (a 360-degree laser scan, Sec. 7), with the
/// projection of scanner-frame points into the map and the pixel footprint that sizes SSAO disks
/// and point radii.
#pragma once

#include <cmath>

#include <Eigen/Core>

#include "core/intrinsics.h"

namespace aoscan {

/// How a scan's pixels map to directions from the scanner.
enum class ScanProjection {
  /// A depth camera: Intrinsics (x right, y down, z forward); a point's depth is its z.
  kPinhole,
  /// A laser scanner's sphere of directions, z up: u = (phi + pi) / (2 pi) width with the azimuth
  /// phi = atan2(y, x), v = theta / pi height with the polar angle theta from the zenith (v = 0
  /// straight up). Pixel (x, y) covers [x, x + 1) x [y, y + 1). A point's depth is its distance
  /// from the scanner.
  kEquirectangular,
};

/// Column x of a map `width` pixels wide that wraps around in x (an equirectangular map, whose
/// columns are azimuths): one addition or subtraction for the columns just off either edge, the
/// usual case.
inline int wrap_column(int x, int width) {
  if (x < 0) x += width;
  if (x >= width) x -= width;
  if (x < 0 || x >= width) x = ((x % width) + width) % width;  // farther than a width off
  return x;
}

/// Moves pixel (x, y) of a map of width x height pixels, which may lie off it, onto it when the
/// map covers the whole sphere of directions (`wrap`, ScanCamera::wraps(): an equirectangular
/// map, 2h x h): across the seam in x, and across a pole, where the row k past the map's top or
/// bottom edge is row k from that edge on the opposite azimuth (x + width / 2). Pixels at most a
/// height above or below the map. False where (x, y) is off the map all the same (beside or
/// above a map that does not wrap).
inline bool onto_map(int& x, int& y, int width, int height, bool wrap) {
  if (wrap) {
    if (y < 0 || y >= height) {
      y = y < 0 ? -1 - y : 2 * height - 1 - y;
      x += width / 2;
    }
    x = wrap_column(x, width);
  }
  return x >= 0 && y >= 0 && x < width && y < height;
}

/// One scan's camera: its projection and map size (pixels).
struct ScanCamera {
  ScanProjection projection = ScanProjection::kPinhole;
  int width = 0;
  int height = 0;
  Intrinsics pinhole;  ///< kPinhole only; width and height equal the map's

  /// A pinhole camera of `intrinsics`' size.
  static ScanCamera make_pinhole(const Intrinsics& intrinsics);
  /// An equirectangular map of 2h x h pixels.
  static ScanCamera make_equirectangular(int h);
  /// The equirectangular map of the paper's Sec. 7 for a cloud of `points` points: 2h x h with
  /// h = sqrt(pi v / 3) rounded to the nearest integer (at least 1): 2 h^2 = 2 pi v / 3 pixels,
  /// about two per point, since a scan covers only part of the sphere.
  static ScanCamera equirectangular_for_points(long long points);

  /// Map coordinates (u, v) of a scanner-frame point (metres), pixel (x, y) covering
  /// [x, x + 1) x [y, y + 1) for the equirectangular map and centred on integers for the pinhole
  /// one (Intrinsics' convention). False for a point the camera cannot see (pinhole: z <= 0 or
  /// not finite; equirectangular: the scanner's own position or not finite).
  bool project(const Eigen::Vector3f& p_scanner, float& u, float& v) const;
  /// Unit direction (scanner frame) of the ray through map coordinates (u, v): the inverse of
  /// project() (pinhole: through (u, v) with pixel centres at integers; equirectangular: pixel
  /// (x, y)'s centre is (x + 0.5, y + 0.5)).
  Eigen::Vector3d ray(double u, double v) const;
  /// The ray through the centre of pixel (x, y).
  Eigen::Vector3d pixel_ray(int x, int y) const {
    return projection == ScanProjection::kPinhole ? ray(x, y) : ray(x + 0.5, y + 0.5);
  }
  /// The integer pixel that project() lands in, or false outside the map.
  bool pixel_of(const Eigen::Vector3f& p_scanner, int& x, int& y) const;
  /// pixel_of() of `n` scanner-frame points given as coordinate arrays, for the integration's
  /// millions of projections: float arithmetic without branches, which the compiler vectorises,
  /// and for the equirectangular map an atan2 by a polynomial (a few float ulp) instead of the
  /// library's. (px[k], py[k]) is point k's pixel, px[k] = -1 where pixel_of() is false. Agrees
  /// with pixel_of() but for points within about 1e-3 pixels of a pixel's edge, which may land
  /// in the pixel beside it (tests/geometry/range_map_test.cpp).
  void pixels_of(const float* x, const float* y, const float* z, int n, int* px, int* py) const;
  /// The depth of a scanner-frame point as this camera measures it: z for a pinhole camera, the
  /// distance to the scanner for an equirectangular map.
  float depth(const Eigen::Vector3f& p_scanner) const {
    return projection == ScanProjection::kPinhole ? p_scanner.z() : p_scanner.norm();
  }
  /// Pixels per metre at depth 1 m across the map's x axis (pinhole: fx; equirectangular:
  /// width / (2 pi) at the equator). A sphere of radius r at depth d covers about
  /// r * pixels_per_metre_at_1m() / d pixels: the adaptive SSAO disk radius of Sec. 4 (the
  /// equirectangular row scale is the same, height / pi = width / (2 pi)).
  float pixels_per_metre_at_1m() const {
    if (projection == ScanProjection::kPinhole) return static_cast<float>(pinhole.fx);
    return static_cast<float>(width / (2.0 * M_PI));
  }
  /// The pixels along row y that span as many metres as one pixel along a column there: 1 on a
  /// pinhole map; 1 / cos(latitude) on an equirectangular one, whose rows shrink towards the
  /// poles (a window of r pixels on the sphere of directions is r pixels high and
  /// r * row_stretch(y) pixels wide).
  double row_stretch(int y) const {
    if (projection != ScanProjection::kEquirectangular) return 1.0;
    return 1.0 / std::sin((y + 0.5) * M_PI / height);
  }
  /// One row of an equirectangular map on the sphere of directions, for laying out a disk of
  /// metres around its pixels (sphere_row()).
  struct SphereRow {
    float sin_theta = 1.0f, cos_theta = 0.0f;  ///< the polar angle of the row's pixel centres
    float v_centre = 0.5f;                     ///< their v: y + 0.5
    float u_scale = 0.0f, v_scale = 0.0f;      ///< pixels per radian of azimuth and polar angle
    /// (du[k], dv[k]): pixels from a pixel centre of the row to the map coordinates of the
    /// direction to the point `tangent` * o[k] away from the centre's direction on the plane
    /// across it at distance 1 (o[k].x() eastward, along the row; o[k].y() southward, along the
    /// column), k < n: the SSAO disk of radius r_s around a point at depth d, with tangent =
    /// r_s / d, as a pinhole image lays it on its image plane. Independent of the column (the
    /// map is the same at every azimuth); where the disk reaches past a pole, du is about half
    /// the map's width and dv turns back. Arctangents of a few float ulp, in a loop that the
    /// compiler vectorises.
    void offsets(float tangent, const Eigen::Vector2f* o, int n, float* du, float* dv) const;
  };
  /// Row y of an equirectangular map (its pixel centres' polar angle (y + 0.5) pi / height).
  SphereRow sphere_row(int y) const;
  /// Whether the map wraps around in x (equirectangular: its columns are azimuths).
  bool wraps() const { return projection == ScanProjection::kEquirectangular; }
  /// True when the model is usable (positive size; a pinhole camera with valid intrinsics of the
  /// same size).
  bool valid() const;
};

}  // namespace aoscan
