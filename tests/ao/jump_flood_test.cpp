// Tests for src/ao/jump_flood.cpp: jump flooding against the exact distance field, the azimuth
// wrap of equirectangular maps, and the border distance d_b of range maps with known edges (an
// equirectangular map's poles among them).
#include "ao/jump_flood.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "ao/jump_flood_kernels.h"
#include "geometry/simd.h"
#include "sim/synth_scanner.h"
#include "sim/synth_scene.h"

namespace aoscan {
namespace {

/// The exact distance field by brute force: the plain reference of jump_flood_distance().
Image<float> exact_distance(const Image<std::uint8_t>& seeds, bool wrap_x) {
  const int w = seeds.width(), h = seeds.height();
  Image<float> out(w, h, std::numeric_limits<float>::infinity());
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int sy = 0; sy < h; ++sy)
        for (int sx = 0; sx < w; ++sx) {
          if (seeds(sx, sy) == 0) continue;
          double dx = std::abs(x - sx);
          if (wrap_x) dx = std::min(dx, w - dx);
          const double d = std::sqrt(dx * dx + double(y - sy) * (y - sy));
          out(x, y) = std::min(out(x, y), static_cast<float>(d));
        }
  return out;
}

TEST(JumpFlood, OneSeedGivesTheExactEuclideanDistance) {
  Image<std::uint8_t> seeds(33, 20, 0);
  seeds(7, 12) = 1;
  Image<float> d;
  jump_flood_distance(seeds, false, d);
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 33; ++x)
      EXPECT_FLOAT_EQ(d(x, y), std::hypot(float(x - 7), float(y - 12))) << x << " " << y;
}

TEST(JumpFlood, RandomSeedsMatchTheExactFieldAlmostEverywhere) {
  // Jump flooding may pick a slightly farther seed at rare pixels; JFA+1 keeps those few and
  // their error small. Tolerance: 99.5 % of the pixels exact, none off by more than one pixel.
  for (const bool wrap : {false, true}) {
    std::mt19937 rng(7);
    Image<std::uint8_t> seeds(96, 48, 0);
    for (int i = 0; i < 40; ++i) seeds(rng() % 96, rng() % 48) = 1;
    Image<float> fast;
    jump_flood_distance(seeds, wrap, fast);
    const Image<float> exact = exact_distance(seeds, wrap);
    int off = 0;
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 96; ++x) {
        EXPECT_GE(fast(x, y), exact(x, y) - 1e-4f);
        EXPECT_LE(fast(x, y), exact(x, y) + 1.0f);
        off += fast(x, y) > exact(x, y) + 1e-4f ? 1 : 0;
      }
    EXPECT_LE(off, 96 * 48 / 200) << (wrap ? "wrapped" : "plain");
  }
}

TEST(JumpFlood, TheEquirectangularSeamIsNoBorder) {
  Image<std::uint8_t> seeds(40, 10, 0);
  seeds(0, 5) = 1;
  Image<float> d;
  jump_flood_distance(seeds, true, d);
  EXPECT_FLOAT_EQ(d(39, 5), 1.0f);
  EXPECT_FLOAT_EQ(d(20, 5), 20.0f);
  jump_flood_distance(seeds, false, d);
  EXPECT_FLOAT_EQ(d(39, 5), 39.0f);
}

TEST(JumpFlood, NoSeedIsInfinitelyFar) {
  Image<float> d;
  jump_flood_distance(Image<std::uint8_t>(5, 4, 0), false, d);
  EXPECT_TRUE(std::isinf(d(2, 2)));
}

