/// @file mvao_grid_test.cpp
/// @brief Tests for src/ao/mvao_grid.h: exact sums from hand-made frames in the three modes,
/// far-from-origin cells, out-of-range and non-finite points, trilinear sampling, nearest cell,
/// memory per brick, slots that stay valid as the grid grows, and the batched integration equal
/// to a plain per-pixel reference on a large random frame.
#include "ao/mvao_grid.h"

#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

namespace aoscan {
namespace {

/// Cell size 0.25 m (exact in binary): 4 cells over 1 m.
AoConfig grid_config(AoIntegration mode) {
  AoConfig c;
  c.grid_extent_m = 1.0;
  c.grid_resolution = 4;
  c.integration = mode;
  return c;
}

/// A 1-row frame of hand-made camera-frame points with their AO and weights.
struct Frame {
  Image<float> ao, w;
  PointMaps maps;
  explicit Frame(const std::vector<Eigen::Vector3f>& points, const std::vector<float>& ao_values,
                 const std::vector<float>& weights) {
    const int n = static_cast<int>(points.size());
    ao.resize(n, 1);
    w.resize(n, 1);
    maps.vertices.resize(n, 1, Eigen::Vector3f::Zero());
    maps.normals.resize(n, 1, Eigen::Vector3f(0.0f, 0.0f, -1.0f));
    for (int i = 0; i < n; ++i) {
      maps.vertices(i, 0) = points[i];
      ao(i, 0) = ao_values[i];
      w(i, 0) = weights[i];
    }
  }
};

const Eigen::Vector3f kA(0.1f, 0.1f, 0.1f);   // cell (0, 0, 0)
const Eigen::Vector3f kB(0.2f, 0.05f, 0.2f);  // cell (0, 0, 0)
const Eigen::Vector3f kC(0.3f, 0.1f, 0.1f);   // cell (1, 0, 0)

TEST(MvaoGrid, ModesGiveTheExactWeightedMeans) {
  const Frame f1({kA, kB, kC}, {0.25f, 0.75f, 0.5f}, {1.0f, 3.0f, 0.5f});
  const Frame f2({kA}, {1.0f}, {2.0f});
  const Pose I = Pose::identity();

  MvaoGrid mvao(grid_config(AoIntegration::kMvao));
  ASSERT_TRUE(mvao.integrate(f1.ao, f1.w, f1.maps, I).is_ok());
  EXPECT_FLOAT_EQ(*mvao.cell_ao({0, 0, 0}), (0.25f + 3.0f * 0.75f) / 4.0f);
  EXPECT_FLOAT_EQ(*mvao.cell_ao({1, 0, 0}), 0.5f);
  ASSERT_TRUE(mvao.integrate(f2.ao, f2.w, f2.maps, I).is_ok());
  EXPECT_FLOAT_EQ(*mvao.cell_ao({0, 0, 0}), (0.25f + 3.0f * 0.75f + 2.0f) / 6.0f);
  EXPECT_EQ(mvao.find({0, 0, 0})->weight_sum, 6.0f);
  EXPECT_EQ(mvao.cell_count(), 2u);
  EXPECT_EQ(mvao.points_integrated(), 4u);
  EXPECT_EQ(mvao.frames_integrated(), 2u);

  MvaoGrid mean(grid_config(AoIntegration::kMean));
  mean.integrate(f1.ao, f1.w, f1.maps, I);
  EXPECT_FLOAT_EQ(*mean.cell_ao({0, 0, 0}), 0.5f);
  mean.integrate(f2.ao, f2.w, f2.maps, I);
  EXPECT_FLOAT_EQ(*mean.cell_ao({0, 0, 0}), 2.0f / 3.0f);
  EXPECT_FLOAT_EQ(*mean.cell_ao({1, 0, 0}), 0.5f);

  MvaoGrid last(grid_config(AoIntegration::kLast));
  last.integrate(f1.ao, f1.w, f1.maps, I);
  EXPECT_FLOAT_EQ(*last.cell_ao({0, 0, 0}), 0.5f);  // both pixels of frame 1, equal weights
  last.integrate(f2.ao, f2.w, f2.maps, I);
  EXPECT_FLOAT_EQ(*last.cell_ao({0, 0, 0}), 1.0f);  // only frame 2's pixel
  EXPECT_FLOAT_EQ(*last.cell_ao({1, 0, 0}), 0.5f);  // untouched by frame 2: keeps frame 1
}

TEST(MvaoGrid, AFrameWeightScalesEveryPixelsWeightInEveryMode) {
  const Frame f1({kA, kB}, {0.25f, 0.75f}, {1.0f, 3.0f});
  const Frame f2({kA}, {1.0f}, {2.0f});
  const Pose I = Pose::identity();
  MvaoGrid mvao(grid_config(AoIntegration::kMvao));
  ASSERT_TRUE(mvao.integrate(f1.ao, f1.w, f1.maps, I).is_ok());
  ASSERT_TRUE(mvao.integrate(f2.ao, f2.w, f2.maps, I, nullptr, 0.25f).is_ok());
  EXPECT_EQ(mvao.find({0, 0, 0})->weight_sum, 4.5f);  // 1 + 3 + 0.25 * 2
  EXPECT_FLOAT_EQ(*mvao.cell_ao({0, 0, 0}), (0.25f + 3.0f * 0.75f + 0.5f) / 4.5f);
  MvaoGrid mean(grid_config(AoIntegration::kMean));
  mean.integrate(f1.ao, f1.w, f1.maps, I);
  mean.integrate(f2.ao, f2.w, f2.maps, I, nullptr, 0.5f);
  EXPECT_FLOAT_EQ(*mean.cell_ao({0, 0, 0}), (0.25f + 0.75f + 0.5f) / 2.5f);
  // Not positive or not finite: refused, nothing changes.
  for (const float bad : {0.0f, -1.0f, std::numeric_limits<float>::quiet_NaN(),
                          std::numeric_limits<float>::infinity()})
    EXPECT_FALSE(mvao.integrate(f2.ao, f2.w, f2.maps, I, nullptr, bad).is_ok());
  EXPECT_EQ(mvao.find({0, 0, 0})->weight_sum, 4.5f);
  EXPECT_EQ(mvao.frames_integrated(), 2u);
}

TEST(MvaoGrid, PoseMapsCameraPointsToWorldCells) {
  // Camera rotated 90 degrees about z and shifted: camera (0.1, 0.1, 0.1) -> world (-0.1+2, ...).
  Eigen::Matrix3d R;
  R << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const Pose T_world_camera(R, Eigen::Vector3d(2.0, -1.0, 0.5));
  const Frame f({kA}, {0.3f}, {1.0f});
  MvaoGrid grid(grid_config(AoIntegration::kMvao));
  grid.integrate(f.ao, f.w, f.maps, T_world_camera);
  // World point (1.9, -0.9, 0.6) -> cell (7, -4, 2).
  EXPECT_FLOAT_EQ(*grid.cell_ao({7, -4, 2}), 0.3f);
  EXPECT_EQ(grid.cell_of({1.9, -0.9, 0.6}), (CellIndex{7, -4, 2}));
}

TEST(MvaoGrid, FarCellsAreKeptAndOutOfRangePointsCounted) {
  MvaoGrid grid(grid_config(AoIntegration::kMvao));
  // The Morton range is [-2^20, 2^20 - 1] cells of 0.25 m: about +-262 km.
  const double edge_m = 0.25 * (1 << 20);
  const Pose far(Eigen::Matrix3d::Identity(), Eigen::Vector3d(edge_m - 1.0, -edge_m + 0.5, 0.0));
  const Frame f({kA, Eigen::Vector3f(2.0f, 0.0f, 0.0f), Eigen::Vector3f(0.0f, -1.0f, 0.0f)},
                {0.4f, 0.5f, 0.6f}, {1.0f, 1.0f, 1.0f});
  ASSERT_TRUE(grid.integrate(f.ao, f.w, f.maps, far).is_ok());
  EXPECT_EQ(grid.cell_count(), 1u);
  EXPECT_EQ(grid.points_out_of_range(), 2u);
  EXPECT_EQ(grid.points_integrated(), 1u);
  const CellIndex c{(1 << 20) - 4, -(1 << 20) + 2, 0};
  EXPECT_FLOAT_EQ(*grid.cell_ao(c), 0.4f);
  EXPECT_FLOAT_EQ(*grid.sample(grid.cell_centre(c)), 0.4f);
  EXPECT_FALSE(grid.cell_of({1e12, 0.0, 0.0}));
  EXPECT_FALSE(grid.sample({1e12, 0.0, 0.0}));
}

TEST(MvaoGrid, NonFiniteInputsAreSkippedAndCounted) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const Frame f({kA, kA, kA, Eigen::Vector3f(nan, 0.0f, 1.0f), kA, kA},
                {nan, 0.5f, 0.5f, 0.5f, 0.5f, 2.0f}, {1.0f, inf, -1.0f, 1.0f, 0.0f, 1.0f});
  MvaoGrid grid(grid_config(AoIntegration::kMvao));
  grid.integrate(f.ao, f.w, f.maps, Pose::identity());
  EXPECT_EQ(grid.points_invalid(), 4u);
  EXPECT_EQ(grid.points_integrated(), 1u);  // the AO of 2 is clamped to 1
  EXPECT_FLOAT_EQ(*grid.cell_ao({0, 0, 0}), 1.0f);
  // A non-finite pose skips every point.
  Eigen::Matrix3d bad = Eigen::Matrix3d::Identity();
  bad(0, 0) = nan;
  const Frame g({kA}, {0.5f}, {1.0f});
  grid.integrate(g.ao, g.w, g.maps, Pose(bad, Eigen::Vector3d::Zero()));
  EXPECT_EQ(grid.points_invalid(), 5u);
  EXPECT_FALSE(grid.sample(Eigen::Vector3d::Constant(std::nan(""))));
  EXPECT_FALSE(grid.nearest_observed(Eigen::Vector3d::Constant(std::nan("")), 3));
  // Size mismatch is reported, not UB.
  Image<float> small(1, 1, 0.5f);
  EXPECT_EQ(grid.integrate(small, g.w, f.maps, Pose::identity()).code(), Status::Code::kInternal);
}

TEST(MvaoGrid, BatchedIntegrationEqualsAPlainPerPixelReference) {
  // 320x240 random camera points (runs of equal cells, holes, zero weights, a rotated pose, the
  // brick index and pool growing during a frame): every cell's sums must be the same bits as a
  // per-pixel accumulation written from the formula (double transform, std::floor, pixel order).
  AoConfig config;  // 4 m / 512 cells
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> xy(-1.0f, 1.0f), z(0.5f, 3.0f), unit(0.0f, 1.0f);
  const int w = 320, h = 240;
  Image<float> ao(w, h), weight(w, h);
  PointMaps maps;
  maps.vertices.resize(w, h, Eigen::Vector3f::Zero());
  maps.normals.resize(w, h, Eigen::Vector3f(0.0f, 0.0f, -1.0f));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      // Pairs of neighbouring pixels share a point, so runs of one cell occur.
      if (x % 2 == 0)
        maps.vertices(x, y) = Eigen::Vector3f(xy(rng), xy(rng), z(rng));
      else
        maps.vertices(x, y) = maps.vertices(x - 1, y);
      ao(x, y) = unit(rng) * 1.2f - 0.1f;  // also outside [0, 1]: clamped
      weight(x, y) = unit(rng) < 0.3f ? 0.0f : unit(rng);
    }
  const Pose T(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1.0, 2.0, 3.0).normalized()).matrix(),
               Eigen::Vector3d(0.3, -1.1, 2.5));
  MvaoGrid grid(config);
  ASSERT_TRUE(grid.integrate(ao, weight, maps, T).is_ok());
  std::map<CellIndex, std::pair<float, float>> expected;
  std::uint64_t count = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!(weight(x, y) > 0.0f)) continue;
      const Eigen::Vector3d p =
          (T.rotation() * maps.vertices(x, y).cast<double>() + T.translation()) *
          (1.0 / grid.cell_size_m());
      const CellIndex c{static_cast<std::int32_t>(std::floor(p.x())),
                        static_cast<std::int32_t>(std::floor(p.y())),
                        static_cast<std::int32_t>(std::floor(p.z()))};
      auto& [aw, ws] = expected[c];
      aw += weight(x, y) * std::min(std::max(ao(x, y), 0.0f), 1.0f);
      ws += weight(x, y);
      ++count;
    }
  EXPECT_EQ(grid.points_integrated(), count);
  EXPECT_EQ(grid.cell_count(), expected.size());
  ASSERT_GT(expected.size(), 5000u);  // the index grew several times within the frame
  for (const auto& [c, sums] : expected) {
    const MvaoCell* cell = grid.find(c);
    ASSERT_NE(cell, nullptr);
    EXPECT_EQ(cell->ao_weight_sum, sums.first);
    EXPECT_EQ(cell->weight_sum, sums.second);
  }
}

