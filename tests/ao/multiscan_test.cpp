// Tests for src/ao/multiscan.cpp: Eq. 6-12 on scans of planes with known poses and SSAO values.
#include "ao/multiscan.h"

#include <cmath>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "ao/ssao.h"
#include "core/status.h"

namespace aoscan {
namespace {

const Intrinsics kCamera{32, 24, 30.0, 30.0, 15.5, 11.5};

/// A pinhole scan of the plane z = depth (scanner frame) at pose T, with grid normals, constant
/// SSAO `ao` and border distance `border_px` everywhere.
ScanAo plane_scan(const Pose& T, float depth, float ao, float border_px) {
  ScanAo s;
  range_map_from_depth(Image<float>(kCamera.width, kCamera.height, depth), kCamera, s.map);
  compute_range_map_normals(s.map);
  s.map.T_world_scanner = T;
  s.ssao.resize(kCamera.width, kCamera.height, ao);
  s.border_px.resize(kCamera.width, kCamera.height, border_px);
  return s;
}

MultiScanParams no_border() {
  MultiScanParams p;
  p.border_weight = false;
  p.d_min_m = 0.5f;
  p.d_max_m = 5.0f;
  return p;
}

TEST(MultiScan, OneScanKeepsItsOwnSsao) {
  std::vector<ScanAo> scans = {plane_scan(Pose::identity(), 2.0f, 0.0f, 100.0f)};
  for (int y = 0; y < kCamera.height; ++y)
    for (int x = 0; x < kCamera.width; ++x) scans[0].ssao(x, y) = 0.01f * ((x * 7 + y * 3) % 97);
  std::vector<Image<float>> mvao;
  const MultiScanStats stats = integrate_scans(scans, MultiScanParams{}, mvao);
  EXPECT_EQ(stats.points, kCamera.width * kCamera.height);
  EXPECT_EQ(stats.points_shared, 0);
  ASSERT_EQ(stats.isolated_scans.size(), 1u);
  for (int y = 0; y < kCamera.height; ++y)
    for (int x = 0; x < kCamera.width; ++x) EXPECT_EQ(mvao[0](x, y), scans[0].ssao(x, y));
}

TEST(MultiScan, TwoScansFromOnePoseAverageWithEqualWeights) {
  std::vector<ScanAo> scans = {plane_scan(Pose::identity(), 2.0f, 0.2f, 100.0f),
                               plane_scan(Pose::identity(), 2.0f, 0.8f, 100.0f)};
  std::vector<Image<float>> mvao;
  const MultiScanStats stats = integrate_scans(scans, no_border(), mvao);
  EXPECT_EQ(stats.pairs_tested, 2);
  EXPECT_EQ(stats.points_shared, 2 * kCamera.width * kCamera.height);
  EXPECT_TRUE(stats.isolated_scans.empty());
  for (int i = 0; i < 2; ++i)
    for (int y = 0; y < kCamera.height; ++y)
      for (int x = 0; x < kCamera.width; ++x) EXPECT_NEAR(mvao[i](x, y), 0.5f, 1e-6f);
}

TEST(MultiScan, TheBorderWeightScalesBySixtyFourPixels) {
  // Scan B is 32 px from its border everywhere: w_b = 32 / 64 = 0.5 (alpha = 1 at one pose), so
  // MVAO = (1 * 0.2 + 0.5 * 0.8) / 1.5 = 0.4; without w_b it is 0.5.
  std::vector<ScanAo> scans = {plane_scan(Pose::identity(), 2.0f, 0.2f, 1000.0f),
                               plane_scan(Pose::identity(), 2.0f, 0.8f, 32.0f)};
  MultiScanParams params = no_border();
  params.border_weight = true;
  std::vector<Image<float>> mvao;
  integrate_scans(scans, params, mvao);
  EXPECT_NEAR(mvao[0](16, 12), 0.4f, 1e-6f);
  params.border_weight = false;
  integrate_scans(scans, params, mvao);
  EXPECT_NEAR(mvao[0](16, 12), 0.5f, 1e-6f);
}

TEST(MultiScan, ANearerScanOutweighsAFartherOne) {
  // Scan B looks at the same plane from 1 m farther back: its samples weigh w_d(3 m) against
  // w_d(2 m) (Eq. 10); at the optical axis w_n = 1 for both.
  const Pose T_b(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.0, 0.0, -1.0));
  std::vector<ScanAo> scans = {plane_scan(Pose::identity(), 2.0f, 0.2f, 100.0f),
                               plane_scan(T_b, 3.0f, 0.8f, 100.0f)};
  const MultiScanParams params = no_border();
  std::vector<Image<float>> mvao;
  integrate_scans(scans, params, mvao);
  // Pixel (15.5, 11.5) is the axis; take pixel (15, 11) of A and the exact weights of the samples.
  const Eigen::Vector3f p_a = scans[0].map.points(15, 11);
  const Eigen::Vector3f q = p_a + Eigen::Vector3f(0.0f, 0.0f, 1.0f);  // in B's frame
  int bx = 0, by = 0;
  ASSERT_TRUE(scans[1].map.camera.pixel_of(q, bx, by));
  const float w_a = view_weight(p_a, scans[0].map.normals(15, 11), 0.5f, 5.0f);
  const float w_b =
      view_weight(scans[1].map.points(bx, by), scans[1].map.normals(bx, by), 0.5f, 5.0f);
  EXPECT_GT(w_a, w_b);
  EXPECT_NEAR(mvao[0](15, 11), (0.2f * w_a + 0.8f * w_b) / (w_a + w_b), 1e-6f);
}

TEST(MultiScan, ASurfaceSeenFromBehindDoesNotCount) {
  // Scan B looks at the plane from its other side: its points face away from scanner A.
  const Pose T_b(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()).toRotationMatrix(),
                 Eigen::Vector3d(0.0, 0.0, 4.0));
  std::vector<ScanAo> scans = {plane_scan(Pose::identity(), 2.0f, 0.2f, 100.0f),
                               plane_scan(T_b, 2.0f, 0.8f, 100.0f)};
  std::vector<Image<float>> mvao;
  const MultiScanStats stats = integrate_scans(scans, no_border(), mvao);
  EXPECT_EQ(stats.pairs_tested, 2);
  EXPECT_EQ(stats.points_shared, 0);
  EXPECT_EQ(mvao[0](16, 12), 0.2f);
  EXPECT_EQ(mvao[1](16, 12), 0.8f);
}

