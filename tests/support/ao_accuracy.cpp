/// @file ao_accuracy.cpp
/// @brief The AO accuracy harness of ao_accuracy.h.
#include "support/ao_accuracy.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "ao/mvao_grid.h"
#include "ao/ssao.h"
#include "core/status.h"
#include "sim/reference_ao.h"
#include "sim/synth_camera.h"
#include "support/ao_test_util.h"

namespace aoscan::test {
namespace {

/// The orbit trajectory's period (s): frames are spread evenly over one turn.
constexpr double kOrbitPeriodS = 24.0;

struct EvalPoint {
  Eigen::Vector3d p, n;
  double reference;
};

AoScore score(const std::vector<double>& a, const std::vector<double>& b) {
  AoScore s;
  const double n = static_cast<double>(a.size());
  s.points = static_cast<int>(a.size());
  if (a.size() < 2) return s;
  double ma = 0, mb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) ma += a[i], mb += b[i];
  ma /= n, mb /= n;
  double se = 0;
  for (std::size_t i = 0; i < a.size(); ++i) se += (a[i] - b[i]) * (a[i] - b[i]);
  s.r = pearson_r(a, b);
  s.bias = ma - mb;
  s.rmse = std::sqrt(se / n);
  return s;
}

}  // namespace

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

std::map<AoKey, AoScore> measure_ao_accuracy(const AoEvalSetup& setup,
                                             const std::vector<AoConfig>& configs) {
  const AnalyticScene scene = AnalyticScene::make(setup.scene);
  SynthParams params;
  params.width = setup.width;
  params.height = setup.height;
  const Intrinsics k = params.intrinsics();

  // Evaluation points: exact surface points and normals, with their reference obscurance.
  std::vector<EvalPoint> points;
  for (int v = 0; v < setup.eval_views; ++v) {
    const double t = kOrbitPeriodS * (v + 0.37) / setup.eval_views;
    const Pose T = synth_camera_pose(setup.scene, SynthTrajectory::kOrbit, 1, t);
    const PointMaps maps = render_exact(scene, k, T);
    for (int y = setup.eval_step_px / 2; y < k.height; y += setup.eval_step_px)
      for (int x = setup.eval_step_px / 2; x < k.width; x += setup.eval_step_px) {
        if (!(maps.vertices(x, y).z() > 0.0f)) continue;
        points.push_back({T * maps.vertices(x, y).cast<double>(),
                          T.rotation() * maps.normals(x, y).cast<double>(), 0.0});
      }
  }
  const RayCaster cast = caster(scene);
  const double t_max = configs.front().t_max_m;
  tbb::parallel_for(std::size_t{0}, points.size(), [&](std::size_t i) {
    points[i].reference = reference_obscurance(cast, points[i].p, points[i].n, t_max, setup.strata);
  });

  std::map<AoKey, MvaoGrid> grids;
  for (const AoConfig& c : configs) grids.emplace(AoKey{c.estimator, c.integration}, MvaoGrid(c));
  Image<float> ao, w;
  for (int f = 0; f < setup.frames; ++f) {
    const Pose T = synth_camera_pose(setup.scene, SynthTrajectory::kOrbit, 1,
                                     kOrbitPeriodS * f / setup.frames);
    const PointMaps maps = render_exact(scene, k, T);
    AoEstimator last_estimator = AoEstimator::kPaper;
    bool have = false;
    for (const AoConfig& c : configs) {
      if (!have || c.estimator != last_estimator) compute_ssao(maps, c, f, ao, w);
      have = true;
      last_estimator = c.estimator;
      grids.at(AoKey{c.estimator, c.integration}).integrate(ao, w, maps, T);
    }
  }

  std::map<AoKey, AoScore> scores;
  for (auto& [key, grid] : grids) {
    std::vector<double> got, want;
    for (const EvalPoint& e : points) {
      const auto v = grid.sample(e.p);
      if (!v) continue;
      got.push_back(*v);
      want.push_back(e.reference);
    }
    AoScore s = score(got, want);
    std::vector<double> got_occ, want_occ;
    for (std::size_t i = 0; i < got.size(); ++i)
      if (want[i] < 0.99) got_occ.push_back(got[i]), want_occ.push_back(want[i]);
    const AoScore occ = score(got_occ, want_occ);
    s.r_occluded = occ.r;
    s.occluded = occ.points;
    scores[key] = s;
  }
  return scores;
}

