/// @file colour_volume_avx2.cpp
/// @brief The colour integration's AVX2 kernels: the projection of a block's shell voxels and the
/// running mean of their colours, eight voxels per vector. Compiled for any x86-64 CPU (each
/// function carries its target attribute); colour_volume.cpp calls them only when the CPU has
/// AVX2.
#include "fusion/tsdf/colour_kernels.h"

#include "geometry/simd.h"

#if AOSCAN_COLOUR_X86
#include <immintrin.h>
#endif

namespace aoscan {
namespace detail {

#if AOSCAN_COLOUR_X86

/// project_shell_portable() eight voxels at a time: the same float operations in the same order
/// (no FMA), the depths gathered for the lanes inside the image, the hits written in order.
__attribute__((target("avx2"))) AOSCAN_NO_CONTRACT void project_shell_avx2(
    const ColourProjection& c, const int origin[3], const std::uint16_t* voxel, int n,
    ColourHits& hits) {
  const __m256 voxel_m = _mm256_set1_ps(c.voxel_m);
  const __m256 zero = _mm256_setzero_ps();
  const __m256 width = _mm256_set1_ps(static_cast<float>(c.width));
  const __m256 height = _mm256_set1_ps(static_cast<float>(c.height));
  const __m256 fx = _mm256_set1_ps(c.fx), fy = _mm256_set1_ps(c.fy);
  const __m256 cx = _mm256_set1_ps(c.cx), cy = _mm256_set1_ps(c.cy);
  const __m256 band = _mm256_set1_ps(c.band_m);
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
  const __m256i seven = _mm256_set1_epi32(7);
  const __m256i ox = _mm256_set1_epi32(origin[0]), oy = _mm256_set1_epi32(origin[1]),
                oz = _mm256_set1_epi32(origin[2]);
  const __m256i image_width = _mm256_set1_epi32(c.width);
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  __m256 R[3][3], t[3];
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) R[i][j] = _mm256_set1_ps(c.R[i][j]);
    t[i] = _mm256_set1_ps(c.t[i]);
  }
  int count = 0;
  for (int k = 0; k < n; k += 8) {
    const int lanes = n - k < 8 ? n - k : 8;
    alignas(32) int vi_lanes[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    for (int l = 0; l < lanes; ++l) vi_lanes[l] = voxel[k + l];
    const __m256i vi = _mm256_load_si256(reinterpret_cast<const __m256i*>(vi_lanes));
    const __m256i live = _mm256_cmpgt_epi32(_mm256_set1_epi32(lanes), lane);
    const __m256 wx = _mm256_mul_ps(
        _mm256_cvtepi32_ps(_mm256_add_epi32(ox, _mm256_and_si256(vi, seven))), voxel_m);
    const __m256 wy = _mm256_mul_ps(
        _mm256_cvtepi32_ps(_mm256_add_epi32(oy, _mm256_and_si256(_mm256_srli_epi32(vi, 3), seven))),
        voxel_m);
    const __m256 wz =
        _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_add_epi32(oz, _mm256_srli_epi32(vi, 6))), voxel_m);
    __m256 p[3];
    for (int i = 0; i < 3; ++i)
      p[i] = _mm256_add_ps(
          _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(R[i][0], wx), _mm256_mul_ps(R[i][1], wy)),
                        _mm256_mul_ps(R[i][2], wz)),
          t[i]);
    const __m256 u = _mm256_add_ps(_mm256_div_ps(_mm256_mul_ps(fx, p[0]), p[2]), cx);
    const __m256 v = _mm256_add_ps(_mm256_div_ps(_mm256_mul_ps(fy, p[1]), p[2]), cy);
    __m256 inside = _mm256_and_ps(_mm256_castsi256_ps(live), _mm256_cmp_ps(p[2], zero, _CMP_GT_OQ));
    inside = _mm256_and_ps(inside, _mm256_and_ps(_mm256_cmp_ps(u, zero, _CMP_GE_OQ),
                                                 _mm256_cmp_ps(u, width, _CMP_LT_OQ)));
    inside = _mm256_and_ps(inside, _mm256_and_ps(_mm256_cmp_ps(v, zero, _CMP_GE_OQ),
                                                 _mm256_cmp_ps(v, height, _CMP_LT_OQ)));
    if (_mm256_movemask_ps(inside) == 0) continue;
    // Truncation is floor for the lanes inside; the others' pixels are masked out of the gather.
    const __m256i pixel = _mm256_add_epi32(
        _mm256_mullo_epi32(_mm256_cvttps_epi32(v), image_width), _mm256_cvttps_epi32(u));
    const __m256i safe_pixel = _mm256_and_si256(pixel, _mm256_castps_si256(inside));
    const __m256 d = _mm256_mask_i32gather_ps(zero, c.depth, safe_pixel, inside, 4);
    const __m256 near = _mm256_and_ps(
        _mm256_cmp_ps(d, zero, _CMP_GT_OQ),
        _mm256_cmp_ps(_mm256_and_ps(_mm256_sub_ps(d, p[2]), abs_mask), band, _CMP_LE_OQ));
    int bits = _mm256_movemask_ps(_mm256_and_ps(inside, near));
    if (bits == 0) continue;
    alignas(32) int pixels[8];
    alignas(32) float xs[8], ys[8], zs[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(pixels), pixel);
    _mm256_store_ps(xs, p[0]);
    _mm256_store_ps(ys, p[1]);
    _mm256_store_ps(zs, p[2]);
    for (; bits != 0; bits &= bits - 1) {
      const int l = __builtin_ctz(static_cast<unsigned>(bits));
      hits.voxel[count] = static_cast<std::uint16_t>(vi_lanes[l]);
      hits.pixel[count] = pixels[l];
      hits.x[count] = xs[l];
      hits.y[count] = ys[l];
      hits.z[count] = zs[l];
      ++count;
    }
  }
  hits.count = count;
}

