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

/// One frame-SSAO comparison of measure_border_deficit() over a region of the image.
struct BorderScore {
  AoScore frame;   ///< the frame's own SSAO (samples beyond the image border find nothing)
  AoScore margin;  ///< the same frame's SSAO rendered with a margin and cropped
};

/// What the frame's SSAO misses near the image border because the occluders beyond it are not in
/// the frame: at every eval_step_px-th pixel (both axes) of each of setup.frames frames along the
/// orbit, the SSAO of the exact W x H frame and of the same view rendered (W + 2m) x (H + 2m) with
/// the principal point moved by m = margin_px (a multiple of 4, so that each pixel keeps its
/// sample pattern) and cropped, both against reference_obscurance() at the pixel's exact surface
/// point (setup.strata^2 rays). `config` is used as given (its ssao_stride_px should be 1: every
/// pixel evaluated). Regions: all pixels, those within border_px of the image border, the rest.
struct BorderDeficit {
  BorderScore all, border, inner;
};
BorderDeficit measure_border_deficit(const AoEvalSetup& setup, const AoConfig& config,
                                     int margin_px, int border_px);

/// `base` with every estimator x every integration mode.
std::vector<AoConfig> all_ao_configs(const AoConfig& base);

const char* estimator_name(AoEstimator e);
const char* integration_name(AoIntegration m);

/// Prints `title` and one row per (estimator, mode) to stdout.
void print_ao_scores(const std::string& title, const std::map<AoKey, AoScore>& scores);

}  // namespace aoscan::test
