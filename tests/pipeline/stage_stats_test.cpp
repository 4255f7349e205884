// Tests for pipeline/stage_stats: exact summaries while the samples fit, a bounded histogram
// after, within its stated error of the exact nearest-rank percentiles.
#include "pipeline/stage_stats.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "core/percentile.h"

namespace aoscan {
namespace {

/// The summary of `ms` computed the plain way: sort everything, nearest rank.
TimingSummary exact_summary(std::vector<double> ms) {
  std::sort(ms.begin(), ms.end());
  TimingSummary s;
  s.count = ms.size();
  s.ms_mean = std::accumulate(ms.begin(), ms.end(), 0.0) / static_cast<double>(ms.size());
  s.ms_p50 = nearest_rank(ms, 0.50);
  s.ms_p95 = nearest_rank(ms, 0.95);
  s.ms_max = ms.back();
  return s;
}

/// Stage-like times: log-normal around 8 ms with a tail, a few stalls of seconds, a few zeros.
std::vector<double> stage_times(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::lognormal_distribution<double> body(std::log(8.0), 0.6);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> ms(n);
  for (double& t : ms) {
    const double r = u(rng);
    t = r < 0.001 ? 0.0 : r > 0.999 ? 1000.0 + 4000.0 * u(rng) : body(rng);
  }
  return ms;
}

TEST(StageStats, EmptyIsAllZero) {
  const StageStats s("x");
  const TimingSummary t = s.summary();
  EXPECT_EQ(t.count, 0u);
  EXPECT_EQ(t.ms_mean, 0.0);
  EXPECT_EQ(t.ms_p50, 0.0);
  EXPECT_EQ(t.ms_p95, 0.0);
  EXPECT_EQ(t.ms_max, 0.0);
  EXPECT_EQ(s.min_ms(), 0.0);
  EXPECT_TRUE(s.exact());
}

TEST(StageStats, ExactWhileTheSamplesFit) {
  const std::vector<double> ms = stage_times(StageStats::kExactSamples, 1);
  StageStats s("track");
  for (const double t : ms) s.add_ms(t);
  ASSERT_TRUE(s.exact());
  const TimingSummary got = s.summary(), want = exact_summary(ms);
  EXPECT_EQ(got.count, want.count);
  EXPECT_EQ(got.ms_mean, want.ms_mean);
  EXPECT_EQ(got.ms_p50, want.ms_p50);
  EXPECT_EQ(got.ms_p95, want.ms_p95);
  EXPECT_EQ(got.ms_max, want.ms_max);
  EXPECT_EQ(s.min_ms(), *std::min_element(ms.begin(), ms.end()));
}

TEST(StageStats, PastTheExactSamplesPercentilesStayWithinHalfAPercent) {
  // An hour of frames at 30 Hz: 108 000 times, in the histogram after the first 16 384.
  const std::vector<double> ms = stage_times(108000, 2);
  StageStats s("track");
  for (const double t : ms) s.add_ms(t);
  ASSERT_FALSE(s.exact());
  const TimingSummary got = s.summary(), want = exact_summary(ms);
  EXPECT_EQ(got.count, want.count);
  EXPECT_NEAR(got.ms_mean, want.ms_mean, 1e-9 * want.ms_mean);
  EXPECT_EQ(got.ms_max, want.ms_max);
  // Bin width 10^(1/256) - 1 = 0.9 %: the centre is within 0.45 % of anything in the bin.
  EXPECT_NEAR(got.ms_p50, want.ms_p50, 0.0046 * want.ms_p50);
  EXPECT_NEAR(got.ms_p95, want.ms_p95, 0.0046 * want.ms_p95);
  EXPECT_EQ(s.min_ms(), 0.0);
}

TEST(StageStats, PercentilesAreClampedToTheTimesSeen) {
  // Every time the same: the histogram's bin centre must not stand for a time never seen.
  StageStats s("filter");
  for (std::size_t i = 0; i <= StageStats::kExactSamples; ++i) s.add_ms(7.0);
  ASSERT_FALSE(s.exact());
  EXPECT_EQ(s.summary().ms_p50, 7.0);
  EXPECT_EQ(s.summary().ms_p95, 7.0);
  EXPECT_EQ(s.summary().ms_mean, 7.0);
}

TEST(StageStats, BinsCoverTheRangeAndItsEdges) {
  EXPECT_EQ(StageStats::bin_of(0.0), 0);
  EXPECT_EQ(StageStats::bin_of(-1.0), 0);
  EXPECT_EQ(StageStats::bin_of(std::nan("")), 0);
  EXPECT_EQ(StageStats::bin_of(1e12), StageStats::kBins - 1);
  EXPECT_EQ(StageStats::bin_of(std::numeric_limits<double>::infinity()), StageStats::kBins - 1);
  for (const double t : {0.0021, 0.5, 1.0, 8.3, 33.3, 999.0, 86400000.0 / 100}) {
    const int b = StageStats::bin_of(t);
    EXPECT_NEAR(StageStats::bin_centre_ms(b), t, 0.0046 * t) << t;
    EXPECT_LT(StageStats::bin_of(t), StageStats::bin_of(t * 1.01)) << t;
  }
}

TEST(StageStats, MergeEqualsAddingEveryTime) {
  // Both sides exact, one side past the exact samples, both past it: the merge summarises as one
  // StageStats given all the times would (the bench merges its repeated runs).
  for (const auto& [na, nb] : {std::pair<std::size_t, std::size_t>{100, 200},
                              {20000, 300},
                              {300, 20000},
                              {20000, 30000}}) {
    const std::vector<double> a = stage_times(na, 3), b = stage_times(nb, 4);
    StageStats merged("m"), other("o"), whole("w");
    for (const double t : a) merged.add_ms(t);
    for (const double t : b) other.add_ms(t);
    merged.merge(other);
    for (const double t : a) whole.add_ms(t);
    for (const double t : b) whole.add_ms(t);
    const TimingSummary got = merged.summary(), want = whole.summary();
    EXPECT_EQ(merged.exact(), whole.exact());
    EXPECT_EQ(got.count, want.count);
    EXPECT_NEAR(got.ms_mean, want.ms_mean, 1e-9 * want.ms_mean);
    EXPECT_EQ(got.ms_p50, want.ms_p50) << na << " + " << nb;
    EXPECT_EQ(got.ms_p95, want.ms_p95) << na << " + " << nb;
    EXPECT_EQ(got.ms_max, want.ms_max);
    EXPECT_EQ(merged.min_ms(), whole.min_ms());
  }
}

}  // namespace
}  // namespace aoscan
