/// @file ssao_kernels.h
/// @brief Internal to SSAO: the constants and per-sample pieces that the real-time estimators
/// (ssao.cpp), the per-scan SSAO of range maps (scan_ssao.cpp) and the plain reference of the tests
/// (tests/support) share. Not for other code.
#pragma once

#include <algorithm>

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

/// One pixel's SSAO and the share of its samples that were counted (inside the image, on valid
/// pixels).
struct PixelAo {
  float ao;
  float coverage;
};

/// Everything a per-pixel evaluation needs, fixed for the frame.
struct FrameSetup {
  const PointMaps* maps;
  const SsaoPattern* pattern;
  float fx, fy, radius_m, t_max_m, d_min_m, d_max_m, bias, coverage_power;
  float area_min_cos;
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
                    static_cast<float>(config.area_min_cos)};
}

}  // namespace detail
}  // namespace aoscan