TEST(MvaoGrid, TrilinearSamplingRenormalisesOverObservedCells) {
  // Cells (0,0,0) AO 0 and (1,0,0) AO 1; centres at x = 0.125 and 0.375.
  const Frame f({kA, kC}, {0.0f, 1.0f}, {1.0f, 1.0f});
  MvaoGrid grid(grid_config(AoIntegration::kMean));
  grid.integrate(f.ao, f.w, f.maps, Pose::identity());
  EXPECT_FLOAT_EQ(*grid.sample({0.125, 0.125, 0.125}), 0.0f);
  EXPECT_FLOAT_EQ(*grid.sample({0.1875, 0.125, 0.125}), 0.25f);
  EXPECT_FLOAT_EQ(*grid.sample({0.3125, 0.125, 0.125}), 0.75f);
  // Off the cell-centre plane: the unobserved y/z neighbours drop out, x weights stay 1:3.
  EXPECT_FLOAT_EQ(*grid.sample({0.3125, 0.2, 0.05}), 0.75f);
  // Beyond the last centre only the observed corner counts.
  EXPECT_FLOAT_EQ(*grid.sample({0.45, 0.125, 0.125}), 1.0f);
  // No observed corner nearby.
  EXPECT_FALSE(grid.sample({2.0, 2.0, 2.0}));
}

