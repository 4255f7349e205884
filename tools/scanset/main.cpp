/// @file main.cpp
/// @brief aoscan-scanset: writes a synthetic set of registered scans of an analytic scene (the
/// input of `aoscan scans`): equirectangular laser scans or pinhole depth frames rendered by the
/// simulator's scanner, as PLY point clouds with a scans.yaml manifest, one PTX file, or 16-bit
/// depth PNGs with a manifest. One scan is held at a time: rendered, written, dropped.
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <Eigen/Geometry>

#include "core/status.h"
#include "io/atomic_write.h"
#include "io/png_write.h"
#include "io/point_cloud_ply.h"
#include "io/ptx_writer.h"
#include "sim/scan_placement.h"
#include "sim/synth_camera.h"
#include "sim/synth_scanner.h"
#include "sim/synth_scene.h"

namespace aoscan::scanset {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

/// The equirectangular map that measures the share of rays that hit something (--points).
constexpr int kCoverageHeight = 64;

struct Options {
  std::string out;
  std::string scene = "room";
  int scans = 3;
  std::string camera = "equirect";
  long long points = 0;  ///< 0: not given
  int width = 0, height = 0;
  double noise_mm = 2.0;
  std::uint64_t seed = 1;
  std::string format = "ply";
  bool no_normals = false;
  int threads = 0;
};

std::string pose_row_major(const Pose& T) {
  const Eigen::Matrix4d m = T.matrix();
  std::string out = "[";
  char number[32];
  for (int i = 0; i < 16; ++i) {
    std::snprintf(number, sizeof number, "%.17g", m(i / 4, i % 4) + 0.0);  // -0 as 0
    out += (i ? ", " : "") + std::string(number);
  }
  return out + "]";
}

/// The camera of scan k: the pinhole of --width x --height (a Kinect's 62.7 degrees across), or
/// the equirectangular map of --height, or of about --points points: 2h x h with
/// h = sqrt(points / (2 c)), c the share of the rays of a 128 x 64 map that hit the scene.
ScanCamera camera_of(const Options& o, const AnalyticScene& scene, const Pose& pose,
                     const std::string& name) {
  if (o.camera == "pinhole") {
    return ScanCamera::make_pinhole(synth_intrinsics(o.width, o.height));
  }
  if (o.points == 0) return ScanCamera::make_equirectangular(o.height);
  RangeMap probe;
  probe.name = name;
  render_scan(scene, ScanCamera::make_equirectangular(kCoverageHeight), pose, kLaserScanMinRangeM,
              kLaserScanMaxRangeM, ScannerNoise{}, probe);
  const double coverage =
      static_cast<double>(probe.count_points()) / (2.0 * kCoverageHeight * kCoverageHeight);
  if (coverage == 0.0)
    throw usage_error("scan " + name + " sees nothing of scene '" + o.scene + "'");
  const double h = std::sqrt(static_cast<double>(o.points) / (2.0 * coverage));
  if (h > 40000.0)
    throw usage_error("--points " + std::to_string(o.points) + ": scan " + name +
                      " would need a map of more than 80000 x 40000 pixels");
  return ScanCamera::make_equirectangular(std::max(1, static_cast<int>(std::lround(h))));
}

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

/// Writes map's points (scanner frame) and normals as a PLY cloud.
void write_cloud(const std::string& path, const RangeMap& map, long long count, bool normals) {
  write_atomically(path, [&](const std::string& partial) {
    PointCloudPlyWriter writer(partial, count, normals);
    for (int y = 0; y < map.camera.height; ++y)
      for (int x = 0; x < map.camera.width; ++x)
        if (map.has_point(x, y)) writer.add(map.points(x, y), map.normals(x, y));
    writer.close();
  });
}

/// Writes a pinhole map as a 16-bit depth PNG (z * kSynthDepthScale; 0 where there is no point).
void write_depth_png(const std::string& path, const RangeMap& map) {
  std::vector<std::uint16_t> row(static_cast<std::size_t>(map.camera.width));
  write_png(path, map.camera.width, map.camera.height, PngFormat::kGrey16,
            [&](int y) -> const void* {
              for (int x = 0; x < map.camera.width; ++x) {
                const double raw =
                    map.has_point(x, y) ? std::round(map.points(x, y).z() * kSynthDepthScale) : 0.0;
                row[static_cast<std::size_t>(x)] =
                    raw >= 1.0 && raw <= 65535.0 ? static_cast<std::uint16_t>(raw) : 0;
              }
              return row.data();
            });
}

/// Appends map as one PTX scan: the map's columns (azimuth) in order, each from its bottom row
/// (the nadir) up; intensity = |cos| of the angle between the ray and the surface normal.
void write_ptx_scan(PtxWriter& writer, const RangeMap& map) {
  writer.begin_scan(map.camera.width, map.camera.height, map.T_world_scanner);
  for (int x = 0; x < map.camera.width; ++x)
    for (int y = map.camera.height - 1; y >= 0; --y) {
      if (!map.has_point(x, y)) {
        writer.add_missing();
        continue;
      }
      const Eigen::Vector3f& p = map.points(x, y);
      writer.add(p, std::min(1.0f, std::abs(map.normals(x, y).dot(p)) / p.norm()));
    }
}

void check_options(Options& o) {
  const bool pinhole = o.camera == "pinhole";
  if (pinhole) {
    if (o.points != 0)
      throw usage_error("--points is for --camera equirect (pinhole: --width, --height)");
    if (o.width == 0) o.width = 640;
    if (o.height == 0) o.height = 480;
    if (o.format == "ptx") throw usage_error("--format ptx needs --camera equirect");
  } else {
    if (o.width != 0)
      throw usage_error("--width is for --camera pinhole (equirect: --points or --height)");
    if (o.points != 0 && o.height != 0)
      throw usage_error("--points and --height both size the map: give one");
    if (o.points == 0 && o.height == 0) o.points = 1000000;
    if (o.format == "png") throw usage_error("--format png needs --camera pinhole");
  }
  if (o.no_normals && o.format != "ply")
    throw usage_error("--no-normals is for --format ply (" + o.format + " has no normals)");
  const std::vector<std::string> names = AnalyticScene::names();
  if (std::find(names.begin(), names.end(), o.scene) == names.end()) {
    std::string valid;
    for (const std::string& n : names) valid += (valid.empty() ? "" : ", ") + n;
    throw usage_error("--scene: unknown scene '" + o.scene + "' (valid: " + valid + ")");
  }
}

int generate(Options o) {
  check_options(o);
  std::unique_ptr<tbb::global_control> threads;
  if (o.threads > 0)
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    static_cast<std::size_t>(o.threads));
  const AnalyticScene scene = AnalyticScene::make(o.scene);
  const ScannerPlacement place = scanner_placement(o.scene);
  const bool pinhole = o.camera == "pinhole";
  require_writable_folder(o.out, "--out DIR");
  const fs::path out(o.out);
  const Clock::time_point start = Clock::now();

