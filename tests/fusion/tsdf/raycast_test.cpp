// Tests for src/fusion/raycast.cpp: depth and normals of fused analytic scenes from new poses,
// the fast raycast against the fixed-step reference, empty and bad input.
#include "fusion/tsdf/raycast.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "core/status.h"
#include "fusion/tsdf/tsdf_integrator.h"
#include "geometry/simd.h"
#include "support/test_scenes.h"
#include "support/tsdf_reference.h"

namespace aoscan {
namespace {

const Intrinsics kKinect{640, 480, 585.0, 585.0, 320.0, 240.0};

/// A sphere in front of a back wall and a floor, fused from three viewpoints.
struct FusedScene {
  test::Scene scene;
  TsdfVolume volume{FusionConfig{}};
  TsdfIntegrator integrator;

  FusedScene() {
    scene.planes.push_back({Eigen::Vector3d(0, 0, 1), 2.4});
    scene.planes.push_back({Eigen::Vector3d(0, 1, 0), 0.6});
    scene.spheres.push_back({Eigen::Vector3d(0.05, 0.1, 1.6), 0.35});
    Image<float> depth;
    for (const Pose& pose :
         {test::look_at({0, 0, 0}, {0, 0.1, 1.6}), test::look_at({-0.4, -0.1, 0.2}, {0, 0.1, 1.6}),
          test::look_at({0.4, -0.2, 0.1}, {0, 0.1, 1.6})}) {
      test::render(scene, kKinect, pose, depth);
      integrator.integrate(volume, depth, kKinect, pose);
    }
  }
};

const Image<float>& depth_small() {
  static const Image<float> small(320, 240, 1.0f);
  return small;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * (v.size() - 1))];
}

TEST(Raycast, FusedSceneFromNewPoseMatchesAnalyticDepthAndNormals) {
  const FusedScene fused;
  const Pose pose = test::look_at({0.15, -0.05, 0.1}, {0, 0.1, 1.6});
  RaycastResult result;
  raycast(fused.volume, kKinect, pose, FusionConfig{}, result);
  Image<float> truth;
  PointMaps truth_maps;
  test::render(fused.scene, kKinect, pose, truth, &truth_maps);
  std::vector<double> depth_errors, angle_errors;
  int truth_valid = 0;
  for (int y = 2; y < kKinect.height - 2; ++y) {
    for (int x = 2; x < kKinect.width - 2; ++x) {
      if (truth(x, y) <= 0) continue;
      // Skip depth discontinuities, where a pixel's ray grazes the silhouette.
      bool edge = false;
      for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx)
          edge |= std::abs(truth(x + dx, y + dy) - truth(x, y)) > 0.05f;
      // Only surfaces seen within 60 degrees of the view ray: at grazing angles the projective
      // TSDF itself is inaccurate, whatever the raycast does.
      const Eigen::Vector3f& n = truth_maps.normals(x, y);
      if (edge || -n.dot(truth_maps.vertices(x, y).normalized()) < 0.5f) continue;
      ++truth_valid;
      if (result.depth_m(x, y) <= 0) continue;
      depth_errors.push_back(std::abs(result.depth_m(x, y) - truth(x, y)));
      const double c = result.maps.normals(x, y).dot(truth_maps.normals(x, y));
      angle_errors.push_back(std::acos(std::min(1.0, c)) * 180.0 / M_PI);
      EXPECT_NEAR((result.maps.vertices(x, y) - truth_maps.vertices(x, y)).norm(),
                  depth_errors.back() * truth_maps.vertices(x, y).norm() / truth(x, y), 1e-4);
    }
  }
  EXPECT_GT(depth_errors.size(), 0.97 * truth_valid);
  EXPECT_EQ(result.hits,
            std::count_if(result.depth_m.data(), result.depth_m.data() + result.depth_m.size(),
                          [](float d) { return d > 0; }));
  EXPECT_LT(percentile(depth_errors, 0.5), 0.0005);
  EXPECT_LT(percentile(depth_errors, 0.99), 0.002);
  EXPECT_LT(percentile(angle_errors, 0.5), 1.5);
  EXPECT_LT(percentile(angle_errors, 0.95), 3.0);
  EXPECT_TRUE(result.T_world_camera.matrix().isApprox(pose.matrix()));
  EXPECT_EQ(result.maps.intrinsics, kKinect);
}