TEST(MultiScan, ScansThatCannotMeetAreNotPaired) {
  const Pose far(Eigen::Matrix3d::Identity(), Eigen::Vector3d(100.0, 0.0, 0.0));
  std::vector<ScanAo> scans = {plane_scan(Pose::identity(), 2.0f, 0.2f, 100.0f),
                               plane_scan(far, 2.0f, 0.8f, 100.0f)};
  std::vector<Image<float>> mvao;
  const MultiScanStats stats = integrate_scans(scans, no_border(), mvao);
  EXPECT_EQ(stats.pairs_tested, 0);
  EXPECT_EQ(stats.pairs_skipped, 2);
  EXPECT_EQ(stats.isolated_scans.size(), 2u);
}

TEST(MultiScan, NoisyScansOfOneSurfaceFindEachOtherWithinTheirNoise) {
  // Scan B measures the plane 0.2 m behind where A does: farther than 2 t (t = the point radius,
  // 2 m / 30 px = 0.067 m at this small camera; 0.073 m for B), so without their noise the two
  // share no point. With a noise sigma of 0.06 m each, 2 x 1.5 x sqrt(2) x 0.06 = 0.255 m
  // covers every pair (0.200-0.238 m apart along the rays), and the boxes, 0.2 m apart, are
  // paired; with 0.04 m (0.170 m) neither.
  const auto with_noise = [](ScanAo s, float sigma) {
    s.map.noise.sigma_m.fill(sigma);
    return s;
  };
  const ScanAo a = plane_scan(Pose::identity(), 2.0f, 0.2f, 100.0f);
  const ScanAo b = plane_scan(Pose::identity(), 2.2f, 0.8f, 100.0f);
  const int pixels = kCamera.width * kCamera.height;
  std::vector<Image<float>> mvao;
  std::vector<ScanAo> scans = {a, b};
  MultiScanStats stats = integrate_scans(scans, no_border(), mvao);
  EXPECT_EQ(stats.pairs_skipped, 2);
  EXPECT_EQ(stats.points_shared, 0);
  scans = {with_noise(a, 0.04f), with_noise(b, 0.04f)};
  stats = integrate_scans(scans, no_border(), mvao);
  EXPECT_EQ(stats.pairs_skipped, 2);
  EXPECT_EQ(stats.points_shared, 0);
  scans = {with_noise(a, 0.06f), with_noise(b, 0.06f)};
  stats = integrate_scans(scans, no_border(), mvao);
  EXPECT_EQ(stats.pairs_tested, 2);
  EXPECT_EQ(stats.points_shared, 2 * pixels);
  EXPECT_GT(mvao[0](16, 12), 0.2f);
  EXPECT_LT(mvao[0](16, 12), 0.8f);

  // The test itself at pixel (16, 12), 0.2001 m apart: accepted when 2 x 1.5 x sqrt(sigma_i^2 +
  // sigma_j^2) exceeds that, with scan B's noise 0.05 m: sigma_i = 0.05 (0.212 m) yes, 0 (0.150 m)
  // no; a scan without a noise (all 0) keeps the 2 t test.
  const ScanAo noisy_b = with_noise(b, 0.05f);
  const Eigen::Vector3f q = a.map.points(16, 12);
  const float rad = point_radius(a.map.camera, 2.0f);
  const Eigen::Vector3f scanner = Eigen::Vector3f::Zero();
  const ScanNoise noisy = with_noise(a, 0.05f).map.noise, quiet;
  int px = 0, py = 0;
  EXPECT_TRUE(corresponding_pixel(noisy_b.map, q, rad, noisy, 2.0f, scanner, px, py));
  EXPECT_EQ(px, 16);
  EXPECT_EQ(py, 12);
  EXPECT_FALSE(corresponding_pixel(noisy_b.map, q, rad, quiet, 2.0f, scanner, px, py));
  EXPECT_FALSE(corresponding_pixel(b.map, q, rad, quiet, 2.0f, scanner, px, py));
  EXPECT_TRUE(corresponding_pixel(b.map, q, 0.101f, quiet, 2.0f, scanner, px, py));
}

