/// @file percentile.h
/// @brief Percentiles of a sample, by the nearest-rank convention.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace aoscan {

/// The nearest-rank `p`-percentile (p in [0, 1]) of `sorted` (ascending, not empty): its
/// ceil(p * n)-th smallest value, the smallest for p = 0. No interpolation: always a sample.
inline double nearest_rank(const std::vector<double>& sorted, double p) {
  const auto rank = static_cast<std::size_t>(std::ceil(p * static_cast<double>(sorted.size())));
  return sorted[std::min(sorted.size(), std::max<std::size_t>(rank, 1)) - 1];
}

}  // namespace aoscan