  std::vector<Pose> poses;
  for (int k = 0; k < o.scans; ++k) {
    poses.push_back(spiral_scanner_pose(place, k, o.scans, pinhole));
    const double clearance = scene.signed_distance(poses.back().translation());
    if (!(clearance >= kScannerClearanceM))
      throw Error(ExitCode::kFailure, "scan " + spiral_scan_name(k, o.scans) + " would stand " +
                                          std::to_string(clearance) + " m from a surface");
  }

  ScannerNoise noise;
  noise.sigma_m = o.noise_mm * 1e-3;
  const double min_range = pinhole ? kDepthScanMinRangeM : kLaserScanMinRangeM;
  const double max_range = pinhole ? kDepthScanMaxRangeM : kLaserScanMaxRangeM;
  long long total = 0;
  char title[256];
  std::snprintf(title, sizeof title,
                "# aoscan-scanset: scene %s, %d %s scans, noise %g mm, seed %llu\n",
                o.scene.c_str(), o.scans, o.camera.c_str(), o.noise_mm,
                static_cast<unsigned long long>(o.seed));
  std::string manifest = std::string(title) + "scans:\n";
  RangeMap map;  // one scan at a time; its storage is reused
  // Renders scan k into map and reports it; returns its point count.
  auto render = [&](int k, Clock::time_point& t) {
    t = Clock::now();
    map.name = spiral_scan_name(k, o.scans);
    noise.seed = spiral_scan_seed(o.seed, k);
    render_scan(scene, camera_of(o, scene, poses[k], map.name), poses[k], min_range, max_range,
                noise, map);
    return map.count_points();
  };
  auto report = [&](int k, long long count, double render_s, double write_s) {
    const Eigen::Vector3d& p = poses[k].translation();
    std::fprintf(stderr,
                 "aoscan-scanset: scan %d/%d %s: %d x %d %s, %lld points, scanner at (%.3f, %.3f, "
                 "%.3f), render %.1f s, write %.1f s\n",
                 k + 1, o.scans, map.name.c_str(), map.camera.width, map.camera.height,
                 o.camera.c_str(), count, p.x(), p.y(), p.z(), render_s, write_s);
  };

