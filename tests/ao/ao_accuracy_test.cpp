/// @file ao_accuracy_test.cpp
/// @brief Measurement harness: SSAO estimators x MVAO integration modes against the ray-traced
/// Eq. 1 reference on analytic scenes, with exact depth, exact normals and exact poses.
///
/// Each scene is rendered along its built-in orbit trajectory; every frame's SSAO goes into one
/// grid per (estimator, mode); then at surface points seen from separate evaluation views the grid
/// AO is compared with reference_obscurance() (Pearson r, mean bias, RMSE). The suite runs a small
/// configuration (320x240, 48 frames); AOSCAN_AO_EVAL_FULL=1 runs the 640x480 measurement of the
/// report, a sample-count / stride sweep and the per-frame timing, and prints the tables.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "ao/mvao_grid.h"
#include "ao/ssao.h"
#include "sim/reference_ao.h"
#include "sim/synth_camera.h"
#include "sim/synth_scene.h"
#include "support/ao_test_util.h"

namespace aoscan {
namespace {

/// Exact camera-frame point maps of `scene` seen from T_world_camera (one ray per pixel centre).
PointMaps render_exact(const AnalyticScene& scene, const Intrinsics& k,
                       const Pose& T_world_camera) {
  PointMaps maps;
  maps.intrinsics = k;
  maps.vertices.resize(k.width, k.height, Eigen::Vector3f::Zero());
  maps.normals.resize(k.width, k.height, Eigen::Vector3f::Zero());
  const Eigen::Matrix3d& R = T_world_camera.rotation();
  tbb::parallel_for(tbb::blocked_range<int>(0, k.height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y)
      for (int x = 0; x < k.width; ++x) {
        const Eigen::Vector3d d_c = k.unproject(double(x), double(y), 1.0).normalized();
        Hit hit;
        if (!scene.intersect(Ray{T_world_camera.translation(), R * d_c}, 1e-4, 20.0, &hit))
          continue;
        maps.vertices(x, y) = (d_c * hit.t).cast<float>();
        maps.normals(x, y) = (R.transpose() * hit.normal).cast<float>();
      }
  });
  return maps;
}

struct EvalPoint {
  Eigen::Vector3d p, n;
  double reference;
};

struct Score {
  double r = 0.0, bias = 0.0, rmse = 0.0;
  int points = 0;
  double r_occluded = 0.0;  ///< r over the points whose reference is below 0.99
  int occluded = 0;
};

Score score(const std::vector<double>& a, const std::vector<double>& b) {
  Score s;
  const double n = static_cast<double>(a.size());
  s.points = static_cast<int>(a.size());
  if (a.size() < 2) return s;
  double ma = 0, mb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) ma += a[i], mb += b[i];
  ma /= n, mb /= n;
  double sab = 0, saa = 0, sbb = 0, se = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
    se += (a[i] - b[i]) * (a[i] - b[i]);
  }
  s.r = sab / std::sqrt(saa * sbb);
  s.bias = ma - mb;
  s.rmse = std::sqrt(se / n);
  return s;
}

struct EvalSetup {
  std::string scene = "corner";
  int width = 320, height = 240;
  int frames = 48;        ///< integrated frames, evenly over one 24 s orbit
  int eval_views = 8;     ///< evaluation views, between integrated frames
  int eval_step_px = 16;  ///< lattice of evaluation pixels in each evaluation view
  int strata = 16;        ///< reference: strata per axis
};

using Key = std::pair<AoEstimator, AoIntegration>;

