/// @file stage_stats.h
/// @brief Per-stage timing: every processed frame's milliseconds, summarised as mean/p50/p95/max.
#pragma once

#include <chrono>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace aoscan {

/// Summary of one stage's per-frame times (milliseconds).
struct TimingSummary {
  double ms_mean = 0.0;
  double ms_p50 = 0.0;
  double ms_p95 = 0.0;
  double ms_max = 0.0;
  std::size_t count = 0;

  /// {PREFIX + "mean", PREFIX + "p50", PREFIX + "p95", PREFIX + "max"} (stats.json).
  nlohmann::json to_json(const std::string& key_prefix) const;
};

/// Times of one stage. Written by that stage's thread only; read after the thread has joined.
class StageStats {
 public:
  explicit StageStats(std::string name) : name_(std::move(name)) { ms_.reserve(4096); }

  const std::string& name() const { return name_; }
  void add_ms(double ms) { ms_.push_back(ms); }
  const std::vector<double>& samples_ms() const { return ms_; }
  /// Mean, nearest-rank percentiles and maximum of the samples (all zero when there are none).
  TimingSummary summary() const;

 private:
  std::string name_;
  std::vector<double> ms_;
};

/// Milliseconds elapsed since `start` on the steady clock.
inline double ms_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace aoscan