BorderDeficit measure_border_deficit(const AoEvalSetup& setup, const AoConfig& config,
                                     int margin_px, int border_px) {
  if (margin_px < 0 || margin_px % 4 != 0)
    throw usage_error("the margin must be a non-negative multiple of 4 pixels");
  const AnalyticScene scene = AnalyticScene::make(setup.scene);
  SynthParams params;
  params.width = setup.width;
  params.height = setup.height;
  const Intrinsics k = params.intrinsics();
  Intrinsics wide = k;
  wide.width += 2 * margin_px;
  wide.height += 2 * margin_px;
  wide.cx += margin_px;
  wide.cy += margin_px;

  // Each evaluated pixel: its surface point, both SSAO values, its region.
  std::vector<EvalPoint> points;
  std::vector<double> frame_ao, margin_ao;
  std::vector<char> near_border;
  Image<float> ao, ao_wide, weight;
  for (int f = 0; f < setup.frames; ++f) {
    const Pose T = synth_camera_pose(setup.scene, SynthTrajectory::kOrbit, 1,
                                     kOrbitPeriodS * f / setup.frames);
    const PointMaps maps = render_exact(scene, k, T);
    compute_ssao(maps, config, f, ao, weight);
    compute_ssao(render_exact(scene, wide, T), config, f, ao_wide, weight);
    for (int y = setup.eval_step_px / 2; y < k.height; y += setup.eval_step_px)
      for (int x = setup.eval_step_px / 2; x < k.width; x += setup.eval_step_px) {
        if (!(maps.vertices(x, y).z() > 0.0f)) continue;
        points.push_back({T * maps.vertices(x, y).cast<double>(),
                          T.rotation() * maps.normals(x, y).cast<double>(), 0.0});
        frame_ao.push_back(ao(x, y));
        margin_ao.push_back(ao_wide(x + margin_px, y + margin_px));
        near_border.push_back(
            std::min(std::min(x, y), std::min(k.width - 1 - x, k.height - 1 - y)) < border_px);
      }
  }
  const RayCaster cast = caster(scene);
  tbb::parallel_for(std::size_t{0}, points.size(), [&](std::size_t i) {
    points[i].reference =
        reference_obscurance(cast, points[i].p, points[i].n, config.t_max_m, setup.strata);
  });

  // 0: all pixels, 1: near the border, 2: the rest.
  std::vector<double> got_frame[3], got_margin[3], want[3];
  for (std::size_t i = 0; i < points.size(); ++i)
    for (int region : {0, near_border[i] ? 1 : 2}) {
      got_frame[region].push_back(frame_ao[i]);
      got_margin[region].push_back(margin_ao[i]);
      want[region].push_back(points[i].reference);
    }
  BorderScore regions[3];
  for (int region = 0; region < 3; ++region)
    regions[region] = {score(got_frame[region], want[region]),
                       score(got_margin[region], want[region])};
  return {regions[0], regions[1], regions[2]};
}

const char* estimator_name(AoEstimator e) {
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
    case AoEstimator::kStatVo:
      return "statvo";
  }
  return "?";
}
const char* integration_name(AoIntegration m) {
  return m == AoIntegration::kMvao ? "mvao" : m == AoIntegration::kMean ? "mean" : "last";
}

std::vector<AoConfig> all_ao_configs(const AoConfig& base) {
  std::vector<AoConfig> out;
  for (AoEstimator e : {AoEstimator::kPaper, AoEstimator::kObscurance, AoEstimator::kAlchemy,
                        AoEstimator::kHorizon, AoEstimator::kHeightfield, AoEstimator::kStatVo})
    for (AoIntegration m : {AoIntegration::kMvao, AoIntegration::kMean, AoIntegration::kLast}) {
      AoConfig c = base;
      c.estimator = e;
      c.integration = m;
      out.push_back(c);
    }
  return out;
}

void print_ao_scores(const std::string& title, const std::map<AoKey, AoScore>& scores) {
  std::printf("%s\n  %-11s %-5s %7s %7s %7s %6s %7s %6s\n", title.c_str(), "estimator", "mode", "r",
              "bias", "rmse", "points", "r_occ", "occ");
  for (const auto& [key, s] : scores)
    std::printf("  %-11s %-5s %7.3f %+7.3f %7.3f %6d %7.3f %6d\n", estimator_name(key.first),
                integration_name(key.second), s.r, s.bias, s.rmse, s.points, s.r_occluded,
                s.occluded);
  std::fflush(stdout);
}

}  // namespace aoscan::test