#if AOSCAN_JUMP_FLOOD_X86
TEST(JumpFlood, TheAvx2InteriorKeepsTheSeedsOfThePortableCode) {
  if (!cpu_has_avx2()) GTEST_SKIP() << "this CPU has no AVX2: only the portable code runs";
  // Rows of random seeds (a third of the pixels none), near and far from the row, with ties:
  // seeds on a few columns and rows only, so that equal distances are common.
  std::mt19937 rng(11);
  const int width = 203;
  for (const int k : {1, 2, 7, 64, 100}) {
    for (const int wrap_width : {0, width}) {
      for (int trial = 0; trial < 20; ++trial) {
        std::vector<detail::PackedSeed> rows[3];
        for (auto& r : rows) {
          r.resize(width);
          for (auto& s : r)
            s = rng() % 3 == 0 ? -1
                               : detail::pack_seed(static_cast<int>(rng() % 8) * 29,
                                                   static_cast<int>(rng() % 5) * 50);
        }
        detail::FloodRow row{{rows[0].data(), trial % 4 == 0 ? nullptr : rows[1].data(),
                              trial % 5 == 0 ? nullptr : rows[2].data()},
                             100,
                             k,
                             wrap_width};
        const int begin = std::min(k, width), end = std::max(begin, width - k);
        std::vector<detail::PackedSeed> fast(width, -2), portable(width, -2);
        detail::flood_interior_avx2(row, begin, end, fast.data());
        detail::flood_interior_portable(row, begin, end, portable.data());
        ASSERT_EQ(fast, portable) << "k " << k << " wrap " << wrap_width << " trial " << trial;
      }
    }
  }
}
#endif

TEST(JumpFlood, TheFieldIsTheSameBitForBitWithAndWithoutSimd) {
  std::mt19937 rng(5);
  for (const bool wrap : {false, true}) {
    Image<std::uint8_t> seeds(301, 157, 0);
    for (int i = 0; i < 60; ++i) seeds(rng() % 301, rng() % 157) = 1;
    for (int x = 20; x < 200; ++x) seeds(x, 80) = 1;
    Image<float> fast, portable;
    jump_flood_distance(seeds, wrap, fast, true);
    jump_flood_distance(seeds, wrap, portable, false);
    for (int y = 0; y < 157; ++y)
      for (int x = 0; x < 301; ++x) ASSERT_EQ(fast(x, y), portable(x, y)) << x << " " << y;
  }
}

TEST(JumpFlood, AnImageWiderThanPackedSeedsReachIsFloodedWithWideSeeds) {
  // 40 000 x 3 pixels: beyond the 32 767 a side of 32-bit seeds. Seeds on one row give the exact
  // field (a pixel's nearest seed is the nearest on that row).
  const int w = 40000, h = 3;
  const std::vector<int> columns = {5, 17000, 39990};
  Image<std::uint8_t> seeds(w, h, 0);
  for (const int x : columns) seeds(x, 1) = 1;
  for (const bool wrap : {false, true}) {
    Image<float> d;
    jump_flood_distance(seeds, wrap, d);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; x += 7) {
        double exact = std::numeric_limits<double>::infinity();
        for (const int sx : columns) {
          double dx = std::abs(x - sx);
          if (wrap) dx = std::min(dx, w - dx);
          exact = std::min(exact, std::sqrt(dx * dx + (y - 1) * (y - 1)));
        }
        ASSERT_EQ(d(x, y), static_cast<float>(exact)) << x << " " << y << (wrap ? " wrapped" : "");
      }
  }
}

TEST(BorderDistance, ADepthStepAndTheMapsEdgeAreTheBorders) {
  // Two fronto-parallel planes, 1 m (left half) and 2 m (right half): the Laplacian is non-zero
  // only on the map's outer ring (outside reads 0) and on the two columns beside the step, 4 % of
  // the pixels, so the 0.95 percentile is 0 and those pixels are exactly the edges, less the two
  // ring pixels of column 79 where the step and the edge cancel (4 * 1 - 1 - 2 - 1 - 0 = 0).
  const int w = 160, h = 120;
  const Intrinsics k{w, h, 100.0, 100.0, 79.5, 59.5};
  Image<float> depth(w, h, 1.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 80; x < w; ++x) depth(x, y) = 2.0f;
  RangeMap map;
  range_map_from_depth(depth, k, map);
  Image<float> d;
  const BorderStats stats = border_distance(map, 0.01f, d);
  EXPECT_EQ(stats.threshold, 0.0f);
  EXPECT_EQ(stats.edges, 2 * w + 2 * (h - 2) + 2 * (h - 2) - 2);
  EXPECT_FLOAT_EQ(d(0, 60), 0.0f);
  EXPECT_FLOAT_EQ(d(79, 60), 0.0f);
  EXPECT_FLOAT_EQ(d(80, 60), 0.0f);
  EXPECT_FLOAT_EQ(d(40, 60), 39.0f);   // 40 from the left edge, 39 from column 79
  EXPECT_FLOAT_EQ(d(120, 10), 10.0f);  // the top ring is nearest
}