/// Runs every (estimator, mode) of `configs` on `setup`; returns the score of each.
std::map<Key, Score> measure(const EvalSetup& setup, const std::vector<AoConfig>& configs) {
  const AnalyticScene scene = AnalyticScene::make(setup.scene);
  SynthParams params;
  params.width = setup.width;
  params.height = setup.height;
  const Intrinsics k = params.intrinsics();
  const double period_s = 24.0;

  // Evaluation points: exact surface points and normals, with their reference obscurance.
  std::vector<EvalPoint> points;
  for (int v = 0; v < setup.eval_views; ++v) {
    const double t = period_s * (v + 0.37) / setup.eval_views;
    const Pose T = synth_camera_pose(setup.scene, SynthTrajectory::kOrbit, 1, t);
    const PointMaps maps = render_exact(scene, k, T);
    for (int y = setup.eval_step_px / 2; y < k.height; y += setup.eval_step_px)
      for (int x = setup.eval_step_px / 2; x < k.width; x += setup.eval_step_px) {
        if (!(maps.vertices(x, y).z() > 0.0f)) continue;
        points.push_back({T * maps.vertices(x, y).cast<double>(),
                          T.rotation() * maps.normals(x, y).cast<double>(), 0.0});
      }
  }
  const RayCaster cast = test::caster(scene);
  const double t_max = configs.front().t_max_m;
  tbb::parallel_for(std::size_t{0}, points.size(), [&](std::size_t i) {
    points[i].reference = reference_obscurance(cast, points[i].p, points[i].n, t_max, setup.strata);
  });

  std::map<Key, MvaoGrid> grids;
  for (const AoConfig& c : configs) grids.emplace(Key{c.estimator, c.integration}, MvaoGrid(c));
  Image<float> ao, w;
  for (int f = 0; f < setup.frames; ++f) {
    const Pose T =
        synth_camera_pose(setup.scene, SynthTrajectory::kOrbit, 1, period_s * f / setup.frames);
    const PointMaps maps = render_exact(scene, k, T);
    AoEstimator last_estimator = AoEstimator::kPaper;
    bool have = false;
    for (const AoConfig& c : configs) {
      if (!have || c.estimator != last_estimator) compute_ssao(maps, c, f, ao, w);
      have = true;
      last_estimator = c.estimator;
      grids.at(Key{c.estimator, c.integration}).integrate(ao, w, maps, T);
    }
  }

  std::map<Key, Score> scores;
  for (auto& [key, grid] : grids) {
    std::vector<double> got, want;
    for (const EvalPoint& e : points) {
      const auto v = grid.sample(e.p);
      if (!v) continue;
      got.push_back(*v);
      want.push_back(e.reference);
    }
    Score s = score(got, want);
    std::vector<double> got_occ, want_occ;
    for (std::size_t i = 0; i < got.size(); ++i)
      if (want[i] < 0.99) got_occ.push_back(got[i]), want_occ.push_back(want[i]);
    const Score occ = score(got_occ, want_occ);
    s.r_occluded = occ.r;
    s.occluded = occ.points;
    scores[key] = s;
  }
  return scores;
}

const char* name(AoEstimator e) {
  switch (e) {
    case AoEstimator::kPaper:
      return "paper";
    case AoEstimator::kObscurance:
      return "obscurance";
    case AoEstimator::kAlchemy:
      return "alchemy";
    case AoEstimator::kHorizon:
      return "horizon";
    case AoEstimator::kHeightfield:
      return "heightfield";
  }
  return "?";
}
const char* name(AoIntegration m) {
  return m == AoIntegration::kMvao ? "mvao" : m == AoIntegration::kMean ? "mean" : "last";
}

std::vector<AoConfig> all_configs(const AoConfig& base) {
  std::vector<AoConfig> out;
  for (AoEstimator e : {AoEstimator::kPaper, AoEstimator::kObscurance, AoEstimator::kAlchemy,
                        AoEstimator::kHorizon, AoEstimator::kHeightfield})
    for (AoIntegration m : {AoIntegration::kMvao, AoIntegration::kMean, AoIntegration::kLast}) {
      AoConfig c = base;
      c.estimator = e;
      c.integration = m;
      out.push_back(c);
    }
  return out;
}

void print(const std::string& title, const std::map<Key, Score>& scores) {
  std::printf("%s\n  %-11s %-5s %7s %7s %7s %6s %7s %6s\n", title.c_str(), "estimator", "mode", "r",
              "bias", "rmse", "points", "r_occ", "occ");
  for (const auto& [key, s] : scores)
    std::printf("  %-11s %-5s %7.3f %+7.3f %7.3f %6d %7.3f %6d\n", name(key.first),
                name(key.second), s.r, s.bias, s.rmse, s.points, s.r_occluded, s.occluded);
  std::fflush(stdout);
}

