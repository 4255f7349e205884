// Tests for src/sim/synth_scanner.cpp: exact range maps of a plane, the noise model's spread, and
// independence from the thread count.
#include "sim/synth_scanner.h"

#include <cmath>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

namespace aoscan {
namespace {

TEST(SynthScanner, AnEquirectangularScanOfAWallLiesOnTheWall) {
  // The `plane` scene's wall is y = 0 (normal -y) for |x|, |z| <= 10; the scanner stands 2 m in
  // front of it, so the rays with a positive y component that leave within 10 m hit it.
  const AnalyticScene scene = AnalyticScene::make("plane");
  const Pose T(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.5, -2.0, 0.3));
  RangeMap map;
  render_scan(scene, ScanCamera::make_equirectangular(90), T, 0.1, 100.0, ScannerNoise{}, map);
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < map.camera.width; ++x) {
      // Independently: does the pixel's ray meet the 20 x 20 m wall within range?
      const Eigen::Vector3d ray = map.camera.pixel_ray(x, y);
      const double t = ray.y() > 0.0 ? 2.0 / ray.y() : -1.0;
      const Eigen::Vector3d hit = T.translation() + t * ray;
      const bool expected =
          t > 0.0 && t <= 100.0 && std::abs(hit.x()) <= 10.0 && std::abs(hit.z()) <= 10.0;
      ASSERT_EQ(map.has_point(x, y), expected) << x << " " << y;
      if (!expected) continue;
      const Eigen::Vector3d p_world = T * map.points(x, y).cast<double>();
      EXPECT_NEAR(p_world.y(), 0.0, 1e-5);
      EXPECT_NEAR((p_world - hit).norm(), 0.0, 1e-4);
      EXPECT_NEAR(map.normals(x, y).y(), -1.0f, 1e-6f);
    }
}

TEST(SynthScanner, RangeNoiseHasItsStatedSpreadAndIsTheSameOnAnyThreadCount) {
  const AnalyticScene scene = AnalyticScene::make("plane");
  const Pose T(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.0, -3.0, 0.0));
  const ScanCamera camera =
      ScanCamera::make_pinhole(Intrinsics{160, 120, 120.0, 120.0, 79.5, 59.5});
  // The pinhole camera looks along +z: turn it to look along +y at the wall.
  const Eigen::Matrix3d look_y = (Eigen::Matrix3d() << 1, 0, 0, 0, 0, 1, 0, -1, 0).finished();
  const Pose T_look(look_y, T.translation());
  ScannerNoise noise;
  noise.sigma_m = 0.002;
  noise.sigma_per_m = 0.001;
  RangeMap exact, noisy, one_thread;
  render_scan(scene, camera, T_look, 0.1, 50.0, ScannerNoise{}, exact);
  render_scan(scene, camera, T_look, 0.1, 50.0, noise, noisy);
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    render_scan(scene, camera, T_look, 0.1, 50.0, noise, one_thread);
  }
  double sum_sq = 0.0, expected_sq = 0.0;
  int n = 0;
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) {
      ASSERT_TRUE(exact.has_point(x, y));
      EXPECT_EQ(noisy.points(x, y), one_thread.points(x, y));
      const double r = exact.points(x, y).cast<double>().norm();
      const double e = noisy.points(x, y).cast<double>().norm() - r;
      const double sigma = 0.002 + 0.001 * r;
      sum_sq += e * e;
      expected_sq += sigma * sigma;
      ++n;
    }
  EXPECT_NEAR(std::sqrt(sum_sq / n), std::sqrt(expected_sq / n), 0.05 * std::sqrt(expected_sq / n));
}

}  // namespace
}  // namespace aoscan
