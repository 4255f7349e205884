/// @file stage_stats.cpp
/// @brief Timing summaries.
#include "pipeline/stage_stats.h"

#include <algorithm>
#include <numeric>

#include <nlohmann/json.hpp>

#include "core/percentile.h"

namespace aoscan {

TimingSummary StageStats::summary() const {
  TimingSummary s;
  s.count = ms_.size();
  if (ms_.empty()) return s;
  std::vector<double> sorted = ms_;
  std::sort(sorted.begin(), sorted.end());
  s.ms_mean = std::accumulate(sorted.begin(), sorted.end(), 0.0) / static_cast<double>(sorted.size());
  s.ms_p50 = nearest_rank(sorted, 0.50);
  s.ms_p95 = nearest_rank(sorted, 0.95);
  s.ms_max = sorted.back();
  return s;
}

nlohmann::json TimingSummary::to_json(const std::string& key_prefix) const {
  return {{key_prefix + "mean", ms_mean},
          {key_prefix + "p50", ms_p50},
          {key_prefix + "p95", ms_p95},
          {key_prefix + "max", ms_max}};
}

}  // namespace aoscan