/// update_colours_portable() eight voxels at a time: the voxels' 4 bytes gathered, the three
/// channels' means in floats rounded to nearest even (the conversion's default rounding, as
/// to_byte()), clamped to a byte, the weight w + 1 capped; the bytes written back lane by lane.
__attribute__((target("avx2"))) AOSCAN_NO_CONTRACT void update_colours_avx2(
    std::uint8_t* voxels, const std::uint16_t* index, const float* r, const float* g,
    const float* b, int n, float cap) {
  const __m256i byte = _mm256_set1_epi32(0xff);
  const __m256i zero = _mm256_setzero_si256();
  const __m256 one = _mm256_set1_ps(1.0f), cap8 = _mm256_set1_ps(cap);
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const float* samples[3] = {r, g, b};
  for (int k = 0; k < n; k += 8) {
    const int lanes = n - k < 8 ? n - k : 8;
    alignas(32) int offsets[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    alignas(32) float s[3][8] = {};
    for (int l = 0; l < lanes; ++l) {
      offsets[l] = 4 * index[k + l];
      for (int ch = 0; ch < 3; ++ch) s[ch][l] = samples[ch][k + l];
    }
    const __m256i live = _mm256_cmpgt_epi32(_mm256_set1_epi32(lanes), lane);
    const __m256i at = _mm256_load_si256(reinterpret_cast<const __m256i*>(offsets));
    const __m256i old = _mm256_mask_i32gather_epi32(zero, reinterpret_cast<const int*>(voxels),
                                                    at, live, 1);
    const __m256 w = _mm256_cvtepi32_ps(_mm256_srli_epi32(old, 24));
    const __m256 w1 = _mm256_add_ps(w, one);
    __m256i out = _mm256_slli_epi32(_mm256_cvttps_epi32(_mm256_min_ps(w1, cap8)), 24);
    for (int ch = 0; ch < 3; ++ch) {
      const __m256 c =
          _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(old, 8 * ch), byte));
      const __m256 mean =
          _mm256_div_ps(_mm256_add_ps(_mm256_mul_ps(c, w), _mm256_load_ps(s[ch])), w1);
      __m256i rounded = _mm256_cvtps_epi32(mean);
      rounded = _mm256_min_epi32(_mm256_max_epi32(rounded, zero), byte);
      out = _mm256_or_si256(out, _mm256_slli_epi32(rounded, 8 * ch));
    }
    alignas(32) std::uint32_t result[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(result), out);
    for (int l = 0; l < lanes; ++l) {
      std::uint8_t* v = voxels + offsets[l];
      v[0] = static_cast<std::uint8_t>(result[l]);
      v[1] = static_cast<std::uint8_t>(result[l] >> 8);
      v[2] = static_cast<std::uint8_t>(result[l] >> 16);
      v[3] = static_cast<std::uint8_t>(result[l] >> 24);
    }
  }
}

#endif

}  // namespace detail
}  // namespace aoscan
