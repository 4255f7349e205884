// Tests for tools/scanset (aoscan-scanset) through its executable: the scan sets it writes hold
// the points of the scene's surface at the poses its manifest or PTX file gives, and `aoscan
// scans` reads every one of them back (scans, points and points.ply's vertices counted exactly);
// the noise has the sigma asked for; bad options are one-line errors with exit 2.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/status.h"
#include "io/ply.h"
#include "io/png_read.h"
#include "io/ptx.h"
#include "io/scan_manifest.h"
#include "sim/synth_scene.h"
#include "support/cli_util.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;
using testing::CliRun;
using testing::quote;
using testing::read_stats;
using testing::ScratchDir;

/// The point-on-surface tolerance of exact scans (the points are floats of a few metres: their
/// rounding is about a micrometre).
constexpr double kOnSurfaceM = 1e-3;

/// Runs aoscan-scanset (next to aoscan) with `args`; stdout and stderr kept in `scratch`.
CliRun run_scanset(const std::string& args, const fs::path& scratch) {
  const fs::path tool = fs::path(AOSCAN_BINARY).parent_path() / "aoscan-scanset";
  const std::string cmd = quote(tool.string()) + " " + args + " > " +
                          quote((scratch / "stdout.txt").string()) + " 2> " +
                          quote((scratch / "stderr.txt").string()) + " < /dev/null";
  return testing::collect(testing::exit_code_of(std::system(cmd.c_str())), scratch);
}

/// The largest distance of `points` (world frame) from the scene's surface.
double max_distance(const AnalyticScene& scene, const std::vector<Eigen::Vector3f>& points) {
  double worst = 0.0;
  for (const Eigen::Vector3f& p : points) worst = std::max(worst, scene.distance(p.cast<double>()));
  return worst;
}

