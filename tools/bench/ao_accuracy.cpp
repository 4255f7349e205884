/// @file ao_accuracy.cpp
/// @brief aoscan-ao-accuracy: SSAO estimators x MVAO integration modes against the ray-traced
/// Eq. 1 reference on the exact room and corner scenes (tables of Pearson r, bias, RMSE), a
/// sample-count / stride sweep on the corner, and the per-frame time of SSAO + grid update; with
/// --seed-methods the seed papers' alternatives to the defaults (Vardis et al. 2013's view weight
/// and importance sampling, Hendrickx et al. 2015's statvo) side by side; with --border-margin
/// what the image border costs each frame's SSAO. The harness is tests/support/ao_accuracy.h,
/// whose small configurations tests/ao asserts on.
#include <chrono>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "ao/ao_config.h"
#include "ao/mvao_grid.h"
#include "ao/ssao.h"
#include "core/status.h"
#include "sim/synth_camera.h"
#include "sim/synth_scene.h"
#include "support/ao_accuracy.h"

namespace aoscan {
namespace {

using test::AoEvalSetup;

void measure_scenes(const AoEvalSetup& size) {
  for (const char* scene : {"room", "corner"}) {
    AoEvalSetup setup = size;
    setup.scene = scene;
    const std::string dims = std::to_string(setup.width) + "x" + std::to_string(setup.height) +
                             ", " + std::to_string(setup.frames) + " frames";
    test::print_ao_scores(std::string(scene) + " " + dims + ", defaults",
                          test::measure_ao_accuracy(setup, test::all_ao_configs(AoConfig{})));
    if (std::string(scene) != "corner") continue;
    for (int stride : {1, 2})
      for (int samples : {8, 16, 32}) {
        std::vector<AoConfig> configs;
        for (AoIntegration m : {AoIntegration::kMvao, AoIntegration::kLast}) {
          AoConfig c;
          c.integration = m;
          c.samples = samples;
          c.ssao_stride_px = stride;
          configs.push_back(c);
        }
        test::print_ao_scores(std::string(scene) + " stride " + std::to_string(stride) +
                                  " samples " + std::to_string(samples),
                              test::measure_ao_accuracy(setup, configs));
      }
  }
}

/// The seed papers' alternatives to the defaults, one at a time (each is its own grid): Vardis et
/// al. 2013's view weight and importance sampling, Hendrickx et al. 2015's statvo estimator.
std::vector<std::pair<std::string, AoConfig>> seed_variants() {
  std::vector<std::pair<std::string, AoConfig>> v;
  v.emplace_back("defaults (alchemy, paper weight)", AoConfig{});
  for (double b : {0.85, 1.0}) {
    AoConfig c;
    c.view_weight = AoViewWeight::kVardis;
    c.vardis_b = b;
    v.emplace_back("view_weight vardis, b " + std::to_string(b).substr(0, 4), c);
  }
  for (int n : {4, 8}) {
    AoConfig c;
    c.importance_samples = n;
    v.emplace_back("importance_samples " + std::to_string(n), c);
  }
  AoConfig both;
  both.view_weight = AoViewWeight::kVardis;
  both.importance_samples = 4;
  v.emplace_back("vardis b 0.85 + importance_samples 4", both);
  AoConfig statvo;
  statvo.estimator = AoEstimator::kStatVo;
  v.emplace_back("estimator statvo", statvo);
  return v;
}

void measure_seed_methods(const AoEvalSetup& size) {
  for (const char* scene : {"room", "corner"}) {
    AoEvalSetup setup = size;
    setup.scene = scene;
    std::printf("seed methods, %s %dx%d, %d frames (mvao r, bias, rmse, r occluded)\n", scene,
                setup.width, setup.height, setup.frames);
    for (const auto& [name, config] : seed_variants()) {
      const auto scores = test::measure_ao_accuracy(setup, {config});
      const test::AoScore& s = scores.begin()->second;
      std::printf("  %-40s r %.3f  bias %+.3f  rmse %.3f  r_occ %.3f\n", name.c_str(), s.r, s.bias,
                  s.rmse, s.r_occluded);
      std::fflush(stdout);
    }
  }
}

/// Per-frame time of SSAO + grid update on one exact corner frame of the given size.
void time_frames(int width, int height) {
  const AnalyticScene scene = AnalyticScene::make("corner");
  SynthParams params;
  params.width = width;
  params.height = height;
  const Pose T = synth_camera_pose("corner", SynthTrajectory::kOrbit, 1, 3.0);
  const PointMaps maps = test::render_exact(scene, params.intrinsics(), T);
  for (AoEstimator e : {AoEstimator::kObscurance, AoEstimator::kAlchemy, AoEstimator::kHorizon,
                        AoEstimator::kHeightfield, AoEstimator::kStatVo})
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
        std::printf("timing %-10s stride %d samples %2d: ssao %.2f ms, grid %.2f ms\n",
                    test::estimator_name(e), stride, samples, ssao_ms / reps, grid_ms / reps);
      }
  // The seed variants as the pipeline runs them: one workspace for every frame.
  for (const auto& [name, c] : seed_variants()) {
    Image<float> ao, w;
    SsaoWorkspace workspace;
    const int reps = 40;
    compute_ssao(maps, c, 0, ao, w, workspace);  // warm
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < reps; ++i) compute_ssao(maps, c, i, ao, w, workspace);
    const auto t1 = std::chrono::steady_clock::now();
    std::printf("timing %-40s ssao %.2f ms\n", name.c_str(),
                std::chrono::duration<double, std::milli>(t1 - t0).count() / reps);
  }
}

