/// @file main.cpp
/// @brief aoscan-colour-registration: estimates the colour camera of a TUM-layout recording (the
/// depth-to-colour transform and the colour intrinsics) from depth and colour edges, and writes it
/// as camera.json.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <CLI/CLI.hpp>
#include <Eigen/Geometry>

#include "core/status.h"
#include "io/camera_json.h"
#include "registration.h"

namespace aoscan::colour_registration {
namespace {

void print_distances(const char* label, const EdgeDistances& d) {
  std::printf(
      "%s median %.2f px, p90 %.2f px, %.1f %% within 2 px (%zu points, %zu outside the "
      "colour image)\n",
      label, d.median_px, d.p90_px, 100.0 * d.within_2px, d.points, d.outside);
}

int run(int argc, char** argv) {
  CLI::App app{
      "aoscan-colour-registration: estimate the colour camera of a TUM-layout recording (depth-to-"
      "colour transform, colour focal length) by aligning depth discontinuities with colour edges"};
  std::string folder, out;
  RecordingOptions options;
  app.add_option("FOLDER", folder, "recording folder (depth.txt, rgb.txt, camera.json)")
      ->required();
  app.add_option("--out", out, "camera.json to write (the folder's depth calibration + colour)")
      ->required();
  app.add_option("--frames", options.max_frames, "pairs read at most (half fit, half measure)")
      ->capture_default_str();
  app.add_option("--step", options.step, "read every K-th pair")->capture_default_str();
  bool on_boundary = false;
  app.add_flag("--edge-on-boundary", on_boundary,
               "put depth-edge points on the boundary between the two pixels of a jump (exact "
               "depth, e.g. synthetic recordings) instead of at the nearer pixel (real depth "
               "cameras, whose nearer surface reaches past the edge)");
  app.add_flag("--fit-principal-point", options.fit.fit_principal_point,
               "fit cx, cy too (to first order the same as a small rotation: kept at the image "
               "centre by default)");
  app.add_flag("--verbose", options.verbose,
               "per-frame edge counts and distances, skips, formal uncertainties");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : static_cast<int>(ExitCode::kUsage);
  }
  try {
    if (on_boundary) options.edges.placement = EdgePlacement::kBoundary;
    if (options.max_frames < 1) throw usage_error("--frames must be at least 1");
    if (options.step < 1) throw usage_error("--step must be at least 1");
    // An output that cannot be written fails now, not after the fit.
    const std::filesystem::path out_dir = std::filesystem::path(out).parent_path();
    if (!out_dir.empty() && !std::filesystem::is_directory(out_dir))
      throw Error(ExitCode::kFailure, out + ": cannot write: no folder " + out_dir.string());
    const auto start = std::chrono::steady_clock::now();
    const RecordingResult r = register_recording(
        folder, options, [](const std::string& m) { std::fprintf(stderr, "%s\n", m.c_str()); });
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    const ColourCamera& c = r.fit.camera;
    const Eigen::Matrix3d& R = c.T_colour_depth.rotation();
    const Eigen::Vector3d& t = c.T_colour_depth.translation();
    const Eigen::AngleAxisd aa(R);
    std::printf("frames              %zu fitted, %zu measured%s, %zu skipped%s%s\n",
                r.fit_frames.size(), r.eval_frames.size(),
                r.held_out ? " (held out: every other pair)" : " (the fitted pair itself)",
                r.skipped, r.skipped ? "; first: " : "", r.first_skip.c_str());
    std::printf("colour intrinsics   %dx%d fx = fy = %.2f px (fitted), cx %.2f cy %.2f (%s)\n",
                c.intrinsics.width, c.intrinsics.height, c.intrinsics.fx, c.intrinsics.cx,
                c.intrinsics.cy,
                options.fit.fit_principal_point ? "fitted" : "kept at the image centre");
    std::printf(
        "depth to colour     t = (%+.4f, %+.4f, %+.4f) m, rotation %.3f deg about "
        "(%+.3f, %+.3f, %+.3f)\n",
        t.x(), t.y(), t.z(), aa.angle() * 180.0 / M_PI, aa.axis().x(), aa.axis().y(),
        aa.axis().z());
    if (options.verbose) {
      const auto& s = r.fit.sigma;
      std::printf(
          "formal sigma        rotation (%.4f, %.4f, %.4f) deg, t (%.2f, %.2f, %.2f) mm, "
          "f %.2f px, cx %.2f cy %.2f px; condition %.3g\n",
          s[0] * 180 / M_PI, s[1] * 180 / M_PI, s[2] * 180 / M_PI, s[3] * 1e3, s[4] * 1e3,
          s[5] * 1e3, s[6], s[7], s[8], r.fit.condition);
      for (std::size_t k = 0; k < r.eval_frames.size(); ++k)
        std::printf(
            "measured frame %4d  before median %5.2f px, after median %5.2f px (%zu points)\n",
            r.eval_frames[k], r.before_per_frame[k].median_px, r.after_per_frame[k].median_px,
            r.after_per_frame[k].points);
    }
    print_distances("before (registered)", r.before);
    print_distances("after              ", r.after);
    std::printf(
        "offset              the fit moves depth-edge points by median %.1f px, p90 %.1f px "
        "from the registered assumption\n",
        r.offset_median_px, r.offset_p90_px);
    std::printf(
        "chance              median %.2f px from any pixel to the nearest colour edge (what "
        "a misplaced point scores)\n",
        r.chance_median_px);
    std::printf(
        "measured            distance from each projected depth-edge point to the nearest "
        "colour Canny edge (distance transform, bilinear, untruncated)\n");
    std::printf("time                %.1f s (reading and edges %.1f s, fit %.1f s)\n", seconds,
                r.read_s, r.fit_s);
    write_camera_json(out, r.depth_intrinsics, r.depth_scale, &c);
    std::printf("wrote               %s\n", out.c_str());
    return 0;
  } catch (const Error& e) {
    std::fprintf(stderr, "aoscan-colour-registration: %s\n", one_line(e.what()).c_str());
    return static_cast<int>(e.code());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "aoscan-colour-registration: %s\n", one_line(e.what()).c_str());
    return static_cast<int>(ExitCode::kFailure);
  }
}

}  // namespace
}  // namespace aoscan::colour_registration

int main(int argc, char** argv) {
  return aoscan::colour_registration::run(argc, argv);
}
