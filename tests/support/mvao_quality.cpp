/// @file mvao_quality.cpp
/// @brief Quality of the multi-scan MVAO on synthetic scan sets (see mvao_quality.h).
#include "support/mvao_quality.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include <Eigen/Geometry>

#include "ao/jump_flood.h"
#include "ao/scan_ssao.h"
#include "core/depth_frame.h"
#include "core/status.h"
#include "fusion/preprocess/preprocess.h"
#include "geometry/range_map.h"
#include "sim/reference_ao.h"
#include "sim/scan_placement.h"
#include "sim/synth_camera.h"
#include "sim/synth_scanner.h"
#include "sim/synth_scene.h"

namespace aoscan::test {
namespace {

/// border_distance(): a Laplacian edge must exceed this share of the pixel's depth (scan_set.cpp).
constexpr float kMinEdgeRatio = 0.01f;
/// Depth frames: raw units per metre (aoscan-scanset's depth PNGs and the synthetic camera's).
/// Evaluated points: their surface point (measured_surface()) must lie within this (m).
constexpr double kSurfaceMatchM = 0.05;
/// Reference rays start this far off the surface (m).
constexpr double kReferenceOffsetM = 1e-4;
/// Border pairs: b's depth within this share of a's (the same surface).
constexpr float kSameSurfaceRatio = 0.05f;

/// The SSAO sample pattern of a scan: FNV-1a of its name, as `aoscan scans` keys it.
std::uint64_t pattern_index(const std::string& name) {
  std::uint64_t h = 14695981039346656037ull;
  for (const unsigned char c : name) h = (h ^ c) * 1099511628211ull;
  return h;
}

const char* camera_name(QualityCamera c) {
  switch (c) {
    case QualityCamera::kEquirect:
      return "equirect";
    case QualityCamera::kPinhole:
      return "pinhole";
    case QualityCamera::kCloud:
      return "cloud";
  }
  return "?";
}

/// A depth camera's scan as `aoscan scans` reads a depth image: raw 16-bit depth, preprocessed
/// with the default configuration, into a pinhole range map (normals zero).
void depth_camera_scan(const AnalyticScene& scene, const QualitySet& set, const Pose& pose,
                       std::uint64_t seed, RangeMap& map) {
  DepthFrame frame;
  frame.intrinsics = synth_intrinsics(set.pinhole_width, set.pinhole_height);
  frame.depth_scale = kSynthDepthScale;
  if (set.noise == QualityNoise::kKinect) {
    SynthRenderOptions o;
    o.noise = SynthNoise::kKinect;
    o.seed = seed;
    o.depth_scale = kSynthDepthScale;
    render_synth_depth(scene, frame.intrinsics, pose, o, frame.depth);
  } else {  // the laser model, written as aoscan-scanset writes a depth PNG
    RangeMap exact;
    exact.name = map.name;
    ScannerNoise noise;
    noise.sigma_m = set.laser_sigma_m;
    noise.seed = seed;
    render_scan(scene, ScanCamera::make_pinhole(frame.intrinsics), pose, kDepthScanMinRangeM,
                kDepthScanMaxRangeM, noise, exact);
    frame.depth.resize(frame.intrinsics.width, frame.intrinsics.height, 0);
    for (int y = 0; y < frame.intrinsics.height; ++y)
      for (int x = 0; x < frame.intrinsics.width; ++x) {
        const double raw =
            exact.has_point(x, y) ? std::round(exact.points(x, y).z() * kSynthDepthScale) : 0.0;
        frame.depth(x, y) = raw >= 1.0 && raw <= 65535.0 ? static_cast<std::uint16_t>(raw) : 0;
      }
  }
  Image<float> depth_m;
  preprocess_depth(frame, PreprocessConfig{}, depth_m);
  range_map_from_depth(depth_m, frame.intrinsics, map);
  map.T_world_scanner = pose;
}

/// A laser scan: its own equirectangular map, or its points rasterised into the map of Sec. 7.
void laser_scan(const AnalyticScene& scene, const QualitySet& set, const Pose& pose,
                std::uint64_t seed, RangeMap& map) {
  ScannerNoise noise;
  noise.sigma_m = set.laser_sigma_m;
  noise.seed = seed;
  render_scan(scene, ScanCamera::make_equirectangular(set.equirect_height), pose,
              kLaserScanMinRangeM, kLaserScanMaxRangeM, noise, map);
  if (set.camera == QualityCamera::kCloud) {
    std::vector<Eigen::Vector3f> points;
    for (int y = 0; y < map.camera.height; ++y)
      for (int x = 0; x < map.camera.width; ++x)
        if (map.has_point(x, y)) points.push_back(map.points(x, y));
    map.camera = ScanCamera::equirectangular_for_points(static_cast<long long>(points.size()));
    rasterize_points(points, {}, map);
  }
  map.normals.fill(Eigen::Vector3f::Zero());  // a laser scan has none: estimated from the points
}

/// Every point's normal: the scene's at its surface point (measured_surface()), in the scanner
/// frame, facing the scanner; zero where there is none.
void set_exact_normals(const AnalyticScene& scene, QualityReference reference, RangeMap& map) {
  const Eigen::Matrix3d R_scanner_world = map.T_world_scanner.rotation().transpose();
  tbb::parallel_for(
      tbb::blocked_range<int>(0, map.camera.height), [&](const tbb::blocked_range<int>& rows) {
        for (int y = rows.begin(); y < rows.end(); ++y)
          for (int x = 0; x < map.camera.width; ++x) {
            map.normals(x, y).setZero();
            if (!map.has_point(x, y)) continue;
            const std::optional<SurfacePoint> s = measured_surface(scene, map, x, y, reference);
            if (!s) continue;
            Eigen::Vector3f n = (R_scanner_world * s->normal).cast<float>();
            if (n.dot(map.points(x, y)) > 0.0f) n = -n;
            map.normals(x, y) = n;
          }
      });
}

RayCaster scene_caster(const AnalyticScene& scene) {
  return [&scene](const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                  double t_max) -> std::optional<double> {
    Hit hit;
    if (!scene.intersect(Ray{o, d}, 0.0, t_max, &hit)) return std::nullopt;
    return hit.t;
  };
}

/// The reference obscurance at pixel (x, y)'s surface point (measured_surface()); nullopt when
/// it has none.
std::optional<double> reference_at(const AnalyticScene& scene, const RayCaster& cast,
                                   const RangeMap& map, int x, int y,
                                   const QualityOptions& options) {
  const std::optional<SurfacePoint> s = measured_surface(scene, map, x, y, options.reference);
  if (!s) return std::nullopt;
  return reference_obscurance(cast, s->p, s->normal, options.ao.t_max_m, options.strata,
                              kReferenceOffsetM);
}

/// Mean |a - b| of two equally long series (0 when empty).
double mean_abs_difference(const std::vector<double>& a, const std::vector<double>& b) {
  const std::size_t n = std::min(a.size(), b.size());
  double sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) sum += std::abs(a[i] - b[i]);
  return n > 0 ? sum / static_cast<double>(n) : 0.0;
}

/// One evaluated point and its border pairs.
struct Sample {
  int scan = 0, x = 0, y = 0;
  int coverage = 0;  ///< coverage_counts() at (x, y)
  double ref = 0.0;
  int partners = 0;  ///< border pairs anchored here (0-2)
  int bx[2] = {0, 0}, by[2] = {0, 0};
  double bref[2] = {0.0, 0.0};
};

}  // namespace

