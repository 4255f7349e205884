/// @file stage_stats.cpp
/// @brief Timing summaries.
#include "pipeline/stage_stats.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace aoscan {

TimingSummary StageStats::summary() const {
  TimingSummary s;
  s.count = ms_.size();
  if (ms_.empty()) return s;
  std::vector<double> sorted = ms_;
  std::sort(sorted.begin(), sorted.end());
  const auto rank = [&](double p) {
    const auto r = static_cast<std::size_t>(std::ceil(p * static_cast<double>(sorted.size())));
    return sorted[std::min(sorted.size(), std::max<std::size_t>(r, 1)) - 1];
  };
  s.ms_mean = std::accumulate(sorted.begin(), sorted.end(), 0.0) / static_cast<double>(sorted.size());
  s.ms_p50 = rank(0.50);
  s.ms_p95 = rank(0.95);
  s.ms_max = sorted.back();
  return s;
}

}  // namespace aoscan
