/// @file ao_accuracy_test.cpp
/// @brief SSAO estimators x MVAO integration modes against the ray-traced Eq. 1 reference on the
/// exact corner scene (320x240, 48 frames; harness in support/ao_accuracy.h): the default
/// estimator must be the best. The full-size tables, the sample-count / stride sweep and the
/// per-frame timing are the aoscan-ao-accuracy benchmark's (tools/bench/ao_accuracy.cpp).
#include <cmath>

#include <gtest/gtest.h>

#include "ao/ao_config.h"
#include "support/ao_accuracy.h"

namespace aoscan {
namespace {

TEST(AoAccuracy, EstimatorsAndModesAgainstRayTracedReference) {
#if defined(AOSCAN_SANITIZED)
  GTEST_SKIP() << "an accuracy measurement of every estimator and mode; too slow under the "
                  "sanitizers, which see the same kernels in Ssao.FastMatchesReference*";
#endif
  const test::AoEvalSetup setup;
  const auto scores = test::measure_ao_accuracy(setup, test::all_ao_configs(AoConfig{}));
  test::print_ao_scores("corner 320x240, 48 frames, defaults", scores);
  const auto r = [&](AoEstimator e, AoIntegration m) { return scores.at(test::AoKey{e, m}).r; };
  // The default estimator is the best one, beats Eq. 3 as printed by far, and integrating many
  // views is not worse than the last view (with exact depth the single view is already good).
  const AoEstimator best = AoConfig{}.estimator;
  for (AoEstimator e : {AoEstimator::kPaper, AoEstimator::kObscurance, AoEstimator::kAlchemy,
                        AoEstimator::kHorizon, AoEstimator::kHeightfield})
    EXPECT_GE(r(best, AoIntegration::kMvao), r(e, AoIntegration::kMvao) - 0.005)
        << test::estimator_name(e);
  EXPECT_GT(r(best, AoIntegration::kMvao), 0.9);
  EXPECT_LT(std::abs(scores.at(test::AoKey{best, AoIntegration::kMvao}).bias), 0.03);
  EXPECT_GT(r(best, AoIntegration::kMvao), r(best, AoIntegration::kLast) - 0.01);
  EXPECT_GT(r(best, AoIntegration::kMvao), r(AoEstimator::kPaper, AoIntegration::kMvao) + 0.3);
  for (const auto& [key, s] : scores) EXPECT_GT(s.points, 1000);
}

}  // namespace
}  // namespace aoscan