TEST(MvaoGrid, NearestObservedFindsTheClosestCentre) {
  const Frame f({kA, kC}, {0.2f, 0.9f}, {1.0f, 1.0f});
  MvaoGrid grid(grid_config(AoIntegration::kMean));
  EXPECT_FALSE(grid.nearest_observed({0.0, 0.0, 0.0}, 5));  // empty grid
  grid.integrate(f.ao, f.w, f.maps, Pose::identity());
  EXPECT_FLOAT_EQ(*grid.nearest_observed({0.9, 0.1, 0.1}, 4), 0.9f);
  EXPECT_FLOAT_EQ(*grid.nearest_observed({-0.6, 0.1, 0.1}, 4), 0.2f);
  EXPECT_FALSE(grid.nearest_observed({2.0, 0.1, 0.1}, 2));  // 7 cells away
  EXPECT_FLOAT_EQ(*grid.nearest_observed({2.0, 0.1, 0.1}, 7), 0.9f);
}

TEST(MvaoGrid, MemoryGrowsOnlyWithObservedBricks) {
  MvaoGrid grid(grid_config(AoIntegration::kMvao));
  EXPECT_EQ(grid.memory_bytes(), 0u);  // nothing before the first cell
  // A plane of 200 x 200 cells in one z layer: 50 x 50 bricks of 4^3 cells, a quarter of each
  // filled (an axis-aligned plane is a surface's worst case; a slanted one fills more).
  std::vector<Eigen::Vector3f> pts;
  for (int j = 0; j < 200; ++j)
    for (int i = 0; i < 200; ++i) pts.emplace_back(0.25f * i + 0.1f, 0.25f * j + 0.1f, 0.1f);
  const Frame f(pts, std::vector<float>(pts.size(), 0.5f), std::vector<float>(pts.size(), 1.0f));
  grid.integrate(f.ao, f.w, f.maps, Pose::identity());
  EXPECT_EQ(grid.cell_count(), 40000u);
  EXPECT_EQ(grid.brick_count(), 2500u);
  // 768 bytes per brick, the pool's last chunk partly empty, 12-byte index entries at load <= 1/2.
  EXPECT_GE(grid.memory_bytes(), 2500 * 64 * sizeof(MvaoCell));
  EXPECT_LE(grid.memory_bytes(), 64 * grid.cell_count());
  for (int j = 0; j < 200; ++j)
    for (int i = 0; i < 200; ++i) ASSERT_FLOAT_EQ(*grid.cell_ao({i, j, 0}), 0.5f);
  EXPECT_FALSE(grid.cell_ao({0, 0, 1}));  // in a brick, never observed
  grid.clear();
  EXPECT_EQ(grid.cell_count(), 0u);
  EXPECT_EQ(grid.brick_count(), 0u);
  EXPECT_EQ(grid.memory_bytes(), 0u);
  EXPECT_FALSE(grid.cell_ao({0, 0, 0}));
}

