/// @file kitchen_test.cpp
/// @brief Real-data test of the fusion chain (icp -> integrate -> raycast) on the shared 7-Scenes
/// RedKitchen frames (loop in support/kitchen_fusion.h; its benchmark, which times each kernel
/// over 500 frames, is aoscan-kitchen-bench).
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "support/kitchen_fusion.h"

namespace aoscan {
namespace {

const std::string kKitchen = std::string(AOSCAN_SHARED_DATA_DIR) + "/7scenes-redkitchen";

TEST(Kitchen, TracksFirstFramesLikeTheReferenceKinectFusion) {
  if (!test::kitchen_present(kKitchen))
    GTEST_SKIP() << "no " << kKitchen << " (shared data absent)";
  test::KitchenRunOptions options;
  options.max_frames = 20;
  const test::KitchenRunStats s = test::run_kitchen(kKitchen, options);
  for (const std::string& error : s.read_errors) ADD_FAILURE() << error;
  EXPECT_EQ(s.lost, 0);
  // The reference poses are themselves KinectFusion estimates: agreement within 1 cm.
  std::printf("kitchen, 20 frames: ATE %.2f mm against the reference poses\n", 1000 * s.ate_m);
  EXPECT_LT(s.ate_m, 0.01) << "ATE " << s.ate_m;
}

}  // namespace
}  // namespace aoscan
