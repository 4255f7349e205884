/// @file raycast_avx2.cpp
/// @brief The raycast's AVX2 path: the rays of a row that carry a depth hint searched eight per
/// vector (the same samples and steps as the portable search of raycast.cpp, bit for bit).
/// Compiled for any x86-64 CPU (each vector function carries its target attribute); raycast.cpp
/// calls it only when the CPU has AVX2.
#include "fusion/tsdf/raycast_kernels.h"

#if defined(AOSCAN_RAYCAST_AVX2)

#include <cstdint>
#include <cstring>

#include <immintrin.h>

#include "geometry/simd.h"

namespace aoscan {
namespace detail {
namespace {

/// The rays of one row that carry a depth hint, up to eight, searched together.
struct HintLanes {
  static constexpr int kLanes = 8;
  int count = 0;
  int x[kLanes];
  Ray ray[kLanes];
  alignas(32) float d[kLanes];        ///< the hint
  alignas(32) float s_begin[kLanes];  ///< the ray's depth range
  alignas(32) float s_end[kLanes];
  alignas(32) float s_per_metre[kLanes];
  alignas(32) float min_step[kLanes];  ///< a voxel, in depth along the optical axis
  alignas(32) float dir[3][kLanes];
};

/// What search_near8() found per lane: the bracket of search_near() (bit l of `found`), or none.
struct HintBrackets {
  int found = 0;
  alignas(32) float s0[HintLanes::kLanes], f0[HintLanes::kLanes];
  alignas(32) float s1[HintLanes::kLanes], f1[HintLanes::kLanes];
};

/// Lanes whose bit is set in `bits`, as an all-ones mask per lane.
__attribute__((target("avx2"))) inline __m256 lane_mask(int bits) {
  const __m256i bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
  return _mm256_castsi256_ps(
      _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(bits), bit), bit));
}

/// u + t (v - u) on eight lanes, as interpolate() per lane.
__attribute__((target("avx2"))) AOSCAN_NO_CONTRACT inline __m256 lerp8(__m256 u, __m256 v,
                                                                       __m256 t) {
  return _mm256_add_ps(u, _mm256_mul_ps(t, _mm256_sub_ps(v, u)));
}

/// trilinear() at depth s of each lane in `active`: the values in `f`, the lanes whose sample
/// exists returned. The eight corners are read lane by lane (cells whose x pairs straddle a block
/// border through trilinear() itself) and interpolated eight lanes at a time with the float
/// operations of TsdfSampler's scalar read, so the same bits.
__attribute__((target("avx2"))) AOSCAN_NO_CONTRACT int sample8(TsdfSampler& sampler,
                                                               const HintLanes& lanes,
                                                               const Eigen::Vector3f& origin,
                                                               __m256 s, int active, __m256& f) {
  alignas(32) float g[3][HintLanes::kLanes];
  alignas(32) std::int32_t cell[3][HintLanes::kLanes];
  __m256 position[3];
  for (int c = 0; c < 3; ++c) {
    position[c] =
        _mm256_add_ps(_mm256_set1_ps(origin[c]), _mm256_mul_ps(s, _mm256_load_ps(lanes.dir[c])));
    _mm256_store_ps(g[c], position[c]);
    // floor_to_int(): truncate, minus one where that rounded up.
    const __m256i i = _mm256_cvttps_epi32(position[c]);
    const __m256 above = _mm256_cmp_ps(_mm256_cvtepi32_ps(i), position[c], _CMP_GT_OQ);
    _mm256_store_si256(reinterpret_cast<__m256i*>(cell[c]),
                       _mm256_add_epi32(i, _mm256_castps_si256(above)));
  }
  // Per lane and x pair k: the pair's two voxels (tsdf_q | count << 16 each) in 64 bits.
  alignas(32) std::uint64_t pair_bits[4][HintLanes::kLanes] = {};
  alignas(32) float scalar_f[HintLanes::kLanes] = {};
  int gathered = 0, scalar = 0;
  for (int bits = active; bits != 0; bits &= bits - 1) {
    const int l = __builtin_ctz(bits);
    if ((cell[0][l] & 7) == 7) {
      if (sampler.trilinear(Eigen::Vector3f(g[0][l], g[1][l], g[2][l]), scalar_f[l]))
        scalar |= 1 << l;
      continue;
    }
    const Voxel* pairs[4];
    if (!sampler.x_pairs(cell[0][l], cell[1][l], cell[2][l], pairs)) continue;
    static_assert(2 * sizeof(Voxel) == sizeof(std::uint64_t), "an x pair is 64 bits");
    for (int k = 0; k < 4; ++k) std::memcpy(&pair_bits[k][l], pairs[k], sizeof(std::uint64_t));
    gathered |= 1 << l;
  }
  const __m256i zero = _mm256_setzero_si256();
  const __m256 step = _mm256_set1_ps(Voxel::kTsdfStep);
  __m256i unobserved = zero;
  __m256 c[8];
  for (int k = 0; k < 4; ++k) {
    // Lanes 0-3 and 4-7 of pair k, each lane's two voxels adjacent: split into the pair's even
    // and odd corners (the shuffle leaves lanes in the order 0 1 4 5 2 3 6 7; the permute
    // restores it).
    const __m256 lo = _mm256_load_ps(reinterpret_cast<const float*>(pair_bits[k]));
    const __m256 hi = _mm256_load_ps(reinterpret_cast<const float*>(pair_bits[k] + 4));
    const __m256i halves[2] = {
        _mm256_castps_si256(_mm256_shuffle_ps(lo, hi, _MM_SHUFFLE(2, 0, 2, 0))),
        _mm256_castps_si256(_mm256_shuffle_ps(lo, hi, _MM_SHUFFLE(3, 1, 3, 1)))};
    for (int odd = 0; odd < 2; ++odd) {
      const __m256i v = _mm256_permute4x64_epi64(halves[odd], _MM_SHUFFLE(3, 1, 2, 0));
      unobserved = _mm256_or_si256(unobserved, _mm256_cmpeq_epi32(_mm256_srli_epi32(v, 16), zero));
      c[2 * k + odd] =
          _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_srai_epi32(_mm256_slli_epi32(v, 16), 16)), step);
    }
  }
  gathered &= ~_mm256_movemask_ps(_mm256_castsi256_ps(unobserved));
  __m256 a[3];
  for (int k = 0; k < 3; ++k)
    a[k] = _mm256_sub_ps(
        position[k],
        _mm256_cvtepi32_ps(_mm256_load_si256(reinterpret_cast<const __m256i*>(cell[k]))));
  const __m256 c0 = lerp8(lerp8(c[0], c[1], a[0]), lerp8(c[2], c[3], a[0]), a[1]);
  const __m256 c1 = lerp8(lerp8(c[4], c[5], a[0]), lerp8(c[6], c[7], a[0]), a[1]);
  f = _mm256_blendv_ps(lerp8(c0, c1, a[2]), _mm256_load_ps(scalar_f), lane_mask(scalar));
  return gathered | scalar;
}