/// Runs `aoscan scans INPUT` and checks what its outputs say against the set that was written:
/// `scan_points` per scan, every output point on the scene's surface within `tolerance_m`.
void check_aoscan_scans(const std::string& input, const fs::path& dir,
                        const std::vector<long long>& scan_points, const AnalyticScene& scene,
                        double tolerance_m) {
  const fs::path out = dir / "out";
  const CliRun r = testing::run_aoscan(
      "scans " + quote(input) + " --out " + quote(out.string()) + " --threads 2", dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json stats = read_stats(out);
  long long total = 0;
  for (long long n : scan_points) total += n;
  EXPECT_EQ(stats["scans"], scan_points.size());
  EXPECT_EQ(stats["points"], total);
  ASSERT_EQ(stats["per_scan"].size(), scan_points.size());
  for (std::size_t k = 0; k < scan_points.size(); ++k) {
    EXPECT_EQ(stats["per_scan"][k]["points"], scan_points[k]) << k;
    EXPECT_EQ(stats["per_scan"][k]["points_skipped"], 0) << k;
  }
  EXPECT_TRUE(stats["isolated_scans"].empty()) << stats["isolated_scans"];
  const TriangleMesh points = read_ply((out / "points.ply").string());
  EXPECT_EQ(static_cast<long long>(points.vertices.size()), total);
  EXPECT_LT(max_distance(scene, points.vertices), tolerance_m);
}

TEST(Scanset, ExactEquirectPlyScansOfTheRoomGoThroughAoscanScansPointForPoint) {
  ScratchDir dir;
  const fs::path set = dir.path("set");
  const CliRun w = run_scanset("--out " + quote(set.string()) +
                                   " --scene room --scans 3 --points 20000 --noise-mm 0 "
                                   "--threads 2",
                               dir.path(""));
  ASSERT_EQ(w.exit_code, 0) << w.err;
  EXPECT_EQ(testing::count(w.err, "aoscan-scanset: scan "), 3u) << w.err;
  EXPECT_NE(w.out.find("wrote 3 scans, 60000 points"), std::string::npos) << w.out;

  const AnalyticScene scene = AnalyticScene::make("room");
  const std::vector<ScanEntry> entries = read_scan_manifest((set / "scans.yaml").string());
  ASSERT_EQ(entries.size(), 3u);
  std::vector<long long> counts;
  for (const ScanEntry& e : entries) {
    EXPECT_EQ(e.kind, ScanEntry::Kind::kPointCloud);
    EXPECT_EQ(e.scanner, Eigen::Vector3d::Zero());
    const TriangleMesh cloud = read_ply(e.path);
    // The room is closed: every ray hits, so the map is 200 x 100 = 20000 points.
    ASSERT_EQ(cloud.vertices.size(), 20000u) << e.path;
    ASSERT_EQ(cloud.normals.size(), cloud.vertices.size()) << e.path;
    std::vector<Eigen::Vector3f> world;
    for (std::size_t i = 0; i < cloud.vertices.size(); ++i) {
      world.push_back((e.T_world_scan * cloud.vertices[i].cast<double>()).cast<float>());
      // Unit normals facing the scanner, which stands at the cloud frame's origin.
      ASSERT_NEAR(cloud.normals[i].norm(), 1.0f, 1e-5f);
      ASSERT_LT(cloud.normals[i].dot(cloud.vertices[i]), 0.0f);
    }
    EXPECT_LT(max_distance(scene, world), kOnSurfaceM) << e.path;
    // Scanners stand 1.5 m high, clear of the furniture.
    EXPECT_DOUBLE_EQ(e.T_world_scan.translation().z(), 1.5);
    EXPECT_GE(scene.signed_distance(e.T_world_scan.translation()), 0.3);
    counts.push_back(static_cast<long long>(cloud.vertices.size()));
  }
  // Three different positions.
  EXPECT_GT((entries[0].T_world_scan.translation() - entries[1].T_world_scan.translation()).norm(),
            0.3);
  EXPECT_GT((entries[1].T_world_scan.translation() - entries[2].T_world_scan.translation()).norm(),
            0.3);
  check_aoscan_scans((set / "scans.yaml").string(), dir.path(""), counts, scene, kOnSurfaceM);
}

/// Reads the PTX file that aoscan-scanset wrote into `set` and checks its scans: a 2h x h grid
/// each, every point on the scene's surface at the scan's registration. Returns each scan's point
/// count.
std::vector<long long> check_ptx(const fs::path& set, const AnalyticScene& scene,
                                 std::size_t scan_count) {
  const std::vector<PtxScan> scans = read_ptx((set / "scans.ptx").string());
  EXPECT_EQ(scans.size(), scan_count);
  std::vector<long long> counts;
  for (const PtxScan& s : scans) {
    EXPECT_EQ(s.columns, 2 * s.rows);
    EXPECT_EQ(static_cast<long long>(s.points.size()) + s.missing,
              static_cast<long long>(s.columns) * s.rows);
    std::vector<Eigen::Vector3f> world;
    for (const Eigen::Vector3f& p : s.points)
      world.push_back((s.T_world_scanner * p.cast<double>()).cast<float>());
    EXPECT_LT(max_distance(scene, world), kOnSurfaceM);
    counts.push_back(static_cast<long long>(s.points.size()));
  }
  return counts;
}

TEST(Scanset, ExactPtxScansOfTheRoomGoThroughAoscanScansPointForPoint) {
  ScratchDir dir;
  const fs::path set = dir.path("set");
  const CliRun w = run_scanset("--out " + quote(set.string()) +
                                   " --scene room --scans 3 --points 20000 --noise-mm 0 "
                                   "--format ptx --threads 2",
                               dir.path(""));
  ASSERT_EQ(w.exit_code, 0) << w.err;
  const AnalyticScene scene = AnalyticScene::make("room");
  const std::vector<long long> counts = check_ptx(set, scene, 3);
  for (long long n : counts) EXPECT_EQ(n, 20000);  // the closed room: every ray hits
  check_aoscan_scans((set / "scans.ptx").string(), dir.path(""), counts, scene, kOnSurfaceM);
}

TEST(Scanset, PtxScansOfAnOpenSceneHaveMissingCellsAndAboutThePointsAsked) {
  ScratchDir dir;
  const fs::path set = dir.path("set");
  ASSERT_EQ(run_scanset("--out " + quote(set.string()) +
                            " --scene corner --scans 2 --points 20000 --noise-mm 0 --format ptx",
                        dir.path(""))
                .exit_code,
            0);
  const std::vector<PtxScan> scans = read_ptx((set / "scans.ptx").string());
  for (const PtxScan& s : scans) EXPECT_GT(s.missing, 0);  // rays into the open sky
  // The map is sized so that about 20000 rays hit: the share that hits is measured on a
  // 128 x 64 map, and rounding h moves the count by about 2 / h.
  for (long long n : check_ptx(set, AnalyticScene::make("corner"), 2))
    EXPECT_NEAR(static_cast<double>(n), 20000.0, 600.0);
}

TEST(Scanset, NoiseMovesEachPointAlongItsRayWithTheSigmaAsked) {
  ScratchDir dir;
  const std::string common = " --scene room --scans 2 --points 30000 --no-normals --seed 5";
  ASSERT_EQ(
      run_scanset("--out " + quote(dir.file("exact")) + common + " --noise-mm 0", dir.path(""))
          .exit_code,
      0);
  ASSERT_EQ(
      run_scanset("--out " + quote(dir.file("noisy")) + common + " --noise-mm 2", dir.path(""))
          .exit_code,
      0);
  std::vector<double> first_scan_errors;  // the range errors of scan-001, pixel by pixel
  for (const char* scan : {"scan-001.ply", "scan-002.ply"}) {
    const bool second = !first_scan_errors.empty();
    const TriangleMesh exact = read_ply((dir.path("exact") / scan).string());
    const TriangleMesh noisy = read_ply((dir.path("noisy") / scan).string());
    EXPECT_TRUE(noisy.normals.empty());
    ASSERT_EQ(exact.vertices.size(), noisy.vertices.size());
    double sum = 0.0, sum2 = 0.0, cross = 0.0;
    const std::size_t n = exact.vertices.size();
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d e = exact.vertices[i].cast<double>();
      const Eigen::Vector3d p = noisy.vertices[i].cast<double>();
      // On the same ray from the scanner (the direction of a float point: 1e-6 relative).
      ASSERT_LT((p.normalized() - e.normalized()).norm(), 1e-5) << i;
      const double error = p.norm() - e.norm();
      sum += error;
      sum2 += error * error;
      if (second)
        cross += error * first_scan_errors.at(i);  // the closed room: both maps are 244 x 122
      else
        first_scan_errors.push_back(error);
    }
    const double mean = sum / n, sigma = std::sqrt(sum2 / n - mean * mean);
    // 30000 Gaussian samples: the mean's standard error is 0.012 mm, the sigma's 0.4 %.
    EXPECT_NEAR(mean, 0.0, 6e-5) << scan;
    EXPECT_NEAR(sigma, 2e-3, 0.05 * 2e-3) << scan;
    // The two scans' noise is independent (correlation 0 within 5 standard errors).
    if (second) {
      EXPECT_LT(std::abs(cross / n) / (sigma * sigma), 5.0 / std::sqrt(n));
    }
  }
}

