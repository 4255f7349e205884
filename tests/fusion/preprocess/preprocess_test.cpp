/// @file preprocess_test.cpp
/// @brief Tests for src/fusion/preprocess.cpp: raw depth to metres, border-outlier removal (fast ==
/// reference bit for bit, analytic cases of Sabbadin et al. 2016 Sec. 6), the fused pass and the
/// whole chain.
#include "fusion/preprocess/preprocess.h"

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <iostream>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "core/status.h"
#include "io/png_read.h"
#include "support/prep_test_util.h"
#include "support/preprocess_reference.h"

namespace aoscan {
namespace {

using Pixels = std::set<std::pair<int, int>>;

/// Bitwise image equality (distinguishes -0 from 0 and compares NaNs by bits).
bool bitwise_equal(const Image<float>& a, const Image<float>& b) {
  return a.width() == b.width() && a.height() == b.height() &&
         std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

/// Runs both outlier filters, checks they agree bit for bit, returns the fast result.
Image<float> filter_both(const Image<float>& in, float t, float per_m2 = 0.0f) {
  Image<float> fast, portable, ref;
  remove_border_outliers(in, t, per_m2, fast);
  remove_border_outliers_portable(in, t, per_m2, portable);
  remove_border_outliers_reference(in, t, per_m2, ref);
  EXPECT_TRUE(bitwise_equal(fast, ref))
      << in.width() << "x" << in.height() << " t=" << t << " per_m2=" << per_m2;
  EXPECT_TRUE(bitwise_equal(portable, ref))
      << "portable " << in.width() << "x" << in.height() << " t=" << t << " per_m2=" << per_m2;
  return fast;
}

/// Pixels that were valid in `in` and are 0 in `out`.
Pixels removed(const Image<float>& in, const Image<float>& out) {
  Pixels r;
  for (int y = 0; y < in.height(); ++y)
    for (int x = 0; x < in.width(); ++x) {
      if (in(x, y) > 0.0f && out(x, y) == 0.0f) r.insert({x, y});
      if (out(x, y) != 0.0f) {
        EXPECT_EQ(out(x, y), in(x, y)) << x << "," << y;
      }
    }
  return r;
}

DepthFrame make_frame(int w, int h, double scale = 1000.0) {
  DepthFrame f;
  f.depth.resize(w, h);
  f.depth_scale = scale;
  f.origin = "test.png";
  f.intrinsics = Intrinsics{w, h, 500.0, 500.0, (w - 1) / 2.0, (h - 1) / 2.0};
  return f;
}

// ----------------------------------------------------------------------------- depth_to_metres

TEST(DepthToMetres, ScaleInvalidValuesAndInclusiveRange) {
  DepthFrame f = make_frame(8, 1, 1000.0);
  const std::uint16_t raw[8] = {0, 65535, 399, 400, 1234, 4500, 4501, 65534};
  std::memcpy(f.depth.row(0), raw, sizeof raw);
  PreprocessConfig config;  // [0.4, 4.5] m
  Image<float> m;
  depth_to_metres(f, config, m);
  ASSERT_EQ(m.width(), 8);
  ASSERT_EQ(m.height(), 1);
  EXPECT_EQ(m(0, 0), 0.0f);
  EXPECT_EQ(m(1, 0), 0.0f);
  EXPECT_EQ(m(2, 0), 0.0f);              // 0.399 m < min
  EXPECT_EQ(m(3, 0), 400.0f / 1000.0f);  // == min: kept
  EXPECT_EQ(m(4, 0), 1234.0f / 1000.0f);
  EXPECT_EQ(m(5, 0), 4500.0f / 1000.0f);  // == max: kept
  EXPECT_EQ(m(6, 0), 0.0f);               // > max
  EXPECT_EQ(m(7, 0), 0.0f);

  // TUM scale 5000, no range clip: every raw value but 0 and 65535 converts.
  config.min_depth_m = 0.0;
  config.max_depth_m = 100.0;
  f.depth_scale = 5000.0;
  depth_to_metres(f, config, m);
  EXPECT_EQ(m(0, 0), 0.0f);
  EXPECT_EQ(m(1, 0), 0.0f);
  EXPECT_EQ(m(7, 0), 65534.0f / 5000.0f);
  EXPECT_EQ(m(4, 0), 1234.0f / 5000.0f);
}

TEST(DepthToMetres, BadScaleIsInputErrorNamingTheFile) {
  for (double scale : {0.0, -1000.0, std::nan(""), HUGE_VAL, 1e300}) {
    DepthFrame f = make_frame(4, 4, scale);
    f.sequence = 17;
    Image<float> m;
    try {
      depth_to_metres(f, PreprocessConfig{}, m);
      ADD_FAILURE() << "no error for scale " << scale;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ExitCode::kBadInput);
      EXPECT_NE(std::string(e.what()).find("test.png: frame 17"), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
    }
    EXPECT_THROW(preprocess_depth(f, PreprocessConfig{}, m), Error);
  }
}

TEST(DepthToMetres, EmptyFrame) {
  DepthFrame f = make_frame(0, 0);
  Image<float> m(3, 3, 1.0f);
  depth_to_metres(f, PreprocessConfig{}, m);
  EXPECT_TRUE(m.empty());
  preprocess_depth(f, PreprocessConfig{}, m);
  EXPECT_TRUE(m.empty());
}

// ----------------------------------------------------------------------- border-outlier removal

TEST(BorderOutliers, StepEdgeLosesExactlyTheAdjacentColumns) {
  Image<float> in(10, 6);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 10; ++x) in(x, y) = x < 5 ? 1.0f : 1.1f;  // a 10 cm step between x=4, 5
  const Image<float> out = filter_both(in, 0.02f);
  Pixels expected;
  for (int y = 0; y < 6; ++y) expected.insert({4, y}), expected.insert({5, y});
  EXPECT_EQ(removed(in, out), expected);
}

TEST(BorderOutliers, SlantedPlaneBelowThresholdKeepsEverything) {
  // A slanted plane 1 + 0.012 x + 0.007 y m: every neighbour differs by at most 1.9 cm < 2 cm.
  Image<float> in(40, 30);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) in(x, y) = 1.0f + 0.012f * x + 0.007f * y;
  EXPECT_TRUE(removed(in, filter_both(in, 0.02f)).empty());
  // A rendered slanted plane at 1-2 m (about 5 mm per pixel) also survives entirely.
  const Intrinsics k{64, 48, 60.0, 60.0, 31.5, 23.5};
  const Image<float> plane =
      test::render_plane(k, Eigen::Vector3d(0.3, 0.1, -1).normalized(), -1.5);
  EXPECT_TRUE(removed(plane, filter_both(plane, 0.02f)).empty());
}

TEST(BorderOutliers, SlantedPlaneAboveThresholdLosesEverything) {
  Image<float> in(40, 30);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) in(x, y) = 1.0f + 0.025f * x;  // 2.5 cm per column
  EXPECT_EQ(removed(in, filter_both(in, 0.02f)).size(), 40u * 30u);
  // Vertical slope only: every pixel still has a neighbour above or below beyond the threshold.
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) in(x, y) = 1.0f + 0.021f * y;
  EXPECT_EQ(removed(in, filter_both(in, 0.02f)).size(), 40u * 30u);
}

