/// @file simd.h
/// @brief What the fusion kernels' SIMD paths share: run-time CPU feature checks, and the
/// attribute that keeps a function's float arithmetic free of fused multiply-adds.
#pragma once

// A SIMD path must round exactly like its scalar reference: no contraction of a * b + c into
// fused multiply-adds where the target has them (SIMD code uses explicit _mm256_fmadd_ps only).
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#define AOSCAN_NO_CONTRACT
#else
#define AOSCAN_NO_CONTRACT __attribute__((optimize("fp-contract=off")))
#endif

namespace aoscan {

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
/// True when the CPU running this process has AVX2 (checked once).
inline bool cpu_has_avx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}

/// True when the CPU running this process has AVX2 and FMA (checked once).
inline bool cpu_has_avx2_fma() {
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}
#endif

}  // namespace aoscan
