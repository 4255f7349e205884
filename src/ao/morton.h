/// @file morton.h
/// @brief 64-bit Morton (Z-order) codes of signed 3-D integer cell coordinates, 21 bits per axis,
/// for the sparse MVAO grid.
///
/// Layout: a coordinate c in [kMortonMin, kMortonMax] is offset to u = c + 2^20 in [0, 2^21); bit i
/// of u_x, u_y, u_z goes to code bit 3i, 3i + 1, 3i + 2 (x lowest, as libmorton). Codes use bits
/// 0..62; bit 63 is always 0. Sorting codes sorts cells in Z order of the offset coordinates, and
/// along any one axis the code grows with the coordinate.
#pragma once

#include <cstdint>
#include <optional>

namespace aoscan {

inline constexpr int kMortonBitsPerAxis = 21;
inline constexpr std::int32_t kMortonOffset = std::int32_t{1} << (kMortonBitsPerAxis - 1);
inline constexpr std::int32_t kMortonMin = -kMortonOffset;     ///< smallest encodable coordinate
inline constexpr std::int32_t kMortonMax = kMortonOffset - 1;  ///< largest encodable coordinate
/// Every bit a valid code may have set (bits 0..62).
inline constexpr std::uint64_t kMortonCodeMask = (std::uint64_t{1} << (3 * kMortonBitsPerAxis)) - 1;

namespace morton_detail {

/// Spreads the low 21 bits of `v` so that bit i lands on bit 3i (magic-number shifts).
constexpr std::uint64_t spread_bits(std::uint64_t v) {
  v &= 0x1FFFFF;
  v = (v | v << 32) & 0x001F00000000FFFFull;
  v = (v | v << 16) & 0x001F0000FF0000FFull;
  v = (v | v << 8) & 0x100F00F00F00F00Full;
  v = (v | v << 4) & 0x10C30C30C30C30C3ull;
  v = (v | v << 2) & 0x1249249249249249ull;
  return v;
}

/// Inverse of spread_bits(): gathers bits 0, 3, 6, ..., 60 of `v` into bits 0..20.
constexpr std::uint64_t compact_bits(std::uint64_t v) {
  v &= 0x1249249249249249ull;
  v = (v ^ (v >> 2)) & 0x10C30C30C30C30C3ull;
  v = (v ^ (v >> 4)) & 0x100F00F00F00F00Full;
  v = (v ^ (v >> 8)) & 0x001F0000FF0000FFull;
  v = (v ^ (v >> 16)) & 0x001F00000000FFFFull;
  v = (v ^ (v >> 32)) & 0x1FFFFF;
  return v;
}

/// Offset coordinate u = c + 2^20 (c must be in range).
constexpr std::uint64_t to_unsigned(std::int32_t c) {
  return static_cast<std::uint64_t>(static_cast<std::int64_t>(c) + kMortonOffset);
}
constexpr std::int32_t to_signed(std::uint64_t u) {
  return static_cast<std::int32_t>(static_cast<std::int64_t>(u) - kMortonOffset);
}

}  // namespace morton_detail

/// True when every coordinate lies in [kMortonMin, kMortonMax] = [-2^20, 2^20 - 1].
constexpr bool morton_in_range(std::int32_t x, std::int32_t y, std::int32_t z) {
  return x >= kMortonMin && x <= kMortonMax && y >= kMortonMin && y <= kMortonMax &&
         z >= kMortonMin && z <= kMortonMax;
}

/// Morton code of cell (x, y, z) (grid cell indices, unitless), or std::nullopt when a coordinate
/// is out of range: never wraps. Fast version (magic-number bit spreading); the test oracle
/// morton_encode_reference() (tests/support) goes bit by bit.
constexpr std::optional<std::uint64_t> morton_encode(std::int32_t x, std::int32_t y,
                                                     std::int32_t z) {
  if (!morton_in_range(x, y, z)) return std::nullopt;
  using namespace morton_detail;
  return spread_bits(to_unsigned(x)) | spread_bits(to_unsigned(y)) << 1 |
         spread_bits(to_unsigned(z)) << 2;
}

/// Cell coordinates of `code`. Bit 63 (never set by morton_encode) is ignored, so every input
/// decodes to an in-range cell. Fast version (magic-number bit compaction); the test oracle
/// morton_decode_reference() (tests/support) goes bit by bit.
constexpr void morton_decode(std::uint64_t code, std::int32_t& x, std::int32_t& y,
                             std::int32_t& z) {
  using namespace morton_detail;
  x = to_signed(compact_bits(code));
  y = to_signed(compact_bits(code >> 1));
  z = to_signed(compact_bits(code >> 2));
}

}  // namespace aoscan