TEST(BorderOutliers, FlyingPixelAndItsNeighboursGo) {
  // Foreground 1 m in columns 0..2, background 2 m elsewhere, a flying pixel of 1.5 m at (8, 4).
  Image<float> in(12, 8);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 12; ++x) in(x, y) = x <= 2 ? 1.0f : 2.0f;
  in(8, 4) = 1.5f;
  Pixels expected;
  for (int y = 0; y < 8; ++y) expected.insert({2, y}), expected.insert({3, y});  // the step
  for (int y = 3; y <= 5; ++y)
    for (int x = 7; x <= 9; ++x) expected.insert({x, y});  // flying pixel and its 8 neighbours
  EXPECT_EQ(removed(in, filter_both(in, 0.02f)), expected);
}

TEST(BorderOutliers, ThresholdBoundaryIsStrict) {
  // Exact float differences (Sterbenz): a difference equal to t is kept, t + 1 ulp is removed.
  struct Case {
    float a, t;
  };
  for (const Case c : {Case{1.0f, 0.03125f}, Case{0.03125f, 0.02f}, Case{2.5f, 0.25f}}) {
    const float b = c.a + c.t;
    ASSERT_EQ(b - c.a, c.t) << "test values must give an exact difference";
    Image<float> in(3, 3, c.a);
    in(2, 2) = b;
    EXPECT_TRUE(removed(in, filter_both(in, c.t)).empty()) << c.a << " " << c.t;
    in(2, 2) = std::nextafter(b, 10.0f);
    ASSERT_GT(in(2, 2) - c.a, c.t);
    EXPECT_EQ(removed(in, filter_both(in, c.t)), (Pixels{{1, 1}, {1, 2}, {2, 1}, {2, 2}}))
        << c.a << " " << c.t;
  }
}

