/// @file ssao.h
/// @brief Screen-space ambient obscurance on camera-frame point maps (Sabbadin et al. 2016 Sec. 4)
/// and the per-pixel view weights of the MVAO integration (Sabbadin et al. 2016 Eq. 10-11).
///
/// Sampling: every evaluated pixel p (camera frame, metres) gets a screen-space disk of radius
/// radius_px = fx * r_s / z (the sphere of radius r_s moved onto the optical axis at depth z,
/// paper's simplification); the heightfield estimator's disk has radius fx * t_max / z instead,
/// out to where rho reaches 1. The disk is sampled by a fixed pattern (SsaoPattern): for the point
/// estimators a Vogel spiral of N points, for the horizon estimator N / 8 slices of 4 steps per
/// side, for the heightfield estimator 2 slices of N / 4 steps per side; a 4x4 interleaved set of
/// 16 rotations picks the rotation of each pixel, and the whole pattern is rotated and radially
/// jittered by the frame index so that successive frames sample new directions (the MVAO grid
/// averages them). A sample is the vertex at the nearest pixel; samples outside the image, at
/// invalid pixels or on the centre pixel are not counted.
///
/// Estimators (v = p_i - p, d = |v|, c = n.v / d, rho = smoothstep(0, t_max, d), h = n.v - beta z
/// the sample's height above the tangent plane less the depth-scaled bias beta = ao.bias):
/// - paper:      AO = mean(rho * (1 - max(c, 0)))           (Eq. 3-5 as printed, no bias)
/// - obscurance: AO = 1 - mean(max(h / d, 0) * (1 - rho))
/// - alchemy:    AO = max(0, 1 - mean(r_s * max(h, 0) / ((d^2 + eps r_s^2) max(cos theta_q, c))))
///               (McGuire 2011; theta_q the angle between the sample's SSAO normal and its ray
///               to the camera, c = ao.area_min_cos: the surface area of the sample's pixel, so an
///               occluder seen at a grazing angle counts as much as one seen face-on; c = 1 off)
/// - horizon:    per slice, the highest horizon on each side (its cosine lowered toward the
///               tangent plane by rho, as XeGTAO's falloff), then the GTAO cosine-weighted arc
///               integral, summed over slices and divided by the same integral with nothing above
///               the tangent plane (which is 1 only averaged over all slice directions, not per
///               slice: without the division open surfaces off the view axis read as occluded).
/// - heightfield: Eq. 1 on each slice's height profile: the cosine-weighted arc (GTAO's
///               integral) between the tangent plane and the final horizon is split at each
///               sample that raises the horizon (samples in order of distance, lowered by beta z
///               along n); the arc a sample newly hides is blocked at its distance d and keeps
///               rho(d) of its visibility, the arc above the final horizon is open; divided by
///               the open integral as for horizon. Exact on a heightfield up to the sample
///               spacing; thin objects read as solid (halos).
/// - statvo:     statistical volumetric obscurance over a box of half size r_s in four adaptive
///               depth layers from summed-area tables (Hendrickx et al. 2015; statvo.h): no
///               samples, the same cost whatever ao.samples; its coverage is the share of the
///               box's pixels with a surface.
/// n is the pixel's SSAO normal: with ao.normal_radius_px > 0, the normalised sum of the raycast
/// normals within that many pixels whose vertices lie within ao.normal_max_distance_m of p (the
/// raycast's nearest-voxel TSDF gradients are noisy by a few degrees on a fused noisy surface, and
/// a tilted tangent plane raises or sinks every sample); it is also the normal of the w_n weight.
/// The whole normal map is smoothed so (smooth_model_normals()), and each sample's area factor
/// reads the sample pixel's SSAO normal.
/// Each pixel's coverage is the share of its samples counted (inside the image, on valid pixels);
/// with ao.coverage_power p > 0 its weight is (w_d w_n) coverage^p.
/// AO is in [0, 1] (1 = open). Invalid pixels (zero, NaN or inf vertex or normal, z <= 0) get AO 0
/// and weight 0; pixels without any counted sample get AO 1.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "ao/ao_config.h"
#include "ao/statvo.h"
#include "core/image.h"
#include "geometry/point_maps.h"

