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
      : state_(mix64(mix64(mix64(seed) ^ (a * 0xd1b54a32d192ed03ULL)) ^ (b * 0xaef17502108ef2d9ULL))) {}

  std::uint64_t next_u64() {
    state_ += 0x9e3779b97f4a7c15ULL;
    return mix64(state_);
  }
  /// Uniform in [0, 1), 53 random bits.
  double uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }
  /// Uniform in (0, 1], safe for log().
  double uniform_positive() { return static_cast<double>((next_u64() >> 11) + 1) * 0x1.0p-53; }
  /// Two independent standard normal values (Box-Muller on two uniforms).
  void normal_pair(double* n0, double* n1) {
    const double r = std::sqrt(-2.0 * std::log(uniform_positive()));
    const double angle = 2.0 * 3.14159265358979323846 * uniform();
    *n0 = r * std::cos(angle);
    *n1 = r * std::sin(angle);
  }

 private:
  std::uint64_t state_;
};

}  // namespace aoscan
