// Tests for src/ao/scan_ssao.cpp: the per-scan SSAO of range maps, here on maps with holes.
#include "ao/scan_ssao.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "ao/ssao_kernels.h"
#include "core/status.h"
#include "geometry/range_map.h"
#include "sim/synth_scanner.h"
#include "support/geometry_reference.h"

namespace aoscan {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// Mean |a - b| over the pixels where `map` has a point and b is below `below`.
double mean_abs_difference(const RangeMap& map, const Image<float>& a, const Image<float>& b,
                           float below) {
  double sum = 0.0;
  long long n = 0;
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < map.camera.width; ++x)
      if (map.has_point(x, y) && b(x, y) < below) {
        sum += std::abs(a(x, y) - b(x, y));
        ++n;
      }
  return n > 0 ? sum / static_cast<double>(n) : 0.0;
}

TEST(ScanSsao, TheSmoothingSpansAtMostItsShareOfTheRadiusInMetres) {
  // A plane facing a 9 x 9 pinhole camera (fx = 100) whose per-pixel SSAO is 1 but for one dark
  // pixel in the middle: each pixel's smoothed value is 1 - w(d) / sum of w over its window, w
  // the Gaussian exp(-d^2 / (2 sigma^2)) of the pixel's distance d to the dark one, sigma =
  // min(1 px, sigma_m / footprint). At 2 m a pixel spans 2 cm: sigma_m = 2 or 4 cm gives the
  // paper's sigma of 1 px, 1 cm gives 0.5 px; at 4 m, 1 cm gives 0.25 px. A pixel without a
  // normal stays 1 and weighs nothing.
  const Intrinsics k{9, 9, 100.0, 100.0, 4.0, 4.0};
  for (const float depth : {2.0f, 4.0f}) {
    Image<float> z(k.width, k.height, depth);
    RangeMap map;
    range_map_from_depth(z, k, map);
    map.normals.fill(Eigen::Vector3f(0.0f, 0.0f, -1.0f));
    map.normals(0, 4).setZero();  // no normal: no SSAO of its own, no weight in its neighbours'
    Image<float> raw(k.width, k.height, 1.0f);
    raw(4, 4) = 0.0f;
    raw(0, 4) = 0.0f;
    for (const float sigma_m : {0.01f, 0.02f, 0.04f}) {
      Image<float> ao;
      smooth_scan_ssao(map, raw, sigma_m, ao);
      const double sigma = std::min(1.0, static_cast<double>(sigma_m) / (depth / 100.0));
      for (int y = 0; y < k.height; ++y)
        for (int x = 0; x < k.width; ++x) {
          if (x == 0 && y == 4) {
            EXPECT_EQ(ao(x, y), 1.0f);
            continue;
          }
          double sum = 0.0, dark = 0.0;
          for (int sy = y - 2; sy <= y + 2; ++sy)
            for (int sx = x - 2; sx <= x + 2; ++sx) {
              if (sx < 0 || sy < 0 || sx >= k.width || sy >= k.height || (sx == 0 && sy == 4))
                continue;
              const double d2 = (sx - x) * (sx - x) + (sy - y) * (sy - y);
              const double weight = std::exp(-d2 / (2.0 * sigma * sigma));
              sum += weight;
              if (sx == 4 && sy == 4) dark = weight;
            }
          EXPECT_NEAR(ao(x, y), 1.0 - dark / sum, 2e-6)
              << "depth " << depth << ", sigma_m " << sigma_m << ", pixel " << x << ", " << y;
        }
    }
  }
  Image<float> wrong(3, 3, 1.0f);
  RangeMap map;
  range_map_from_depth(Image<float>(k.width, k.height, 2.0f), k, map);
  Image<float> ao;
  EXPECT_THROW(smooth_scan_ssao(map, wrong, 0.01f, ao), Error);
}