namespace aoscan {

/// Number of per-pixel rotations of the interleaved pattern (a 4x4 tile).
inline constexpr int kSsaoPatternTile = 4;
inline constexpr int kSsaoPatternClasses = kSsaoPatternTile * kSsaoPatternTile;

/// The sample offsets of one frame, in units of the disk radius, for each of the 16 pixel classes
/// (class = (x & 3) + 4 (y & 3)). Built once per frame by make_ssao_pattern(); plain data.
struct SsaoPattern {
  AoEstimator estimator = AoEstimator::kObscurance;
  int samples = 0;  ///< offsets per class
  /// Horizon estimator: slices per pixel and steps per slice side; samples = 2 slices steps,
  /// ordered slice-major, then side (+, -), then step.
  int slices = 0;
  int steps = 0;
  std::vector<Eigen::Vector2f> offsets;     ///< kSsaoPatternClasses * samples, unit disk
  std::vector<Eigen::Vector2f> slice_dirs;  ///< horizon: kSsaoPatternClasses * slices, unit
};

/// The deterministic sample pattern of frame `frame_index` for `config.samples` and
/// `config.estimator` (the horizon estimator rounds the sample count to a multiple of 8, at least
/// 8; the heightfield estimator to a multiple of 4, at least 4).
SsaoPattern make_ssao_pattern(const AoConfig& config, std::uint64_t frame_index);

/// Eq. 10-11 weight of a camera-frame point `p_camera` (metres) with unit normal `n_camera`:
/// w_d * w_n with w_d = max(1 - max(|p| - d_min, 0) / d_max, 0.1) (|p| = distance to the camera
/// centre, as printed) and w_n = max(n . l, 0), l = -p / |p| the direction to the camera.
inline float view_weight(const Eigen::Vector3f& p_camera, const Eigen::Vector3f& n_camera,
                         float d_min_m, float d_max_m) {
  const float dist = p_camera.norm();
  if (!(dist > 0.0f) || !std::isfinite(dist)) return 0.0f;
  const float w_d = std::max(1.0f - std::max(dist - d_min_m, 0.0f) / d_max_m, 0.1f);
  const float w_n = std::max(-n_camera.dot(p_camera) / dist, 0.0f);
  const float w = w_d * w_n;
  return std::isfinite(w) ? w : 0.0f;
}

/// True when a point-map pixel can be used: finite vertex with z > 0 and a finite, non-zero normal.
bool ssao_pixel_valid(const Eigen::Vector3f& vertex, const Eigen::Vector3f& normal);

/// SSAO of `maps` (camera frame) for frame `frame_index`: fills `ao` (in [0, 1], 1 = open) and
/// `weight` (Eq. 10-11 times the coverage weight, 0 where invalid or not evaluated) at the maps'
/// resolution, reusing their buffers. With config.ssao_stride_px = 2, one pixel per 2x2 block is
/// evaluated (the first valid one in an order that rotates with the frame) and its AO is copied to
/// the block's other valid pixels with weight 0. Rows run in parallel through TBB; the result is
/// bit-identical for any thread count. It matches the plain serial test oracle
/// compute_ssao_reference() (tests/support), written directly from the formulas, within 1e-5.
void compute_ssao(const PointMaps& maps, const AoConfig& config, std::uint64_t frame_index,
                  Image<float>& ao, Image<float>& weight);

/// Reusable buffers of compute_ssao(): the maps with smoothed normals (config.normal_radius_px >
/// 0) and the smoothing's scratch. A caller that runs SSAO every frame keeps one, so the frame
/// allocates nothing; one workspace serves one call at a time.
struct SsaoWorkspace {
  PointMaps smoothed;
  std::vector<float> smoothing_planes;  ///< scratch of smooth_model_normals()
  StatVoTables statvo;                  ///< statvo estimator: the frame's layered tables
};

/// compute_ssao() with the caller's buffers (the overload above makes its own each call).
void compute_ssao(const PointMaps& maps, const AoConfig& config, std::uint64_t frame_index,
                  Image<float>& ao, Image<float>& weight, SsaoWorkspace& workspace);

}  // namespace aoscan
