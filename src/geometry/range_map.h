/// @file range_map.h
/// @brief One registered scan as a range map (Sabbadin et al. 2016 Sec. 5 and 7): per pixel the
/// scanner-frame position and normal of the point seen there, the scan's camera and its pose.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "core/pose.h"
#include "geometry/scan_camera.h"

namespace aoscan {

/// A scan's range noise as a function of depth: the spread of its points along their normals
/// (m), in kBins bins spaced evenly in log depth (compute_scan_normals() measures it). All zero,
/// the default, when it is not known.
struct ScanNoise {
  static constexpr int kBins = 16;
  float log_lo = 0.0f;       ///< log of the nearest bin's lower depth bound (m)
  float bin_per_log = 0.0f;  ///< bins per unit of log depth
  std::array<float, kBins> sigma_m{};

  /// The bin of `depth_m` (> 0); the first or the last beyond them.
  int bin(float depth_m) const {
    const float b = (std::log(depth_m) - log_lo) * bin_per_log;
    return b >= kBins - 1 ? kBins - 1 : (b > 0.0f ? static_cast<int>(b) : 0);
  }
  /// The noise at `depth_m` (> 0).
  float sigma(float depth_m) const { return sigma_m[bin(depth_m)]; }
  /// The largest noise at any depth.
  float max_sigma() const { return *std::max_element(sigma_m.begin(), sigma_m.end()); }
  /// True when some bin's noise is known (not 0).
  bool known() const { return max_sigma() > 0.0f; }
};

/// A scan's G-buffer. A pixel without a point has a zero position and a zero normal.
struct RangeMap {
  std::string name;      ///< for messages and output file names
  ScanCamera camera;     ///< how pixels map to directions from the scanner
  Pose T_world_scanner;  ///< scanner frame to world (the registration); the scanner sits at 0
  Image<Eigen::Vector3f> points;   ///< scanner frame (metres)
  Image<Eigen::Vector3f> normals;  ///< scanner frame, unit, facing the scanner (n . p < 0)
  ScanNoise noise;                 ///< measured by compute_scan_normals(), else unknown