TEST(Scanset, PinholeDepthPngsHoldTheScenesDepthsAndAoscanScansReadsThem) {
  ScratchDir dir;
  const fs::path set = dir.path("set");
  const CliRun w = run_scanset("--out " + quote(set.string()) +
                                   " --scene corner --scans 2 --camera pinhole --width 160 "
                                   "--height 120 --noise-mm 0 --format png",
                               dir.path(""));
  ASSERT_EQ(w.exit_code, 0) << w.err;
  const AnalyticScene scene = AnalyticScene::make("corner");
  const std::vector<ScanEntry> entries = read_scan_manifest((set / "scans.yaml").string());
  ASSERT_EQ(entries.size(), 2u);
  for (const ScanEntry& e : entries) {
    ASSERT_EQ(e.kind, ScanEntry::Kind::kDepthImage);
    EXPECT_EQ(e.depth_scale, 5000.0);
    EXPECT_DOUBLE_EQ(e.intrinsics.fx, 525.0 * 160 / 640);
    Image<std::uint16_t> raw;
    ASSERT_TRUE(read_grey16_png(e.path, raw).is_ok()) << e.path;
    ASSERT_EQ(raw.width(), 160);
    ASSERT_EQ(raw.height(), 120);
    std::vector<Eigen::Vector3f> world;
    for (int y = 0; y < raw.height(); ++y)
      for (int x = 0; x < raw.width(); ++x) {
        if (raw(x, y) == 0) continue;
        const Eigen::Vector3d p = e.intrinsics.unproject(
            static_cast<double>(x), static_cast<double>(y), raw(x, y) / e.depth_scale);
        world.push_back((e.T_world_scan * p).cast<float>());
      }
    // The camera looks at the scene: most pixels see it.
    EXPECT_GT(world.size(), 160u * 120u / 2) << e.path;
    // Depth quantised to 0.2 mm steps: z within 0.1 mm, the point within 0.13 mm along its ray
    // (37 degrees off the axis at the image's corners), no farther from the surface.
    EXPECT_LT(max_distance(scene, world), 1.3e-4) << e.path;
  }
  const fs::path out = dir.path("out");
  const CliRun r = testing::run_aoscan(
      "scans " + quote((set / "scans.yaml").string()) + " --out " + quote(out.string()),
      dir.path(""));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(read_stats(out)["scans"], 2);
}

TEST(Scanset, BadOptionsAreOneLineErrorsWithExitTwo) {
  ScratchDir dir;
  const std::string out = " --out " + quote(dir.file("set"));
  const struct {
    std::string args;
    std::string expected;
  } cases[] = {
      {"--scans 3", "--out is required"},
      {out + " --scene attic", "unknown scene 'attic' (valid: corner, room, plane)"},
      {out + " --scans 0", "--scans"},
      {out + " --camera fisheye", "--camera"},
      {out + " --points 1000 --height 10", "--points and --height both size the map"},
      {out + " --camera pinhole --points 1000", "--points is for --camera equirect"},
      {out + " --camera pinhole --format ptx", "--format ptx needs --camera equirect"},
      {out + " --format png", "--format png needs --camera pinhole"},
      {out + " --format ptx --no-normals", "--no-normals is for --format ply"},
      {out + " --width 100", "--width is for --camera pinhole"},
      {out + " --noise-mm -1", "--noise-mm"},
      {" --out /proc/aoscan-scanset", "--out DIR"},
  };
  for (const auto& c : cases) {
    const CliRun r = run_scanset(c.args, dir.path(""));
    EXPECT_EQ(r.exit_code, 2) << c.args << ": " << r.err;
    EXPECT_EQ(r.err.rfind("aoscan: error: ", 0), 0u) << c.args << ": " << r.err;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << c.args << ": " << r.err;
    EXPECT_EQ(testing::count(r.err, "\n"), 1u) << c.args << ": " << r.err;
  }
  EXPECT_FALSE(fs::exists(dir.path("set") / "scans.yaml"));
}

}  // namespace
}  // namespace aoscan