/// What the frames' SSAO misses near the image border: the frame's own SSAO against the same
/// view's SSAO with `margin_px` more image on every side, cropped (test::measure_border_deficit).
void measure_border(const AoEvalSetup& size, int margin_px, int border_px) {
  AoConfig config;
  config.ssao_stride_px = 1;
  std::printf(
      "SSAO (defaults but stride 1) against ray-traced AO, %dx%d frames, the frame's own and with "
      "a %d px margin cropped; border: within %d px of the image border\n"
      "| scene | region | pixels | r frame | r margin | bias frame | bias margin | rmse frame | "
      "rmse margin |\n|---|---|---|---|---|---|---|---|---|\n",
      size.width, size.height, margin_px, border_px);
  for (const char* scene : {"corner", "room"}) {
    AoEvalSetup setup = size;
    setup.scene = scene;
    const test::BorderDeficit d = test::measure_border_deficit(setup, config, margin_px, border_px);
    const std::pair<const char*, const test::BorderScore*> rows[] = {
        {"all", &d.all}, {"border", &d.border}, {"inner", &d.inner}};
    for (const auto& [name, s] : rows)
      std::printf("| %s | %s | %d | %.3f | %.3f | %+.4f | %+.4f | %.4f | %.4f |\n", scene, name,
                  s->frame.points, s->frame.r, s->margin.r, s->frame.bias, s->margin.bias,
                  s->frame.rmse, s->margin.rmse);
    std::fflush(stdout);
  }
}

int run(int argc, char** argv) {
  CLI::App app{"aoscan-ao-accuracy: SSAO estimators and MVAO modes against ray-traced AO"};
  AoEvalSetup setup;
  setup.width = 640;
  setup.height = 480;
  setup.frames = 96;
  setup.eval_step_px = 24;
  bool no_timing = false;
  bool seed_only = false;
  int border_margin_px = 0, border_px = 40;
  app.add_option("--width", setup.width, "image width (pixels)")
      ->capture_default_str()
      ->check(CLI::Range(16, 4096));
  app.add_option("--height", setup.height, "image height (pixels)")
      ->capture_default_str()
      ->check(CLI::Range(16, 4096));
  app.add_option("--frames", setup.frames, "frames integrated over one orbit")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--eval-step", setup.eval_step_px, "evaluation lattice step (pixels)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1024));
  app.add_flag("--no-timing", no_timing, "skip the per-frame timing");
  app.add_flag("--seed-methods", seed_only,
               "only the seed papers' alternatives (Vardis et al. weights and importance "
               "sampling, statvo) against the defaults");
  app.add_option("--border-margin", border_margin_px,
                 "only the border measurement: each frame's SSAO against the same view's with "
                 "this many pixels more on every side, cropped (a multiple of 4)")
      ->check(CLI::Range(4, 1024));
  app.add_option("--border", border_px, "the border measurement's border region (pixels)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1024));
  CLI11_PARSE(app, argc, argv);
  try {
    if (border_margin_px > 0) {
      measure_border(setup, border_margin_px, border_px);
      return 0;
    }
    if (seed_only)
      measure_seed_methods(setup);
    else
      measure_scenes(setup);
    if (!no_timing) time_frames(setup.width, setup.height);
    return 0;
  } catch (const Error& e) {
    std::fprintf(stderr, "aoscan-ao-accuracy: error: %s\n", e.what());
    return static_cast<int>(e.code());
  }
}

}  // namespace
}  // namespace aoscan

int main(int argc, char** argv) {
  return aoscan::run(argc, argv);
}