TEST(MvaoGrid, SlotsStayValidWhileTheGridGrows) {
  // The slots of a frame read its cells after later frames made thousands of new bricks: cells
  // never move.
  MvaoGrid grid(grid_config(AoIntegration::kMvao));
  const Frame first({kA, kC, {-0.1f, 0.1f, 0.1f}, {0.1f, 0.1f, -5.0f}}, {0.2f, 0.6f, 0.9f, 0.4f},
                    {1.0f, 0.0f, 2.0f, 1.0f});
  Image<std::uint32_t> slots;
  ASSERT_TRUE(grid.integrate(first.ao, first.w, first.maps, Pose::identity(), &slots).is_ok());
  EXPECT_EQ(slots(1, 0), MvaoGrid::kNoSlot);  // weight 0: not integrated
  const Image<std::uint32_t> kept = slots;
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 20000; ++i) pts.emplace_back(1.1f * i + 3.0f, 0.1f, 0.1f);  // a brick each
  const Frame more(pts, std::vector<float>(pts.size(), 1.0f), std::vector<float>(pts.size(), 1.0f));
  ASSERT_TRUE(grid.integrate(more.ao, more.w, more.maps, Pose::identity(), &slots).is_ok());
  EXPECT_GE(grid.brick_count(), 20000u);
  EXPECT_FLOAT_EQ(grid.slot_ao(kept(0, 0)), 0.2f);
  EXPECT_FLOAT_EQ(grid.slot_ao(kept(2, 0)), 0.9f);
  EXPECT_FLOAT_EQ(grid.slot_ao(kept(3, 0)), 0.4f);
  EXPECT_FLOAT_EQ(grid.slot_ao(slots(5, 0)), 1.0f);
  EXPECT_TRUE(std::isnan(grid.slot_ao(MvaoGrid::kNoSlot)));
}

