/// @file jump_flood_avx2.cpp
/// @brief The jump flooding's AVX2 kernel: the interior of a pass's row, eight pixels per vector.
/// Compiled for any x86-64 CPU (the function carries its target attribute); jump_flood.cpp calls
/// it only when the CPU has AVX2.
#include "ao/jump_flood_kernels.h"

#if AOSCAN_JUMP_FLOOD_X86
#include <immintrin.h>

#include <limits>
#endif

namespace aoscan {
namespace detail {

#if AOSCAN_JUMP_FLOOD_X86

__attribute__((target("avx2"))) void flood_interior_avx2(const FloodRow& row, int x_begin,
                                                         int x_end, PackedSeed* out) {
  const __m256i y = _mm256_set1_epi32(row.y);
  const __m256i low16 = _mm256_set1_epi32(0xFFFF);
  const __m256i none = _mm256_set1_epi32(-1);
  const __m256i far = _mm256_set1_epi32(std::numeric_limits<std::int32_t>::max());
  const __m256i wrap_width = _mm256_set1_epi32(row.wrap_width);
  const __m256i eight = _mm256_set1_epi32(8);
  __m256i xs =
      _mm256_add_epi32(_mm256_set1_epi32(x_begin), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
  int x = x_begin;
  for (; x + 8 <= x_end; x += 8, xs = _mm256_add_epi32(xs, eight)) {
    __m256i best_d = far, best = none;
    for (const PackedSeed* r : row.rows) {
      if (r == nullptr) continue;
      for (int c = -1; c <= 1; ++c) {
        const __m256i s = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(r + x + c * row.k));
        __m256i dx = _mm256_abs_epi32(_mm256_sub_epi32(xs, _mm256_and_si256(s, low16)));
        if (row.wrap_width > 0) dx = _mm256_min_epi32(dx, _mm256_sub_epi32(wrap_width, dx));
        const __m256i dy = _mm256_sub_epi32(y, _mm256_srai_epi32(s, 16));
        __m256i d = _mm256_add_epi32(_mm256_mullo_epi32(dx, dx), _mm256_mullo_epi32(dy, dy));
        d = _mm256_blendv_epi8(far, d, _mm256_cmpgt_epi32(s, none));
        // Nearer, or as near and smaller: what the portable code keeps, in any order.
        const __m256i take = _mm256_or_si256(
            _mm256_cmpgt_epi32(best_d, d),
            _mm256_and_si256(_mm256_cmpeq_epi32(d, best_d), _mm256_cmpgt_epi32(best, s)));
        best_d = _mm256_blendv_epi8(best_d, d, take);
        best = _mm256_blendv_epi8(best, s, take);
      }
    }
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + x), best);
  }
  if (x < x_end) flood_interior_portable(row, x, x_end, out);
}

#endif

}  // namespace detail
}  // namespace aoscan
