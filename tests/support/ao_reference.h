/// @file ao_reference.h
/// @brief Test oracles of the ao module: bit-by-bit Morton codes, and the plain serial per-pixel
/// SSAO written directly from the formulas.
#pragma once

#include <cstdint>
#include <optional>

#include "ao/ao_config.h"
#include "ao/morton.h"
#include "core/image.h"
#include "geometry/point_maps.h"

namespace aoscan {

/// Bit-by-bit reference of morton_encode() (same contract), as libmorton's control_encode.
constexpr std::optional<std::uint64_t> morton_encode_reference(std::int32_t x, std::int32_t y,
                                                               std::int32_t z) {
  if (!morton_in_range(x, y, z)) return std::nullopt;
  const std::uint64_t u[3] = {morton_detail::to_unsigned(x), morton_detail::to_unsigned(y),
                              morton_detail::to_unsigned(z)};
  std::uint64_t code = 0;
  for (int bit = 0; bit < kMortonBitsPerAxis; ++bit)
    for (int axis = 0; axis < 3; ++axis) code |= ((u[axis] >> bit) & 1u) << (3 * bit + axis);
  return code;
}

/// Bit-by-bit reference of morton_decode() (same contract).
constexpr void morton_decode_reference(std::uint64_t code, std::int32_t& x, std::int32_t& y,
                                       std::int32_t& z) {
  std::uint64_t u[3] = {0, 0, 0};
  for (int bit = 0; bit < kMortonBitsPerAxis; ++bit)
    for (int axis = 0; axis < 3; ++axis) u[axis] |= ((code >> (3 * bit + axis)) & 1u) << bit;
  x = morton_detail::to_signed(u[0]);
  y = morton_detail::to_signed(u[1]);
  z = morton_detail::to_signed(u[2]);
}

/// Plain serial per-pixel implementation of compute_ssao() (same contract), written directly from
/// the formulas (normals smoothed by smooth_model_normals_reference()); the fast version matches
/// it within 1e-5.
void compute_ssao_reference(const PointMaps& maps, const AoConfig& config,
                            std::uint64_t frame_index, Image<float>& ao, Image<float>& weight);

}  // namespace aoscan