TEST(ScanSsao, SamplesFallingInHolesReadTheNeighbouringPoints) {
  // An exact 640 x 320 laser scan of the room (exact normals), and the same map with half of its
  // pixels emptied at random: the map a cloud rebuilt as in Sec. 7 gives, about two pixels per
  // point. A sample that lands in a hole reads a neighbouring point of the same surface, so the
  // points kept take nearly the SSAO of the full map. Measured, mean |difference| over all the
  // points kept / over those whose AO in the full map is below 0.9: 0.0022 / 0.0462, against
  // 0.0042 / 0.0932 when samples in holes are dropped (each point's AO then rests on half of its
  // samples). (Without alchemy's area factor, which makes the occlusion and its differences
  // larger: 0.0013 / 0.0322 against 0.0026 / 0.0655; with the smoothing of 1 px whatever the
  // pixel's size, before it was limited to r_s / 10 in metres, and without the area factor:
  // 0.0012 / 0.0230 against 0.0018 / 0.0373; the map's pixels span 2-3 cm.)
  const AnalyticScene scene = AnalyticScene::make("room");
  RangeMap full;
  render_scan(scene, ScanCamera::make_equirectangular(320),
              Pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(1.6, 2.1, 1.3)), 0.3, 20.0,
              ScannerNoise{}, full);
  RangeMap holed = full;
  std::uint64_t state = 12345;
  long long holes = 0;
  for (int y = 0; y < holed.camera.height; ++y)
    for (int x = 0; x < holed.camera.width; ++x) {
      state = state * 6364136223846793005ULL + 1442695040888963407ULL;
      if ((state >> 63) != 0) {
        holed.points(x, y).setZero();
        holed.normals(x, y).setZero();
        ++holes;
      }
    }
  ASSERT_GT(holes, holed.camera.width * holed.camera.height * 45 / 100);
  const AoConfig config;
  Image<float> ao_full, ao_holed;
  compute_scan_ssao(full, config, 0, ao_full);
  compute_scan_ssao(holed, config, 0, ao_holed);
  const double difference = mean_abs_difference(holed, ao_holed, ao_full, 2.0f);
  const double occluded = mean_abs_difference(holed, ao_holed, ao_full, 0.9f);
  std::printf("mean |SSAO with holes - SSAO of the full map|: %.4f, where occluded: %.4f\n",
              difference, occluded);
  EXPECT_LT(difference, 0.003);
  EXPECT_LT(occluded, 0.065);
  for (int y = 0; y < holed.camera.height; ++y)
    for (int x = 0; x < holed.camera.width; ++x) {
      if (!holed.has_point(x, y)) {
        EXPECT_EQ(ao_holed(x, y), 1.0f);  // no point, no AO
      }
    }
}

TEST(ScanSsao, APointsSsaoDoesNotDependOnWhereTheScannersPoleLooks) {
  // A laser scanner 0.5 m above the corner scene's floor, 5 cm from the wall y = 0 (exact
  // ranges and normals, 800 x 400). Scan A looks down with its pole: the floor and the crease
  // below lie near the nadir, where a row's pixels are narrow. Scan B, at the same spot, is
  // turned so that they lie near its equator. Each floor point near A's nadir is found in B, and
  // its SSAO there compared with A's: the sample disk must span r_s along A's rows as along its
  // columns, or A reads the crease's wall only in the narrow direction, and reach across the
  // pole. Measured, mean |A - B| over the points with some occlusion in B (B < 0.97): 0.0884
  // with disks as many pixels wide as high; 0.0289 with disks 1 / cos(latitude) times wider
  // along the row (at most half the map), which stopped at the pole; 0.0090 with the disk laid
  // across the view ray and projected into the map. Two scans that both see the floor near
  // their equator (B and B turned 90 degrees about its view) differ by 0.0127 with the wider
  // disks and 0.0097 with the projected one (their pixel grids and sample patterns differ).
  // These figures are of alchemy without its area factor, which this test keeps off: the factor
  // scales every sample's occlusion by the same 1 / cos in A and B (the two scanners stand at one
  // spot), and so the differences with it (0.0158 here), not what the disks cover.
  const AnalyticScene scene = AnalyticScene::make("corner");
  const Eigen::Vector3d at(0.6, 0.05, 0.5);
  Eigen::Matrix3d turned;
  turned.col(0) = Eigen::Vector3d(0.0, 0.0, -1.0);  // B's x axis (its equator at phi = 0) down
  turned.col(1) = Eigen::Vector3d(0.0, 1.0, 0.0);
  turned.col(2) = Eigen::Vector3d(1.0, 0.0, 0.0);
  const Pose pose_a(Eigen::Matrix3d::Identity(), at), pose_b(turned, at);
  RangeMap a, b;
  render_scan(scene, ScanCamera::make_equirectangular(400), pose_a, 0.01, 20.0, ScannerNoise{}, a);
  render_scan(scene, ScanCamera::make_equirectangular(400), pose_b, 0.01, 20.0, ScannerNoise{}, b);
  AoConfig config;
  config.area_min_cos = 1.0;
  Image<float> ao_a, ao_b;
  compute_scan_ssao(a, config, 0, ao_a);
  compute_scan_ssao(b, config, 0, ao_b);
  const Pose b_from_a = pose_b.inverse() * pose_a;
  double sum = 0.0;
  long long compared = 0;
  const double min_theta = kPi * (1.0 - 20.0 / 180.0);  // within 20 degrees of A's nadir
  for (int y = 0; y < a.camera.height; ++y) {
    if ((y + 0.5) * kPi / a.camera.height < min_theta) continue;
    for (int x = 0; x < a.camera.width; ++x) {
      if (!a.has_point(x, y)) continue;
      const Eigen::Vector3f q = (b_from_a * a.points(x, y).cast<double>()).cast<float>();
      int bx = 0, by = 0;
      if (!b.camera.pixel_of(q, bx, by) || !b.has_point(bx, by)) continue;
      if ((b.points(bx, by) - q).norm() > 0.005f || !(ao_b(bx, by) < 0.97f)) continue;
      sum += std::abs(ao_a(x, y) - ao_b(bx, by));
      ++compared;
    }
  }
  const double mean = sum / static_cast<double>(std::max(compared, 1LL));
  std::printf("%lld occluded points near A's nadir: mean |SSAO in A - SSAO in B| %.4f\n", compared,
              mean);
  EXPECT_GT(compared, 2000);
  EXPECT_LT(mean, 0.015);
}