TEST(BorderDistance, DropoutsAreNoBordersButWiderHolesAre) {
  // A plane at 1.5 m with holes: a single missing pixel, a 3-pixel gap in a row, a 2 x 2 and a
  // 3 x 3 hole (each of their pixels has points within 2 pixels on both sides along its row or
  // column, or on both sides along a diagonal: dropouts, read as the surface around them), and
  // a 4 x 4 hole (a coverage border: the 8 points beside its sides' middle pixels are edges, as
  // is the map's outer ring; its corner pixels, with points diagonally on both sides, are
  // dropouts). With every hole taken for a border, the first four would add 4 + 8 + 8 + 12 edge
  // pixels; with rows and columns alone, the 3 x 3 hole's corners would add 8 and the 4 x 4's 8.
  const int w = 160, h = 120;
  const Intrinsics k{w, h, 100.0, 100.0, 79.5, 59.5};
  Image<float> depth(w, h, 1.5f);
  depth(40, 30) = 0.0f;
  for (int x = 60; x <= 62; ++x) depth(x, 30) = 0.0f;
  for (int y = 30; y <= 31; ++y)
    for (int x = 100; x <= 101; ++x) depth(x, y) = 0.0f;
  for (int y = 80; y <= 82; ++y)
    for (int x = 120; x <= 122; ++x) depth(x, y) = 0.0f;
  for (int y = 80; y <= 83; ++y)
    for (int x = 40; x <= 43; ++x) depth(x, y) = 0.0f;
  RangeMap map;
  range_map_from_depth(depth, k, map);
  Image<float> d;
  const BorderStats stats = border_distance(map, 0.01f, d);
  EXPECT_EQ(stats.edges, 2 * w + 2 * (h - 2) + 8);
  EXPECT_FLOAT_EQ(d(41, 30), 30.0f);   // beside the single dropout: the top ring is nearest
  EXPECT_FLOAT_EQ(d(101, 29), 29.0f);  // above the 2 x 2 hole
  EXPECT_FLOAT_EQ(d(119, 80), 39.0f);  // beside the 3 x 3 hole's corner: the bottom ring
  EXPECT_FLOAT_EQ(d(39, 81), 0.0f);    // beside the 4 x 4 hole
  EXPECT_FLOAT_EQ(d(44, 82), 0.0f);
  EXPECT_FLOAT_EQ(d(41, 79), 0.0f);
  EXPECT_FLOAT_EQ(d(39, 80), 1.0f);  // beside its corner: no edge, one from the next point
  EXPECT_FLOAT_EQ(d(41, 86), 2.0f);  // two rows below the point beside the hole
}

/// A 160 x 120 pinhole map of fronto-parallel planes at `left_m` (columns 0-79) and `right_m`
/// (columns 80-159) with Gaussian depth noise of `sigma_m` (seeded).
constexpr int kNoisyWidth = 160, kNoisyHeight = 120;
RangeMap noisy_planes(float left_m, float right_m, float sigma_m, unsigned seed) {
  const Intrinsics k{kNoisyWidth, kNoisyHeight, 100.0, 100.0, 79.5, 59.5};
  Image<float> depth(kNoisyWidth, kNoisyHeight, 0.0f);
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, sigma_m);
  for (int y = 0; y < kNoisyHeight; ++y)
    for (int x = 0; x < kNoisyWidth; ++x) depth(x, y) = (x < 80 ? left_m : right_m) + noise(rng);
  RangeMap map;
  range_map_from_depth(depth, k, map);
  return map;
}