TEST(Raycast, FastRaycastAgreesWithFixedStepReference) {
  const FusedScene fused;
  const Pose pose = test::look_at({-0.1, 0.0, 0.05}, {0, 0.1, 1.6});
  const Intrinsics small = kKinect.scaled(2);
  FusionConfig config;
  config.raycast_min_depth_m = 0.5;
  config.raycast_max_depth_m = 3.0;
  RaycastResult fast, reference;
  raycast(fused.volume, small, pose, config, fast);
  test::raycast_reference(fused.volume, small, pose, config, 0.25f, reference);
  int both = 0, disagree_mask = 0;
  std::vector<double> depth_diff, plane_diff;
  for (int y = 0; y < small.height; ++y) {
    for (int x = 0; x < small.width; ++x) {
      const bool a = fast.depth_m(x, y) > 0, b = reference.depth_m(x, y) > 0;
      if (a != b) ++disagree_mask;
      if (!a || !b) continue;
      ++both;
      depth_diff.push_back(std::abs(fast.depth_m(x, y) - reference.depth_m(x, y)));
      // Distance between the two hits across the surface: the depth along a grazing ray is
      // ill-conditioned, the surface position is not.
      plane_diff.push_back(std::abs(reference.maps.normals(x, y).dot(
          fast.maps.vertices(x, y) - reference.maps.vertices(x, y))));
    }
  }
  std::printf(
      "masks differ %d of %d; depth diff p50 %.5f p99 %.5f max %.5f; across surface p99 "
      "%.5f max %.5f\n",
      disagree_mask, both, percentile(depth_diff, 0.5), percentile(depth_diff, 0.99),
      percentile(depth_diff, 1.0), percentile(plane_diff, 0.99), percentile(plane_diff, 1.0));
  EXPECT_GT(both, small.width * small.height / 2);
  EXPECT_LE(disagree_mask, both / 400);  // 0.25 % at silhouettes
  EXPECT_LT(percentile(depth_diff, 0.5), 0.0001);
  EXPECT_LT(percentile(depth_diff, 0.99), 0.001);
  EXPECT_LT(percentile(plane_diff, 0.99), 0.0003);
  // A different surface altogether: at silhouettes, where a grazing crossing is thinner than a
  // step, one march sees the front object and the other the background. At most 0.5 %.
  EXPECT_LE(std::count_if(depth_diff.begin(), depth_diff.end(), [](double d) { return d > 0.01; }),
            both / 200);
}

TEST(Raycast, DepthHintFindsTheSameSurface) {
  // The last frame fused from this pose is the hint, as the tracking loop does.
  const FusedScene fused;
  const Pose pose = test::look_at({0.4, -0.2, 0.1}, {0, 0.1, 1.6});
  Image<float> hint;
  test::render(fused.scene, kKinect, pose, hint, nullptr, 0.003, 5);
  TsdfVolume volume{FusionConfig{}};
  TsdfIntegrator integrator;
  Image<float> depth;
  for (const Pose& p : {test::look_at({0, 0, 0}, {0, 0.1, 1.6}), pose}) {
    test::render(fused.scene, kKinect, p, depth, nullptr, 0.003, p.translation().x() > 0 ? 5 : 6);
    integrator.integrate(volume, depth, kKinect, p);
  }
  RaycastResult with, without;
  raycast(volume, kKinect, pose, FusionConfig{}, with, &hint);
  raycast(volume, kKinect, pose, FusionConfig{}, without);
  int both = 0, only_one = 0, differ = 0, gross = 0;
  for (int y = 0; y < kKinect.height; ++y)
    for (int x = 0; x < kKinect.width; ++x) {
      const bool a = with.depth_m(x, y) > 0, b = without.depth_m(x, y) > 0;
      only_one += a != b;
      if (!a || !b) continue;
      ++both;
      // Both find a crossing of the same noisy field; they may bracket different wiggles of it.
      const float diff = std::abs(with.depth_m(x, y) - without.depth_m(x, y));
      differ += diff > 0.001f;
      gross += diff > 0.01f;
    }
  EXPECT_GT(both, 200000);
  EXPECT_LE(only_one, both / 100);
  EXPECT_LE(differ, both * 3 / 100);
  EXPECT_LE(gross, both / 200);
  EXPECT_THROW(raycast(volume, kKinect, pose, FusionConfig{}, with, &depth_small()), Error);
}

