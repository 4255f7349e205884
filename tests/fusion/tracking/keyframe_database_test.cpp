// Tests for src/fusion/tracking/keyframe_database.cpp: fern codes of rendered frames, the
// keyframe rule, the lookup of the most similar keyframe, and what a loaded keyframe must satisfy.
#include "fusion/tracking/keyframe_database.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "support/error_message.h"
#include "support/test_scenes.h"

namespace aoscan {
namespace {

const Intrinsics kCamera{320, 240, 292.5, 292.5, 160.0, 120.0};

/// The corner seen from `eye` towards the sphere.
DepthPyramid view(const Eigen::Vector3d& eye, double noise_m = 0.0, unsigned seed = 1) {
  return test::render_pyramid(test::corner_scene(), kCamera,
                              test::look_at(eye, {0.0, 0.5, 2.4}), noise_m, seed);
}

/// Adds `frame` at `T` if novel.
bool add(KeyframeDatabase& db, const DepthPyramid& frame, const Pose& T = Pose()) {
  return db.add_if_novel(db.encode(frame), T, frame);
}

/// Fraction of ferns whose codes differ.
double dissimilarity(const FernCodes& a, const FernCodes& b) {
  int differ = 0;
  for (std::size_t i = 0; i < a.size(); ++i) differ += a[i] != b[i];
  return static_cast<double>(differ) / static_cast<double>(a.size());
}

TEST(KeyframeDatabase, CodesAreDeterministicAndFitTheirBits) {
  RelocalisationConfig config;
  const KeyframeDatabase a(config), b(config);
  const DepthPyramid frame = view({0.3, -0.2, 0.2});
  const FernCodes codes = a.encode(frame);
  ASSERT_EQ(codes.size(), static_cast<std::size_t>(config.ferns));
  EXPECT_EQ(codes, b.encode(frame));  // the ferns come from a fixed seed
  int ones = 0;
  for (const std::uint8_t c : codes) {
    EXPECT_LT(c, 1u << config.fern_decisions);
    ones += __builtin_popcount(c);
  }
  // The decisions split a real view: neither (almost) all no nor all yes.
  const int bits = config.ferns * config.fern_decisions;
  EXPECT_GT(ones, bits / 10);
  EXPECT_LT(ones, bits * 9 / 10);
}

TEST(KeyframeDatabase, AnEmptyFrameAnswersNoEverywhere) {
  const KeyframeDatabase db{RelocalisationConfig{}};
  DepthPyramid empty = view({0.3, -0.2, 0.2});
  for (int level = 0; level < kPyramidLevels; ++level) {
    empty.depth_m[level].fill(0.0f);
    empty.maps[level].vertices.fill(Eigen::Vector3f::Zero());
    empty.maps[level].normals.fill(Eigen::Vector3f::Zero());
  }
  for (const std::uint8_t c : db.encode(empty)) EXPECT_EQ(c, 0u);
}

TEST(KeyframeDatabase, NearbyViewsShareMoreCodesThanDistantOnes) {
  const KeyframeDatabase db{RelocalisationConfig{}};
  const FernCodes here = db.encode(view({0.3, -0.2, 0.2}, 0.003, 1));
  const FernCodes near = db.encode(view({0.32, -0.2, 0.21}, 0.003, 2));  // 2 cm away, noisy
  const FernCodes far = db.encode(view({-0.5, -0.3, 1.2}, 0.003, 3));
  const double d_near = dissimilarity(here, near), d_far = dissimilarity(here, far);
  std::printf("dissimilarity: 2 cm away %.3f, across the scene %.3f\n", d_near, d_far);
  EXPECT_LT(d_near, 0.1);
  EXPECT_GT(d_far, 0.3);
}

TEST(KeyframeDatabase, KeyframesAreAddedOnlyWhenNovelAndFoundAgain) {
  RelocalisationConfig config;
  KeyframeDatabase db(config);
  // Keyframes 39 cm apart along a 1.6 m path; the same view again is not novel.
  const int n = 5;
  const auto path = [](int i) { return Eigen::Vector3d(0.6 - 0.3 * i, -0.2, 0.1 + 0.25 * i); };
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d eye = path(i);
    const Pose T = test::look_at(eye, {0.0, 0.5, 2.4});
    const DepthPyramid frame = view(eye);
    EXPECT_TRUE(add(db, frame, T)) << "view " << i;
    EXPECT_FALSE(add(db, frame, T)) << "view " << i << " again";
  }
  ASSERT_EQ(db.keyframes().size(), static_cast<std::size_t>(n));
  // A noisy view 2 cm from keyframe 3 finds keyframe 3 first, with a smaller dissimilarity than
  // the next one.
  const Eigen::Vector3d eye3 = path(3);
  const auto matches = db.nearest(db.encode(view(eye3 + Eigen::Vector3d(0.02, 0.0, 0.0), 0.003, 9)), 3);
  ASSERT_EQ(matches.size(), 3u);
  EXPECT_EQ(matches[0].keyframe, 3);
  EXPECT_LT(matches[0].dissimilarity, matches[1].dissimilarity);
  EXPECT_LE(matches[1].dissimilarity, matches[2].dissimilarity);
  EXPECT_TRUE(db.keyframes()[3].T_world_camera.translation().isApprox(
      test::look_at(eye3, {0.0, 0.5, 2.4}).translation()));
  // Each keyframe keeps its depth at the coarsest level, in millimetres.
  const DepthPyramid frame3 = view(eye3);
  const Image<std::uint16_t>& kept = db.keyframes()[3].depth_mm;
  const Image<float>& coarse = frame3.depth_m[kPyramidLevels - 1];
  ASSERT_EQ(kept.width(), coarse.width());
  ASSERT_EQ(kept.height(), coarse.height());
  for (std::size_t i = 0; i < coarse.size(); ++i)
    EXPECT_NEAR(kept.data()[i] * 0.001, coarse.data()[i], 0.0005);
}

TEST(KeyframeDatabase, DepthInMillimetresRoundsAndDropsWhatDoesNotFit) {
  Image<float> m(5, 1, 0.0f);
  m(0, 0) = 1.2344f;
  m(1, 0) = 1.2346f;
  m(2, 0) = 70.0f;  // beyond 65.534 m
  m(3, 0) = -1.0f;
  m(4, 0) = 0.0004f;  // rounds to 0: none
  const Image<std::uint16_t> mm = depth_to_mm(m);
  EXPECT_EQ(mm(0, 0), 1234);
  EXPECT_EQ(mm(1, 0), 1235);
  EXPECT_EQ(mm(2, 0), 0);
  EXPECT_EQ(mm(3, 0), 0);
  EXPECT_EQ(mm(4, 0), 0);
  Image<float> back;
  depth_from_mm(mm, back);
  EXPECT_FLOAT_EQ(back(0, 0), 1.234f);
  EXPECT_EQ(back(2, 0), 0.0f);
}

TEST(KeyframeDatabase, StopsGrowingWhenFullAndClears) {
  RelocalisationConfig config;
  config.max_keyframes = 2;
  KeyframeDatabase db(config);
  EXPECT_TRUE(add(db, view({0.3, -0.2, 0.2})));
  EXPECT_TRUE(add(db, view({-0.5, -0.3, 1.2})));
  EXPECT_TRUE(db.full());
  EXPECT_FALSE(add(db, view({0.6, -0.4, 0.9})));
  EXPECT_EQ(db.keyframes().size(), 2u);
  db.clear();
  EXPECT_TRUE(db.keyframes().empty());
  EXPECT_TRUE(db.nearest(db.encode(view({0.3, -0.2, 0.2})), 3).empty());
  EXPECT_TRUE(add(db, view({0.3, -0.2, 0.2})));
  EXPECT_EQ(db.nearest(db.encode(view({0.3, -0.2, 0.2})), 3).size(), 1u);
}

TEST(KeyframeDatabase, ALoadedKeyframeMustFitTheFerns) {
  RelocalisationConfig config;
  KeyframeDatabase db(config);
  Keyframe short_codes{FernCodes(10, 0), Pose(), {}};
  EXPECT_EQ(testing::error_message([&] { db.add(short_codes); }),
            "a keyframe has 10 fern codes, the database 500");
  Keyframe wide{FernCodes(500, 0), Pose(), {}};
  wide.codes[7] = 16;
  EXPECT_EQ(testing::error_message([&] { db.add(wide); }),
            "a keyframe's fern code 16 has more than 4 bits");
  Keyframe nan_pose{FernCodes(500, 0),
                    Pose(Eigen::Matrix3d::Identity(),
                         Eigen::Vector3d(std::numeric_limits<double>::quiet_NaN(), 0, 0)),
                    {}};
  EXPECT_EQ(testing::error_message([&] { db.add(nan_pose); }), "a keyframe's pose is not finite");
  EXPECT_TRUE(db.keyframes().empty());
  // Relocalisation off: no ferns, no codes, nothing found.
  config.ferns = 0;
  KeyframeDatabase off(config);
  EXPECT_TRUE(off.encode(view({0.3, -0.2, 0.2})).empty());
  EXPECT_FALSE(add(off, view({0.3, -0.2, 0.2})));
}

}  // namespace
}  // namespace aoscan