TEST(BorderDistance, AFlatScanWithoutHolesHasOnlyItsOuterBorder) {
  // A smooth surface's Laplacian noise must not become "the most valuable borders": the outer
  // ring is 3 % of the pixels, so the 0.95 percentile falls in the noise, and the floor of 1 % of
  // the depth (15 mm against a noise Laplacian of about 2 mm) rejects it.
  const int w = kNoisyWidth, h = kNoisyHeight;
  const RangeMap map = noisy_planes(1.5f, 1.5f, 0.0005f, 3);
  Image<float> d;
  const BorderStats stats = border_distance(map, 0.01f, d);
  EXPECT_EQ(stats.edges, 2 * w + 2 * (h - 2));
  EXPECT_FLOAT_EQ(d(80, 60), 59.0f);  // the bottom row is nearest
}

TEST(BorderDistance, RangeNoiseAboveTheDepthFloorMakesNoEdges) {
  // A laser's 2 mm range noise at 2 m: its Laplacian (sigma about 9 mm) passes the 0.95
  // percentile and the 1 % depth floor (20 mm) at about 1 % of the pixels; the noise floor (24
  // medians of the Laplacian, about 0.15 m here) leaves only the outer ring and the two columns
  // beside the 0.3 m step as edges.
  const int w = kNoisyWidth, h = kNoisyHeight;
  const RangeMap map = noisy_planes(2.0f, 2.3f, 0.002f, 5);
  Image<float> d;
  const BorderStats stats = border_distance(map, 0.01f, d);
  EXPECT_GT(stats.threshold, 0.1f);
  EXPECT_LT(stats.threshold, 0.2f);
  EXPECT_EQ(stats.edges, 2 * w + 2 * (h - 2) + 2 * (h - 2));
  EXPECT_FLOAT_EQ(d(40, 60), 39.0f);  // 40 from the left edge, 39 from column 79
  EXPECT_FLOAT_EQ(d(79, 60), 0.0f);
  EXPECT_FLOAT_EQ(d(80, 60), 0.0f);
}

TEST(BorderDistance, AnEquirectangularMapsPolesAreNoBorders) {
  // A 800 x 400 laser map from the middle of the closed room, 1.5 m above its floor and 1.1 m
  // below its ceiling (exact ranges). Its first and last rows are the rings around the zenith and
  // the nadir: the sphere goes on across the pole, on the opposite azimuth, so they are no edge
  // of the scan's coverage. The floor's nearest border is the sphere resting on it (68 px from
  // the nadir's ring) and the ceiling's its creases with the walls (136 px from the zenith's). Read
  // as outside the map, the rows beyond the poles made every pixel of the first and last rows an
  // edge (distance 0).
  const AnalyticScene scene = AnalyticScene::make("room");
  const Pose pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(2.0, 2.0, 1.5));
  RangeMap map;
  render_scan(scene, ScanCamera::make_equirectangular(400), pose, 0.01, 20.0, ScannerNoise{}, map);
  Image<float> d;
  border_distance(map, 0.01f, d);
  const int w = map.camera.width, h = map.camera.height;
  float zenith = std::numeric_limits<float>::infinity(), nadir = zenith;
  for (int x = 0; x < w; ++x) {
    ASSERT_TRUE(map.has_point(x, 0) && map.has_point(x, h - 1)) << x;
    zenith = std::min(zenith, d(x, 0));
    nadir = std::min(nadir, d(x, h - 1));
  }
  std::printf("nearest border: %.1f px from the zenith's ring, %.1f px from the nadir's\n", zenith,
              nadir);
  EXPECT_GE(zenith, 40.0f);
  EXPECT_GE(nadir, 40.0f);
}

}  // namespace
}  // namespace aoscan
