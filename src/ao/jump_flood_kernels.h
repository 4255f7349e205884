/// @file jump_flood_kernels.h
/// @brief Internal to the jump flooding: what its portable code (jump_flood.cpp) and its AVX2
/// kernel (jump_flood_avx2.cpp) share. Not for use outside src/ao/ and its tests.
#pragma once

#include <cstdint>

#if defined(__x86_64__) && defined(__GNUC__)
#define AOSCAN_JUMP_FLOOD_X86 1
#else
#define AOSCAN_JUMP_FLOOD_X86 0
#endif

namespace aoscan {
namespace detail {

/// A seed as (y << 16) | x, for images of at most kMaxPackedSide pixels a side; -1 for none.
/// Seeds compare as their (y, x): the order that breaks ties between equally near seeds.
using PackedSeed = std::int32_t;
inline constexpr int kMaxPackedSide = 32767;
inline PackedSeed pack_seed(int x, int y) {
  return (y << 16) | x;
}

/// One output row of a jump flooding pass of step k: the pass's input rows y - k, y and y + k
/// (null when off the image).
struct FloodRow {
  const PackedSeed* rows[3];
  int y = 0;
  int k = 1;
  int wrap_width = 0;  ///< the map's width if it wraps (x distances taken around it), or 0
};

/// out[x] for x in [x_begin, x_end), all of whose columns x - k, x, x + k lie in the image: the
/// nearest of the up to nine seeds at rows y - k, y, y + k and those columns, ties to the smaller
/// seed; -1 when none of them is a seed. Squared distances in 32-bit integers (exact: at most
/// 2 * 32767^2).
void flood_interior_portable(const FloodRow& row, int x_begin, int x_end, PackedSeed* out);

#if AOSCAN_JUMP_FLOOD_X86
/// flood_interior_portable() eight pixels per AVX2 vector: the same seeds. Only on a CPU with AVX2.
void flood_interior_avx2(const FloodRow& row, int x_begin, int x_end, PackedSeed* out);
#endif

}  // namespace detail
}  // namespace aoscan
