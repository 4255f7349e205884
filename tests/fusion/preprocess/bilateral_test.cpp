/// @file bilateral_test.cpp
/// @brief Tests for src/fusion/bilateral.cpp: constant depth and step edges preserved exactly,
/// noise reduced, invalid pixels kept invalid, fast == reference within 1e-6 m, thread-count
/// independence.
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "fusion/preprocess/bilateral.h"
#include "fusion/preprocess/preprocess.h"
#include "io/png_read.h"
#include "support/prep_test_util.h"
#include "support/preprocess_reference.h"

namespace aoscan {
namespace {

/// Runs the fast filter (the AVX2 path on a CPU that has it), the portable path and the
/// reference; checks both fast paths == reference within 1e-6 m with the same validity; returns
/// the fast result.
Image<float> filter_both(const Image<float>& in, const PreprocessConfig& config) {
  Image<float> fast, portable, ref;
  bilateral_filter(in, config, fast);
  bilateral_filter_portable(in, config, portable);
  bilateral_filter_reference(in, config, ref);
  EXPECT_EQ(fast.width(), in.width());
  EXPECT_EQ(fast.height(), in.height());
  EXPECT_EQ(ref.width(), in.width());
  EXPECT_EQ(portable.width(), in.width());
  EXPECT_EQ(portable.height(), in.height());
  float worst = 0.0f;
  float worst_portable = 0.0f;
  for (std::size_t i = 0; i < in.size(); ++i) {
    EXPECT_EQ(fast.data()[i] > 0.0f, ref.data()[i] > 0.0f) << i;
    EXPECT_EQ(portable.data()[i] > 0.0f, ref.data()[i] > 0.0f) << i;
    worst = std::max(worst, std::fabs(fast.data()[i] - ref.data()[i]));
    worst_portable = std::max(worst_portable, std::fabs(portable.data()[i] - ref.data()[i]));
  }
  EXPECT_LE(worst, 1e-6f);
  EXPECT_LE(worst_portable, 1e-6f);
  return fast;
}

TEST(Bilateral, ConstantDepthIsPreservedExactly) {
  const PreprocessConfig config;
  for (float z : {0.4f, 1.2345678f, 3.9f}) {
    Image<float> in(50, 40, z);
    in(10, 10) = 0.0f;  // a hole
    Image<float> expected = in;
    EXPECT_EQ(filter_both(in, config), expected) << z;
  }
}

TEST(Bilateral, StepEdgeOfTenCentimetresIsPreserved) {
  // 1.0 m left, 1.1 m right: the 10 cm step is beyond 3 sigma_depth (9 cm), so no mixing at all.
  const PreprocessConfig config;
  Image<float> in(40, 30);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) in(x, y) = x < 20 ? 1.0f : 1.1f;
  EXPECT_EQ(filter_both(in, config), in);
}

TEST(Bilateral, InvalidPixelsStayInvalidAndDoNotContribute) {
  const PreprocessConfig config;
  Image<float> in = test::random_depth(80, 60, 3, 0.3);
  const Image<float> out = filter_both(in, config);
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 80; ++x) EXPECT_EQ(out(x, y) > 0.0f, in(x, y) > 0.0f) << x << "," << y;
  // A 2 m plane with holes: the holes add nothing, the plane stays exactly 2 m.
  Image<float> plane(30, 20, 2.0f);
  for (int i = 0; i < 30; i += 3) plane(i, i % 20) = 0.0f;
  EXPECT_EQ(filter_both(plane, config), plane);
}