/// Removes pixel (x, y)'s point from `scan` (a hole of its map).
void make_hole(ScanAo& scan, int x, int y) {
  scan.map.points(x, y).setZero();
  scan.map.normals(x, y).setZero();
}

TEST(MultiScan, APointOverAHoleTakesTheNearestMeasuredNeighbour) {
  // Scan B sees the same plane from the same pose with a hole at A's pixel (16, 12) and at three
  // of its four side neighbours: the point nearest to A's is B's (16, 13) (one pixel away; the
  // diagonals are sqrt(2) away), whose SSAO joins with its weight.
  std::vector<ScanAo> scans = {plane_scan(Pose::identity(), 2.0f, 0.2f, 100.0f),
                               plane_scan(Pose::identity(), 2.0f, 0.8f, 100.0f)};
  for (int y = 0; y < kCamera.height; ++y)
    for (int x = 0; x < kCamera.width; ++x) scans[1].ssao(x, y) = 0.01f * ((x * 7 + y * 3) % 97);
  for (const auto& [x, y] : {std::pair{16, 12}, {16, 11}, {15, 12}, {17, 12}})
    make_hole(scans[1], x, y);
  std::vector<Image<float>> mvao;
  const MultiScanStats stats = integrate_scans(scans, no_border(), mvao);
  // Every point of A finds one of B (B's holes have measured neighbours within 2 t).
  EXPECT_EQ(stats.points_shared, 2 * kCamera.width * kCamera.height - 4);
  const float w_a =
      view_weight(scans[0].map.points(16, 12), scans[0].map.normals(16, 12), 0.5f, 5.0f);
  const float w_b =
      view_weight(scans[1].map.points(16, 13), scans[1].map.normals(16, 13), 0.5f, 5.0f);
  EXPECT_NEAR(mvao[0](16, 12), (0.2f * w_a + scans[1].ssao(16, 13) * w_b) / (w_a + w_b), 1e-6f);

  // A 5 x 5 hole in B: A's points over its inner 3 x 3 have no measured neighbour there and keep
  // their SSAO; the others (and all of B's 743 points) are shared.
  for (int y = 10; y <= 14; ++y)
    for (int x = 14; x <= 18; ++x) make_hole(scans[1], x, y);
  const int pixels = kCamera.width * kCamera.height;
  EXPECT_EQ(integrate_scans(scans, no_border(), mvao).points_shared, (pixels - 9) + (pixels - 25));
  EXPECT_EQ(mvao[0](16, 12), 0.2f);
  EXPECT_EQ(mvao[0](15, 11), 0.2f);
  EXPECT_NE(mvao[0](14, 10), 0.2f);
}

TEST(MultiScan, TheNeighbourhoodAveragesTheNByNPixelsWithTheirWeights) {
  std::vector<ScanAo> scans = {plane_scan(Pose::identity(), 2.0f, 0.0f, 100.0f)};
  for (int y = 0; y < kCamera.height; ++y)
    for (int x = 0; x < kCamera.width; ++x) scans[0].ssao(x, y) = (x + y) % 2 ? 1.0f : 0.0f;
  MultiScanParams params = no_border();
  params.neighbourhood = 3;
  std::vector<Image<float>> mvao;
  integrate_scans(scans, params, mvao);
  double sum = 0.0, weights = 0.0;
  for (int y = 9; y <= 11; ++y)
    for (int x = 19; x <= 21; ++x) {
      const float w =
          view_weight(scans[0].map.points(x, y), scans[0].map.normals(x, y), 0.5f, 5.0f);
      sum += static_cast<double>(w) * scans[0].ssao(x, y);
      weights += w;
    }
  EXPECT_NEAR(mvao[0](20, 10), sum / weights, 1e-6);
  params.neighbourhood = 4;
  EXPECT_THROW(integrate_scans(scans, params, mvao), Error);
}

}  // namespace
}  // namespace aoscan