TEST(MvaoGrid, CoarsenedCellsHoldTheWeightedMeanOfTheirCells) {
  MvaoGrid grid(grid_config(AoIntegration::kMvao));  // cells of 0.25 m
  // Cells (0,0,0), (1,0,0) and (1,1,1) lie in coarse cell (0,0,0) of factor 2; (2,0,0) and the
  // negative cell (-1,0,0) in coarse cells (1,0,0) and (-1,0,0).
  const Frame f({kA, kC, {0.3f, 0.3f, 0.3f}, {0.6f, 0.1f, 0.1f}, {-0.1f, 0.1f, 0.1f}},
                {0.2f, 0.6f, 1.0f, 0.4f, 0.9f}, {1.0f, 0.5f, 0.25f, 2.0f, 1.0f});
  ASSERT_TRUE(grid.integrate(f.ao, f.w, f.maps, Pose::identity()).is_ok());
  const MvaoGrid coarse = grid.coarsened(2);
  EXPECT_DOUBLE_EQ(coarse.cell_size_m(), 0.5);
  EXPECT_EQ(coarse.cell_count(), 3u);
  EXPECT_EQ(coarse.integration(), AoIntegration::kMvao);
  ASSERT_TRUE(coarse.cell_ao({0, 0, 0}));
  EXPECT_FLOAT_EQ(*coarse.cell_ao({0, 0, 0}),
                  (0.2f * 1.0f + 0.6f * 0.5f + 1.0f * 0.25f) / (1.0f + 0.5f + 0.25f));
  EXPECT_FLOAT_EQ(*coarse.cell_ao({1, 0, 0}), 0.4f);
  EXPECT_FLOAT_EQ(*coarse.cell_ao({-1, 0, 0}), 0.9f);
  EXPECT_EQ(coarse.frames_integrated(), 1u);
  // Factor 1 (and below) keeps every cell as it is.
  const MvaoGrid same = grid.coarsened(0);
  EXPECT_EQ(same.cell_count(), grid.cell_count());
  EXPECT_FLOAT_EQ(*same.cell_ao({1, 1, 1}), 1.0f);
}

