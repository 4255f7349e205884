/// @file reloc_bench.cpp
/// @brief aoscan-reloc-bench: relocalisation measured against the targets of BENCHMARKS.md.
///   kitchen: the kidnapped-camera measure on the 7-Scenes RedKitchen recording (frames 0-249
///            mapped, each later frame relocalised on its own): the share of the coverable frames
///            relocalised within 5 cm and 5 degrees, the false accepts above 10 cm or 10 degrees,
///            the time of an attempt and of the fern encoding.
///   takes:   the synthetic corner take with a 2 s blackout and with 2 s cut out, against the
///            uninterrupted take: frames to relocalise and the ATE difference.
/// The harnesses are tests/support/relocalisation_takes.h, which tests/fusion checks in part.
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include <tbb/global_control.h>
#include <CLI/CLI.hpp>

#include "support/kitchen_fusion.h"
#include "support/relocalisation_takes.h"

namespace aoscan {
namespace {

double pct(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))];
}

void print_times(const char* name, const std::vector<double>& ms) {
  std::printf("%s: %zu, median %.2f ms, p95 %.2f ms, max %.2f ms\n", name, ms.size(),
              pct(ms, 0.5), pct(ms, 0.95), pct(ms, 1.0));
}

int kitchen(const test::KidnapOptions& options, bool verbose) {
  if (!test::kitchen_present(options.dir)) {
    std::fprintf(stderr, "%s: no depth.txt (give the RedKitchen folder)\n", options.dir.c_str());
    return 2;
  }
  const test::KidnapResult r = test::run_kidnapped(options);
  if (verbose)
    for (const test::KidnapFrame& f : r.frames)
      std::printf("frame %d: %s%s, nearest keyframe %.0f mm %.1f deg, first candidate %.0f mm %.1f "
                  "deg, %s, error %.1f mm %.2f deg, "
                  "%.1f ms (%d candidates, raycasts %.1f ms, ICP %.1f ms; first search: inliers "
                  "%.2f, moved %.0f mm %.1f deg; check: %s, inliers %.2f, rms %.1f mm, %s, moved "
                  "%.1f mm %.2f deg)\n",
                  f.index, f.coverable ? "coverable" : "not coverable",
                  f.accepted ? ", accepted" : "", 1e3 * f.nearest_keyframe_m,
                  f.nearest_keyframe_deg, 1e3 * f.candidate_m, f.candidate_deg, f.accepted ? "-" : f.rejection, 1e3 * f.error_m,
                  f.error_deg, f.ms, f.candidates, f.raycast_ms, f.icp_ms,
                  f.first_search.inlier_ratio, 1e3 * f.first_search.translation_m,
                  f.first_search.rotation_deg, to_string(f.check.status), f.check.inlier_ratio,
                  1e3 * f.check.rms_residual_m, f.check.degenerate ? "degenerate" : "-",
                  1e3 * f.check.translation_m, f.check.rotation_deg);
  for (const std::string& e : r.read_errors) std::fprintf(stderr, "%s\n", e.c_str());
  if (r.kidnapped == 0) {
    std::fprintf(stderr, "%s: no frames after the mapped ones\n", options.dir.c_str());
    return 1;
  }
  std::printf("map: frames 0-%d, %d lost, ATE %.1f mm against the reference (both from the first frame), %zu keyframes\n",
              options.map_frames - 1, r.map_lost, 1e3 * r.map_ate_m, r.keyframes);
  std::printf("kidnapped frames: %d, coverable (within %.0f cm and %.0f deg of a mapped pose) "
              "%d\n",
              r.kidnapped, 100 * options.near_m, options.near_deg, r.coverable);
  std::printf("coverable relocalised within 5 cm and 5 deg: %d = %.1f %% (target >= 80 %%)\n",
              r.coverable_right, r.coverable ? 100.0 * r.coverable_right / r.coverable : 0.0);
  std::printf("accepted: %d, of which above 10 cm or 10 deg: %d (target 0); worst accepted %.1f "
              "mm %.2f deg\n",
              r.accepted, r.accepted_wrong, 1e3 * r.worst_accepted_m, r.worst_accepted_deg);
  print_times("relocalisation attempts", r.attempt_ms);
  print_times("fern encodings", r.encode_ms);
  return 0;
}

int takes() {
  test::TakeOptions whole_options;
  const test::TakeResult whole = test::run_take(whole_options);
  std::printf("uninterrupted: ATE %.3f mm, losses %zu, keyframes %zu\n", 1e3 * whole.ate_m,
              whole.losses, whole.keyframes);
  for (const bool cut : {false, true}) {
    test::TakeOptions options;
    options.gap_begin = test::kTakeGapBegin;
    options.gap_end = test::kTakeGapEnd;
    options.cut_gap = cut;
    const test::TakeResult r = test::run_take(options);
    std::vector<double> lost_ms;
    for (const test::TakeFrame& f : r.frames)
      if (f.index >= test::kTakeGapEnd && (f.index <= r.first_relocalised || r.first_relocalised < 0))
        lost_ms.push_back(f.track_ms);
    std::printf("%s frames %d-%d: losses %zu, relocalised at frame %d (%d frames after the gap; "
                "target < 10), ATE %.3f mm (%+.3f mm against uninterrupted; target within 1 mm), "
                "worst relocalised pose %.1f mm %.2f deg\n",
                cut ? "cut" : "blackout", test::kTakeGapBegin, test::kTakeGapEnd - 1, r.losses,
                r.first_relocalised, r.first_relocalised - test::kTakeGapEnd, 1e3 * r.ate_m,
                1e3 * (r.ate_m - whole.ate_m), 1e3 * r.worst_relocalised_m,
                r.worst_relocalised_deg);
    print_times("  lost frames' Reconstruction::process", lost_ms);
  }
  return 0;
}

int run(int argc, char** argv) {
  CLI::App app{"aoscan-reloc-bench: relocalisation after tracking loss, measured"};
  app.require_subcommand(1);
  int threads = 2;
  app.add_option("--threads", threads, "threads for data-parallel kernels")
      ->capture_default_str()
      ->check(CLI::Range(1, 1024));
  test::KidnapOptions kidnap;
  kidnap.dir = std::string(AOSCAN_SHARED_DATA_DIR) + "/7scenes-redkitchen";
  CLI::App* k = app.add_subcommand("kitchen", "kidnapped frames on the RedKitchen recording");
  k->add_option("FOLDER", kidnap.dir, "the RedKitchen folder")->capture_default_str();
  k->add_option("--map-frames", kidnap.map_frames, "frames mapped before the kidnapped ones")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  k->add_option("--frames", kidnap.frames, "frames read in all")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  bool verbose = false;
  k->add_flag("--verbose", verbose, "one line per kidnapped frame");
  app.add_subcommand("takes", "the synthetic blackout and cut takes");
  CLI11_PARSE(app, argc, argv);
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(threads));
  if (k->parsed()) return kitchen(kidnap, verbose);
  return takes();
}

}  // namespace
}  // namespace aoscan

int main(int argc, char** argv) { return aoscan::run(argc, argv); }