/// The lanes with s in [s_begin, s_end) as bits.
__attribute__((target("avx2"))) inline int in_range8(__m256 s, __m256 s_begin, __m256 s_end) {
  return _mm256_movemask_ps(
      _mm256_and_ps(_mm256_cmp_ps(s, s_begin, _CMP_GE_OQ), _mm256_cmp_ps(s, s_end, _CMP_LT_OQ)));
}

/// search_near() for the rays of `lanes` at once, up to the bracket: the same samples and steps
/// in the same float operations, so the same brackets.
__attribute__((target("avx2"))) AOSCAN_NO_CONTRACT void search_near8(TsdfSampler& sampler,
                                                                     const HintLanes& lanes,
                                                                     const Eigen::Vector3f& origin,
                                                                     float truncation,
                                                                     HintBrackets& out) {
  const __m256 s_begin = _mm256_load_ps(lanes.s_begin);
  const __m256 s_end = _mm256_load_ps(lanes.s_end);
  const __m256 zero = _mm256_setzero_ps();
  __m256 s_a = _mm256_load_ps(lanes.d);
  __m256 f_a = zero;
  int active = ((1 << lanes.count) - 1) & in_range8(s_a, s_begin, s_end);
  active &= sample8(sampler, lanes, origin, s_a, active, f_a);
  const __m256 forward = _mm256_cmp_ps(f_a, zero, _CMP_GE_OQ);
  const __m256 direction = _mm256_blendv_ps(_mm256_set1_ps(-1.0f), _mm256_set1_ps(1.0f), forward);
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7FFFFFFF));
  const __m256 trunc = _mm256_set1_ps(truncation);
  const __m256 s_per_metre = _mm256_load_ps(lanes.s_per_metre);
  const __m256 half_step = _mm256_mul_ps(_mm256_set1_ps(0.5f), _mm256_load_ps(lanes.min_step));
  __m256 s0 = zero, f0 = zero, s1 = zero, f1 = zero;
  out.found = 0;
  for (int i = 0; i < kHintSteps && active != 0; ++i) {
    const __m256 distance =
        _mm256_mul_ps(_mm256_mul_ps(_mm256_and_ps(f_a, abs_mask), trunc), s_per_metre);
    const __m256 s_b =
        _mm256_add_ps(s_a, _mm256_mul_ps(direction, _mm256_add_ps(distance, half_step)));
    active &= in_range8(s_b, s_begin, s_end);
    __m256 f_b = zero;
    active &= sample8(sampler, lanes, origin, s_b, active, f_b);
    const int crossed =
        active & _mm256_movemask_ps(_mm256_xor_ps(_mm256_cmp_ps(f_b, zero, _CMP_GE_OQ),
                                                  _mm256_cmp_ps(f_a, zero, _CMP_GE_OQ)));
    if (crossed != 0) {
      const __m256 take = lane_mask(crossed);
      s0 = _mm256_blendv_ps(s0, _mm256_blendv_ps(s_b, s_a, forward), take);
      f0 = _mm256_blendv_ps(f0, _mm256_blendv_ps(f_b, f_a, forward), take);
      s1 = _mm256_blendv_ps(s1, _mm256_blendv_ps(s_a, s_b, forward), take);
      f1 = _mm256_blendv_ps(f1, _mm256_blendv_ps(f_a, f_b, forward), take);
      out.found |= crossed;
      active &= ~crossed;
    }
    s_a = s_b;
    f_a = f_b;
  }
  _mm256_store_ps(out.s0, s0);
  _mm256_store_ps(out.f0, f0);
  _mm256_store_ps(out.s1, s1);
  _mm256_store_ps(out.f1, f1);
}

}  // namespace

