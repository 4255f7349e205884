/// @file stage_stats.cpp
/// @brief Timing summaries.
#include "pipeline/stage_stats.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <nlohmann/json.hpp>

#include "core/percentile.h"

namespace aoscan {

StageStats::StageStats(std::string name) : name_(std::move(name)) { ms_.reserve(4096); }

int StageStats::bin_of(double ms) {
  if (!(ms > kHistogramMinMs)) return 0;  // NaN too
  const double b = std::floor(std::log10(ms / kHistogramMinMs) * kBinsPerDecade);
  return b >= kBins - 1 ? kBins - 1 : static_cast<int>(b);
}

double StageStats::bin_centre_ms(int b) {
  return kHistogramMinMs * std::pow(10.0, (b + 0.5) / kBinsPerDecade);
}

void StageStats::add_ms(double ms) {
  min_ = count_ ? std::min(min_, ms) : ms;
  max_ = count_ ? std::max(max_, ms) : ms;
  sum_ += ms;
  ++count_;
  if (!exact()) {
    ++histogram_[static_cast<std::size_t>(bin_of(ms))];
    return;
  }
  ms_.push_back(ms);
  if (ms_.size() > kExactSamples) to_histogram();
}

void StageStats::to_histogram() {
  histogram_.assign(kBins, 0);
  for (const double ms : ms_) ++histogram_[static_cast<std::size_t>(bin_of(ms))];
  std::vector<double>().swap(ms_);
}

void StageStats::merge(const StageStats& other) {
  if (other.exact()) {
    for (const double ms : other.ms_) add_ms(ms);
    return;
  }
  if (exact()) to_histogram();
  for (std::size_t b = 0; b < histogram_.size(); ++b) histogram_[b] += other.histogram_[b];
  min_ = count_ ? std::min(min_, other.min_) : other.min_;
  max_ = count_ ? std::max(max_, other.max_) : other.max_;
  sum_ += other.sum_;
  count_ += other.count_;
}

TimingSummary StageStats::summary() const {
  TimingSummary s;
  s.count = count_;
  if (count_ == 0) return s;
  s.ms_max = max_;
  if (exact()) {
    std::vector<double> sorted = ms_;
    std::sort(sorted.begin(), sorted.end());
    s.ms_mean = std::accumulate(sorted.begin(), sorted.end(), 0.0) / static_cast<double>(count_);
    s.ms_p50 = nearest_rank(sorted, 0.50);
    s.ms_p95 = nearest_rank(sorted, 0.95);
    return s;
  }
  s.ms_mean = sum_ / static_cast<double>(count_);
  const auto percentile = [&](double p) {
    const std::size_t index = nearest_rank_index(count_, p);  // the (index + 1)-th smallest
    std::uint64_t seen = 0;
    for (int b = 0; b < kBins; ++b) {
      seen += histogram_[static_cast<std::size_t>(b)];
      if (seen > index) return std::clamp(bin_centre_ms(b), min_, max_);
    }
    return max_;
  };
  s.ms_p50 = percentile(0.50);
  s.ms_p95 = percentile(0.95);
  return s;
}

nlohmann::json TimingSummary::to_json(const std::string& key_prefix) const {
  return {{key_prefix + "mean", ms_mean},
          {key_prefix + "p50", ms_p50},
          {key_prefix + "p95", ms_p95},
          {key_prefix + "max", ms_max}};
}

}  // namespace aoscan