TEST(ScanSsao, TheSamplesOffsetsRoundAsLround) {
  // detail::round_half_away against std::lround, its reference: halves, the floats just below
  // them, zeros, the tiny and the large, and a million random floats over every magnitude.
  std::vector<float> values = {
      0.0f,    -0.0f,   0.5f,       -0.5f,
      1.5f,    -1.5f,   2.5f,       -2.5f,
      159.5f,  -159.5f, 8388607.5f, 1e-30f,
      -1e-30f, 1e9f,    -1e9f,      std::numeric_limits<float>::denorm_min()};
  for (float half : {0.5f, 1.5f, 2.5f, 100.5f, 8388607.5f}) {
    values.push_back(std::nextafter(half, 0.0f));
    values.push_back(-std::nextafter(half, 0.0f));
    values.push_back(std::nextafter(half, 1e10f));
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> mantissa(-1.0f, 1.0f);
  std::uniform_int_distribution<int> exponent(-30, 30);
  for (int k = 0; k < 1000000; ++k) values.push_back(std::ldexp(mantissa(rng), exponent(rng)));
  for (float v : values) ASSERT_EQ(detail::round_half_away(v), std::lround(v)) << v;
}

TEST(ScanSsao, AlchemysSampleTermsWeighTheAreaTheirPixelsStandFor) {
  // Every point of a bumpy 21 x 21 map at about 2 m gets a normal at the same angle to its ray
  // to the scanner, cos theta = c0: every alchemy sample term is then divided by the same
  // max(c0, area_min_cos), and as the smoothing is a weighted mean, every pixel's occlusion
  // 1 - SSAO is that of area_min_cos = 1 (off) divided by it, exactly. A sample pixel without a
  // normal keeps its term.
  const Intrinsics k{21, 21, 100.0, 100.0, 10.0, 10.0};
  Image<float> z(k.width, k.height, 2.0f);
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x)
      z(x, y) = 2.0f + 0.01f * std::sin(1.3f * x) * std::cos(0.9f * y);
  RangeMap map;
  range_map_from_depth(z, k, map);
  for (const float c0 : {0.45f, 0.9f}) {
    for (int y = 0; y < k.height; ++y)
      for (int x = 0; x < k.width; ++x) {
        const Eigen::Vector3f ray = map.points(x, y).normalized();
        const Eigen::Vector3f side = (Eigen::Vector3f::UnitX() - ray.x() * ray).normalized();
        map.normals(x, y) = -(c0 * ray + std::sqrt(1.0f - c0 * c0) * side);
      }
    AoConfig config;
    // The tilted planes rise steeply across the samples: a bias of 60 % of their rise at r_s
    // keeps the occlusion low enough that no pixel's is clamped at 1.
    config.bias = 0.6 * std::sqrt(1.0 - c0 * c0) * config.radius_m / 2.0;
    config.area_min_cos = 1.0;
    Image<float> off, on;
    compute_scan_ssao(map, config, 3, off);
    config.area_min_cos = 0.5;
    compute_scan_ssao(map, config, 3, on);
    const float factor = 1.0f / std::max(c0, 0.5f);
    double most = 0.0;
    for (int y = 0; y < k.height; ++y)
      for (int x = 0; x < k.width; ++x) {
        most = std::max(most, 1.0 - static_cast<double>(off(x, y)));
        ASSERT_LT(factor * (1.0f - off(x, y)), 1.0f) << "clamped: the test's premise fails";
        EXPECT_NEAR(1.0f - on(x, y), factor * (1.0f - off(x, y)), 2e-6f) << x << ", " << y;
      }
    EXPECT_GT(most, 0.05) << "too little occlusion to show the factor";
  }
  // A map whose samples have no normals but the centre pixel's: no factor anywhere.
  map.normals.fill(Eigen::Vector3f::Zero());
  map.normals(10, 10) = Eigen::Vector3f(0.0f, 0.6f, -0.8f);
  AoConfig config;
  Image<float> off, on;
  config.area_min_cos = 1.0;
  compute_scan_ssao(map, config, 3, off);
  config.area_min_cos = 0.5;
  compute_scan_ssao(map, config, 3, on);
  EXPECT_EQ(on(10, 10), off(10, 10));
  EXPECT_LT(on(10, 10), 0.95f);
}