std::optional<SurfacePoint> measured_surface(const AnalyticScene& scene, const RangeMap& map, int x,
                                             int y, QualityReference reference) {
  const Eigen::Vector3d p = map.T_world_scanner * map.points(x, y).cast<double>();
  const Eigen::Vector3d o = map.T_world_scanner.translation();
  std::optional<SurfacePoint> s;
  if (reference == QualityReference::kNearest) {
    s = scene.nearest_surface_point(p, kSurfaceMatchM);
  } else {
    const double range = (p - o).norm();
    if (!(range > 0.0)) return std::nullopt;
    const Eigen::Vector3d d = (p - o) / range;
    Hit hit;
    if (scene.intersect(Ray{o, d}, 0.0, range + kSurfaceMatchM, &hit) &&
        hit.t >= range - kSurfaceMatchM)
      s = SurfacePoint{o + hit.t * d, hit.normal.dot(d) > 0.0 ? -hit.normal : hit.normal,
                       hit.primitive};
  }
  return s;
}

std::string QualitySet::label() const {
  return scene + " " + camera_name(camera) + " " + std::to_string(scans) + " " +
         (noise == QualityNoise::kKinect ? "kinect" : "laser");
}

PreparedSet prepare_quality_set(const QualitySet& set, const QualityOptions& options) {
  if (set.noise == QualityNoise::kKinect && set.camera != QualityCamera::kPinhole)
    throw usage_error(set.label() + ": the Kinect noise model is for pinhole sets");
  const AnalyticScene scene = AnalyticScene::make(set.scene);
  const ScannerPlacement place = scanner_placement(set.scene);
  const bool pinhole = set.camera == QualityCamera::kPinhole;
  PreparedSet prepared;
  prepared.scans.resize(static_cast<std::size_t>(set.scans));
  for (int k = 0; k < set.scans; ++k) {
    ScanAo& scan = prepared.scans[static_cast<std::size_t>(k)];
    RangeMap& map = scan.map;
    map.name = spiral_scan_name(k, set.scans);
    const Pose pose = spiral_scanner_pose(place, k, set.scans, pinhole);
    const std::uint64_t seed = spiral_scan_seed(set.seed, k);
    if (pinhole)
      depth_camera_scan(scene, set, pose, seed, map);
    else
      laser_scan(scene, set, pose, seed, map);
    if (map.count_points() == 0) throw input_error(set.label() + ": " + map.name + " is empty");
    if (options.exact_normals) set_exact_normals(scene, options.reference, map);
    const Image<float> plane_offset_m = compute_scan_normals(map);
    compute_scan_ssao(map, options.ao, pattern_index(map.name), scan.ssao, plane_offset_m);
    border_distance(map, kMinEdgeRatio, scan.border_px);
    for (int y = 0; y < map.camera.height; ++y)
      for (int x = 0; x < map.camera.width; ++x)
        if (map.has_point(x, y))
          prepared.d_max_m = std::max(prepared.d_max_m, map.camera.depth(map.points(x, y)));
  }
  return prepared;
}

