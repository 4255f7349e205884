/// @file pyramid_test.cpp
/// @brief Tests for src/fusion/preprocess/pyramid.cpp: pyramid levels, their intrinsics and maps.
#include <cmath>
#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "core/status.h"
#include "fusion/preprocess/pyramid.h"
#include "support/prep_test_util.h"

namespace aoscan {
namespace {

const Intrinsics kKinect{640, 480, 585.0, 585.0, 320.0, 240.0};

using test::angle;
using test::kPlanes;
using test::Plane;

TEST(Pyramid, LevelsIntrinsicsAndMapsAreConsistent) {
  const Plane& plane = kPlanes[1];
  const Image<float> depth = test::render_plane(kKinect, plane.n, plane.d);
  DepthPyramid pyramid;
  build_pyramid(depth, kKinect, pyramid);
  EXPECT_EQ(pyramid.depth_m[0], depth);
  for (int level = 0; level < kPyramidLevels; ++level) {
    const Intrinsics k = kKinect.scaled(level);
    const PointMaps& maps = pyramid.maps[level];
    EXPECT_EQ(maps.intrinsics, k);
    EXPECT_EQ(pyramid.depth_m[level].width(), k.width);
    EXPECT_EQ(pyramid.depth_m[level].height(), k.height);
    EXPECT_EQ(maps.vertices.width(), k.width);
    EXPECT_EQ(maps.normals.height(), k.height);
    double worst_angle = 0;
    for (int y = 0; y + 1 < k.height; ++y)
      for (int x = 0; x + 1 < k.width; ++x)
        worst_angle = std::max(worst_angle, angle(maps.normals(x, y).cast<double>(), plane.n));
    EXPECT_LT(worst_angle, 3e-4) << "level " << level;
  }
  // A level-1 vertex is the mean of its block's four level-0 vertices: exact for a fronto-parallel
  // plane; for a tilted one the mean depth differs from the depth on the centre ray by a term of
  // second order in the pixel size.
  for (const Plane& p : {kPlanes[0], kPlanes[1]}) {
    build_pyramid(test::render_plane(kKinect, p.n, p.d), kKinect, pyramid);
    double worst = 0;
    for (int y = 0; y < kKinect.height / 2; ++y)
      for (int x = 0; x < kKinect.width / 2; ++x) {
        const Eigen::Vector3f mean =
            (pyramid.maps[0].vertices(2 * x, 2 * y) + pyramid.maps[0].vertices(2 * x + 1, 2 * y) +
             pyramid.maps[0].vertices(2 * x, 2 * y + 1) +
             pyramid.maps[0].vertices(2 * x + 1, 2 * y + 1)) /
            4.0f;
        worst =
            std::max(worst, static_cast<double>((pyramid.maps[1].vertices(x, y) - mean).norm()));
      }
    EXPECT_LT(worst, p.n.z() == -1.0 ? 1e-6 : 2e-5) << p.n.transpose();
  }
}

TEST(Pyramid, ResultDoesNotDependOnThreadCount) {
  // Random depth with holes at VGA size: every level's depth, vertex and normal map must be the
  // same bits with one thread as with all of them (rows run in parallel).
  const Intrinsics k = test::redkitchen_intrinsics();
  const Image<float> depth = test::random_depth(k.width, k.height, 21, 0.1);
  DepthPyramid many, one;
  build_pyramid(depth, k, many);
  {
    tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    build_pyramid(depth, k, one);
  }
  for (int l = 0; l < kPyramidLevels; ++l) {
    ASSERT_EQ(many.depth_m[l].size(), one.depth_m[l].size());
    EXPECT_EQ(std::memcmp(many.depth_m[l].data(), one.depth_m[l].data(),
                          one.depth_m[l].size() * sizeof(float)),
              0)
        << l;
    EXPECT_EQ(many.maps[l].vertices, one.maps[l].vertices) << l;
    EXPECT_EQ(many.maps[l].normals, one.maps[l].normals) << l;
  }
}

TEST(Pyramid, SizeMismatchIsAnInputError) {
  DepthPyramid pyramid;
  try {
    build_pyramid(Image<float>(320, 240, 1.0f), kKinect, pyramid);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kBadInput);
  }
}

TEST(Pyramid, TinyImagesDoNotCrash) {
  for (const auto& [w, h] : {std::pair{1, 1}, std::pair{2, 2}, std::pair{3, 5}, std::pair{0, 0}}) {
    const Intrinsics k{w, h, 10.0, 10.0, 0.0, 0.0};
    DepthPyramid pyramid;
    build_pyramid(Image<float>(w, h, 1.0f), k, PreprocessConfig{}, pyramid);
    EXPECT_EQ(pyramid.depth_m[2].width(), w / 4);
    EXPECT_EQ(pyramid.maps[2].normals.height(), h / 4);
  }
}

}  // namespace
}  // namespace aoscan
