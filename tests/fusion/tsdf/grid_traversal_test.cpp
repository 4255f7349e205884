/// @file grid_traversal_test.cpp
/// @brief traverse_cells() against the exact cells a segment crosses (slab tests in double).
#include "fusion/tsdf/grid_traversal.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace aoscan {
namespace {

Eigen::Vector3i floor3(const Eigen::Vector3f& q) {
  return {static_cast<int>(std::floor(q.x())), static_cast<int>(std::floor(q.y())),
          static_cast<int>(std::floor(q.z()))};
}

std::vector<Eigen::Vector3i> traversed(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  std::vector<Eigen::Vector3i> cells;
  traverse_cells(a, b, floor3(a), floor3(b),
                 [&](const Eigen::Vector3i& c) { cells.push_back(c); });
  return cells;
}

/// The cells whose interior the segment a-b passes through, by entry parameter, and the smallest
/// gap between the segment's boundary crossings (ties make the order ambiguous).
std::vector<Eigen::Vector3i> reference_cells(const Eigen::Vector3f& af, const Eigen::Vector3f& bf,
                                             double& closest_crossings) {
  const Eigen::Vector3d a = af.cast<double>(), d = (bf - af).cast<double>();
  const Eigen::Vector3i lo = floor3(af).cwiseMin(floor3(bf));
  const Eigen::Vector3i hi = floor3(af).cwiseMax(floor3(bf));
  std::vector<std::pair<double, Eigen::Vector3i>> hits;
  std::vector<double> crossings;
  for (int i = 0; i < 3; ++i)
    for (int p = lo[i] + 1; p <= hi[i]; ++p) crossings.push_back((p - a[i]) / d[i]);
  std::sort(crossings.begin(), crossings.end());
  closest_crossings = 1.0;
  for (std::size_t k = 1; k < crossings.size(); ++k)
    closest_crossings = std::min(closest_crossings, crossings[k] - crossings[k - 1]);
  for (int x = lo.x(); x <= hi.x(); ++x)
    for (int y = lo.y(); y <= hi.y(); ++y)
      for (int z = lo.z(); z <= hi.z(); ++z) {
        const Eigen::Vector3i c(x, y, z);
        double t0 = 0.0, t1 = 1.0;
        for (int i = 0; i < 3; ++i) {
          if (d[i] == 0.0) {
            if (!(a[i] >= c[i] && a[i] < c[i] + 1)) t1 = -1.0;
            continue;
          }
          double e0 = (c[i] - a[i]) / d[i], e1 = (c[i] + 1 - a[i]) / d[i];
          if (e0 > e1) std::swap(e0, e1);
          t0 = std::max(t0, e0);
          t1 = std::min(t1, e1);
        }
        if (t1 > t0) hits.emplace_back(t0, c);
      }
  std::sort(hits.begin(), hits.end(), [](const auto& p, const auto& q) { return p.first < q.first; });
  std::vector<Eigen::Vector3i> cells;
  for (const auto& h : hits) cells.push_back(h.second);
  return cells;
}

TEST(GridTraversal, VisitsExactlyTheCrossedCellsInOrder) {
  // Random segments up to 3.5 cells long, so both the short (at most one cell per axis) and the
  // incremental traversal run; segments with two boundary crossings closer than 1e-5 of their
  // length are left out (their order depends on rounding).
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> pos(-6.0f, 6.0f), len(0.0f, 3.5f), comp(-1.0f, 1.0f);
  int checked = 0, short_ones = 0, long_ones = 0, ambiguous = 0;
  for (int n = 0; n < 20000; ++n) {
    const Eigen::Vector3f a(pos(rng), pos(rng), pos(rng));
    Eigen::Vector3f dir(comp(rng), comp(rng), comp(rng));
    if (dir.norm() < 1e-3f) continue;
    const Eigen::Vector3f b = a + dir.normalized() * len(rng);
    double closest = 0.0;
    const std::vector<Eigen::Vector3i> expected = reference_cells(a, b, closest);
    if (closest < 1e-5) {
      ++ambiguous;
      continue;
    }
    const std::vector<Eigen::Vector3i> got = traversed(a, b);
    ASSERT_EQ(got, expected) << "segment " << n;
    ++checked;
    ((floor3(b) - floor3(a)).cwiseAbs().maxCoeff() <= 1 ? short_ones : long_ones) += 1;
  }
  EXPECT_GT(short_ones, 5000);
  EXPECT_GT(long_ones, 2000);
  EXPECT_LT(ambiguous, 100);
  EXPECT_GT(checked, 19000);
}

TEST(GridTraversal, ExactTiesStillWalkFaceConnectedToTheEnd) {
  // Through a cell corner and along an edge: both ends are reached by unit steps, lower axis
  // first at a tie.
  const std::vector<Eigen::Vector3i> diagonal =
      traversed({0.5f, 0.5f, 0.5f}, {1.5f, 1.5f, 1.5f});
  const std::vector<Eigen::Vector3i> expected{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {1, 1, 1}};
  EXPECT_EQ(diagonal, expected);
  const std::vector<Eigen::Vector3i> long_diagonal =
      traversed({0.5f, 0.5f, 0.25f}, {2.5f, 2.5f, 0.75f});
  ASSERT_EQ(long_diagonal.size(), 5u);
  EXPECT_EQ(long_diagonal.front(), Eigen::Vector3i(0, 0, 0));
  EXPECT_EQ(long_diagonal.back(), Eigen::Vector3i(2, 2, 0));
  for (std::size_t k = 1; k < long_diagonal.size(); ++k)
    EXPECT_EQ((long_diagonal[k] - long_diagonal[k - 1]).cwiseAbs().sum(), 1);
  // A segment inside one cell, and negative coordinates.
  EXPECT_EQ(traversed({0.2f, 0.3f, 0.4f}, {0.7f, 0.6f, 0.5f}),
            std::vector<Eigen::Vector3i>{Eigen::Vector3i(0, 0, 0)});
  const std::vector<Eigen::Vector3i> backwards{{-1, 0, 0}, {-2, 0, 0}, {-3, 0, 0}};
  EXPECT_EQ(traversed({-0.5f, 0.5f, 0.5f}, {-2.5f, 0.5f, 0.5f}), backwards);
}

}  // namespace
}  // namespace aoscan