MultiScanParams quality_params(const PreparedSet& prepared, const QualityOptions& options) {
  MultiScanParams params;
  params.d_min_m = static_cast<float>(options.ao.d_min_m);
  params.d_max_m = std::max(prepared.d_max_m, params.d_min_m + 1e-3f);
  params.t_p_px = options.t_p_px;
  return params;
}

std::vector<Image<std::uint8_t>> coverage_counts(const std::vector<ScanAo>& scans,
                                                 const MultiScanParams& params) {
  const std::size_t n = scans.size();
  std::vector<Eigen::AlignedBox3f> boxes(n);
  for (std::size_t i = 0; i < n; ++i) boxes[i] = scan_world_box(scans[i].map);
  std::vector<Image<std::uint8_t>> counts(n);
  for (std::size_t i = 0; i < n; ++i) {
    const RangeMap& map_i = scans[i].map;
    Image<std::uint8_t>& count = counts[i];
    count.resize(map_i.camera.width, map_i.camera.height, 0);
    for (int y = 0; y < map_i.camera.height; ++y)
      for (int x = 0; x < map_i.camera.width; ++x) count(x, y) = map_i.has_point(x, y) ? 1 : 0;
    for (std::size_t j = 0; j < n; ++j) {
      if (j == i || !scan_boxes_meet(boxes[i], boxes[j], params.pair_margin_m)) continue;
      const RangeMap& map_j = scans[j].map;
      // The transform of MvaoAccumulator::add, so that the same points pass.
      const Pose T_j_i = map_j.T_world_scanner.inverse() * map_i.T_world_scanner;
      const Eigen::Matrix3f R = T_j_i.rotation().cast<float>();
      const Eigen::Vector3f t = T_j_i.translation().cast<float>();
      tbb::parallel_for(tbb::blocked_range<int>(0, map_i.camera.height),
                        [&](const tbb::blocked_range<int>& rows) {
                          for (int y = rows.begin(); y < rows.end(); ++y)
                            for (int x = 0; x < map_i.camera.width; ++x) {
                              if (!map_i.has_point(x, y)) continue;
                              const Eigen::Vector3f& p = map_i.points(x, y);
                              const Eigen::Vector3f q = R * p + t;
                              const float depth = map_i.camera.depth(p);
                              const float rad_i = point_radius(map_i.camera, depth);
                              int px = 0, py = 0;
                              if (!corresponding_pixel(map_j, q, rad_i, map_i.noise, depth, t, px,
                                                       py))
                                continue;
                              if (count(x, y) < 255) ++count(x, y);
                            }
                        });
    }
  }
  return counts;
}

