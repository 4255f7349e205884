/// @file mvao_quality.h
/// @brief Quality of the multi-scan MVAO (Sabbadin et al. 2016 Sec. 5) on synthetic scan sets:
/// the per-scan SSAO and the MVAO against the ray-traced Eq. 1 reference at the surface points the
/// scans measured (measured_surface()), and the smoothness of the MVAO across coverage borders
/// with and without the border weight w_b.
/// Shared by tests/ao/mvao_quality_test.cpp (small sets with assertions) and the
/// aoscan-mvao-quality benchmark (the table of BENCHMARKS.md); free of GoogleTest.
///
/// A set is rendered by the simulator with the scanners on aoscan-scanset's sunflower spiral
/// (sim/scan_placement.h), then every scan goes through what `aoscan scans` does to it
/// (src/pipeline/scan_set.cpp): a depth camera's frame as 16-bit depth through the preprocessing
/// (range clip, border outliers) into a pinhole range map; a laser scan as its equirectangular
/// range map, or as a point cloud rasterised into the 2h x h map of Sec. 7; normals from the
/// points (compute_scan_normals, as `aoscan scans`), the SSAO with the default AoConfig and a
/// sample pattern keyed by the scan's name, the border distance (min_edge_ratio 0.01); then
/// integrate_scans with d_min = ao.d_min_m, d_max = the largest depth of the set's points and t_p =
/// 64 px.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "ao/ao_config.h"
#include "ao/multiscan.h"
#include "core/image.h"
#include "sim/synth_scene.h"

namespace aoscan::test {

/// How a set's scans are taken.
enum class QualityCamera {
  kEquirect,  ///< 360-degree laser scans, the scanner's own 2h x h grid
  kPinhole,   ///< depth cameras looking at the scene's centre (640 x 480, fx = fy = 525)
  /// laser scans handed over as point clouds without normals (a PLY or PTX file): the points of
  /// the 2h x h scan rasterised into ScanCamera::equirectangular_for_points(v), v points
  kCloud,
};

/// Range noise of a set's scans.
enum class QualityNoise {
  kLaser,   ///< Gaussian along the ray, sigma QualitySet::laser_sigma_m (a time-of-flight laser)
  kKinect,  ///< the simulator's Kinect v1 model (pinhole only): axial sigma 1.2 mm + 1.9 mm
            ///< (z - 0.4)^2, lateral jitter, disparity quantisation, dropouts, range 0.4-4.5 m
};

/// One synthetic scan set.
struct QualitySet {
  std::string scene = "corner";  ///< AnalyticScene::names(): corner, room (plane has no AO)
  QualityCamera camera = QualityCamera::kEquirect;
  int scans = 3;
  QualityNoise noise = QualityNoise::kLaser;
  double laser_sigma_m = 0.002;
  int equirect_height = 400;  ///< laser scans: 2h x h, h = this
  int pinhole_width = 640, pinhole_height = 480;
  std::uint64_t seed = 1;  ///< noise key of the set (each scan's: spiral_scan_seed(seed, k))

