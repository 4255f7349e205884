/// @file median_ms.h
/// @brief The benchmarks' timing loop: each step once per round, the median over the rounds.
#pragma once

#include <algorithm>
#include <chrono>
#include <functional>
#include <vector>

#include "core/percentile.h"

namespace aoscan {

using BenchClock = std::chrono::steady_clock;

inline double ms_since(BenchClock::time_point start) {
  return std::chrono::duration<double, std::milli>(BenchClock::now() - start).count();
}

/// Runs every step once per round for `repeat` rounds (so that a change of machine load hits all
/// steps alike) and returns each step's median time (ms). A step's last result stays in its
/// captures.
inline std::vector<double> median_ms(int repeat, const std::vector<std::function<void()>>& steps) {
  std::vector<std::vector<double>> times(steps.size());
  for (int r = 0; r < repeat; ++r) {
    for (std::size_t s = 0; s < steps.size(); ++s) {
      const auto start = BenchClock::now();
      steps[s]();
      times[s].push_back(ms_since(start));
    }
  }
  std::vector<double> medians;
  for (std::vector<double>& t : times) {
    std::sort(t.begin(), t.end());
    medians.push_back(nearest_rank(t, 0.5));
  }
  return medians;
}

}  // namespace aoscan
