/// @file percentile.h
/// @brief Percentiles of a sample, by the nearest-rank convention.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace aoscan {

/// The index in ascending order of the nearest-rank `p`-percentile of `n` > 0 values: ceil(p * n)
/// - 1, at least 0 and at most n - 1 (for std::nth_element when a full sort costs too much).
inline std::size_t nearest_rank_index(std::size_t n, double p) {
  const auto rank = static_cast<std::size_t>(std::ceil(p * static_cast<double>(n)));
  return std::min(n, std::max<std::size_t>(rank, 1)) - 1;
}

/// The nearest-rank `p`-percentile (p in [0, 1]) of `sorted` (ascending, not empty): its
/// ceil(p * n)-th smallest value, the smallest for p = 0. No interpolation: always a sample.
inline double nearest_rank(const std::vector<double>& sorted, double p) {
  return sorted[nearest_rank_index(sorted.size(), p)];
}

}  // namespace aoscan
