// Tests for src/core/intrinsics.h and src/core/pose.h.
#include <gtest/gtest.h>

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/pose.h"

namespace aoscan {
namespace {

TEST(Intrinsics, ProjectUnprojectRoundTrip) {
  const Intrinsics k{640, 480, 585.0, 580.0, 320.0, 240.0};
  const Eigen::Vector3d p(0.3, -0.2, 1.7);
  const Eigen::Vector2d uv = k.project(p);
  EXPECT_NEAR((k.unproject(uv.x(), uv.y(), p.z()) - p).norm(), 0.0, 1e-12);
  const Eigen::Vector2d centre = k.project({0, 0, 2});
  EXPECT_DOUBLE_EQ(centre.x(), 320.0);
  EXPECT_DOUBLE_EQ(centre.y(), 240.0);
}

TEST(Intrinsics, ImplausibleNamesThePrincipalPointOrTheFieldOfView) {
  EXPECT_EQ(Intrinsics({640, 480, 525.0, 525.0, 319.5, 239.5}).implausible(), "");
  EXPECT_EQ(Intrinsics({640, 480, 525.0, 525.0, 640.0, 0.0}).implausible(), "");  // on the edge
  EXPECT_EQ(Intrinsics({640, 480, 525.0, 525.0, -1.0, 239.5}).implausible(),
            "cx -1 lies outside the image (0 to 640)");
  EXPECT_EQ(Intrinsics({640, 480, 525.0, 525.0, 319.5, 480.5}).implausible(),
            "cy 480.5 lies outside the image (0 to 480)");
  // 170 degrees across 640 pixels: f = 320 / tan(85 deg) = 27.997 px.
  EXPECT_EQ(Intrinsics({640, 480, 28.0, 525.0, 319.5, 239.5}).implausible(), "");
  EXPECT_EQ(Intrinsics({640, 480, 27.9, 525.0, 319.5, 239.5}).implausible(),
            "fx 27.9 gives a field of view over 170 degrees across 640 pixels");
  EXPECT_EQ(Intrinsics({640, 480, 525.0, 20.0, 319.5, 239.5}).implausible(),
            "fy 20 gives a field of view over 170 degrees across 480 pixels");
}

TEST(Intrinsics, PyramidScalingKeepsRaysThroughBlockCentres) {
  const Intrinsics k{640, 480, 525.0, 525.0, 319.5, 239.5};
  const Intrinsics k1 = k.scaled(1);
  EXPECT_EQ(k1.width, 320);
  EXPECT_EQ(k1.height, 240);
  EXPECT_DOUBLE_EQ(k1.fx, 262.5);
  // The ray through level-1 pixel (x, y) is the mean ray of level-0 pixels 2x..2x+1.
  const Eigen::Vector3d r1 = k1.unproject(10.0, 20.0, 1.0);
  const Eigen::Vector3d r0 = k.unproject(20.5, 40.5, 1.0);
  EXPECT_NEAR((r1 - r0).norm(), 0.0, 1e-12);
  const Intrinsics k2 = k.scaled(2);
  EXPECT_EQ(k2.width, 160);
  EXPECT_NEAR((k2.unproject(3.0, 4.0, 1.0) - k.unproject(13.5, 17.5, 1.0)).norm(), 0.0, 1e-12);
}

TEST(Intrinsics, Validity) {
  EXPECT_TRUE(Intrinsics{}.valid());
  Intrinsics bad;
  bad.fx = -1;
  EXPECT_FALSE(bad.valid());
  bad = Intrinsics{};
  bad.cy = std::nan("");
  EXPECT_FALSE(bad.valid());
}

TEST(Pose, ComposeAndInverse) {
  const Pose T_world_a = Pose::from_quaternion(
      {1, 2, 3}, Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 1, 0).normalized())));
  const Pose T_a_b = Pose::from_quaternion({-0.5, 0.1, 0.2},
                                           Eigen::Quaterniond(Eigen::AngleAxisd(1.1, Eigen::Vector3d::UnitZ())));
  const Eigen::Vector3d p_b(0.4, -0.7, 2.0);
  const Eigen::Vector3d direct = T_world_a * (T_a_b * p_b);
  EXPECT_NEAR(((T_world_a * T_a_b) * p_b - direct).norm(), 0.0, 1e-12);
  EXPECT_NEAR(((T_world_a.inverse() * T_world_a) * p_b - p_b).norm(), 0.0, 1e-12);
  EXPECT_TRUE(T_world_a.finite());
  const Pose back = Pose::from_matrix(T_world_a.matrix());
  EXPECT_NEAR((back.matrix() - T_world_a.matrix()).norm(), 0.0, 1e-15);
}

TEST(Image, ResizeFillAndAccess) {
  Image<float> img(4, 3, 1.5f);
  EXPECT_EQ(img.size(), 12u);
  img(3, 2) = 7.0f;
  EXPECT_EQ(img.row(2)[3], 7.0f);
  EXPECT_TRUE(img.contains(3, 2));
  EXPECT_FALSE(img.contains(4, 0));
  img.resize(2, 2, 0.0f);
  EXPECT_EQ(img.width(), 2);
  EXPECT_EQ(img(1, 1), 0.0f);
}

}  // namespace
}  // namespace aoscan
