// Tests for src/geometry/scan_camera.cpp and src/geometry/range_map.cpp: projections with exact
// answers, the paper's equirectangular map size, rasterising clouds, and normals of planes.
#include "geometry/scan_camera.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "core/status.h"
#include "geometry/range_map.h"

namespace aoscan {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(ScanCamera, EquirectangularAxesLandWhereTheConventionSays) {
  const ScanCamera c = ScanCamera::make_equirectangular(100);
  ASSERT_TRUE(c.valid());
  float u = 0, v = 0;
  ASSERT_TRUE(c.project({2.0f, 0.0f, 0.0f}, u, v));  // +x: azimuth 0 on the horizon
  EXPECT_FLOAT_EQ(u, 100.0f);
  EXPECT_FLOAT_EQ(v, 50.0f);
  ASSERT_TRUE(c.project({0.0f, 3.0f, 0.0f}, u, v));  // +y: azimuth pi / 2
  EXPECT_FLOAT_EQ(u, 150.0f);
  ASSERT_TRUE(c.project({0.0f, 0.0f, 1.0f}, u, v));  // the zenith is the top row
  EXPECT_FLOAT_EQ(v, 0.0f);
  EXPECT_FALSE(c.project({0.0f, 0.0f, 0.0f}, u, v));  // the scanner itself
  EXPECT_FLOAT_EQ(c.depth({3.0f, 4.0f, 0.0f}), 5.0f);
  EXPECT_FLOAT_EQ(c.pixels_per_metre_at_1m(), static_cast<float>(200.0 / (2.0 * kPi)));
}

TEST(ScanCamera, EveryEquirectangularPixelCentreMapsBackToItsPixel) {
  const ScanCamera c = ScanCamera::make_equirectangular(37);
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) {
      const double phi = (x + 0.5) / c.width * 2.0 * kPi - kPi;
      const double theta = (y + 0.5) / c.height * kPi;
      const Eigen::Vector3f p(static_cast<float>(std::sin(theta) * std::cos(phi) * 4.0),
                              static_cast<float>(std::sin(theta) * std::sin(phi) * 4.0),
                              static_cast<float>(std::cos(theta) * 4.0));
      int px = -1, py = -1;
      ASSERT_TRUE(c.pixel_of(p, px, py));
      EXPECT_EQ(px, x);
      EXPECT_EQ(py, y);
    }
}

TEST(ScanCamera, PinholeProjectsLikeItsIntrinsics) {
  const Intrinsics k{64, 48, 60.0, 61.0, 31.5, 23.5};
  const ScanCamera c = ScanCamera::make_pinhole(k);
  ASSERT_TRUE(c.valid());
  const Eigen::Vector3f p(0.3f, -0.2f, 2.0f);
  float u = 0, v = 0;
  ASSERT_TRUE(c.project(p, u, v));
  const Eigen::Vector2d expected = k.project(p.cast<double>());
  EXPECT_NEAR(u, expected.x(), 1e-4);
  EXPECT_NEAR(v, expected.y(), 1e-4);
  int x = 0, y = 0;
  ASSERT_TRUE(c.pixel_of(p, x, y));
  EXPECT_EQ(x, static_cast<int>(std::lround(expected.x())));
  EXPECT_EQ(y, static_cast<int>(std::lround(expected.y())));
  EXPECT_FALSE(c.project({0.0f, 0.0f, -1.0f}, u, v));
  EXPECT_FALSE(c.pixel_of({10.0f, 0.0f, 1.0f}, x, y));  // far outside the image
  EXPECT_FLOAT_EQ(c.depth(p), 2.0f);
  EXPECT_FLOAT_EQ(point_radius(c, 3.0f), 3.0f / 60.0f);
}

TEST(ScanCamera, TheMapOfAPointCloudIsTwoHByH) {
  // Sec. 7: 2h x h with h = sqrt(pi v / 3); the paper's 3538 x 1769 maps hold about 2.99 M points.
  const ScanCamera c = ScanCamera::equirectangular_for_points(2988000);
  EXPECT_EQ(c.height, 1769);
  EXPECT_EQ(c.width, 3538);
  EXPECT_EQ(ScanCamera::equirectangular_for_points(0).height, 1);
}