TEST(Bilateral, ReducesNoiseOnAPlane) {
  // Fronto-parallel plane at 2 m with Gaussian noise sigma 5 mm (Kinect v1 at 2 m is about this).
  const int w = 160, h = 120;
  std::mt19937 rng(11);
  std::normal_distribution<float> noise(0.0f, 0.005f);
  Image<float> in(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) in(x, y) = 2.0f + noise(rng);
  PreprocessConfig config;  // sigma_space 4.5 px, sigma_depth 3 cm
  config.bilateral_radius_px = 6;
  const Image<float> out = filter_both(in, config);
  auto stddev = [&](const Image<float>& img) {
    double s = 0, s2 = 0;
    int n = 0;
    for (int y = 10; y < h - 10; ++y)
      for (int x = 10; x < w - 10; ++x, ++n) {
        s += img(x, y) - 2.0;
        s2 += (img(x, y) - 2.0) * (img(x, y) - 2.0);
      }
    return std::sqrt(s2 / n - (s / n) * (s / n));
  };
  const double before = stddev(in), after = stddev(out);
  // A 13x13 window with sigma 4.5 px averages about 130 effective samples, so the noise should
  // drop by about sqrt(130) ~ 11 (the depth weights are close to 1 for 5 mm noise); require 8.
  EXPECT_NEAR(before, 0.005, 0.0003);
  EXPECT_LT(after, before / 8.0) << before << " -> " << after;
  // A 7x7 window: about 45 effective samples, expected factor ~6.7; require 5.
  config.bilateral_radius_px = 3;
  const double after_7 = stddev(filter_both(in, config));
  EXPECT_LT(after_7, before / 5.0) << before << " -> " << after_7;
  EXPECT_GT(after_7, after);
  // The default 5x5 window: about 23 effective samples, expected factor ~4.8; require 4.
  config.bilateral_radius_px = PreprocessConfig{}.bilateral_radius_px;
  ASSERT_EQ(config.bilateral_radius_px, 2);
  const double after_small = stddev(filter_both(in, config));
  EXPECT_LT(after_small, before / 4.0) << before << " -> " << after_small;
  EXPECT_GT(after_small, after_7);
}

TEST(Bilateral, RadiusZeroCopies) {
  PreprocessConfig config;
  config.bilateral_radius_px = 0;
  const Image<float> in = test::random_depth(31, 17, 4, 0.2);
  EXPECT_EQ(filter_both(in, config), in);
}

TEST(Bilateral, FastMatchesReferenceOnRandomImages) {
  std::uint32_t seed = 100;
  // Widths around 2 r + 8 exercise the AVX2 blocks next to the scalar border pixels.
  for (const auto& [w, h] :
       {std::pair{1, 1}, std::pair{3, 2}, std::pair{7, 1}, std::pair{1, 9}, std::pair{14, 5},
        std::pair{15, 6}, std::pair{21, 4}, std::pair{37, 23}, std::pair{130, 97}}) {
    for (int radius : {1, 3, 6}) {
      PreprocessConfig config;
      config.bilateral_radius_px = radius;
      filter_both(test::random_depth(w, h, seed++, 0.15), config);
      config.bilateral_sigma_depth_m = 0.01;
      config.bilateral_sigma_space_px = 1.5;
      filter_both(test::random_depth(w, h, seed++, 0.15), config);
    }
  }
}

TEST(Bilateral, ResultDoesNotDependOnThreadCount) {
  const Image<float> in = test::random_depth(320, 240, 9, 0.1);
  const PreprocessConfig config;
  Image<float> many, one;
  bilateral_filter(in, config, many);
  {
    tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    bilateral_filter(in, config, one);
  }
  ASSERT_EQ(many.size(), one.size());
  EXPECT_EQ(std::memcmp(many.data(), one.data(), many.size() * sizeof(float)), 0);
}

TEST(Bilateral, RealFrameFastMatchesReference) {
  if (!std::filesystem::exists(test::redkitchen_dir()))
    GTEST_SKIP() << "shared data folder " << test::redkitchen_dir() << " is absent";
  DepthFrame f;
  f.depth_scale = 1000.0;
  f.intrinsics = test::redkitchen_intrinsics();
  const Status read = read_grey16_png(test::redkitchen_frame(250), f.depth);
  ASSERT_TRUE(read.is_ok()) << read.message();
  const PreprocessConfig config;
  Image<float> depth;
  preprocess_depth(f, config, depth);
  filter_both(depth, config);
}

}  // namespace
}  // namespace aoscan
