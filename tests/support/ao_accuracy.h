/// @file ao_accuracy.h
/// @brief AO accuracy harness: SSAO estimators x MVAO integration modes against the ray-traced
/// Eq. 1 reference on analytic scenes, with exact depth, exact normals and exact poses. Shared by
/// tests/ao/ao_accuracy_test.cpp (a small configuration with assertions) and the
/// aoscan-ao-accuracy benchmark (the full-size tables); free of GoogleTest.
///
/// Each scene is rendered along its built-in orbit trajectory; every frame's SSAO goes into one
/// grid per (estimator, mode); then at surface points seen from separate evaluation views the grid
/// AO is compared with reference_obscurance() (Pearson r, mean bias, RMSE).
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "ao/ao_config.h"
#include "core/intrinsics.h"
#include "core/pose.h"
#include "geometry/point_maps.h"
#include "sim/synth_scene.h"

namespace aoscan::test {

/// Exact camera-frame point maps of `scene` seen from T_world_camera (one ray per pixel centre).
PointMaps render_exact(const AnalyticScene& scene, const Intrinsics& k, const Pose& T_world_camera);

/// Agreement of one grid's AO with the reference at the evaluation points.
struct AoScore {
  double r = 0.0, bias = 0.0, rmse = 0.0;
  int points = 0;
  double r_occluded = 0.0;  ///< r over the points whose reference is below 0.99
  int occluded = 0;
};

/// What one measurement renders and where it evaluates.
struct AoEvalSetup {
  std::string scene = "corner";
  int width = 320, height = 240;
  int frames = 48;        ///< integrated frames, evenly over one 24 s orbit
  int eval_views = 8;     ///< evaluation views, between integrated frames
  int eval_step_px = 16;  ///< lattice of evaluation pixels in each evaluation view
  int strata = 16;        ///< reference: strata per axis
};

/// An (estimator, integration mode) pair.
using AoKey = std::pair<AoEstimator, AoIntegration>;

/// Runs every (estimator, mode) of `configs` on `setup`; returns the score of each.
std::map<AoKey, AoScore> measure_ao_accuracy(const AoEvalSetup& setup,
                                             const std::vector<AoConfig>& configs);

/// `base` with every estimator x every integration mode.
std::vector<AoConfig> all_ao_configs(const AoConfig& base);

const char* estimator_name(AoEstimator e);
const char* integration_name(AoIntegration m);

/// Prints `title` and one row per (estimator, mode) to stdout.
void print_ao_scores(const std::string& title, const std::map<AoKey, AoScore>& scores);

}  // namespace aoscan::test