TEST(ScanSsao, ANoisyScansPointsMovedOntoTheirPlanesDoNotOccludeAnOpenPlane) {
  // An open plane at 2-3 m seen by a depth camera with 7 mm of depth noise (a Kinect's there):
  // every point's true AO is 1. Read raw, the noise passes for occluders above the tangent
  // planes; read on the planes compute_scan_normals() fitted, hardly. Measured, mean occlusion
  // (1 - SSAO) 0.0279 -> 0.0000, pixels below 0.95: 13.0 % -> 0 (without alchemy's area factor
  // 0.0261 -> 0.0004, 12.0 % -> 0).
  const Eigen::Vector3f normal = Eigen::Vector3f(0.2f, 0.4f, -1.0f).normalized();
  RangeMap map = noisy_plane_scan(
      normal, 2.4f, [](float) { return 0.007f; }, 5);
  const int w = map.camera.width, h = map.camera.height;
  const Image<float> offset = compute_scan_normals(map);
  ASSERT_FALSE(offset.empty());
  const AoConfig config;
  Image<float> raw, moved, zero_moved;
  compute_scan_ssao(map, config, 0, raw);
  compute_scan_ssao(map, config, 0, moved, offset);
  auto summary = [&](const Image<float>& ao, double& mean, double& below) {
    double sum = 0.0;
    long long n = 0, low = 0;
    for (int y = 20; y < h - 20; ++y)
      for (int x = 20; x < w - 20; ++x) {
        sum += ao(x, y);
        low += ao(x, y) < 0.95f ? 1 : 0;
        ++n;
      }
    mean = sum / static_cast<double>(n);
    below = static_cast<double>(low) / static_cast<double>(n);
  };
  double raw_mean = 0.0, raw_below = 0.0, moved_mean = 0.0, moved_below = 0.0;
  summary(raw, raw_mean, raw_below);
  summary(moved, moved_mean, moved_below);
  std::printf("mean occlusion %.4f -> %.4f, below 0.95: %.2f %% -> %.2f %%\n", 1.0 - raw_mean,
              1.0 - moved_mean, 100.0 * raw_below, 100.0 * moved_below);
  EXPECT_GT(1.0 - raw_mean, 0.02);
  EXPECT_LT(1.0 - moved_mean, (1.0 - raw_mean) / 20.0);
  EXPECT_LT(moved_below, raw_below / 20.0);
  // Offsets of zero read the points themselves: the same bits as no offsets.
  compute_scan_ssao(map, config, 0, zero_moved, Image<float>(w, h, 0.0f));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) ASSERT_EQ(zero_moved(x, y), raw(x, y));
  EXPECT_THROW(compute_scan_ssao(map, config, 0, zero_moved, Image<float>(w, 1, 0.0f)), Error);
}

}  // namespace
}  // namespace aoscan