TEST(BorderOutliers, InvalidNeighboursAreIgnoredAndStayInvalid) {
  // A lone valid pixel in a hole and a surface next to a hole are both kept.
  Image<float> in(7, 5, 0.0f);
  in(1, 1) = 3.0f;
  for (int y = 0; y < 5; ++y) in(5, y) = in(6, y) = 1.0f;
  const Image<float> out = filter_both(in, 0.02f);
  EXPECT_TRUE(removed(in, out).empty());
  EXPECT_EQ(out, in);
  // Negative and NaN input depths count as invalid: written as 0, ignored as neighbours.
  Image<float> odd(3, 1);
  odd(0, 0) = -1.0f;
  odd(1, 0) = 1.0f;
  odd(2, 0) = std::nanf("");
  const Image<float> cleaned = filter_both(odd, 0.02f);
  EXPECT_EQ(cleaned(0, 0), 0.0f);
  EXPECT_EQ(cleaned(1, 0), 1.0f);
  EXPECT_EQ(cleaned(2, 0), 0.0f);
}

TEST(BorderOutliers, BordersCompareWithTheNeighboursTheyHave) {
  // Only the corner pixel (0, 0) differs: it and its three neighbours go, nothing else.
  Image<float> in(5, 4, 2.0f);
  in(0, 0) = 2.5f;
  EXPECT_EQ(removed(in, filter_both(in, 0.02f)), (Pixels{{0, 0}, {1, 0}, {0, 1}, {1, 1}}));
  // The bottom-right corner's diagonal neighbour.
  Image<float> in2(5, 4, 2.0f);
  in2(3, 2) = 2.5f;
  in2(4, 3) = 2.0f;
  const Pixels r = removed(in2, filter_both(in2, 0.02f));
  EXPECT_TRUE(r.count({4, 3}));
  EXPECT_EQ(r.size(), 9u);
  // Degenerate shapes: single pixel, single row, single column.
  EXPECT_TRUE(
      removed(Image<float>(1, 1, 1.0f), filter_both(Image<float>(1, 1, 1.0f), 0.02f)).empty());
  Image<float> row(5, 1, 1.0f);
  row(4, 0) = 1.5f;
  EXPECT_EQ(removed(row, filter_both(row, 0.02f)), (Pixels{{3, 0}, {4, 0}}));
  Image<float> col(1, 5, 1.0f);
  col(0, 0) = 1.5f;
  EXPECT_EQ(removed(col, filter_both(col, 0.02f)), (Pixels{{0, 0}, {0, 1}}));
}

TEST(BorderOutliers, ZeroThresholdDisables) {
  Image<float> in(10, 6);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 10; ++x) in(x, y) = x < 5 ? 1.0f : 1.1f;
  EXPECT_EQ(filter_both(in, 0.0f), in);
  EXPECT_EQ(filter_both(in, -1.0f), in);
}

TEST(BorderOutliers, FastEqualsReferenceOnRandomImages) {
  const std::pair<int, int> sizes[] = {{1, 1},   {2, 2},   {1, 9},   {9, 1},    {3, 2},
                                       {37, 23}, {64, 64}, {641, 3}, {640, 480}};
  std::uint32_t seed = 1;
  for (const auto& [w, h] : sizes)
    for (double holes : {0.0, 0.1, 0.5}) {
      const Image<float> in = test::random_depth(w, h, seed++, holes);
      for (float t : {0.005f, 0.02f, 0.1f})
        for (float per_m2 : {0.0f, 0.002f, 0.05f}) filter_both(in, t, per_m2);
    }
}

TEST(BorderOutliers, ThresholdGrowsWithTheSquareOfTheDepth) {
  // Kinect-v1-like disparity steps: a fronto-parallel staircase of 3 cm steps every 4 columns at
  // 3.5 m (t = 2 cm + 0.002 * 3.5^2 = 4.45 cm keeps it), and a 20 cm jump at 1 m (t = 2.2 cm
  // removes the columns on both sides of it).
  Image<float> far(16, 4), near(16, 4);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 16; ++x) {
      far(x, y) = 3.5f + 0.03f * static_cast<float>(x / 4);
      near(x, y) = x < 8 ? 1.0f : 1.2f;
    }
  EXPECT_TRUE(removed(far, filter_both(far, 0.02f, 0.002f)).empty());
  EXPECT_EQ(removed(far, filter_both(far, 0.02f, 0.0f)).size(), 3u * 2u * 4u);  // the paper's
  Pixels jump;
  for (int y = 0; y < 4; ++y) jump.insert({7, y}), jump.insert({8, y});
  EXPECT_EQ(removed(near, filter_both(near, 0.02f, 0.002f)), jump);
}

// ----------------------------------------------------------------------------- fused pass