TEST(AoAccuracy, EstimatorsAndModesAgainstRayTracedReference) {
  const EvalSetup setup;
  const auto scores = measure(setup, all_configs(AoConfig{}));
  print("corner 320x240, 48 frames, defaults", scores);
  const auto r = [&](AoEstimator e, AoIntegration m) { return scores.at(Key{e, m}).r; };
  // The default estimator is the best one, beats Eq. 3 as printed by far, and integrating many
  // views is not worse than the last view (with exact depth the single view is already good).
  const AoEstimator best = AoConfig{}.estimator;
  for (AoEstimator e : {AoEstimator::kPaper, AoEstimator::kObscurance, AoEstimator::kAlchemy,
                        AoEstimator::kHorizon, AoEstimator::kHeightfield})
    EXPECT_GE(r(best, AoIntegration::kMvao), r(e, AoIntegration::kMvao) - 0.005) << name(e);
  EXPECT_GT(r(best, AoIntegration::kMvao), 0.9);
  EXPECT_LT(std::abs(scores.at(Key{best, AoIntegration::kMvao}).bias), 0.03);
  EXPECT_GT(r(best, AoIntegration::kMvao), r(best, AoIntegration::kLast) - 0.01);
  EXPECT_GT(r(best, AoIntegration::kMvao), r(AoEstimator::kPaper, AoIntegration::kMvao) + 0.3);
  for (const auto& [key, s] : scores) EXPECT_GT(s.points, 1000);
}

TEST(AoAccuracy, FullMeasurement) {
  if (!std::getenv("AOSCAN_AO_EVAL_FULL"))
    GTEST_SKIP() << "set AOSCAN_AO_EVAL_FULL=1 for the 640x480 measurement tables";
  for (const char* scene : {"room", "corner"}) {
    EvalSetup setup;
    setup.scene = scene;
    setup.width = 640;
    setup.height = 480;
    setup.frames = 96;
    setup.eval_step_px = 24;
    print(std::string(scene) + " 640x480, 96 frames, defaults",
          measure(setup, all_configs(AoConfig{})));
    if (std::string(scene) != "corner") continue;
    for (int stride : {1, 2})
      for (int samples : {8, 16, 32}) {
        std::vector<AoConfig> configs;
        for (AoEstimator e : {AoConfig{}.estimator})
          for (AoIntegration m : {AoIntegration::kMvao, AoIntegration::kLast}) {
            AoConfig c;
            c.estimator = e;
            c.integration = m;
            c.samples = samples;
            c.ssao_stride_px = stride;
            configs.push_back(c);
          }
        print(std::string(scene) + " stride " + std::to_string(stride) + " samples " +
                  std::to_string(samples),
              measure(setup, configs));
      }
  }
  // Per-frame time of SSAO + grid update on a 640x480 exact frame.
  const AnalyticScene scene = AnalyticScene::make("corner");
  SynthParams params;
  const Pose T = synth_camera_pose("corner", SynthTrajectory::kOrbit, 1, 3.0);
  const PointMaps maps = render_exact(scene, params.intrinsics(), T);
  for (AoEstimator e : {AoEstimator::kObscurance, AoEstimator::kAlchemy, AoEstimator::kHorizon,
                        AoEstimator::kHeightfield})
    for (int stride : {1, 2})
      for (int samples : {16, 32}) {
        AoConfig c;
        c.estimator = e;
        c.ssao_stride_px = stride;
        c.samples = samples;
        MvaoGrid grid(c);
        Image<float> ao, w;
        const int reps = 20;
        double ssao_ms = 0.0, grid_ms = 0.0;
        for (int i = 0; i < reps; ++i) {
          const auto t0 = std::chrono::steady_clock::now();
          compute_ssao(maps, c, i, ao, w);
          const auto t1 = std::chrono::steady_clock::now();
          grid.integrate(ao, w, maps, T);
          const auto t2 = std::chrono::steady_clock::now();
          ssao_ms += std::chrono::duration<double, std::milli>(t1 - t0).count();
          grid_ms += std::chrono::duration<double, std::milli>(t2 - t1).count();
        }
        std::printf("timing %-10s stride %d samples %2d: ssao %.2f ms, grid %.2f ms\n", name(e),
                    stride, samples, ssao_ms / reps, grid_ms / reps);
      }
}

}  // namespace
}  // namespace aoscan
