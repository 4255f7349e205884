/// @file host_cpu_test.cpp
/// @brief Tests for src/core/host_cpu.h: /proc/stat lines parsed to exact sums, old kernels and
/// broken files, the steal share between two readings.
#include "core/host_cpu.h"

#include <string>

#include <gtest/gtest.h>

#include "support/scratch_dir.h"

namespace aoscan {
namespace {

/// Writes `text` to the file `name` of `dir`; returns its path.
std::string write_stat(const testing::ScratchDir& dir, const std::string& name,
                       const std::string& text) {
  const std::string path = dir.file(name);
  testing::write_text(path, text);
  return path;
}

TEST(HostCpu, SumsTheEightTimesAndTakesTheEighthAsSteal) {
  aoscan::testing::ScratchDir scratch;
  const std::string path =
      write_stat(scratch, "stat_full",
                 "cpu  100 2 30 400 5 6 7 50 9 10\ncpu0 1 2 3 4 5 6 7 8 9 10\nintr 1\n");
  const auto t = read_host_cpu_times(path);
  ASSERT_TRUE(t.has_value());
  EXPECT_EQ(t->total, 100u + 2 + 30 + 400 + 5 + 6 + 7 + 50);  // guest times are not added
  EXPECT_EQ(t->steal, 50u);
}

TEST(HostCpu, AKernelWithoutStealReadsAsNone) {
  aoscan::testing::ScratchDir scratch;
  const auto t = read_host_cpu_times(write_stat(scratch, "stat_old", "cpu 10 0 5 85\n"));
  ASSERT_TRUE(t.has_value());
  EXPECT_EQ(t->total, 100u);
  EXPECT_EQ(t->steal, 0u);
}

TEST(HostCpu, MissingOrBrokenFilesGiveNothing) {
  aoscan::testing::ScratchDir scratch;
  EXPECT_FALSE(read_host_cpu_times("/nonexistent/aoscan/stat").has_value());
  EXPECT_FALSE(read_host_cpu_times(write_stat(scratch, "stat_empty", "")).has_value());
  EXPECT_FALSE(read_host_cpu_times(write_stat(scratch, "stat_cpu0", "cpu0 1 2 3 4\n")).has_value());
  EXPECT_FALSE(read_host_cpu_times(write_stat(scratch, "stat_short", "cpu 1 2 x\n")).has_value());
}

TEST(HostCpu, StealPercentBetweenTwoReadings) {
  const HostCpuTimes a{1000, 100}, b{1400, 160};
  const auto p = steal_percent(a, b);
  ASSERT_TRUE(p.has_value());
  EXPECT_DOUBLE_EQ(*p, 15.0);                     // 60 of 400 ticks
  EXPECT_FALSE(steal_percent(a, a).has_value());  // no time passed
  EXPECT_FALSE(steal_percent(b, a).has_value());  // backwards
  EXPECT_FALSE(steal_percent(std::nullopt, b).has_value());
}

TEST(HostCpu, ThisMachineReportsAShareWithinRange) {
  const auto before = read_host_cpu_times();
  if (!before) GTEST_SKIP() << "no /proc/stat here";
  volatile double sink = 0;
  for (int i = 0; i < 20000000; ++i) sink = sink + 1e-9 * i;  // let the counters move
  const auto p = steal_percent(before, read_host_cpu_times());
  if (!p) GTEST_SKIP() << "the counters did not move";
  EXPECT_GE(*p, 0.0);
  EXPECT_LE(*p, 100.0);
}

}  // namespace
}  // namespace aoscan