TEST(PreprocessDepth, FusedEqualsSeparateSteps) {
  std::mt19937 rng(5);
  for (const auto& [w, h] : {std::pair{640, 480}, std::pair{1, 1}, std::pair{5, 1}, std::pair{1, 5},
                             std::pair{33, 17}}) {
    DepthFrame f = make_frame(w, h);
    // Smooth surfaces with steps, raw 0 and 65535, values outside the range.
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const std::uint32_t r = rng() % 100;
        std::uint16_t v =
            static_cast<std::uint16_t>(800 + 3 * x + 2 * y + (x / 50) * 40 + rng() % 15);
        if (r < 5)
          v = 0;
        else if (r < 7)
          v = 65535;
        else if (r < 9)
          v = static_cast<std::uint16_t>(rng() % 400);
        else if (r < 11)
          v = static_cast<std::uint16_t>(4500 + rng() % 60000);
        f.depth(x, y) = v;
      }
    for (double t : {0.02, 0.0, 0.001})
      for (double per_m2 : {0.0, 0.006})
        for (double tracking_per_m2 : {0.0, 0.004, 0.006}) {
          PreprocessConfig config;
          config.outlier_threshold_m = t;
          config.outlier_threshold_per_m2 = per_m2;
          config.tracking_outlier_threshold_per_m2 = tracking_per_m2;
          Image<float> metres, separate, fused, tracking_separate, tracking_fused, fused_alone;
          depth_to_metres(f, config, metres);
          remove_border_outliers_reference(metres, static_cast<float>(t),
                                           static_cast<float>(per_m2), separate);
          remove_border_outliers_reference(metres, static_cast<float>(t),
                                           static_cast<float>(tracking_per_m2), tracking_separate);
          preprocess_depth(f, config, fused, &tracking_fused);
          preprocess_depth(f, config, fused_alone);
          EXPECT_TRUE(bitwise_equal(fused, separate)) << w << "x" << h << " t=" << t;
          EXPECT_TRUE(bitwise_equal(fused_alone, separate)) << w << "x" << h << " t=" << t;
          // The tracking depth with its own growth, or empty when that is `fused` itself.
          if (per_m2 != tracking_per_m2 && t > 0.0) {
            EXPECT_TRUE(bitwise_equal(tracking_fused, tracking_separate))
                << w << "x" << h << " t=" << t << " tracking_per_m2=" << tracking_per_m2;
          } else {
            EXPECT_TRUE(tracking_fused.empty());
          }
        }
  }
}

TEST(PreprocessFrame, WholeChainAndSizeMismatch) {
  DepthFrame f = make_frame(64, 48);
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) f.depth(x, y) = 1500;
  PreprocessedFrame out;
  preprocess_frame(f, PreprocessConfig{}, out);
  EXPECT_EQ(out.depth_m, Image<float>(64, 48, 1.5f));
  EXPECT_EQ(out.filtered_m, Image<float>(64, 48, 1.5f));
  EXPECT_EQ(out.pyramid.depth_m[2], Image<float>(16, 12, 1.5f));
  EXPECT_EQ(out.pyramid.maps[1].intrinsics, f.intrinsics.scaled(1));
  f.intrinsics.width = 640;
  try {
    preprocess_frame(f, PreprocessConfig{}, out);
    ADD_FAILURE() << "no error on a size mismatch";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kBadInput);
    EXPECT_NE(std::string(e.what()).find("test.png"), std::string::npos);
  }
}

// ----------------------------------------------------------------------------- real frames

TEST(PreprocessRealData, FastEqualsReferenceOnRedKitchen) {
  if (!std::filesystem::exists(test::redkitchen_dir()))
    GTEST_SKIP() << "shared data folder " << test::redkitchen_dir() << " is absent";
  DepthFrame f;
  f.depth_scale = 1000.0;
  f.intrinsics = test::redkitchen_intrinsics();
  const PreprocessConfig config;
  std::size_t removed_total = 0, valid_total = 0;
  for (int i = 0; i < 500; i += 25) {
    const Status read = read_grey16_png(test::redkitchen_frame(i), f.depth);
    ASSERT_TRUE(read.is_ok()) << read.message();
    Image<float> metres, ref, fast, fused;
    depth_to_metres(f, config, metres);
    const float t = static_cast<float>(config.outlier_threshold_m);
    const float per_m2 = static_cast<float>(config.outlier_threshold_per_m2);
    remove_border_outliers_reference(metres, t, per_m2, ref);
    remove_border_outliers(metres, t, per_m2, fast);
    preprocess_depth(f, config, fused);
    ASSERT_TRUE(bitwise_equal(fast, ref)) << "frame " << i;
    ASSERT_TRUE(bitwise_equal(fused, ref)) << "frame " << i;
    for (std::size_t p = 0; p < metres.size(); ++p) {
      valid_total += metres.data()[p] > 0.0f;
      removed_total += metres.data()[p] > 0.0f && ref.data()[p] == 0.0f;
    }
  }
  // Real Kinect depth has edges: the filter removes some, but only a small share, of the pixels.
  const double share = static_cast<double>(removed_total) / static_cast<double>(valid_total);
  EXPECT_GT(share, 0.001);
  EXPECT_LT(share, 0.2);
  std::cout << "[ info     ] border outliers removed: " << 100.0 * share << " % of valid pixels\n";
}

}  // namespace
}  // namespace aoscan
