/// @file stage_stats.h
/// @brief Per-stage timing: every processed frame's milliseconds, summarised as mean/p50/p95/max,
/// in bounded memory however long the run.
#pragma once

#include <chrono>
#include <cstdint>
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
///
/// The first kExactSamples times are kept as they are, and the summary's percentiles are exact
/// samples (nearest rank). Past that (9 minutes of frames at 30 Hz) the times move into a histogram
/// of kBinsPerDecade logarithmic bins per decade from kHistogramMinMs to kHistogramMaxMs, so that
/// an hour-long or day-long run keeps a fixed 20 KB per stage: the percentiles are then the
/// geometric centre of their bin (within 0.5 % of the exact sample, clamped to the smallest and
/// largest time), while count, mean, smallest and largest stay exact.
class StageStats {
 public:
  static constexpr std::size_t kExactSamples = 16384;
  static constexpr int kBinsPerDecade = 256;
  static constexpr double kHistogramMinMs = 1e-3;  ///< times below share the first bin
  static constexpr double kHistogramMaxMs = 1e6;    ///< times above share the last bin
  static constexpr int kBins = 9 * kBinsPerDecade;  ///< log10(max / min) decades

  explicit StageStats(std::string name);

  const std::string& name() const { return name_; }
  void add_ms(double ms);
  /// Adds every time of `other` (as if each had been given to add_ms; the bench's repeated runs).
  void merge(const StageStats& other);

  std::size_t count() const { return count_; }
  /// Smallest and largest time (0 when there are none).
  double min_ms() const { return count_ ? min_ : 0.0; }
  double max_ms() const { return count_ ? max_ : 0.0; }
  /// True while every time is kept exactly (count() <= kExactSamples and no merge of a histogram).
  bool exact() const { return histogram_.empty(); }
  /// Mean, percentiles and maximum (all zero when there are none).
  TimingSummary summary() const;

  /// The histogram bin of a time, 0..kBins-1, and the geometric centre of bin `b` (ms).
  static int bin_of(double ms);
  static double bin_centre_ms(int b);

 private:
  void to_histogram();

  std::string name_;
  std::vector<double> ms_;                ///< the times while exact()
  std::vector<std::uint64_t> histogram_;  ///< kBins counts once past kExactSamples, else empty
  std::size_t count_ = 0;
  double sum_ = 0.0;
  double min_ = 0.0;
  double max_ = 0.0;
};

/// Milliseconds elapsed since `start` on the steady clock.
inline double ms_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace aoscan