TEST(MvaoGrid, CoarseLookupInterpolatesTheBricksMeans) {
  // Cells of 0.25 m: bricks of 1 m, their centres at 0.5 + integer. Brick (0,0,0) holds cells of
  // AO 0.2 (weight 1) and 0.6 (weight 3): mean 0.5; brick (1,0,0) one cell of AO 0.9.
  MvaoGrid grid(grid_config(AoIntegration::kMvao));
  const Frame f({kA, kC, {1.6f, 0.1f, 0.7f}}, {0.2f, 0.6f, 0.9f}, {1.0f, 3.0f, 2.0f});
  ASSERT_TRUE(grid.integrate(f.ao, f.w, f.maps, Pose::identity()).is_ok());
  EXPECT_EQ(grid.stale_bricks(), 2u);
  grid.refresh_brick_sums();
  EXPECT_EQ(grid.stale_bricks(), 0u);
  const std::vector<Eigen::Vector3f> at = {
      {0.5f, 0.5f, 0.5f},   // brick (0,0,0)'s centre
      {1.0f, 0.5f, 0.5f},   // half way: (0.5 + 0.9) / 2
      {1.25f, 0.3f, 0.6f},  // a quarter from brick (1,0,0): only x matters, y/z neighbours unseen
      {0.0f, 0.0f, 0.0f},   // no surface
      {5.0f, 5.0f, 5.0f}};  // nothing observed around
  float out[5];
  grid.lookup_ao_coarse(at.data(), at.size(), Pose::identity(), out);
  EXPECT_FLOAT_EQ(out[0], 0.5f);
  EXPECT_FLOAT_EQ(out[1], 0.7f);
  EXPECT_FLOAT_EQ(out[2], 0.25f * 0.5f + 0.75f * 0.9f);
  EXPECT_TRUE(std::isnan(out[3]));
  EXPECT_TRUE(std::isnan(out[4]));
}

TEST(MvaoGrid, CoarseLookupEqualsTheCoarsenedGridsSampleInEveryMode) {
  // Frames of random points over a few bricks (negative coordinates too, runs of pixels in one
  // brick, a rotated pose), a restored cell between them: after refresh_brick_sums() the coarse
  // read is coarsened(kBrickSide).sample() bit for bit, also after `last` reset cells.
  for (const AoIntegration mode :
       {AoIntegration::kMvao, AoIntegration::kMean, AoIntegration::kLast}) {
    AoConfig config = grid_config(mode);
    config.grid_resolution = 64;  // cells of 1/64 m, bricks of 1/16 m
    MvaoGrid grid(config);
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> coord(-0.2f, 0.2f), unit(0.0f, 1.0f);
    const Pose T(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1.0, -2.0, 0.5).normalized()).matrix(),
                 Eigen::Vector3d(0.01, -0.02, 0.03));
    std::vector<Eigen::Vector3f> queries;
    for (int frame = 0; frame < 6; ++frame) {
      std::vector<Eigen::Vector3f> points;
      std::vector<float> ao, w;
      for (int i = 0; i < 400; ++i) {
        points.push_back(i % 3 == 1 ? points.back()
                                    : Eigen::Vector3f(coord(rng), coord(rng), coord(rng)));
        ao.push_back(unit(rng));
        w.push_back(unit(rng) < 0.2f ? 0.0f : unit(rng));
      }
      const Frame f(points, ao, w);
      ASSERT_TRUE(grid.integrate(f.ao, f.w, f.maps, T).is_ok());
      if (frame == 2) {
        ASSERT_TRUE(grid.restore_cell({-20, 3, 7}, {0.3f, 0.5f, 3}));
      }
      if (frame % 2 == 0) continue;
      grid.refresh_brick_sums();
      const MvaoGrid coarse = grid.coarsened(MvaoGrid::kBrickSide);
      queries.clear();
      for (int i = 0; i < 2000; ++i)
        queries.push_back(
            i % 4 == 3
                ? Eigen::Vector3f(Eigen::Vector3f::Zero())
                : Eigen::Vector3f(Eigen::Vector3f(coord(rng), coord(rng), coord(rng)) * 1.3f));
      std::vector<float> out(queries.size());
      grid.lookup_ao_coarse(queries.data(), queries.size(), T, out.data());
      int found = 0;
      for (std::size_t i = 0; i < queries.size(); ++i) {
        const std::optional<float> expected =
            queries[i].isZero()
                ? std::nullopt
                : coarse.sample(T.rotation() * queries[i].cast<double>() + T.translation());
        if (expected) {
          ++found;
          EXPECT_EQ(out[i], *expected) << i;
        } else {
          EXPECT_TRUE(std::isnan(out[i])) << i;
        }
      }
      EXPECT_GT(found, 1000);
    }
  }
}

TEST(MvaoGrid, RejectsADegenerateCellSize) {
  AoConfig c;
  c.grid_extent_m = std::nan("");
  EXPECT_THROW(MvaoGrid{c}, Error);
}

}  // namespace
}  // namespace aoscan
