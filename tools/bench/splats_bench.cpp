/// @file splats_bench.cpp
/// @brief aoscan-splats-bench: the CPU composite of the orbit views of one mesh (a PLY with AO in
/// its quality, e.g. a session's mesh.ply) from the fitted orbit camera: median milliseconds of
/// `orbit` (square points) and `splats` (Gaussian splats, three passes) and the pixels each covers.
/// With --points the faces are dropped: the splats take the style's spacing, as for the live
/// view's orbit cloud.
#include <cstdio>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "io/ply.h"
#include "median_ms.h"
#include "render/composite.h"

int main(int argc, char** argv) {
  using namespace aoscan;
  CLI::App app{"CPU composite time of the orbit and splats views of a mesh"};
  std::string path;
  int width = 640;
  int height = 480;
  int repeat = 20;
  bool points = false;
  app.add_option("mesh", path, "PLY mesh with per-vertex AO as quality")->required();
  app.add_option("--width", width, "image width (pixels)")->check(CLI::PositiveNumber);
  app.add_option("--height", height, "image height (pixels)")->check(CLI::PositiveNumber);
  app.add_option("--repeat", repeat, "rounds (each view once per round)")
      ->check(CLI::PositiveNumber);
  app.add_flag("--points", points, "drop the faces (the splats take ViewStyle::splat_spacing_m)");
  CLI11_PARSE(app, argc, argv);
  try {
    TriangleMesh mesh = read_ply(path);
    if (points) mesh.faces.clear();
    const ViewStyle style;
    const OrbitCamera camera = fit_orbit(mesh);
    Image<Rgb8> orbit(width, height);
    Image<Rgb8> splats(width, height);
    const std::vector<double> ms =
        median_ms(repeat, {[&] { composite_orbit(mesh, camera, orbit, style); },
                           [&] { composite_splats(mesh, camera, splats, style); }});
    const auto covered = [&](const Image<Rgb8>& image) {
      std::size_t n = 0;
      for (std::size_t i = 0; i < image.size(); ++i) n += image.data()[i] != style.background;
      return n;
    };
    std::printf(
        "%zu vertices, %zu faces, spacing %.4f m, camera %.2f m from the centre, %dx%d, median "
        "of %d rounds\n",
        mesh.vertices.size(), mesh.faces.size(), surface_spacing_m(mesh, style), camera.distance_m,
        width, height, repeat);
    std::printf("orbit  %8.2f ms  %zu pixels covered\n", ms[0], covered(orbit));
    std::printf("splats %8.2f ms  %zu pixels covered\n", ms[1], covered(splats));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "aoscan-splats-bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