void raycast_row_avx2(TsdfSampler& sampler, const RaycastRows& rows, int y) {
  const RaySetup& setup = rows.setup;
  HintLanes lanes{};  // lanes past `count` are never read as results
  // Searches the collected hinted rays together and runs each to its end.
  auto flush = [&] {
    HintBrackets b;
    search_near8(sampler, lanes, setup.origin_voxels, rows.truncation, b);
    for (int l = 0; l < lanes.count; ++l)
      finish_hinted_ray(sampler, lanes.ray[l], lanes.x[l], y, lanes.d[l], lanes.s_begin[l],
                        lanes.s_end[l], (b.found >> l) & 1,
                        Bracket{b.s0[l], b.f0[l], b.s1[l], b.f1[l]}, rows.voxel_size,
                        rows.truncation, setup.R_camera_world, rows.result);
    lanes.count = 0;
  };
  for (int x = 0; x < rows.width; ++x) {
    Ray ray;
    float s_begin, s_end, d;
    if (!rows.pixel(x, y, ray, s_begin, s_end, d)) continue;
    if (usable_hint(d)) {
      const int l = lanes.count++;
      lanes.x[l] = x;
      lanes.ray[l] = ray;
      lanes.d[l] = d;
      lanes.s_begin[l] = s_begin;
      lanes.s_end[l] = s_end;
      lanes.s_per_metre[l] = 1.0f / ray.metres_per_s;
      lanes.min_step[l] = rows.voxel_size * lanes.s_per_metre[l];
      for (int c = 0; c < 3; ++c) lanes.dir[c][l] = ray.dir[c];
      if (lanes.count == HintLanes::kLanes) flush();
      continue;
    }
    if (rows.hinted_only) continue;
    march(sampler, ray, s_begin, s_end, rows.voxel_size, rows.truncation, setup.R_camera_world,
          rows.result, x, y);
  }
  if (lanes.count > 0) flush();
}

}  // namespace detail
}  // namespace aoscan

#endif  // AOSCAN_RAYCAST_AVX2
