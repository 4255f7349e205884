/// @file counter_rng.h
/// @brief Counter-based random numbers: every draw is a pure function of (key, draw index), so
/// results do not depend on the order or the thread in which pixels are processed.
#pragma once

#include <cmath>
#include <cstdint>

namespace aoscan {

/// The splitmix64 finaliser: a bijective 64-bit mixing function.
inline std::uint64_t mix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

/// A short random stream keyed by (seed, a, b), e.g. (seed, frame index, pixel index). The n-th
/// draw is mix64(key + n * golden), i.e. the splitmix64 sequence started at the key.
class CounterRng {
 public:
  CounterRng(std::uint64_t seed, std::uint64_t a, std::uint64_t b)
      : state_(mix64(mix64(mix64(seed) ^ (a * 0xd1b54a32d192ed03ULL)) ^
                     (b * 0xaef17502108ef2d9ULL))) {}

  std::uint64_t next_u64() {
    state_ += 0x9e3779b97f4a7c15ULL;
    return mix64(state_);
  }
  /// Uniform in [0, 1), 53 random bits.
  double uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }
  /// Two independent standard normal values: the Box-Muller transform in Marsaglia's polar form
  /// (no trigonometry; on average 2.55 uniform draws). Every value is finite and bounded by
  /// sqrt(-2 ln 2^-104) < 12.1 in magnitude (s >= 2^-104 for 53-bit uniforms).
  void normal_pair(double* n0, double* n1) {
    for (;;) {
      const double x = 2.0 * uniform() - 1.0;
      const double y = 2.0 * uniform() - 1.0;
      const double s = x * x + y * y;
      if (s >= 1.0 || s == 0.0) continue;
      const double f = std::sqrt(-2.0 * std::log(s) / s);
      *n0 = x * f;
      *n1 = y * f;
      return;
    }
  }

 private:
  std::uint64_t state_;
};

}  // namespace aoscan