  /// True when the pixel has a point (a non-zero, finite position).
  bool has_point(int x, int y) const {
    const Eigen::Vector3f& p = points(x, y);
    return p.allFinite() && !(p.x() == 0.0f && p.y() == 0.0f && p.z() == 0.0f);
  }
  /// Pixels with a point.
  long long count_points() const;
};

/// Makes `map` a pinhole range map of a metric depth image (metres along z, 0 = invalid) seen
/// with `intrinsics`: every valid pixel's camera-frame point, normals zero (see
/// compute_range_map_normals()). Throws input_error when the sizes differ.
void range_map_from_depth(const Image<float>& depth_m, const Intrinsics& intrinsics, RangeMap& map);

/// Rasterises a point cloud given in the scanner frame into `map` (whose camera must be set and
/// valid): each point goes to the pixel it projects to, and where several land in one pixel the
/// nearest one (smallest depth) stays, ties to the first. `normals` (same length, scanner frame)
/// may be empty: then the map's normals are zero. Points that are not finite, sit at the scanner
/// or fall outside the map are skipped; returns how many.
long long rasterize_points(const std::vector<Eigen::Vector3f>& points,
                           const std::vector<Eigen::Vector3f>& normals, RangeMap& map);

/// Normals of the pixels whose normal is zero, by principal component analysis of the points in the
/// (2 r + 1)^2 window around the pixel (the equirectangular map wraps in azimuth and across its
/// poles, onto_map(), and off its equator the window is ScanCamera::row_stretch() times wider, at
/// most the map's width, so that it spans as many metres along the row as along the column; it then
/// grows as a whole) whose depth lies within max_jump_ratio times the pixel's depth of its own (the
/// same surface, not the one across a depth discontinuity): the direction of least spread, oriented
/// toward the scanner (Hoppe et al. 1992). r is radius_px, or more where support_m > 0: the pixels
/// within support_m metres of the point (point_radius() at its depth; past kDenseNormalRadiusPx, 7
/// x 7 pixels spread over the window); then, while fewer than min_points points qualify, one pixel
/// more (the paper uses the 16 nearest points; a map rebuilt from a cloud has holes between them);
/// r stays within max(radius_px, kMaxNormalRadiusPx). No normal where fewer than three points
/// qualify or they lie on a line. Rows run in parallel; the result does not depend on the thread
/// count.
void compute_range_map_normals(RangeMap& map, float max_jump_ratio = 0.05f, int radius_px = 2,
                               float support_m = 0.0f, int min_points = 0);

/// The largest window radius of compute_range_map_normals() (a 17 x 17 window).
inline constexpr int kMaxNormalRadiusPx = 8;
/// The largest window radius of compute_scan_normals()'s fits over a noisy scan's wider support
/// (a 25 x 25 window, read at 7 x 7 pixels spread over it).
inline constexpr int kMaxNoiseNormalRadiusPx = 12;
/// compute_range_map_normals() reads every pixel of windows up to this radius (7 x 7) or radius_px;
/// a wider metric support is read at 7 x 7 pixels spread evenly over it.
inline constexpr int kDenseNormalRadiusPx = 3;

/// The normals `aoscan scans` gives a scan's points: compute_range_map_normals() over at least
/// kScanNormalSupportM around each point (a depth camera's noisy frames need more points than a
/// 5 x 5 window holds; a laser scan's coarser pixels keep 5 x 5 to 7 x 7) and at least
/// kScanNormalMinPoints points. Then, where the scan's own range noise is large, again over a
/// wider support: the spread of the points along those normals (the root of each fit's least
/// eigenvalue), its median in bins of depth, is the noise sigma(depth); the pixels at depths where
/// kNoiseSupportFactor * sigma exceeds kScanNormalSupportM are fitted over that many metres, in
/// windows of up to kMaxNoiseNormalRadiusPx (a Kinect-class camera's noise grows with the square
/// of the depth; a laser's few millimetres grow nothing); `map.noise` keeps sigma(depth). Where
/// such a wider window straddles a crease (its points spread along its normal by more than
/// kCreaseSpreadFactor sigma), the windows beside the pixel are fitted too and the one whose plane
/// fits the pixel and its points best is kept, so that a corner keeps its two faces instead of a
/// plane cutting across it. Returns, for those pixels, the signed distance (m) along the normal
/// from the point to the plane fitted through its support (0 elsewhere): the point moved by it onto
/// the plane is the surface without most of its noise (compute_scan_ssao() reads it). Returns an
/// empty image when no pixel's support grew; the normals are then those of the first fit.
Image<float> compute_scan_normals(RangeMap& map);
inline constexpr float kScanNormalSupportM = 0.02f;
inline constexpr int kScanNormalMinPoints = 16;
/// Neighbours farther in depth than this times the point's depth are on another surface.
inline constexpr float kScanNormalMaxJumpRatio = 0.05f;
/// The support compute_scan_normals() gives a noisy scan, in multiples of its noise sigma.
inline constexpr float kNoiseSupportFactor = 8.0f;
/// compute_scan_normals()'s wider fits: a window whose points spread along its normal by more
/// than this many noise sigmas straddles a crease, and the windows beside the pixel are tried.
inline constexpr float kCreaseSpreadFactor = 2.0f;

/// The radius of the surface patch one pixel of `camera` covers at `depth_m` (metres): the
/// footprint depth / pixels_per_metre_at_1m(). The rad(p) of Eq. 12's alpha = rad(p_i) / rad(p_ij)
/// for range maps, whose point spacing is set by the pixel grid (the paper estimates it from the
/// 32 nearest points of an unstructured cloud).
inline float point_radius(const ScanCamera& camera, float depth_m) {
  return depth_m / camera.pixels_per_metre_at_1m();
}

}  // namespace aoscan
