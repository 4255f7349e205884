/// @file mvao_quality.cpp
/// @brief aoscan-mvao-quality: the multi-scan MVAO of `aoscan scans` against the ray-traced
/// Eq. 1 reference on synthetic scan sets of the corner and room scenes (3, 5 and 8 laser scans
/// and depth-camera frames, noisy): Pearson r of the per-scan SSAO and of the MVAO (1 x 1, 3 x 3,
/// without w_b), the MVAO's step across coverage borders with and without w_b, and r and mean
/// error apart over the points that two or more scans measured and those only one did. The harness
/// is tests/support/mvao_quality.h, whose small sets tests/ao asserts on.
#include <tbb/global_control.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "core/status.h"
#include "support/mvao_quality.h"

namespace aoscan {
namespace {

using test::QualityCamera;
using test::QualityNoise;
using test::QualitySet;

/// The sets of the table: per scene, laser scans (equirectangular), depth cameras with the
/// laser's noise and with the Kinect's, 3, 5 and 8 of each; and the room's three laser scans
/// handed over as point clouds.
std::vector<QualitySet> default_sets(int equirect_height) {
  std::vector<QualitySet> sets;
  for (const char* scene : {"corner", "room"})
    for (const auto& [camera, noise] : {std::pair{QualityCamera::kEquirect, QualityNoise::kLaser},
                                        std::pair{QualityCamera::kPinhole, QualityNoise::kLaser},
                                        std::pair{QualityCamera::kPinhole, QualityNoise::kKinect}})
      for (int scans : {3, 5, 8}) {
        QualitySet s;
        s.scene = scene;
        s.camera = camera;
        s.noise = noise;
        s.scans = scans;
        s.equirect_height = equirect_height;
        sets.push_back(s);
      }
  QualitySet cloud;
  cloud.scene = "room";
  cloud.camera = QualityCamera::kCloud;
  cloud.scans = 3;
  cloud.equirect_height = equirect_height;
  sets.push_back(cloud);
  return sets;
}

const char* yes_no(bool b) {
  return b ? "yes" : "no";
}

int run(int argc, char** argv) {
  CLI::App app{
      "aoscan-mvao-quality: the multi-scan MVAO of `aoscan scans` against ray-traced AO on "
      "synthetic scan sets (scanners on aoscan-scanset's sunflower spiral; laser noise 2 mm, "
      "depth cameras also with the Kinect v1 model); prints one Markdown table row per set"};
  test::QualityOptions options;
  int equirect_height = 400;
  double laser_sigma_mm = 2.0;
  std::vector<std::string> only;
  int threads = 0;
  app.add_option("--only", only,
                 "measure only the sets whose label contains this text (repeatable), e.g. "
                 "\"room pinhole\"");
  app.add_option("--height", equirect_height, "laser scans: 2H x H maps")
      ->capture_default_str()
      ->check(CLI::Range(16, 8000));
  app.add_option("--noise-mm", laser_sigma_mm, "laser range noise sigma (mm)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("--radius", options.ao.radius_m, "ao.radius_m: SSAO sphere radius r_s (m)")
      ->capture_default_str()
      ->check(CLI::Range(0.001, 10.0));
  app.add_option("--t-max", options.ao.t_max_m,
                 "ao.t_max_m: SSAO and reference distance falloff t_max (m)")
      ->capture_default_str()
      ->check(CLI::Range(0.001, 10.0));
  app.add_option("--bias", options.ao.bias,
                 "ao.bias: SSAO tangent-plane bias, a share of the point's depth")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 0.1));
  app.add_option("--t-p", options.t_p_px, "Eq. 12's t_p (pixels)")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 10000.0));
  app.add_option("--strata", options.strata, "reference: strata per axis (their square: rays)")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  app.add_flag("--exact-normals", options.exact_normals,
               "diagnostic: every point takes the scene's exact normal instead of the one "
               "estimated from the points");
  app.add_option("--reference", options.reference,
                 "where a scan point's reference is taken: ray, the surface its scanner's ray "
                 "hits (the point's own surface); nearest, the surface point nearest to it")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, test::QualityReference>{
              {"ray", test::QualityReference::kRayHit},
              {"nearest", test::QualityReference::kNearest}},
          CLI::ignore_case))
      ->default_str("ray");
  app.add_option("--threads", threads, "worker threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "aoscan: error: %s (see aoscan-mvao-quality --help)\n", e.what());
    return static_cast<int>(ExitCode::kUsage);
  }
  std::unique_ptr<tbb::global_control> limit;
  if (threads > 0)
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                  static_cast<std::size_t>(threads));
  try {
    std::vector<QualitySet> sets;
    for (QualitySet& s : default_sets(equirect_height)) {
      s.laser_sigma_m = laser_sigma_mm * 1e-3;
      bool wanted = only.empty();
      for (const std::string& o : only) wanted = wanted || s.label().find(o) != std::string::npos;
      if (wanted) sets.push_back(s);
    }
    if (sets.empty()) throw usage_error("--only: no set's label contains the text given");
    std::printf(
        "# aoscan-mvao-quality: ao.radius_m %g, ao.t_max_m %g, t_p %g px, laser noise %g mm, "
        "laser maps %d x %d, reference %d rays at %s%s\n",
        options.ao.radius_m, options.ao.t_max_m, options.t_p_px, laser_sigma_mm,
        2 * equirect_height, equirect_height, options.strata * options.strata,
        options.reference == test::QualityReference::kRayHit ? "the points' ray hits"
                                                             : "the surface points nearest",
        options.exact_normals ? ", exact normals (diagnostic)" : "");
    std::fflush(stdout);
    const auto start = std::chrono::steady_clock::now();
    std::vector<test::QualityRow> rows;
    for (const QualitySet& s : sets) {
      const auto t0 = std::chrono::steady_clock::now();
      rows.push_back(test::measure_mvao_quality(s, options));
      std::fprintf(stderr, "aoscan-mvao-quality: %s in %.0f s\n", s.label().c_str(),
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    int missed = 0;
    std::printf(
        "\n| set | map | points | evaluated | seen by >= 2 scans | SSAO r | MVAO r | MVAO r 3x3 | "
        "MVAO r without w_b | r target |\n|---|---|---|---|---|---|---|---|---|---|\n");
    for (const test::QualityRow& r : rows) {
      missed += !r.meets_r_target();
      std::printf("| %s | %dx%d | %lld | %lld | %.1f %% | %.3f | %.3f | %.3f | %.3f | %s |\n",
                  r.set.c_str(), r.map_width, r.map_height, r.points, r.evaluated,
                  100.0 * static_cast<double>(r.covered_twice) / static_cast<double>(r.points),
                  r.ssao_r, r.mvao_r, r.mvao_3x3_r, r.mvao_no_wb_r, yes_no(r.meets_r_target()));
    }
    std::printf(
        "\n| set | border pairs | reference step | MVAO step w_b | without w_b | excess w_b | "
        "excess without w_b | step error w_b | step error without w_b | w_b smoother |\n"
        "|---|---|---|---|---|---|---|---|---|---|\n");
    for (const test::QualityRow& r : rows)
      std::printf("| %s | %lld | %.4f | %.4f | %.4f | %+.4f | %+.4f | %.4f | %.4f | %s |\n",
                  r.set.c_str(), r.border_pairs, r.ref_step, r.wb_step, r.no_wb_step,
                  r.wb_step - r.ref_step, r.no_wb_step - r.ref_step, r.wb_step_error,
                  r.no_wb_step_error, yes_no(r.wb_smoother()));
    std::printf(
        "\n| set | evaluated points seen by >= 2 scans | there: SSAO r | MVAO r | SSAO mean "
        "error | MVAO mean error | seen by 1 scan: r | mean error |\n"
        "|---|---|---|---|---|---|---|---|\n");
    for (const test::QualityRow& r : rows)
      std::printf(
          "| %s | %.1f %% | %.3f | %.3f | %.4f | %.4f | %.3f | %.4f |\n", r.set.c_str(),
          100.0 * static_cast<double>(r.evaluated_covered) / static_cast<double>(r.evaluated),
          r.ssao_covered_r, r.mvao_covered_r, r.ssao_covered_mae, r.mvao_covered_mae, r.single_r,
          r.single_mae);
    std::printf("\n# %zu sets, %d below the r target, %.0f s\n", sets.size(), missed,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    return 0;
  } catch (const Error& e) {
    std::fprintf(stderr, "aoscan: error: %s\n", one_line(e.what()).c_str());
    return static_cast<int>(e.code());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "aoscan: error: %s\n", one_line(e.what()).c_str());
    return static_cast<int>(ExitCode::kFailure);
  }
}

}  // namespace
}  // namespace aoscan

int main(int argc, char** argv) {
  return aoscan::run(argc, argv);
}
