/// @file ssao_kernels.h
/// @brief Internal to SSAO: the constants and per-sample pieces that the real-time estimators
/// (ssao.cpp), the per-scan SSAO of range maps (scan_ssao.cpp) and the plain reference of the tests
/// (tests/support) share. Not for other code.
#pragma once

#include <algorithm>
#include <cmath>

#include <Eigen/Core>

#include "ao/ssao.h"

namespace aoscan {
namespace detail {

inline constexpr float kHalfPiF = 1.57079632679490f;
/// Largest disk radius in pixels (points nearer than ~0.25 m would otherwise sample whole images).
inline constexpr float kMaxRadiusPx = 160.0f;
/// Alchemy: epsilon of the 1 / (d^2 + eps r_s^2) term, relative to r_s^2.
inline constexpr float kAlchemyEpsilon = 0.01f;
/// Order in which the pixels of a 2x2 block are tried at stride 2 (rotating with the frame).
inline constexpr int kBlockOrder[4][2] = {{0, 0}, {1, 1}, {1, 0}, {0, 1}};

/// rho of Eq. 4: smoothstep(0, t_max, d).
inline float smoothstep01(float d, float t_max) {
  const float u = std::min(std::max(d / t_max, 0.0f), 1.0f);
  return u * u * (3.0f - 2.0f * u);
}

/// std::lround(v) for a finite float, without the library call (the scan SSAO rounds two offsets
/// a sample): v + 0.5 away from zero is exact in double for every float of magnitude 0.5 or
/// more, and below 1 in magnitude for the smaller ones, so truncating it rounds halves away from
/// zero as lround does.
inline long round_half_away(float v) {
  const double d = static_cast<double>(v);
  return static_cast<long>(d + std::copysign(0.5, d));
}

/// The class of pixel (x, y) in the 4x4 tile of pattern rotations.
inline int pattern_class(int x, int y) {
  return (x & 3) + kSsaoPatternTile * (y & 3);
}

/// Alchemy's area factor of a sample at camera-frame vertex q with raycast normal n_q:
/// 1 / max(cos theta_q, min_cos), cos theta_q = n_q . (-q / |q|). A zero or non-finite normal
/// gives min_cos (std::max keeps its first argument against NaN).
inline float area_factor(const Eigen::Vector3f& q, const Eigen::Vector3f& n_q, float min_cos) {
  return 1.0f / std::max(min_cos, -n_q.dot(q) / q.norm());
}

/// statvo (statvo.h): the box half size in pixels of a point at depth z,
/// round(min(f * r_s / z, kMaxRadiusPx)).
inline int statvo_half_px(float f, float radius_m, float z) {
  return static_cast<int>(std::min(f * radius_m / z, kMaxRadiusPx) + 0.5f);
}

/// statvo: a pixel goes to the far half of its layer when it lies at least this far (m) behind the
/// layer's mean depth in its box.
inline constexpr double kStatVoTieM = 1e-7;

/// statvo: psi, the obscurance of a layer whose mean lies u box heights above the tangent plane;
/// `falloff_end` = 1 + t_max / r_s.
inline float statvo_psi(float u, float falloff_end) {
  if (!(u > 0.0f)) return 0.0f;
  if (u <= 1.0f) return u;
  return std::max(0.0f, (falloff_end - u) / (falloff_end - 1.0f));
}

/// One pixel's SSAO and the share of its samples that were counted (inside the image, on valid
/// pixels).
struct PixelAo {
  float ao;
  float coverage;
  /// Vardis et al.'s distance weight 1 - mean(min(|q - p|, r_s)) / r_s over the samples taken
  /// (a sample not counted is r_s away); 1 unless ao.view_weight = vardis.
  float distance_weight = 1.0f;
};

/// Everything a per-pixel evaluation needs, fixed for the frame.
struct FrameSetup {
  const PointMaps* maps;
  const SsaoPattern* pattern;
  float fx, fy, radius_m, t_max_m, d_min_m, d_max_m, bias, coverage_power;
  float area_min_cos;
  const StatVoTables* statvo = nullptr;  ///< the frame's layered tables (statvo estimator)
  bool vardis = false;                   ///< ao.view_weight = vardis
  float vardis_b = 1.0f;
  int importance_samples = 0;  ///< ao.importance_samples
};

/// The frame's constants for `maps` and `pattern`.
inline FrameSetup make_setup(const PointMaps& maps, const SsaoPattern& pattern,
                             const AoConfig& config) {
  return FrameSetup{&maps,
                    &pattern,
                    static_cast<float>(maps.intrinsics.fx),
                    static_cast<float>(maps.intrinsics.fy),
                    static_cast<float>(config.radius_m),
                    static_cast<float>(config.t_max_m),
                    static_cast<float>(config.d_min_m),
                    static_cast<float>(config.d_max_m),
                    static_cast<float>(config.bias),
                    static_cast<float>(config.coverage_power),
                    static_cast<float>(config.area_min_cos),
                    nullptr,
                    config.view_weight == AoViewWeight::kVardis,
                    static_cast<float>(config.vardis_b),
                    config.importance_samples};
}

/// The weight of an evaluated pixel at p with SSAO normal n and result r: the paper's w_d * w_n
/// (view_weight()) or Vardis et al.'s b * r.distance_weight + (1 - b) * w_n, times the coverage
/// weight coverage^coverage_power.
inline float pixel_weight(const FrameSetup& s, const Eigen::Vector3f& p, const Eigen::Vector3f& n,
                          const PixelAo& r) {
  float w;
  if (s.vardis) {
    const float dist = p.norm();
    const float w_n = dist > 0.0f ? std::max(-n.dot(p) / dist, 0.0f) : 0.0f;
    w = s.vardis_b * r.distance_weight + (1.0f - s.vardis_b) * w_n;
    if (!std::isfinite(w)) w = 0.0f;
  } else {
    w = view_weight(p, n, s.d_min_m, s.d_max_m);
  }
  if (!(s.coverage_power > 0.0f)) return w;
  return w * std::pow(std::min(std::max(r.coverage, 0.0f), 1.0f), s.coverage_power);
}

/// Importance sampling (Vardis et al. 2013 Eq. 6): how many more samples a pixel takes after the
/// first ones gave it AO `ao` (obscurance 1 - ao) and weight `weight` (clamped to [0, 1]), of
/// `remaining` left: round(remaining * weight * (1 + (1 - ao)) / 2).
inline int importance_extra_samples(int remaining, float weight, float ao) {
  const float share = std::min(std::max(weight, 0.0f), 1.0f) * (1.0f + (1.0f - ao)) * 0.5f;
  return std::min(remaining, static_cast<int>(static_cast<float>(remaining) * share + 0.5f));
}

}  // namespace detail
}  // namespace aoscan