TEST(Raycast, HintedOnlyCastsExactlyTheHintedRays) {
  // A hint with a hole: with RaycastRays::kHintedOnly the hole stays empty and every other pixel
  // is the hinted raycast's, in the fast and the portable version alike.
  const FusedScene fused;
  const Pose pose = test::look_at({0.2, -0.1, 0.05}, {0, 0.1, 1.6});
  Image<float> hint;
  test::render(fused.scene, kKinect, pose, hint, nullptr, 0.003, 7);
  for (int y = 100; y < 200; ++y)
    for (int x = 200; x < 360; ++x) hint(x, y) = 0.0f;
  RaycastResult all, only, only_portable;
  raycast(fused.volume, kKinect, pose, FusionConfig{}, all, &hint);
  raycast(fused.volume, kKinect, pose, FusionConfig{}, only, &hint, RaycastRays::kHintedOnly);
  raycast_portable(fused.volume, kKinect, pose, FusionConfig{}, only_portable, &hint,
                   RaycastRays::kHintedOnly);
  int hole_hits_all = 0;
  for (int y = 0; y < kKinect.height; ++y)
    for (int x = 0; x < kKinect.width; ++x) {
      if (hint(x, y) > 0.0f) {
        ASSERT_EQ(only.depth_m(x, y), all.depth_m(x, y)) << x << "," << y;
        ASSERT_EQ(only.maps.normals(x, y), all.maps.normals(x, y)) << x << "," << y;
      } else {
        ASSERT_EQ(only.depth_m(x, y), 0.0f) << x << "," << y;
        hole_hits_all += all.depth_m(x, y) > 0.0f;
      }
      ASSERT_EQ(only_portable.depth_m(x, y), only.depth_m(x, y)) << x << "," << y;
    }
  EXPECT_GT(hole_hits_all, 100 * 160 / 2);  // kAll marches the hole's rays and finds the scene
  EXPECT_EQ(only.hits, count_hits(only.depth_m));
}

TEST(Raycast, HintedRaysSearchedEightAtATimeMatchTheOneAtATimeSearch) {
  // raycast() searches the hinted rays of a row eight per AVX2 vector (on a CPU with AVX2);
  // raycast_portable() one at a time. Same hits, vertices and normals bit for bit: with the
  // frame's own depth as the hint, and with hints that are off (the search fails and the ray
  // marches the hint's window), missing (the whole ray is marched) or outside the depth range,
  // at full and half resolution (rows whose hinted rays do not fill the last vector).
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
  if (!cpu_has_avx2()) GTEST_SKIP() << "this CPU has no AVX2: raycast() is raycast_portable()";
#else
  GTEST_SKIP() << "no AVX2 path on this architecture: raycast() is raycast_portable()";
#endif
  const FusedScene fused;
  const Pose pose = test::look_at({0.4, -0.2, 0.1}, {0, 0.1, 1.6});
  TsdfVolume volume{FusionConfig{}};
  TsdfIntegrator integrator;
  Image<float> depth;
  for (const Pose& p : {test::look_at({0, 0, 0}, {0, 0.1, 1.6}), pose}) {
    test::render(fused.scene, kKinect, p, depth, nullptr, 0.003, p.translation().x() > 0 ? 5 : 6);
    integrator.integrate(volume, depth, kKinect, p);
  }
  for (const int level : {0, 1}) {
    const Intrinsics k = kKinect.scaled(level);
    Image<float> hint;
    test::render(fused.scene, k, pose, hint, nullptr, 0.003, 5);
    for (const bool perturbed : {false, true}) {
      if (perturbed)
        for (std::size_t i = 0; i < hint.size(); ++i) {
          float& d = hint.data()[i];
          if (i % 7 == 0) d += 0.05f;  // beyond the search, inside the window
          if (i % 11 == 0) d = 0.0f;   // no hint
          if (i % 13 == 0) d -= 0.2f;  // beyond the window
          if (i % 17 == 0) d = 50.0f;  // beyond the depth range
        }
      RaycastResult fast, portable;
      raycast(volume, k, pose, FusionConfig{}, fast, &hint);
      raycast_portable(volume, k, pose, FusionConfig{}, portable, &hint);
      EXPECT_GT(fast.hits, k.width * k.height / 2) << "level " << level;
      EXPECT_EQ(fast.hits, portable.hits);
      EXPECT_TRUE(fast.depth_m == portable.depth_m) << "level " << level << " " << perturbed;
      EXPECT_TRUE(fast.maps.vertices == portable.maps.vertices);
      EXPECT_TRUE(fast.maps.normals == portable.maps.normals);
    }
  }
}