  /// "corner equirect 3 laser", "room pinhole 5 kinect", "room cloud 3 laser", ...
  std::string label() const;
};

/// The scene surface point a scan point measured, where the reference is taken.
enum class QualityReference {
  /// The surface the scanner's ray through the point hits first: the sample's own surface point.
  /// Every noise model here moves a point along its ray (the Kinect model also takes the range
  /// of a ray jittered by 0.5 px sigma), so the pixel's ray still meets the surface the point
  /// stands for, however large the noise.
  kRayHit,
  /// The scene surface point nearest to the point: where the noise moved the point to. Near a
  /// crease or at a grazing angle this is another surface point than the measured one, farther
  /// from it the larger the noise, so even the exact AO of the measured points falls short of
  /// r = 1 against it (BENCHMARKS.md).
  kNearest,
};

/// How a set is measured.
struct QualityOptions {
  AoConfig ao;           ///< the SSAO configuration (aoscan scans's ao.* keys)
  float t_p_px = 64.0f;  ///< Eq. 12's t_p
  int strata = 8;        ///< reference_obscurance(): strata per axis (64 rays a point)
  /// Evaluated points: pixel (x, y) of a scan with a point when y % step == 0 and
  /// x % step == (y / step) % step (every step^2-th pixel, staggered), whose surface point
  /// (measured_surface()) lies within 5 cm.
  int eval_step = 3;
  /// A diagnostic, not what `aoscan scans` does: every point takes the exact normal of its surface
  /// point (measured_surface()) instead of the normal estimated from the points.
  bool exact_normals = false;
  /// Which surface point stands for a scan point, for the reference and for exact_normals.
  QualityReference reference = QualityReference::kRayHit;
};

/// The surface point that pixel (x, y) of `map` (which has a point) stands for, in the world
/// frame: the first hit of the scanner's ray through the point, its normal facing the scanner,
/// or the surface point nearest to the point, its normal the outward one (see QualityReference);
/// nullopt when it lies more than 5 cm from the point.
std::optional<SurfacePoint> measured_surface(const AnalyticScene& scene, const RangeMap& map, int x,
                                             int y, QualityReference reference);

/// The scans of a set after the first stage, ready for integrate_scans().
struct PreparedSet {
  std::vector<ScanAo> scans;
  float d_max_m = 0.0f;  ///< the largest depth of the scans' points
};

/// Renders `set` and runs the first stage of `aoscan scans` on every scan (see the file comment).
PreparedSet prepare_quality_set(const QualitySet& set, const QualityOptions& options);

/// The integration parameters of `aoscan scans` for `prepared` (w_b on, 1 x 1).
MultiScanParams quality_params(const PreparedSet& prepared, const QualityOptions& options);

/// The coverage of every pixel of every scan: 0 without a point, else 1 + the number of other
/// scans j whose L_2 (Eq. 7) holds the point, i.e. that measured it: the test of
/// MvaoAccumulator::add (the point taken into scan j's frame lands on a pixel with a point within
/// 2t of it whose normal faces scanner i), for the pairs integrate_scans() tests (world boxes
/// grown by params.pair_margin_m meet). Counts stop at 255.
std::vector<Image<std::uint8_t>> coverage_counts(const std::vector<ScanAo>& scans,
                                                 const MultiScanParams& params);

/// What measure_mvao_quality() found on one set.
struct QualityRow {
  std::string set;
  int scans = 0;
  int map_width = 0, map_height = 0;  ///< of the first scan
  long long points = 0;               ///< points of all scans
  long long evaluated = 0;            ///< points compared with the reference
  /// Points measured by at least two scans (coverage >= 2), and integrate_scans()'s points_shared
  /// at 1 x 1 without w_b (every L_2 member then weighs > 0: the two agree).
  long long covered_twice = 0, shared_without_wb = 0;
  double ssao_r = 0.0;        ///< per-scan SSAO against the reference
  double mvao_r = 0.0;        ///< MVAO, w_b, 1 x 1 (`aoscan scans` defaults)
  double mvao_3x3_r = 0.0;    ///< MVAO, w_b, 3 x 3
  double mvao_no_wb_r = 0.0;  ///< MVAO without w_b (w_b = 1), 1 x 1
  /// Where the integration has something to average: the evaluated points measured by at least
  /// two scans (coverage >= 2), the r and the mean |AO - reference| over those alone of the SSAO
  /// and of the MVAO (w_b, 1 x 1); and the same over the points that only their own scan measured
  /// (coverage 1), where the MVAO at 1 x 1 is the point's own SSAO.
  long long evaluated_covered = 0;
  double ssao_covered_r = 0.0, mvao_covered_r = 0.0;
  double ssao_covered_mae = 0.0, mvao_covered_mae = 0.0;
  double single_r = 0.0, single_mae = 0.0;
  /// Coverage borders: pairs (a, b) of 4-neighbouring pixels of one scan, a an evaluated point and
  /// b its right (equirectangular: wrapping) or lower neighbour, both with a point on the same
  /// surface (depths within 5 % of a's) and a surface point (measured_surface()), whose coverage
  /// counts differ. Over these pairs: the mean |AO_a - AO_b| of the reference, of the MVAO with w_b
  /// and without (1 x 1). The MVAO's step beyond the reference's is roughness of the integration.
  /// The step error, mean |(MVAO_a - MVAO_b) - (ref_a - ref_b)|, counts both a step that the
  /// reference does not have and one that the MVAO smooths away.
  long long border_pairs = 0;
  double ref_step = 0.0, wb_step = 0.0, no_wb_step = 0.0;
  double wb_step_error = 0.0, no_wb_step_error = 0.0;

  /// The target: MVAO r >= 0.90 and >= SSAO r + 0.05.
  bool meets_r_target() const { return mvao_r >= 0.90 && mvao_r >= ssao_r + 0.05; }
  /// w_b smooths the coverage borders (a smaller step error) without lowering r.
  bool wb_smoother() const { return wb_step_error < no_wb_step_error && mvao_r >= mvao_no_wb_r; }
};

/// Prepares `set`, integrates it three ways (w_b 1 x 1, w_b 3 x 3, without w_b 1 x 1) and
/// measures each against the reference.
QualityRow measure_mvao_quality(const QualitySet& set, const QualityOptions& options);

}  // namespace aoscan::test
