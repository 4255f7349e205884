/// @file ao_load_shedder_test.cpp
/// @brief Tests for src/pipeline/ao_load_shedder.h: no skipping without drops, odd intervals
/// widened by drops up to the maximum, narrowed after calm frames.
#include "pipeline/ao_load_shedder.h"

#include <vector>

#include <gtest/gtest.h>

namespace aoscan {
namespace {

/// Which of `n` frames carrying the drop count `drops` are taken.
std::vector<bool> take_run(AoLoadShedder& s, std::size_t drops, int n) {
  std::vector<bool> taken;
  for (int i = 0; i < n; ++i) taken.push_back(s.take(drops));
  return taken;
}

TEST(AoLoadShedder, WithoutDropsEveryFrameIsTaken) {
  AoLoadShedder s(5);
  for (bool t : take_run(s, 0, 200)) ASSERT_TRUE(t);
  EXPECT_EQ(s.interval(), 1);
  EXPECT_EQ(s.skipped(), 0u);
}

TEST(AoLoadShedder, DropsWidenTheIntervalInOddStepsUpToTheMaximum) {
  AoLoadShedder s(5);
  EXPECT_TRUE(s.take(1));  // a new drop: interval 3, this frame opens it
  EXPECT_EQ(s.interval(), 3);
  EXPECT_EQ(take_run(s, 1, 5), (std::vector<bool>{false, false, true, false, false}));
  EXPECT_TRUE(s.take(2));  // another drop: interval 5
  EXPECT_EQ(s.interval(), 5);
  s.take(7);  // more drops: stays at the maximum
  EXPECT_EQ(s.interval(), 5);
  EXPECT_GT(s.skipped(), 0u);
}

TEST(AoLoadShedder, CalmFramesNarrowTheIntervalAgain) {
  AoLoadShedder s(3);
  s.take(4);
  ASSERT_EQ(s.interval(), 3);
  const std::vector<bool> calm = take_run(s, 4, AoLoadShedder::kCalmFrames - 1);
  EXPECT_EQ(s.interval(), 3);
  int taken = 0;
  for (bool t : calm) taken += t;
  EXPECT_EQ(taken, 9);  // every 3rd of the 29 frames after the one that opened the interval
  s.take(4);  // the kCalmFrames-th frame without a new drop
  EXPECT_EQ(s.interval(), 1);
  for (bool t : take_run(s, 4, 20)) ASSERT_TRUE(t);
}

TEST(AoLoadShedder, MaximumOneOrEvenValues) {
  AoLoadShedder never(1);
  for (bool t : take_run(never, 9, 3)) EXPECT_TRUE(t);
  never.take(10);
  EXPECT_EQ(never.interval(), 1);
  AoLoadShedder even(4);  // counts as 3
  even.take(1);
  even.take(2);
  EXPECT_EQ(even.interval(), 3);
}

}  // namespace
}  // namespace aoscan