QualityRow measure_mvao_quality(const QualitySet& set, const QualityOptions& options) {
  if (options.eval_step < 1) throw usage_error("the evaluation step must be at least 1");
  const PreparedSet prepared = prepare_quality_set(set, options);
  const std::vector<ScanAo>& scans = prepared.scans;
  MultiScanParams params = quality_params(prepared, options);
  QualityRow row;
  row.set = set.label();
  row.scans = set.scans;
  row.map_width = scans.front().map.camera.width;
  row.map_height = scans.front().map.camera.height;

  const std::vector<Image<std::uint8_t>> counts = coverage_counts(scans, params);
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const RangeMap& map = scans[i].map;
    for (int y = 0; y < map.camera.height; ++y)
      for (int x = 0; x < map.camera.width; ++x) {
        row.points += counts[i](x, y) > 0;
        row.covered_twice += counts[i](x, y) >= 2;
      }
  }

  // The evaluated points, their border partners and the reference at both.
  const int step = options.eval_step;
  std::vector<Sample> samples;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const RangeMap& map = scans[i].map;
    for (int y = 0; y < map.camera.height; y += step)
      for (int x = (y / step) % step; x < map.camera.width; x += step) {
        if (!map.has_point(x, y)) continue;
        Sample s;
        s.scan = static_cast<int>(i);
        s.x = x;
        s.y = y;
        s.coverage = counts[i](x, y);
        const bool wrap = map.camera.projection == ScanProjection::kEquirectangular;
        const float depth = map.camera.depth(map.points(x, y));
        const int nx[2] = {wrap ? (x + 1) % map.camera.width : x + 1, x};
        const int ny[2] = {y, y + 1};
        for (int k = 0; k < 2; ++k) {
          if (nx[k] >= map.camera.width || ny[k] >= map.camera.height) continue;
          if (!map.has_point(nx[k], ny[k])) continue;
          if (counts[i](nx[k], ny[k]) == counts[i](x, y)) continue;
          const float d = map.camera.depth(map.points(nx[k], ny[k]));
          if (!(std::abs(d - depth) <= kSameSurfaceRatio * depth)) continue;
          s.bx[s.partners] = nx[k];
          s.by[s.partners] = ny[k];
          ++s.partners;
        }
        samples.push_back(s);
      }
  }
  const AnalyticScene scene = AnalyticScene::make(set.scene);
  const RayCaster cast = scene_caster(scene);
  std::vector<std::uint8_t> valid(samples.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, samples.size(), 64),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t k = r.begin(); k < r.end(); ++k) {
                        Sample& s = samples[k];
                        const RangeMap& map = scans[static_cast<std::size_t>(s.scan)].map;
                        const std::optional<double> ref =
                            reference_at(scene, cast, map, s.x, s.y, options);
                        if (!ref) continue;
                        valid[k] = 1;
                        s.ref = *ref;
                        int kept = 0;
                        for (int b = 0; b < s.partners; ++b) {
                          const std::optional<double> bref =
                              reference_at(scene, cast, map, s.bx[b], s.by[b], options);
                          if (!bref) continue;
                          s.bx[kept] = s.bx[b];
                          s.by[kept] = s.by[b];
                          s.bref[kept] = *bref;
                          ++kept;
                        }
                        s.partners = kept;
                      }
                    });
  std::vector<Sample> kept;
  for (std::size_t k = 0; k < samples.size(); ++k)
    if (valid[k]) kept.push_back(samples[k]);
  samples.swap(kept);
  row.evaluated = static_cast<long long>(samples.size());

  std::vector<double> ref, ao, covered_ref, covered_ao, single_ref, single_ao;
  for (const Sample& s : samples) {
    ref.push_back(s.ref);
    ao.push_back(scans[static_cast<std::size_t>(s.scan)].ssao(s.x, s.y));
    (s.coverage >= 2 ? covered_ref : single_ref).push_back(s.ref);
    (s.coverage >= 2 ? covered_ao : single_ao).push_back(ao.back());
    row.border_pairs += s.partners;
    for (int b = 0; b < s.partners; ++b) row.ref_step += std::abs(s.ref - s.bref[b]);
  }
  row.ssao_r = pearson_r(ao, ref);
  row.evaluated_covered = static_cast<long long>(covered_ref.size());
  row.ssao_covered_r = pearson_r(covered_ao, covered_ref);
  row.ssao_covered_mae = mean_abs_difference(covered_ao, covered_ref);
  row.single_r = pearson_r(single_ao, single_ref);
  row.single_mae = mean_abs_difference(single_ao, single_ref);
  if (row.border_pairs > 0) row.ref_step /= static_cast<double>(row.border_pairs);

  // r of one integration, and its mean step over the border pairs.
  std::vector<Image<float>> mvao;
  auto score = [&](double& r, double* border_step, double* step_error) {
    ao.clear();
    double sum = 0.0, error = 0.0;
    for (const Sample& s : samples) {
      const Image<float>& m = mvao[static_cast<std::size_t>(s.scan)];
      ao.push_back(m(s.x, s.y));
      for (int b = 0; b < s.partners; ++b) {
        const double step = static_cast<double>(m(s.x, s.y)) - m(s.bx[b], s.by[b]);
        sum += std::abs(step);
        error += std::abs(step - (s.ref - s.bref[b]));
      }
    }
    r = pearson_r(ao, ref);
    if (border_step && row.border_pairs > 0) {
      *border_step = sum / static_cast<double>(row.border_pairs);
      *step_error = error / static_cast<double>(row.border_pairs);
    }
  };
  integrate_scans(scans, params, mvao);
  score(row.mvao_r, &row.wb_step, &row.wb_step_error);
  covered_ao.clear();
  for (const Sample& s : samples)
    if (s.coverage >= 2) covered_ao.push_back(mvao[static_cast<std::size_t>(s.scan)](s.x, s.y));
  row.mvao_covered_r = pearson_r(covered_ao, covered_ref);
  row.mvao_covered_mae = mean_abs_difference(covered_ao, covered_ref);
  params.neighbourhood = 3;
  integrate_scans(scans, params, mvao);
  score(row.mvao_3x3_r, nullptr, nullptr);
  params.neighbourhood = 1;
  params.border_weight = false;
  row.shared_without_wb = integrate_scans(scans, params, mvao).points_shared;
  score(row.mvao_no_wb_r, &row.no_wb_step, &row.no_wb_step_error);
  return row;
}

}  // namespace aoscan::test
