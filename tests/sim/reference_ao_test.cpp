/// @file reference_ao_test.cpp
/// @brief Tests for src/ao/reference_ao.h on analytic scenes: open plane (exactly 1), inner edge
/// of two planes (1/2) and inner corner of three (1/4), and a floor point near a wall against an
/// independent quadrature of Eq. 1.
#include "sim/reference_ao.h"

#include <cmath>

#include <gtest/gtest.h>

#include "sim/synth_scene.h"
#include "support/ao_test_util.h"

namespace aoscan {
namespace {

using test::caster;

/// Floor z <= 0, wall x <= 0 and (optionally) wall y <= 0, 50 m wide: infinite within t_max.
AnalyticScene corner(bool three_planes) {
  AnalyticScene s("test-corner");
  s.add_box({-1.0, -25.0, -1.0}, {25.0, 25.0, 0.0});
  s.add_box({-1.0, -25.0, 0.0}, {0.0, 25.0, 25.0});
  if (three_planes) s.add_box({0.0, -1.0, 0.0}, {25.0, 0.0, 25.0});
  return s;
}

double smoothstep(double d, double t_max) {
  const double u = std::clamp(d / t_max, 0.0, 1.0);
  return u * u * (3.0 - 2.0 * u);
}

TEST(ReferenceAo, PearsonRExactCases) {
  EXPECT_NEAR(pearson_r({1, 2, 3, 4}, {2, 4, 6, 8}), 1.0, 1e-12);
  EXPECT_NEAR(pearson_r({1, 2, 3, 4}, {-1, -2, -3, -4}), -1.0, 1e-12);
  EXPECT_EQ(pearson_r({1, 1, 1}, {1, 2, 3}), 0.0);   // constant: 0, not a division by zero
  EXPECT_EQ(pearson_r({1}, {2}), 0.0);               // fewer than two values
  EXPECT_NEAR(pearson_r({1, 2, 3, 9}, {2, 4, 6}), 1.0, 1e-12);  // the first min(|a|, |b|)
}

TEST(ReferenceAo, OpenPlaneIsExactlyOne) {
  const AnalyticScene plane = AnalyticScene::make("plane");
  EXPECT_EQ(reference_obscurance(caster(plane), {0.3, 0.0, -0.2}, {0.0, -1.0, 0.0}, 0.2), 1.0);
  EXPECT_EQ(reference_obscurance(caster(plane), {0.3, 0.0, -0.2}, {0.0, -1.0, 0.0}, 5.0, 32), 1.0);
}

TEST(ReferenceAo, InnerEdgeAndCornerHaveClosedFormValues) {
  // On the edge every direction toward a wall hits it at distance ~0 (rho ~ 0), every other
  // direction escapes: the open fraction of the cosine-weighted hemisphere is 1/2 for one wall
  // and 1/4 for two. Points sit 1e-6 m off the walls.
  const double e = 1e-6;
  const AnalyticScene two = corner(false);
  const AnalyticScene three = corner(true);
  EXPECT_NEAR(reference_obscurance(caster(two), {e, 0.7, 0.0}, {0.0, 0.0, 1.0}, 0.2, 32), 0.5,
              1e-3);
  EXPECT_NEAR(reference_obscurance(caster(three), {e, e, 0.0}, {0.0, 0.0, 1.0}, 0.2, 32), 0.25,
              1e-3);
  // The same corner seen from the wall's side.
  EXPECT_NEAR(reference_obscurance(caster(three), {0.0, e, e}, {1.0, 0.0, 0.0}, 0.2, 32), 0.25,
              1e-3);
}

TEST(ReferenceAo, FloorNearWallMatchesQuadratureOfEquation1) {
  // Floor point at distance h from the wall x = 0. Direction (sin t cos f, sin t sin f, cos t)
  // with f measured from -x (toward the wall) hits it at h / (sin t cos f) when cos f > 0.
  const AnalyticScene two = corner(false);
  const double t_max = 0.2;
  for (double h : {0.03, 0.1, 0.18}) {
    const int m = 1500;
    double occluded = 0.0;
    for (int i = 0; i < m; ++i) {
      const double theta = (i + 0.5) / m * 0.5 * M_PI;
      for (int j = 0; j < m; ++j) {
        const double f = -0.5 * M_PI + (j + 0.5) / m * M_PI;
        const double dist = h / (std::sin(theta) * std::cos(f));
        occluded += (1.0 - smoothstep(dist, t_max)) * std::cos(theta) * std::sin(theta);
      }
    }
    occluded *= (0.5 * M_PI / m) * (M_PI / m) / M_PI;
    const double expected = 1.0 - occluded;
    const double got = reference_obscurance(caster(two), {h, 0.4, 0.0}, {0.0, 0.0, 1.0}, t_max, 64);
    EXPECT_NEAR(got, expected, 2e-3) << "h = " << h;
    EXPECT_LT(got, 1.0);
  }
}

TEST(ReferenceAo, NonFiniteInputsAreOpen) {
  const AnalyticScene two = corner(false);
  EXPECT_EQ(reference_obscurance(caster(two), {std::nan(""), 0.0, 0.0}, {0, 0, 1}, 0.2), 1.0);
  EXPECT_EQ(reference_obscurance(caster(two), {1.0, 0.0, 0.0}, {0, 0, 0}, 0.2), 1.0);
}

}  // namespace
}  // namespace aoscan