TEST(Raycast, RaysCrossingLongEmptySpaceAgreeWithTheReference) {
  // A small ball at 1 m and a wall 4.5 m away: most rays cross metres of space without a block,
  // which the march jumps a region of 4^3 blocks at a time, and the rays grazing the ball pass
  // regions that do hold blocks. Hits must be where the fixed-step reference finds them.
  test::Scene scene;
  scene.planes.push_back({Eigen::Vector3d(0, 0, 1), 4.5});
  scene.spheres.push_back({Eigen::Vector3d(0.1, -0.05, 1.0), 0.12});
  TsdfVolume volume{FusionConfig{}};
  TsdfIntegrator integrator;
  Image<float> depth;
  const Pose fused_from = test::look_at({0, 0, 0}, {0, 0, 1});
  test::render(scene, kKinect, fused_from, depth);
  integrator.integrate(volume, depth, kKinect, fused_from);
  const Pose pose = test::look_at({0.05, 0.02, 0.0}, {0.02, 0.0, 1.0});
  const Intrinsics small = kKinect.scaled(2);
  FusionConfig config;
  config.raycast_max_depth_m = 5.0;
  RaycastResult fast, reference;
  raycast(volume, small, pose, config, fast);
  test::raycast_reference(volume, small, pose, config, 0.25f, reference);
  int both = 0, disagree = 0, far_hits = 0, other_surface = 0;
  std::vector<double> depth_diff;
  for (int y = 0; y < small.height; ++y)
    for (int x = 0; x < small.width; ++x) {
      const bool a = fast.depth_m(x, y) > 0, b = reference.depth_m(x, y) > 0;
      disagree += a != b;
      if (!a || !b) continue;
      ++both;
      far_hits += fast.depth_m(x, y) > 4.0f;
      const double diff = std::abs(fast.depth_m(x, y) - reference.depth_m(x, y));
      // At the ball's silhouette a grazing crossing thinner than a step can be passed by one
      // march and not the other (as in FastRaycastAgreesWithFixedStepReference).
      if (diff > 0.01)
        ++other_surface;
      else
        depth_diff.push_back(diff);
    }
  EXPECT_GT(far_hits, small.width * small.height / 2);
  EXPECT_GT(both - far_hits, 500);  // the ball is hit too
  EXPECT_LE(disagree, both / 200);
  EXPECT_LE(other_surface, both / 1000);
  EXPECT_LT(percentile(depth_diff, 0.5), 0.0001);
  EXPECT_LT(percentile(depth_diff, 0.99), 0.001);
}

TEST(Raycast, SameResultForOneAndTwoThreads) {
  const FusedScene fused;
  const Pose pose = test::look_at({0.1, 0.0, 0.0}, {0, 0.1, 1.6});
  RaycastResult one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    raycast(fused.volume, kKinect, pose, FusionConfig{}, one);
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    raycast(fused.volume, kKinect, pose, FusionConfig{}, two);
  }
  EXPECT_TRUE(one.depth_m == two.depth_m);
  EXPECT_TRUE(one.maps.vertices == two.maps.vertices);
  EXPECT_TRUE(one.maps.normals == two.maps.normals);
}

TEST(Raycast, EmptyVolumeAndBadPoseGiveNoHits) {
  TsdfVolume volume{FusionConfig{}};
  RaycastResult result;
  raycast(volume, kKinect, Pose::identity(), FusionConfig{}, result);
  EXPECT_EQ(result.hits, 0);
  EXPECT_EQ(result.depth_m.width(), 640);
  const FusedScene fused;
  raycast(fused.volume, kKinect,
          Pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, std::nan(""))), FusionConfig{},
          result);
  EXPECT_EQ(result.hits, 0);
  raycast(fused.volume, kKinect, Pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(1e12, 0, 0)),
          FusionConfig{}, result);
  EXPECT_EQ(result.hits, 0);
  // Looking away from everything.
  raycast(fused.volume, kKinect, test::look_at({0, 0, 0}, {0, 0, -1}), FusionConfig{}, result);
  EXPECT_EQ(result.hits, 0);
  FusionConfig bad;
  bad.raycast_min_depth_m = 3.0;
  bad.raycast_max_depth_m = 1.0;
  EXPECT_THROW(raycast(fused.volume, kKinect, Pose::identity(), bad, result), Error);
}

}  // namespace
}  // namespace aoscan
