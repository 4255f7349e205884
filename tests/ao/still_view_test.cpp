// Tests for ao/still_view: the weights of a still camera's repeated views.
#include "ao/still_view.h"

#include <cmath>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

namespace aoscan {
namespace {

AoConfig still_config(double decay) {
  AoConfig c;
  c.still_view_decay = decay;
  c.still_view_distance_m = 0.01;
  c.still_view_angle_deg = 1.0;
  return c;
}

Pose at(double x, double yaw_deg = 0.0) {
  return Pose(Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix(),
              Eigen::Vector3d(x, 0.0, 0.0));
}

TEST(StillViewWeight, OffByDefaultEveryViewCountsFully) {
  StillViewWeight w{AoConfig{}};
  for (int i = 0; i < 5; ++i) EXPECT_EQ(w.next(at(0.0)), 1.0f);
  EXPECT_EQ(w.repeats(), 0u);
}

TEST(StillViewWeight, RepeatsOfTheAnchorDecayGeometricallyUntilTheCameraMoves) {
  StillViewWeight w(still_config(0.5));
  EXPECT_EQ(w.next(at(0.0)), 1.0f);     // the anchor
  EXPECT_EQ(w.next(at(0.004)), 0.5f);   // 4 mm away: a repeat
  EXPECT_EQ(w.next(at(0.009)), 0.25f);  // 9 mm from the anchor (5 mm from the last frame)
  EXPECT_EQ(w.next(at(0.0, 0.9)), 0.125f);  // turned 0.9 degrees
  EXPECT_EQ(w.repeats(), 3u);
  EXPECT_EQ(w.next(at(0.011)), 1.0f);   // 11 mm from the anchor: a new anchor
  EXPECT_EQ(w.repeats(), 0u);
  EXPECT_EQ(w.next(at(0.011, 1.1)), 1.0f);  // turned 1.1 degrees from it: a new anchor
  EXPECT_EQ(w.next(at(0.011, 1.1)), 0.5f);
  w.reset();
  EXPECT_EQ(w.next(at(0.011, 1.1)), 1.0f);  // after a reset the next frame is an anchor
}

TEST(StillViewWeight, TenSecondsStillAddAtMostDecayOverOneMinusDecayViews) {
  StillViewWeight w(still_config(0.9));
  double total = 0.0;
  for (int i = 0; i < 300; ++i) total += w.next(at(0.0));
  EXPECT_NEAR(total, (1.0 - std::pow(0.9, 300)) / (1.0 - 0.9), 1e-3);  // 1 + 0.9 + 0.81 + ...
  EXPECT_LT(total, 10.0);
  StillViewWeight none(still_config(0.0));  // only the first view of each still period
  EXPECT_EQ(none.next(at(0.0)), 1.0f);
  EXPECT_EQ(none.next(at(0.0)), 0.0f);
  EXPECT_EQ(none.next(at(0.05)), 1.0f);
}

}  // namespace
}  // namespace aoscan
