/// @file ssao_test.cpp
/// @brief Tests for src/ao/ssao.h: view weights (Eq. 10-11), exact values on analytic planes and
/// corners, fast == reference, a reused workspace, thread-count determinism, stride-2 evaluation,
/// invalid inputs.
#include "ao/ssao.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "fusion/tracking/icp.h"
#include "sim/synth_camera.h"
#include "support/ao_reference.h"
#include "support/ao_test_util.h"
#include "support/geometry_reference.h"

namespace aoscan {
namespace {

using test::Plane;
using test::render_planes;
using test::small_camera;

constexpr AoEstimator kAllEstimators[] = {AoEstimator::kPaper, AoEstimator::kObscurance,
                                          AoEstimator::kAlchemy, AoEstimator::kHorizon,
                                          AoEstimator::kHeightfield, AoEstimator::kStatVo};

AoConfig config_for(AoEstimator e, int stride) {
  AoConfig c;
  c.estimator = e;
  c.ssao_stride_px = stride;
  return c;
}

/// Camera 1.2 m in front of the wall z = 0 (world), looking straight at it.
PointMaps open_wall() {
  const Pose T = look_at({0.0, 0.0, 1.2}, {0.0, 0.0, 0.0}, {0.0, 1.0, 0.0});
  return render_planes(small_camera(), T, {Plane{{0.0, 0.0, 1.0}, 0.0}});
}

/// The inner edge between the floor y = 0 and the wall x = 0, seen at 45 degrees from 1.5 m.
PointMaps floor_wall_edge(Pose* T_out = nullptr) {
  const Pose T = look_at({1.0, 1.0, 0.3}, {0.0, 0.0, 0.0}, {0.0, 0.0, 1.0});
  if (T_out) *T_out = T;
  return render_planes(small_camera(), T,
                       {Plane{{1.0, 0.0, 0.0}, 0.0}, Plane{{0.0, 1.0, 0.0}, 0.0}});
}

/// The weight compute_ssao() gives a pixel at p with SSAO normal n and full coverage.
float pixel_view_weight(const Eigen::Vector3f& p, const Eigen::Vector3f& n, const AoConfig& c) {
  return view_weight(p, n, static_cast<float>(c.d_min_m), static_cast<float>(c.d_max_m));
}

TEST(ViewWeight, MatchesEquations10And11) {
  const Eigen::Vector3f facing(0.0f, 0.0f, -1.0f);
  // |p| = 2 m: w_d = 1 - (2 - 0.4) / 3.
  EXPECT_FLOAT_EQ(view_weight({0.0f, 0.0f, 2.0f}, facing, 0.4f, 3.0f), 1.0f - 1.6f / 3.0f);
  // Nearer than d_min: w_d = 1.
  EXPECT_FLOAT_EQ(view_weight({0.0f, 0.0f, 0.3f}, facing, 0.4f, 3.0f), 1.0f);
  // Far: w_d floors at 0.1.
  EXPECT_FLOAT_EQ(view_weight({0.0f, 0.0f, 10.0f}, facing, 0.4f, 3.0f), 0.1f);
  // Normal tilted 60 degrees from the view direction: w_n = 0.5.
  const Eigen::Vector3f tilted(std::sin(1.04719755f), 0.0f, -std::cos(1.04719755f));
  EXPECT_NEAR(view_weight({0.0f, 0.0f, 0.4f}, tilted, 0.4f, 3.0f), 0.5f, 1e-6f);
  // Off-axis point: |p| is the distance, l points to the camera.
  const Eigen::Vector3f p(0.6f, 0.0f, 0.8f);
  EXPECT_NEAR(view_weight(p, -p, 0.4f, 3.0f), 1.0f - 0.6f / 3.0f, 1e-6f);
  // Back-facing and invalid inputs give 0.
  EXPECT_EQ(view_weight({0.0f, 0.0f, 2.0f}, -facing, 0.4f, 3.0f), 0.0f);
  EXPECT_EQ(view_weight(Eigen::Vector3f::Zero(), facing, 0.4f, 3.0f), 0.0f);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(view_weight({nan, 0.0f, 1.0f}, facing, 0.4f, 3.0f), 0.0f);
}

TEST(Ssao, PatternIsInsideTheUnitDiskAndChangesWithTheFrame) {
  for (AoEstimator e : kAllEstimators) {
    const AoConfig c = config_for(e, 1);
    const SsaoPattern a = make_ssao_pattern(c, 0);
    const SsaoPattern b = make_ssao_pattern(c, 1);
    ASSERT_EQ(a.offsets.size(), static_cast<std::size_t>(kSsaoPatternClasses * a.samples));
    EXPECT_EQ(a.samples, AoConfig{}.samples);  // a multiple of 8, so horizon keeps it too
    for (const auto& o : a.offsets) EXPECT_LE(o.norm(), 1.0f + 1e-6f);
    EXPECT_NE(a.offsets, b.offsets);
    EXPECT_EQ(a.offsets, make_ssao_pattern(c, 0).offsets);  // deterministic
  }
}

TEST(Ssao, OpenWallIsFullyOpenExceptForThePaperEstimator) {
  const PointMaps maps = open_wall();
  Image<float> ao, w;
  // Every sample lies exactly in the tangent plane: no occlusion (exact for the point forms).
  // statvo: every layer's mean lies in the plane, below the bias.
  for (AoEstimator e : {AoEstimator::kObscurance, AoEstimator::kAlchemy, AoEstimator::kStatVo}) {
    compute_ssao(maps, config_for(e, 1), 0, ao, w);
    for (int y = 0; y < ao.height(); ++y)
      for (int x = 0; x < ao.width(); ++x) ASSERT_EQ(ao(x, y), 1.0f) << x << " " << y;
  }
  // Horizon: samples are rounded to pixel centres, so slightly off the slice plane.
  compute_ssao(maps, config_for(AoEstimator::kHorizon, 1), 0, ao, w);
  double mean = 0.0;
  for (float v : std::vector<float>(ao.data(), ao.data() + ao.size())) mean += v;
  EXPECT_GT(mean / ao.size(), 0.98);
  // Heightfield: the bias lowers every sample below the tangent plane, no horizon rises; the
  // visibility is then the open arc integral, exactly 1 on the view axis (within float rounding).
  compute_ssao(maps, config_for(AoEstimator::kHeightfield, 1), 0, ao, w);
  EXPECT_NEAR(ao(160, 120), 1.0f, 1e-5f);
  EXPECT_NEAR(ao(161, 121), 1.0f, 2e-3f);
  // Eq. 3 as printed counts tangent samples within t_max as occluders: an open wall is dark.
  compute_ssao(maps, config_for(AoEstimator::kPaper, 1), 0, ao, w);
  EXPECT_LT(ao(160, 120), 0.8f);
  // The wall faces the camera at 1.2 m on the axis: w = w_d = 1 - 0.8 / 3.
  EXPECT_NEAR(w(160, 120), 1.0f - 0.8f / 3.0f, 1e-5f);
}

TEST(Ssao, InnerEdgeIsDarkerNearTheEdgeAndOpenBeyondTMax) {
  Pose T;
  const PointMaps maps = floor_wall_edge(&T);
  Image<float> ao, w;
  for (AoEstimator e : {AoEstimator::kObscurance, AoEstimator::kAlchemy, AoEstimator::kHorizon,
                        AoEstimator::kHeightfield, AoEstimator::kStatVo})
    for (double bias : {0.0, AoConfig{}.bias}) {
      AoConfig config = config_for(e, 1);
      config.bias = bias;
      compute_ssao(maps, config, 3, ao, w);
      double near_sum = 0.0, far_sum = 0.0;
      int near_n = 0, far_n = 0;
      float far_min = 1.0f;
      for (int y = 0; y < ao.height(); ++y)
        for (int x = 0; x < ao.width(); ++x) {
          const Eigen::Vector3d p = T * maps.vertices(x, y).cast<double>();
          const double dist_to_edge = std::hypot(p.x(), p.y());
          if (dist_to_edge < 0.03) near_sum += ao(x, y), ++near_n;
          if (dist_to_edge > 0.25)
            far_sum += ao(x, y), ++far_n, far_min = std::min(far_min, ao(x, y));
        }
      ASSERT_GT(near_n, 100);
      ASSERT_GT(far_n, 1000);
      // The bias (4-5 mm at this depth) keeps the nearest samples on the wall from occluding.
      EXPECT_LT(near_sum / near_n, bias > 0.0 ? 0.87 : 0.85) << static_cast<int>(e);
      EXPECT_GT(far_sum / far_n, 0.98) << static_cast<int>(e);
      // Obscurance: a sample on the other plane farther than t_max has rho = 1 and does not count
      // (float rounding of n . v on the tilted planes leaves ~1e-6).
      if (e == AoEstimator::kObscurance) {
        EXPECT_GT(far_min, 1.0f - 1e-5f);
      }
    }
}

TEST(Ssao, HorizonIsOpenOffTheViewAxis) {
  // A wall seen at about 30 degrees from grazing: each slice's open arc integral differs from 1
  // (only the mean over slice directions is 1); dividing by it keeps an open surface open with
  // one slice per pixel (without the division the mean here is 0.86).
  const Pose T = look_at({0.0, -1.0, 0.6}, {0.0, 0.0, 0.0}, {0.0, 0.0, 1.0});
  const PointMaps maps = render_planes(small_camera(), T, {Plane{{0.0, 0.0, 1.0}, 0.0}});
  Image<float> ao, w;
  AoConfig c = config_for(AoEstimator::kHorizon, 1);
  c.samples = 8;  // one slice per pixel
  double sum = 0.0;
  int counted = 0;
  for (std::uint64_t frame : {0u, 1u, 2u}) {
    compute_ssao(maps, c, frame, ao, w);
    for (int y = 20; y < 220; y += 10)
      for (int x = 20; x < 300; x += 10) {
        if (!(maps.vertices(x, y).z() > 0.0f)) continue;
        sum += ao(x, y);
        ++counted;
      }
  }
  ASSERT_GT(counted, 500);
  std::printf("horizon mean on the tilted wall: %.4f\n", sum / counted);
  EXPECT_GT(sum / counted, 0.97);
}

TEST(Ssao, CoverageWeightLowersPixelsWhoseDiskLeavesTheImage) {
  const PointMaps maps = open_wall();  // the wall fills the image
  Image<float> ao, w, w_off;
  AoConfig c = config_for(AoEstimator::kAlchemy, 1);
  c.coverage_power = 0.0;
  compute_ssao(maps, c, 0, ao, w_off);
  c.coverage_power = 2.0;
  compute_ssao(maps, c, 0, ao, w);
  // Centre: the whole disk (radius fx r_s / z = 24 px) is inside the image.
  EXPECT_EQ(w(160, 120), w_off(160, 120));
  // Corner pixel: a quarter of the disk at most is inside, so the weight is at most 1/16.
  EXPECT_GT(w_off(0, 0), 0.0f);
  EXPECT_LE(w(0, 0), w_off(0, 0) / 16.0f + 1e-6f);
  EXPECT_GT(w(0, 0), 0.0f);
  // Edge pixel: about half the disk inside: between 1/9 and 1/2 of the weight (power 2).
  EXPECT_LT(w(160, 0), w_off(160, 0) * 0.5f);
  EXPECT_GT(w(160, 0), w_off(160, 0) / 9.0f);
  // The fast path and the reference agree on the weights.
  Image<float> ao_ref, w_ref;
  compute_ssao_reference(maps, c, 0, ao_ref, w_ref);
  EXPECT_EQ(w, w_ref);
}

TEST(Ssao, StatVoIsTheMeanHeightOfTheBoxOverItsHeight) {
  // A 41 x 41 map of the plane z = 1 m facing the camera (normal (0, 0, -1)) with columns 25-30
  // raised 5 cm towards the camera; fx = fy = 100 px, r_s = 0.1 m: the box of a pixel at z = 1 is
  // 21 x 21 pixels. Every layer's mean height lies within [0, r_s], where psi is linear, so however
  // the layers split the box, the obscurance is sum(heights) / (r_s * pixels in the box).
  PointMaps maps;
  maps.intrinsics.width = maps.intrinsics.height = 41;
  maps.intrinsics.fx = maps.intrinsics.fy = 100.0;
  maps.intrinsics.cx = maps.intrinsics.cy = 20.0;
  maps.vertices.resize(41, 41, Eigen::Vector3f::Zero());
  maps.normals.resize(41, 41, Eigen::Vector3f(0.0f, 0.0f, -1.0f));
  const float raised = 0.05f;
  for (int y = 0; y < 41; ++y)
    for (int x = 0; x < 41; ++x)
      maps.vertices(x, y) = {0.01f * (x - 20), 0.01f * (y - 20),
                             x >= 25 && x <= 30 ? 1.0f - raised : 1.0f};
  AoConfig c = config_for(AoEstimator::kStatVo, 1);
  c.radius_m = 0.1;
  c.bias = 0.0;
  c.normal_radius_px = 0;
  c.coverage_power = 1.0;
  Image<float> ao, w;
  compute_ssao(maps, c, 0, ao, w);
  // Centre (20, 20): the box holds columns 10-30, six of them raised: 6 x 21 of 441 pixels.
  EXPECT_NEAR(ao(20, 20), 1.0f - raised / 0.1f * (6.0f * 21.0f) / 441.0f, 1e-6f);
  // Far from the raised columns the box is flat: open.
  EXPECT_EQ(ao(3, 20), 1.0f);
  // On the raised columns the tangent plane is the raised one: the plane beside lies below it.
  EXPECT_EQ(ao(27, 20), 1.0f);
  // The coverage weight: at (3, 3) the box keeps columns and rows 0-13 of its 21 x 21.
  const float full = view_weight(maps.vertices(20, 20), maps.normals(20, 20),
                                 static_cast<float>(c.d_min_m), static_cast<float>(c.d_max_m));
  EXPECT_NEAR(w(20, 20), full, 1e-6f);
  EXPECT_NEAR(w(3, 3) / view_weight(maps.vertices(3, 3), maps.normals(3, 3),
                                    static_cast<float>(c.d_min_m), static_cast<float>(c.d_max_m)),
              14.0f * 14.0f / 441.0f, 1e-6f);
  // The same answers from the plain reference.
  Image<float> ao_ref, w_ref;
  compute_ssao_reference(maps, c, 0, ao_ref, w_ref);
  EXPECT_NEAR(ao_ref(20, 20), ao(20, 20), 1e-6f);
  EXPECT_EQ(w, w_ref);
}

TEST(Ssao, BiasIgnoresBumpsLowerThanBiasTimesDepth) {
  // The open wall at 1.2 m with a checkerboard of 3 mm bumps toward the camera (each vertex moved
  // along its pixel ray): below the default bias of 0.0035 * 1.2 m = 4.2 mm, so the point
  // estimators see an open wall; without the bias the bumps occlude the pixels between them.
  PointMaps maps = open_wall();
  for (int y = 0; y < maps.vertices.height(); ++y)
    for (int x = 0; x < maps.vertices.width(); ++x) {
      Eigen::Vector3f& v = maps.vertices(x, y);
      if (((x / 4) + (y / 4)) % 2 == 1) v *= (v.z() - 0.003f) / v.z();
    }
  Image<float> ao, w;
  for (AoEstimator e : {AoEstimator::kObscurance, AoEstimator::kAlchemy}) {
    AoConfig config = config_for(e, 1);
    ASSERT_EQ(config.bias, 0.0035);
    compute_ssao(maps, config, 0, ao, w);
    for (int y = 0; y < ao.height(); ++y)
      for (int x = 0; x < ao.width(); ++x) ASSERT_EQ(ao(x, y), 1.0f) << x << " " << y;
    config.bias = 0.0;
    compute_ssao(maps, config, 0, ao, w);
    EXPECT_LT(ao(160 + 2, 120 + 2), 0.99f) << static_cast<int>(e);  // a low square
  }
}

TEST(Ssao, NormalSmoothingAveragesTheSameSurfaceOnly) {
  // The open wall with its normals tilted about the camera's y axis by -2a, -a, 0, a, 2a in
  // columns x mod 5: any 5 neighbouring columns hold each tilt once, so the smoothed normal at
  // radius 2 is the wall's own, and alchemy reads the wall open; with the pixels' own normals the
  // tilted tangent planes put the wall's samples above them by more than the bias.
  PointMaps maps = open_wall();
  const float a = 0.1f;  // 5.7 degrees
  const Eigen::Vector3f facing = maps.normals(160, 120);
  ASSERT_NEAR(facing.z(), -1.0f, 1e-6f);
  for (int y = 0; y < maps.normals.height(); ++y)
    for (int x = 0; x < maps.normals.width(); ++x) {
      const float t = a * static_cast<float>(x % 5 - 2);
      maps.normals(x, y) = Eigen::Vector3f(std::sin(t), 0.0f, -std::cos(t));
    }
  AoConfig config = config_for(AoEstimator::kAlchemy, 1);
  ASSERT_EQ(config.normal_radius_px, 2);
  config.coverage_power = 0.0;  // the weight is w_d w_n alone
  Image<float> ao, w;
  compute_ssao(maps, config, 0, ao, w);
  for (int y = 40; y < 200; y += 7)
    for (int x = 60; x < 260; x += 3) {
      ASSERT_EQ(ao(x, y), 1.0f) << x << " " << y;
      // The w_n weight uses the smoothed normal too: that of the untilted wall.
      EXPECT_NEAR(w(x, y), pixel_view_weight(maps.vertices(x, y), facing, config), 1e-5f)
          << x << " " << y;
    }
  config.normal_radius_px = 0;
  compute_ssao(maps, config, 0, ao, w);
  EXPECT_LT(ao(160 + 4, 120), 0.99f);  // x mod 5 = 4: tilted by 2a
  EXPECT_LT(ao(160 + 5, 120), 0.99f);  // x mod 5 = 0: tilted by -2a

  // A depth step: right of column 160 the surface lies 10 cm behind, with sideways normals; the
  // near surface's pixels at the step keep the wall's normal (same weight as without the step).
  PointMaps step = open_wall();
  for (int y = 0; y < step.vertices.height(); ++y)
    for (int x = 161; x < step.vertices.width(); ++x) {
      Eigen::Vector3f& v = step.vertices(x, y);
      v *= (v.z() + 0.1f) / v.z();
      step.normals(x, y) = Eigen::Vector3f(1.0f, 0.0f, 0.0f);
    }
  config.normal_radius_px = 2;
  compute_ssao(step, config, 0, ao, w);
  for (int y = 40; y < 200; y += 7)
    for (int x = 158; x <= 160; ++x)
      EXPECT_FLOAT_EQ(w(x, y), pixel_view_weight(step.vertices(x, y), facing, config)) << x;
}

TEST(Ssao, AlchemyAreaFactorDividesByTheOccludersSlant) {
  // floor_wall_edge(): the camera at (1, 1, 0.3) sees both planes at cos theta_q <= 0.9 within
  // 0.3 m of the edge (|eye - q| >= 1.11 m there), so for a pixel near the edge every occluding
  // sample gets the factor 1 / max(cos, 0.9) = 1 / 0.9 exactly, and the occlusion 1 - AO is that
  // of plain alchemy (area_min_cos = 1) divided by 0.9. (The tangent plane's own samples lie
  // below the bias and add nothing either way.)
  Pose T;
  const PointMaps maps = floor_wall_edge(&T);
  AoConfig plain = config_for(AoEstimator::kAlchemy, 1);
  plain.area_min_cos = 1.0;
  AoConfig slanted = plain;
  slanted.area_min_cos = 0.9;
  Image<float> ao_plain, ao_slanted, w;
  compute_ssao(maps, plain, 0, ao_plain, w);
  compute_ssao(maps, slanted, 0, ao_slanted, w);
  int occluded = 0;
  for (int y = 0; y < maps.vertices.height(); ++y)
    for (int x = 0; x < maps.vertices.width(); ++x) {
      const Eigen::Vector3d p = T * maps.vertices(x, y).cast<double>();
      if (!(maps.vertices(x, y).z() > 0.0f) || p.z() > 0.2 || std::max(p.x(), p.y()) > 0.1)
        continue;
      if (!(ao_plain(x, y) < 0.99f)) continue;
      ++occluded;
      // Not clamped at 0 (the division would otherwise not show).
      ASSERT_GT(ao_slanted(x, y), 0.0f) << x << " " << y;
      EXPECT_NEAR(1.0f - ao_slanted(x, y), (1.0f - ao_plain(x, y)) / 0.9f, 2e-5f) << x << " " << y;
    }
  EXPECT_GT(occluded, 100);
}

TEST(Ssao, EvaluatedPixelsAndSamplesBothReadTheSmoothedNormal) {
  // The SSAO normal smoothing acts on the whole normal map: at normal_radius_px = r the AO and
  // the weights are those of radius 0 on the map smooth_model_normals() gives, so the area
  // factor of each occluding sample reads the sample's smoothed normal too, not its raycast one.
  // floor_wall_edge() with each normal tilted by a different angle about the camera's y axis.
  PointMaps maps = floor_wall_edge();
  for (int y = 0; y < maps.normals.height(); ++y)
    for (int x = 0; x < maps.normals.width(); ++x) {
      const float t = 0.08f * static_cast<float>((x * 7 + y * 3) % 5 - 2);
      const Eigen::Vector3f n = maps.normals(x, y);
      maps.normals(x, y) = Eigen::Vector3f(std::cos(t) * n.x() + std::sin(t) * n.z(), n.y(),
                                           -std::sin(t) * n.x() + std::cos(t) * n.z());
    }
  AoConfig config = config_for(AoEstimator::kAlchemy, 1);
  ASSERT_EQ(config.normal_radius_px, 2);
  ASSERT_LT(config.area_min_cos, 1.0);
  PointMaps smoothed;
  smooth_model_normals_reference(maps, config.normal_radius_px,
                                 static_cast<float>(config.normal_max_distance_m), smoothed);
  AoConfig own = config;
  own.normal_radius_px = 0;
  for (int stride : {1, 2}) {
    config.ssao_stride_px = own.ssao_stride_px = stride;
    Image<float> ao, w, ao_own, w_own, ao_raw, w_raw;
    compute_ssao(maps, config, 3, ao, w);
    compute_ssao(smoothed, own, 3, ao_own, w_own);
    compute_ssao(maps, own, 3, ao_raw, w_raw);
    float max_diff = 0.0f, raw_diff = 0.0f;
    for (std::size_t i = 0; i < ao.size(); ++i) {
      max_diff = std::max(max_diff, std::abs(ao.data()[i] - ao_own.data()[i]));
      raw_diff = std::max(raw_diff, std::abs(ao.data()[i] - ao_raw.data()[i]));
    }
    EXPECT_EQ(max_diff, 0.0f) << "stride " << stride;
    EXPECT_EQ(w, w_own) << "stride " << stride;
    EXPECT_GT(raw_diff, 0.01f) << "stride " << stride;  // the smoothing matters here
    Image<float> ao_ref, w_ref;
    compute_ssao_reference(maps, config, 3, ao_ref, w_ref);
    float ref_diff = 0.0f;
    for (std::size_t i = 0; i < ao.size(); ++i)
      ref_diff = std::max(ref_diff, std::abs(ao.data()[i] - ao_ref.data()[i]));
    EXPECT_LE(ref_diff, 1e-5f) << "stride " << stride;
  }
}

TEST(Ssao, AReusedWorkspaceGivesWhatAFreshOneGives) {
  // One workspace through maps of two sizes and back: nothing of an earlier call leaks into a
  // later one (the smoothed maps are rebuilt at each call's size).
  const PointMaps edge = floor_wall_edge();
  PointMaps half;
  downsample_model(open_wall(), half);
  ASSERT_NE(half.vertices.width(), edge.vertices.width());
  const AoConfig config = config_for(AoEstimator::kAlchemy, 1);
  ASSERT_GT(config.normal_radius_px, 0);
  SsaoWorkspace workspace;
  for (const PointMaps* maps : std::vector<const PointMaps*>{&edge, &half, &edge}) {
    Image<float> ao, w, ao_fresh, w_fresh;
    compute_ssao(*maps, config, 1, ao, w, workspace);
    compute_ssao(*maps, config, 1, ao_fresh, w_fresh);
    EXPECT_EQ(workspace.smoothed.vertices.width(), maps->vertices.width());
    EXPECT_EQ(ao, ao_fresh);
    EXPECT_EQ(w, w_fresh);
  }
}

TEST(Ssao, FastMatchesReferenceForEveryEstimatorAndStride) {
  const PointMaps maps = floor_wall_edge();
  for (AoEstimator e : kAllEstimators)
    for (int stride : {1, 2})
      for (std::uint64_t frame : {0u, 5u}) {
        // statvo has no pattern: the frame only rotates the stride's pixel (its brute-force
        // reference is slow under the sanitizers).
        if (e == AoEstimator::kStatVo && frame != static_cast<std::uint64_t>(stride - 1) * 5u)
          continue;
        const AoConfig c = config_for(e, stride);
        Image<float> ao, w, ao_ref, w_ref;
        compute_ssao(maps, c, frame, ao, w);
        compute_ssao_reference(maps, c, frame, ao_ref, w_ref);
        ASSERT_EQ(w, w_ref);
        float max_diff = 0.0f;
        for (std::size_t i = 0; i < ao.size(); ++i)
          max_diff = std::max(max_diff, std::abs(ao.data()[i] - ao_ref.data()[i]));
        EXPECT_LE(max_diff, 1e-5f) << static_cast<int>(e) << " stride " << stride;
      }
}

TEST(Ssao, VardisWeightAndImportanceSamplingMatchTheReference) {
  const PointMaps maps = floor_wall_edge();
  for (AoEstimator e : {AoEstimator::kPaper, AoEstimator::kObscurance, AoEstimator::kAlchemy})
    for (int stride : {1, 2})
      for (int variant = 0; variant < 3; ++variant) {
        AoConfig c = config_for(e, stride);
        if (variant != 1) c.view_weight = AoViewWeight::kVardis;
        if (variant != 0) c.importance_samples = 5;
        Image<float> ao, w, ao_ref, w_ref;
        compute_ssao(maps, c, 3, ao, w);
        compute_ssao_reference(maps, c, 3, ao_ref, w_ref);
        ASSERT_EQ(w, w_ref) << static_cast<int>(e) << " variant " << variant;
        float max_diff = 0.0f;
        for (std::size_t i = 0; i < ao.size(); ++i)
          max_diff = std::max(max_diff, std::abs(ao.data()[i] - ao_ref.data()[i]));
        EXPECT_LE(max_diff, 1e-5f) << static_cast<int>(e) << " variant " << variant;
      }
}

TEST(Ssao, VardisWeightBlendsTheSamplesDistanceAndTheNormal) {
  // A single valid pixel facing the camera: no sample is counted, each counts r_s away, so the
  // distance weight is 0 and the weight is (1 - b) w_n = 1 - b (w_n = 1 within 1e-5).
  PointMaps lone = open_wall();
  for (int y = 0; y < lone.vertices.height(); ++y)
    for (int x = 0; x < lone.vertices.width(); ++x)
      if (x != 160 || y != 120) lone.vertices(x, y) = lone.normals(x, y) = Eigen::Vector3f::Zero();
  AoConfig c = config_for(AoEstimator::kAlchemy, 1);
  c.view_weight = AoViewWeight::kVardis;
  c.coverage_power = 0.0;
  Image<float> ao, w;
  compute_ssao(lone, c, 0, ao, w);
  EXPECT_EQ(ao(160, 120), 1.0f);
  EXPECT_NEAR(w(160, 120), 1.0f - static_cast<float>(c.vardis_b), 1e-6f);
  // On the whole wall every sample lies within r_s: the distance weight is 1 - (mean sample
  // distance) / r_s, strictly between 0 and 1, and b = 0 leaves w_n = 1 alone.
  const PointMaps wall = open_wall();
  compute_ssao(wall, c, 0, ao, w);
  EXPECT_GT(w(160, 120), 1.0f - static_cast<float>(c.vardis_b) + 0.1f);
  EXPECT_LT(w(160, 120), 1.0f - 0.1f);
  c.vardis_b = 0.0;
  compute_ssao(wall, c, 0, ao, w);
  EXPECT_NEAR(w(160, 120), 1.0f, 1e-5f);  // the pixel's ray is half a pixel off the normal
}

TEST(Ssao, ImportanceSamplingKeepsTheAoOfAllTheSamples) {
  // Fewer samples where a pixel is open or weighs little, the same AO on average: exact on the
  // open wall, close to the full count's at the inner edge.
  AoConfig c = config_for(AoEstimator::kAlchemy, 1);
  AoConfig is = c;
  is.importance_samples = 4;
  Image<float> ao, w, ao_is, w_is;
  compute_ssao(open_wall(), is, 0, ao_is, w_is);
  for (std::size_t i = 0; i < ao_is.size(); ++i) ASSERT_EQ(ao_is.data()[i], 1.0f);
  const PointMaps edge = floor_wall_edge();
  double diff = 0.0, mean = 0.0, mean_is = 0.0;
  for (std::uint64_t frame = 0; frame < 4; ++frame) {
    compute_ssao(edge, c, frame, ao, w);
    compute_ssao(edge, is, frame, ao_is, w_is);
    for (std::size_t i = 0; i < ao.size(); ++i) {
      diff += std::abs(ao.data()[i] - ao_is.data()[i]);
      mean += ao.data()[i];
      mean_is += ao_is.data()[i];
    }
  }
  const double n = 4.0 * static_cast<double>(ao.size());
  EXPECT_LT(diff / n, 0.02);
  EXPECT_NEAR(mean_is / n, mean / n, 0.01);
}

TEST(Ssao, BitIdenticalForAnyThreadCount) {
  const PointMaps maps = floor_wall_edge();
  for (int stride : {1, 2}) {
    const AoConfig c = config_for(AoEstimator::kObscurance, stride);
    Image<float> ao1, w1, ao2, w2;
    {
      tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
      compute_ssao(maps, c, 7, ao1, w1);
    }
    {
      tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
      compute_ssao(maps, c, 7, ao2, w2);
    }
    EXPECT_EQ(ao1, ao2);
    EXPECT_EQ(w1, w2);
  }
}

TEST(Ssao, StrideTwoEvaluatesOnePixelPerBlockAndRotates) {
  const PointMaps maps = floor_wall_edge();
  const AoConfig c = config_for(AoEstimator::kObscurance, 2);
  Image<float> ao, w;
  Image<int> evaluated(maps.vertices.width(), maps.vertices.height(), 0);
  for (std::uint64_t frame = 0; frame < 4; ++frame) {
    compute_ssao(maps, c, frame, ao, w);
    for (int by = 0; by < ao.height() / 2; ++by)
      for (int bx = 0; bx < ao.width() / 2; ++bx) {
        int with_weight = 0;
        for (int i = 0; i < 4; ++i) {
          const int x = 2 * bx + (i & 1), y = 2 * by + (i >> 1);
          if (w(x, y) > 0.0f) ++with_weight, ++evaluated(x, y);
          // Valid pixels of a block share the evaluated pixel's AO.
          if (maps.vertices(x, y).z() > 0.0f) {
            EXPECT_EQ(ao(x, y), ao(2 * bx, 2 * by));
          }
        }
        ASSERT_EQ(with_weight, 1);  // every pixel of this scene is valid
      }
  }
  // Over four frames every pixel was evaluated exactly once.
  for (int v : std::vector<int>(evaluated.data(), evaluated.data() + evaluated.size()))
    ASSERT_EQ(v, 1);
}

TEST(Ssao, InvalidAndNonFiniteInputsGiveZeroAndNeverNaN) {
  PointMaps maps = floor_wall_edge();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  maps.vertices(10, 10) = Eigen::Vector3f(nan, 0.0f, 1.0f);
  maps.vertices(11, 10) = Eigen::Vector3f(0.0f, inf, 1.0f);
  maps.normals(12, 10) = Eigen::Vector3f(nan, nan, nan);
  maps.vertices(13, 10) = Eigen::Vector3f::Zero();
  maps.normals(13, 10) = Eigen::Vector3f::Zero();
  maps.vertices(14, 10) = Eigen::Vector3f(0.0f, 0.0f, -1.0f);
  // A block of NaN samples around a valid pixel.
  for (int y = 50; y < 90; ++y)
    for (int x = 50; x < 90; ++x)
      if (x != 70 || y != 70) maps.vertices(x, y) = Eigen::Vector3f::Constant(nan);
  for (AoEstimator e : kAllEstimators)
    for (int stride : {1, 2}) {
      Image<float> ao, w;
      compute_ssao(maps, config_for(e, stride), 1, ao, w);
      for (int x = 10; x <= 14; ++x) {
        EXPECT_EQ(ao(x, 10), 0.0f);
        EXPECT_EQ(w(x, 10), 0.0f);
      }
      for (std::size_t i = 0; i < ao.size(); ++i) {
        ASSERT_TRUE(ao.data()[i] >= 0.0f && ao.data()[i] <= 1.0f);
        ASSERT_TRUE(w.data()[i] >= 0.0f && w.data()[i] <= 1.0f);
      }
    }
  // Mismatched or empty maps give empty / zero outputs.
  PointMaps empty;
  Image<float> ao, w;
  compute_ssao(empty, AoConfig{}, 0, ao, w);
  EXPECT_TRUE(ao.empty());
}

}  // namespace
}  // namespace aoscan