TEST(RangeMap, DepthImagePixelsBecomeTheirCameraFramePoints) {
  const Intrinsics k{8, 6, 10.0, 10.0, 3.5, 2.5};
  Image<float> depth(8, 6, 2.0f);
  depth(1, 1) = 0.0f;
  RangeMap map;
  range_map_from_depth(depth, k, map);
  EXPECT_EQ(map.count_points(), 47);
  EXPECT_FALSE(map.has_point(1, 1));
  EXPECT_TRUE(map.points(5, 4).isApprox(Eigen::Vector3f(0.3f, 0.3f, 2.0f)));
  EXPECT_THROW(range_map_from_depth(Image<float>(7, 6, 1.0f), k, map), Error);
}

TEST(RangeMap, RasterisingKeepsTheNearestPointOfEachPixel) {
  RangeMap map;
  map.camera = ScanCamera::make_equirectangular(10);
  const std::vector<Eigen::Vector3f> points = {{3.0f, 0.0f, 0.0f},
                                               {2.0f, 0.0f, 0.0f},
                                               {4.0f, 0.0f, 0.0f},  // one pixel, nearest is 2 m
                                               {0.0f, 0.0f, 0.0f},  // the scanner: skipped
                                               {NAN, 0.0f, 1.0f}};  // not finite: skipped
  const std::vector<Eigen::Vector3f> normals = {
      {1.0f, 0.0f, 0.0f}, {2.0f, 0.0f, 0.0f}, {1.0f, 0.0f, 0.0f}, {0, 0, 1}, {0, 0, 1}};
  EXPECT_EQ(rasterize_points(points, normals, map), 2);
  EXPECT_EQ(map.count_points(), 1);
  int x = 0, y = 0;
  ASSERT_TRUE(map.camera.pixel_of(points[0], x, y));
  EXPECT_EQ(map.points(x, y), Eigen::Vector3f(2.0f, 0.0f, 0.0f));
  EXPECT_EQ(map.normals(x, y), Eigen::Vector3f(-1.0f, 0.0f, 0.0f));  // unit, facing the scanner
  EXPECT_THROW(rasterize_points(points, {{0, 0, 1}}, map), Error);
}

TEST(RangeMap, NormalsOfAFloorUnderALaserScannerPointUp) {
  // The floor z = -1.5 seen by an equirectangular scanner: every grid normal is (0, 0, 1) up to
  // float rounding, including across the azimuth seam; pixels beyond the horizon see nothing.
  RangeMap map;
  map.camera = ScanCamera::make_equirectangular(60);
  std::vector<Eigen::Vector3f> points;
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < map.camera.width; ++x) {
      const double phi = (x + 0.5) / map.camera.width * 2.0 * kPi - kPi;
      const double theta = (y + 0.5) / map.camera.height * kPi;
      if (std::cos(theta) > -0.2) continue;  // up to 11.5 degrees below the horizon
      const double t = -1.5 / std::cos(theta);
      points.emplace_back(static_cast<float>(t * std::sin(theta) * std::cos(phi)),
                          static_cast<float>(t * std::sin(theta) * std::sin(phi)), -1.5f);
    }
  ASSERT_EQ(rasterize_points(points, {}, map), 0);
  compute_range_map_normals(map, 0.2f);
  int with_normal = 0;
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < map.camera.width; ++x) {
      if (!map.has_point(x, y)) {
        EXPECT_EQ(map.normals(x, y), Eigen::Vector3f::Zero());
        continue;
      }
      ++with_normal;
      EXPECT_NEAR(map.normals(x, y).z(), 1.0f, 1e-4f) << x << " " << y;
    }
  EXPECT_EQ(with_normal, static_cast<int>(points.size()));
}

TEST(RangeMap, NoNormalAcrossADepthJump) {
  const Intrinsics k{10, 4, 10.0, 10.0, 4.5, 1.5};
  Image<float> depth(10, 4, 1.0f);
  for (int y = 0; y < 4; ++y)
    for (int x = 5; x < 10; ++x) depth(x, y) = 2.0f;
  RangeMap map;
  range_map_from_depth(depth, k, map);
  compute_range_map_normals(map, 0.05f);
  // Pixels 4 and 5 take their normals from their own side of the jump: both get the plane's
  // normal; a lone column between two jumps (points on a line) gets none.
  EXPECT_NEAR(map.normals(4, 1).z(), -1.0f, 1e-6f);
  EXPECT_NEAR(map.normals(5, 1).z(), -1.0f, 1e-6f);
  for (int y = 0; y < 4; ++y) depth(7, y) = 3.0f;
  range_map_from_depth(depth, k, map);
  compute_range_map_normals(map, 0.05f);
  EXPECT_EQ(map.normals(7, 1), Eigen::Vector3f::Zero());
}

}  // namespace
}  // namespace aoscan