  if (o.format == "ptx") {
    const std::string path = (out / "scans.ptx").string();
    write_atomically(path, [&](const std::string& partial) {
      PtxWriter writer(partial);
      for (int k = 0; k < o.scans; ++k) {
        Clock::time_point t;
        const long long count = render(k, t);
        const double render_s = seconds_since(t);
        t = Clock::now();
        write_ptx_scan(writer, map);
        total += count;
        report(k, count, render_s, seconds_since(t));
      }
      writer.close();
    });
  } else {
    for (int k = 0; k < o.scans; ++k) {
      Clock::time_point t;
      const long long count = render(k, t);
      const double render_s = seconds_since(t);
      t = Clock::now();
      manifest += "  - name: " + map.name + "\n";
      if (o.format == "ply") {
        write_cloud((out / (map.name + ".ply")).string(), map, count, !o.no_normals);
        manifest += "    points: " + map.name + ".ply\n    scanner: [0, 0, 0]\n";
      } else {
        write_depth_png((out / (map.name + ".png")).string(), map);
        const Intrinsics& c = map.camera.pinhole;
        char camera[256];
        std::snprintf(camera, sizeof camera,
                      "{fx: %.17g, fy: %.17g, cx: %.17g, cy: %.17g, depth_scale: %g}", c.fx, c.fy,
                      c.cx, c.cy, kSynthDepthScale);
        manifest += "    depth: " + map.name + ".png\n    camera: " + camera + "\n";
      }
      manifest += "    pose: " + pose_row_major(poses[k]) + "\n";
      total += count;
      report(k, count, render_s, seconds_since(t));
    }
    const std::string path = (out / "scans.yaml").string();
    write_atomically(path, [&](const std::string& partial) {
      std::FILE* file = std::fopen(partial.c_str(), "wb");
      if (!file) throw_write_failed(partial);
      const bool ok = std::fwrite(manifest.data(), 1, manifest.size(), file) == manifest.size();
      if (std::fclose(file) != 0 || !ok) throw_write_failed(partial);
    });
  }
  std::printf("wrote %d scans, %lld points, to %s in %.1f s\n", o.scans, total,
              (out / (o.format == "ptx" ? "scans.ptx" : "scans.yaml")).string().c_str(),
              seconds_since(start));
  return 0;
}

int report_error(ExitCode code, const std::string& message) {
  std::fprintf(stderr, "aoscan: error: %s\n", one_line(message).c_str());
  return static_cast<int>(code);
}

int run(int argc, char** argv) {
  CLI::App app{
      "aoscan-scanset: writes a synthetic set of registered scans of an analytic scene for "
      "`aoscan scans`. Scan k of N stands on the sunflower spiral filling the scene's free floor "
      "(room: an ellipse in [0.6, 3.4]^2 at 1.5 m; corner: [0.8, 3.2]^2 at 1.5 m; plane: "
      "x in [-2, 2], y in [-3.5, -1.5] at 0 m), radius sqrt((k + 0.5) / N) of the half-axes, "
      "azimuth k times the golden angle; laser scanners stand upright, depth cameras look at "
      "the middle of the scene."};
  Options o;
  app.add_option("--out", o.out, "folder to write the set to (created if missing)")->required();
  app.add_option("--scene", o.scene, "analytic scene: room, corner or plane")
      ->capture_default_str();
  app.add_option("--scans", o.scans, "number of scans")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--camera", o.camera,
                 "equirect (a 360-degree laser scan, z up) or pinhole (a depth camera)")
      ->check(CLI::IsMember({"equirect", "pinhole"}))
      ->capture_default_str();
  app.add_option("--points", o.points,
                 "equirect: about this many points per scan (default 1000000): a 2h x h map with "
                 "h = sqrt(points / (2 c)), c the share of rays that hit the scene")
      ->check(CLI::Range(1LL, 3000000000LL));
  app.add_option("--height", o.height,
                 "equirect: the map is 2H x H pixels (instead of --points); pinhole: image "
                 "height (default 480)")
      ->check(CLI::Range(1, 40000));
  app.add_option("--width", o.width, "pinhole: image width (default 640); fx = fy = 525 W / 640")
      ->check(CLI::Range(1, 40000));
  app.add_option("--noise-mm", o.noise_mm,
                 "laser range noise: Gaussian sigma along the ray (mm); 0 gives exact points")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str();
  app.add_option("--seed", o.seed, "noise seed (each scan's noise is keyed by it and the scan)")
      ->capture_default_str();
  app.add_option("--format", o.format,
                 "ply: a PLY point cloud per scan (scanner frame) and scans.yaml; ptx: one "
                 "scans.ptx (equirect); png: a 16-bit depth PNG per scan and scans.yaml (pinhole)")
      ->check(CLI::IsMember({"ply", "ptx", "png"}))
      ->capture_default_str();
  app.add_flag("--no-normals", o.no_normals, "ply: write points without normals");
  app.add_option("--threads", o.threads, "rendering threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return report_error(ExitCode::kUsage, e.what() + std::string(" (see aoscan-scanset --help)"));
  }
  // A write past a file size limit fails with EFBIG (an error naming the file) instead of
  // killing the process.
  std::signal(SIGXFSZ, SIG_IGN);
  try {
    return generate(o);
  } catch (const Error& e) {
    return report_error(e.code(), e.what());
  } catch (const std::exception& e) {
    return report_error(ExitCode::kFailure, e.what());
  }
}

}  // namespace
}  // namespace aoscan::scanset

int main(int argc, char** argv) {
  return aoscan::scanset::run(argc, argv);
}
