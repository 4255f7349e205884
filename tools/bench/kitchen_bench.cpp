/// @file kitchen_bench.cpp
/// @brief aoscan-kitchen-bench: the fusion kernels (icp, integrate, raycast, marching cubes) timed
/// on the 7-Scenes RedKitchen recording with a small stand-in preprocessing (bilateral filter, 2x2
/// pyramid, central-difference normals): per-frame mean, p50, p95 and max of each kernel, then
/// each kernel repeated alone on the last frame (wall and CPU time), the mesh, the volume's size,
/// the peak RSS and the ATE against the reference poses. The loop is
/// tests/support/kitchen_fusion.h, whose first 20 frames tests/fusion checks.
#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include <tbb/global_control.h>
#include <CLI/CLI.hpp>

#include "support/kitchen_fusion.h"

namespace aoscan {
namespace {

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / v.size();
}

double pct(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * (v.size() - 1))];
}

int run(int argc, char** argv) {
  CLI::App app{"aoscan-kitchen-bench: fusion kernel timings on the 7-Scenes RedKitchen recording"};
  std::string dir = std::string(AOSCAN_SHARED_DATA_DIR) + "/7scenes-redkitchen";
  test::KitchenRunOptions options;
  options.max_frames = 500;
  options.mesh = true;
  options.kernel_loops = 10;
  int threads = 2;
  app.add_option("FOLDER", dir, "the RedKitchen folder (depth.txt, groundtruth.txt, depth/)")
      ->capture_default_str();
  app.add_option("--frames", options.max_frames, "at most N frames")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--threads", threads, "threads for data-parallel kernels")
      ->capture_default_str()
      ->check(CLI::Range(1, 1024));
  app.add_option("--loops", options.kernel_loops,
                 "repeat each kernel N times on the last frame (0 = not)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--verbose", options.verbose,
               "print every frame's ICP outcome and the eigenvalues of its system");
  app.add_flag("--gt", options.fuse_at_reference,
               "fuse at the reference poses (ICP still runs from the previous reference pose)");
  app.add_flag("--no-hint", options.no_hint, "raycast without the depth hint");
  CLI11_PARSE(app, argc, argv);
  if (!test::kitchen_present(dir)) {
    std::fprintf(stderr, "aoscan-kitchen-bench: error: %s/depth.txt: missing file\n",
                 dir.c_str());
    return 3;
  }
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(threads));
  const test::KitchenRunStats s = test::run_kitchen(dir, options);
  for (const std::string& error : s.read_errors) std::fprintf(stderr, "%s\n", error.c_str());
  auto row = [](const char* name, const std::vector<double>& v) {
    std::printf("%-12s mean %6.2f  p50 %6.2f  p95 %6.2f  max %6.2f ms\n", name, mean(v),
                pct(v, 0.5), pct(v, 0.95), pct(v, 1.0));
  };
  row("preprocess*", s.ms_preprocess);
  row("icp", s.ms_icp);
  row("integrate", s.ms_integrate);
  row("raycast", s.ms_raycast);
  std::printf("track+integrate+raycast mean %.2f ms (%.1f fps)\n",
              mean(s.ms_icp) + mean(s.ms_integrate) + mean(s.ms_raycast),
              1000.0 / (mean(s.ms_icp) + mean(s.ms_integrate) + mean(s.ms_raycast)));
  std::printf("mesh %.0f ms: %zu vertices, %zu faces\n", s.ms_mesh, s.mesh_vertices, s.mesh_faces);
  struct rusage usage;
  getrusage(RUSAGE_SELF, &usage);
  std::printf("blocks %d, volume %.1f MB, peak RSS %.1f MB\n", s.blocks, s.volume_mb,
              usage.ru_maxrss / 1024.0);
  std::printf("ATE vs reference %.2f mm; good %d poor %d lost %d\n", 1000 * s.ate_m, s.good, s.poor,
              s.lost);
  return s.read_errors.empty() ? 0 : 3;
}

}  // namespace
}  // namespace aoscan

int main(int argc, char** argv) {
  return aoscan::run(argc, argv);
}
