// Tests for src/pipeline/scan_set.cpp (`aoscan scans`): a manifest of laser point clouds and a
// recording folder posed by its ground truth, through to points.ply, the per-scan PLYs and
// stats.json; errors for inputs that hold no scan.
#include "pipeline/scan_set.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <unordered_map>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "capture/recorder.h"
#include "capture/synth_source.h"
#include "core/status.h"
#include "io/ply.h"
#include "sim/synth_scanner.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

using testing::ScratchDir;
using testing::write_text;

/// The points of a laser scan of the corner scene from `position`, in the scanner's frame.
std::vector<Eigen::Vector3f> laser_points(const Eigen::Vector3d& position) {
  RangeMap map;
  render_scan(AnalyticScene::make("corner"), ScanCamera::make_equirectangular(120),
              Pose(Eigen::Matrix3d::Identity(), position), 0.3, 20.0, ScannerNoise{}, map);
  std::vector<Eigen::Vector3f> points;
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < map.camera.width; ++x)
      if (map.has_point(x, y)) points.push_back(map.points(x, y));
  return points;
}

/// laser_points() written as a PLY cloud in a frame whose origin lies `below` metres under the
/// scanner.
void write_laser_cloud(const std::string& path, const Eigen::Vector3d& position,
                       float below = 1.0f) {
  TriangleMesh cloud;
  for (const Eigen::Vector3f& p : laser_points(position))
    cloud.vertices.push_back(p + Eigen::Vector3f(0, 0, below));
  write_ply(path, cloud);
}

/// Two laser clouds of the corner scene (a.ply, b.ply) and the manifest set.yaml that places them
/// (each cloud's frame sits 1 m below its scanner: pose = the frame's place in the world); returns
/// the manifest's path.
std::string write_two_laser_scans(const ScratchDir& dir) {
  write_laser_cloud(dir.file("a.ply"), {2.6, 1.2, 1.4});
  write_laser_cloud(dir.file("b.ply"), {1.1, 2.7, 1.6});
  write_text(dir.file("set.yaml"), R"(scans:
  - points: a.ply
    scanner: [0, 0, 1]
    pose: {t: [2.6, 1.2, 0.4], q: [0, 0, 0, 1]}
  - points: b.ply
    scanner: [0, 0, 1]
    pose: {t: [1.1, 2.7, 0.6], q: [0, 0, 0, 1]}
)");
  return dir.file("set.yaml");
}

/// Options of a run on write_two_laser_scans()'s manifest into `out` in `dir`.
ScansOptions two_laser_scans_run(const ScratchDir& dir, const std::string& out) {
  ScansOptions options;
  options.inputs = {write_two_laser_scans(dir)};
  options.out_dir = dir.file(out);
  return options;
}

nlohmann::json read_json(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

TEST(ScanSet, AManifestOfLaserCloudsGivesEveryPointItsMultiViewAo) {
  ScratchDir dir;
  ScansOptions options = two_laser_scans_run(dir, "out");
  const ScansResult r = run_scans(options);
  ASSERT_EQ(r.scans.size(), 2u);
  EXPECT_TRUE(r.isolated_scans.empty());
  EXPECT_EQ(r.pairs_tested, 2);
  EXPECT_GT(r.points_shared, r.points / 4);
  const TriangleMesh all = read_ply(dir.file("out/points.ply"));
  const TriangleMesh a = read_ply(dir.file("out/scans/a.ply"));
  const TriangleMesh b = read_ply(dir.file("out/scans/b.ply"));
  EXPECT_EQ(static_cast<long long>(all.vertices.size()), r.points);
  EXPECT_EQ(a.vertices.size() + b.vertices.size(), all.vertices.size());
  ASSERT_EQ(all.quality.size(), all.vertices.size());
  int occluded = 0, without_normal = 0;
  for (std::size_t i = 0; i < all.vertices.size(); ++i) {
    EXPECT_GE(all.quality[i], 0.0f);
    EXPECT_LE(all.quality[i], 1.0f);
    occluded += all.quality[i] < 0.9f ? 1 : 0;
    // World frame: the corner's floor, walls and furniture lie within its bounds.
    EXPECT_GT(all.vertices[i].z(), -0.01f);
    // A unit normal, or none where too few points of one surface surround it (a table leg one
    // pixel wide).
    const float length = all.normals[i].norm();
    if (length == 0.0f)
      ++without_normal;
    else
      EXPECT_NEAR(length, 1.0f, 1e-4f);
  }
  EXPECT_GT(occluded, 0);
  EXPECT_LT(without_normal, static_cast<int>(all.vertices.size() / 100));
  const nlohmann::json stats = read_json(dir.file("out/stats.json"));
  EXPECT_EQ(stats["scans"], 2);
  EXPECT_EQ(stats["points"], r.points);
  EXPECT_TRUE(stats.contains("wall_s"));
  EXPECT_TRUE(stats.contains("peak_rss_mb"));
  EXPECT_EQ(stats["per_scan"][1]["name"], "b");

  // --ssao-only writes each scan's own SSAO: different values, same points.
  options.ssao_only = true;
  options.out_dir = dir.file("ssao");
  run_scans(options);
  const TriangleMesh ssao = read_ply(dir.file("ssao/points.ply"));
  ASSERT_EQ(ssao.vertices.size(), all.vertices.size());
  EXPECT_EQ(ssao.vertices, all.vertices);
  EXPECT_NE(ssao.quality, all.quality);
}

TEST(ScanSet, AStoppedRunWritesOnlyItsInterruptedStatusAndResumesToTheSameBytes) {
  ScratchDir dir;
  ScansOptions options = two_laser_scans_run(dir, "whole");
  run_scans(options);

  // Stopped before its first scan: no point cloud, stats.json "interrupted", the scratch folder
  // kept.
  const std::atomic<bool> stop{true};
  options.out_dir = dir.file("out");
  options.stop = &stop;
  const ScansResult stopped = run_scans(options);
  EXPECT_TRUE(stopped.interrupted);
  EXPECT_FALSE(std::filesystem::exists(dir.file("out/points.ply")));
  EXPECT_FALSE(std::filesystem::exists(dir.file("out/scans")));
  const nlohmann::json stats = read_json(dir.file("out/stats.json"));
  EXPECT_EQ(stats["status"], "interrupted");
  EXPECT_TRUE(std::filesystem::exists(dir.file("out/scratch/run.json")));

  // Continued with --resume and no stop: the bytes of the whole run.
  options.stop = nullptr;
  options.resume = true;
  const ScansResult resumed = run_scans(options);
  EXPECT_FALSE(resumed.interrupted);
  EXPECT_EQ(read_json(dir.file("out/stats.json"))["status"], "complete");
  std::ifstream a(dir.file("whole/points.ply"), std::ios::binary);
  std::ifstream b(dir.file("out/points.ply"), std::ios::binary);
  EXPECT_TRUE(std::equal(std::istreambuf_iterator<char>(a), std::istreambuf_iterator<char>(),
                         std::istreambuf_iterator<char>(b), std::istreambuf_iterator<char>()));
}

TEST(ScanSet, PtxFilesAndMeshlabProjectsGiveTheSameScanSets) {
  ScratchDir dir;
  const std::vector<Eigen::Vector3d> positions = {{2.6, 1.2, 1.4}, {1.1, 2.7, 1.6}};
  // One PTX file with both scans (the grid here is a plain list of the returned points: PTX
  // points that did not return are written as 0 0 0 and skipped).
  std::string ptx;
  for (const Eigen::Vector3d& c : positions) {
    const std::vector<Eigen::Vector3f> points = laser_points(c);
    ptx += std::to_string(points.size() + 1) + "\n1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n" +
           "1 0 0 0\n0 1 0 0\n0 0 1 0\n" + std::to_string(c.x()) + " " + std::to_string(c.y()) +
           " " + std::to_string(c.z()) + " 1\n0 0 0 0\n";
    for (const Eigen::Vector3f& p : points)
      ptx += std::to_string(p.x()) + " " + std::to_string(p.y()) + " " + std::to_string(p.z()) +
             " 0.5\n";
  }
  write_text(dir.file("hall.ptx"), ptx);
  ScansOptions options;
  options.inputs = {dir.file("hall.ptx")};
  options.out_dir = dir.file("ptx");
  const ScansResult from_ptx = run_scans(options);
  ASSERT_EQ(from_ptx.scans.size(), 2u);
  EXPECT_EQ(from_ptx.scans[0].name, "hall-1");
  EXPECT_TRUE(from_ptx.isolated_scans.empty());
  EXPECT_GT(from_ptx.points_shared, from_ptx.points / 4);

  // The same scans as MeshLab layers in their scanners' frames.
  write_laser_cloud(dir.file("s1.ply"), positions[0], 0.0f);
  write_laser_cloud(dir.file("s2.ply"), positions[1], 0.0f);
  auto layer = [](const std::string& file, const Eigen::Vector3d& c) {
    return "<MLMesh filename=\"" + file + "\"><MLMatrix44>1 0 0 " + std::to_string(c.x()) +
           " 0 1 0 " + std::to_string(c.y()) + " 0 0 1 " + std::to_string(c.z()) +
           " 0 0 0 1</MLMatrix44></MLMesh>";
  };
  write_text(dir.file("set.mlp"), "<MeshLabProject><MeshGroup>" + layer("s1.ply", positions[0]) +
                                      layer("s2.ply", positions[1]) +
                                      "</MeshGroup></MeshLabProject>");
  options.inputs = {dir.file("set.mlp")};
  options.out_dir = dir.file("mlp");
  const ScansResult from_mlp = run_scans(options);
  ASSERT_EQ(from_mlp.scans.size(), 2u);
  EXPECT_EQ(from_mlp.points, from_ptx.points);
  EXPECT_EQ(from_mlp.points_shared, from_ptx.points_shared);
}

TEST(ScanSet, EveryKthFrameOfARecordingIsAScanPosedByItsGroundTruth) {
  ScratchDir dir;
  const std::unique_ptr<Source> source =
      open_synth_source("synth:corner?frames=25&width=160&height=120");
  record_source(*source, dir.file("rec"), std::nullopt, nullptr);
  ScansOptions options;
  options.inputs = {dir.file("rec")};
  options.out_dir = dir.file("out");
  options.every = 10;
  const ScansResult r = run_scans(options);
  ASSERT_EQ(r.scans.size(), 3u);  // frames 0, 10, 20
  EXPECT_EQ(r.scans[1].name, "rec-10");
  EXPECT_EQ(r.frames_without_pose, 0);
  EXPECT_EQ(r.frames_corrupt, 0);
  // An unreadable frame is skipped and counted: frame 10 is gone, frame 20 is still a scan.
  write_text(dir.file("rec/depth/000010.png"), "not a png");
  const ScansResult skipped = run_scans(options);
  EXPECT_EQ(skipped.frames_corrupt, 1);
  ASSERT_EQ(skipped.scans.size(), 2u);
  EXPECT_EQ(skipped.scans[1].name, "rec-20");
  EXPECT_TRUE(std::filesystem::is_regular_file(dir.file("out/scans/rec-20.ply")));
  // Without a trajectory the frames cannot be posed.
  std::filesystem::remove(dir.file("rec/groundtruth.txt"));
  try {
    run_scans(options);
    ADD_FAILURE() << "no error without poses";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kBadInput);
    EXPECT_NE(std::string(e.what()).find("--poses"), std::string::npos) << e.what();
  }
}

TEST(ScanSet, InputsThatHoldNoScanAreErrors) {
  ScratchDir dir;
  ScansOptions options;
  options.out_dir = dir.file("out");
  EXPECT_THROW(run_scans(options), Error);  // no input
  options.inputs = {dir.file("nothing.txt")};
  write_text(dir.file("nothing.txt"), "x");
  EXPECT_THROW(run_scans(options), Error);
  TriangleMesh empty;
  write_ply(dir.file("empty.ply"), empty);
  write_text(dir.file("m.json"), R"({"scans": [{"points": "empty.ply"}]})");
  options.inputs = {dir.file("m.json")};
  try {
    run_scans(options);
    ADD_FAILURE() << "no error for an empty cloud";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("empty"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir.file("out/points.ply")));
}

TEST(ScanSet, TheMeshOfTheScansLiesOnTheSurfaceAndTakesTheAoOfItsNearestScanPoints) {
  ScratchDir dir;
  ScansOptions options = two_laser_scans_run(dir, "out");
  options.show_progress = false;
  options.mesh = true;
  options.config.fusion.voxel_size_m = 0.02;
  options.config.fusion.truncation_m = 0.06;
  const ScansResult r = run_scans(options);
  EXPECT_FALSE(r.mesh_capacity_reached);
  const TriangleMesh mesh = read_ply(dir.file("out/mesh.ply"));
  const TriangleMesh points = read_ply(dir.file("out/points.ply"));
  ASSERT_GT(mesh.vertices.size(), 1000u);
  EXPECT_EQ(static_cast<long long>(mesh.vertices.size()), r.mesh_vertices);
  EXPECT_EQ(static_cast<long long>(mesh.faces.size()), r.mesh_faces);
  EXPECT_LT(r.mesh_vertices_without_ao, r.mesh_vertices / 20);

  // The vertices lie on the scene's surface (the scans are exact) but for the TSDF's usual
  // overshoot of up to a voxel or two along concave edges: half of them within 2 mm, 95 % within
  // about a voxel (2 cm), 99 % within about 1.5 voxels (measured: 2.05 and 3.0 cm, the cube
  // faces' depths taken on the tangent planes of compute_scan_normals()).
  const AnalyticScene scene = AnalyticScene::make("corner");
  std::vector<double> distance;
  for (const Eigen::Vector3f& v : mesh.vertices) distance.push_back(scene.distance(v.cast<double>()));
  std::sort(distance.begin(), distance.end());
  const auto quantile = [&distance](double q) {
    return distance[static_cast<std::size_t>(q * static_cast<double>(distance.size() - 1))];
  };
  EXPECT_LT(quantile(0.5), 0.002);
  EXPECT_LT(quantile(0.95), 0.021);
  EXPECT_LT(quantile(0.99), 0.031);

  // Each shaded vertex's AO is exactly that of a scan point within the truncation distance: a
  // grid of the points, cells of that size, searched around the vertex.
  // The reach: the truncation distance or two point radii, which for these 240 x 120 maps (2.6 cm
  // a metre of depth) stays below this across the corner scene.
  const float reach = 0.22f;
  std::unordered_map<std::uint64_t, std::vector<int>> cells;
  auto cell_of = [reach](const Eigen::Vector3f& p, int dx, int dy, int dz) {
    const auto c = [reach](float v, int d) {
      return static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(v / reach)) + d + 4096);
    };
    return (c(p.x(), dx) << 42) | (c(p.y(), dy) << 21) | c(p.z(), dz);
  };
  for (int i = 0; i < static_cast<int>(points.vertices.size()); ++i)
    cells[cell_of(points.vertices[i], 0, 0, 0)].push_back(i);
  int matched = 0, unmatched = 0;
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    bool found = false;
    for (int dz = -1; dz <= 1 && !found; ++dz)
      for (int dy = -1; dy <= 1 && !found; ++dy)
        for (int dx = -1; dx <= 1 && !found; ++dx) {
          const auto it = cells.find(cell_of(mesh.vertices[v], dx, dy, dz));
          if (it == cells.end()) continue;
          for (int i : it->second)
            if ((points.vertices[i] - mesh.vertices[v]).norm() <= reach &&
                points.quality[i] == mesh.quality[v]) {
              found = true;
              break;
            }
        }
    (found ? matched : unmatched) += 1;
  }
  // Only vertices without a scan point nearby (AO 1, which some far points have too) match none.
  EXPECT_LE(unmatched, r.mesh_vertices_without_ao);
  EXPECT_GE(matched, r.mesh_vertices - r.mesh_vertices_without_ao);
}

/// The run in `dirty_out` skipped `extra` more points than the one in `clean_out` and wrote the
/// same points, byte for byte.
void expect_only_more_skipped(const std::string& clean_out, const std::string& dirty_out,
                              long long extra) {
  const nlohmann::json clean = read_json(clean_out + "/stats.json");
  const nlohmann::json dirty = read_json(dirty_out + "/stats.json");
  EXPECT_EQ(dirty["per_scan"][0]["points_skipped"].get<long long>(),
            clean["per_scan"][0]["points_skipped"].get<long long>() + extra);
  EXPECT_EQ(dirty["points"], clean["points"]);
  std::ifstream a(clean_out + "/points.ply", std::ios::binary);
  std::ifstream b(dirty_out + "/points.ply", std::ios::binary);
  EXPECT_TRUE(std::equal(std::istreambuf_iterator<char>(a), {}, std::istreambuf_iterator<char>(b)));
}

TEST(ScanSet, NonFinitePointsAreSkippedAndCountedAndChangeNothingElse) {
  ScratchDir dir;
  write_laser_cloud(dir.file("clean.ply"), Eigen::Vector3d(1.5, 1.5, 1.2));
  TriangleMesh cloud = read_ply(dir.file("clean.ply"));
  cloud.normals.clear();
  cloud.quality.clear();
  cloud.colours.clear();
  write_ply(dir.file("clean.ply"), cloud);
  const std::size_t good = cloud.vertices.size();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (const Eigen::Vector3f& bad : {Eigen::Vector3f(nan, 0, 0), Eigen::Vector3f(0, inf, 1),
                                     Eigen::Vector3f(-inf, nan, 2)})
    cloud.vertices.push_back(bad);
  write_ply(dir.file("dirty.ply"), cloud);
  ScansOptions options;
  options.show_progress = false;
  for (const std::string name : {"clean", "dirty"}) {
    write_text(dir.file(name + ".json"), R"({"scans": [{"name": "s", "points": ")" + name +
                                             R"(.ply", "scanner": [0, 0, 1]}]})");
    options.inputs = {dir.file(name + ".json")};
    options.out_dir = dir.file("out-" + name);
    run_scans(options);
  }
  expect_only_more_skipped(dir.file("out-clean"), dir.file("out-dirty"), 3);

  // The same cloud as a PTX scan (scanner frame, registered by a translation to the scanner),
  // with three lines of nan and inf points in the dirty one.
  for (const std::string name : {"clean", "dirty"}) {
    const bool dirty = name == "dirty";
    std::string ptx = std::to_string(dirty ? good + 3 : good) +
                      "\n1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n";
    char line[96];
    for (std::size_t i = 0; i < good; ++i) {
      const Eigen::Vector3f q = cloud.vertices[i] - Eigen::Vector3f(0, 0, 1);
      std::snprintf(line, sizeof(line), "%.9g %.9g %.9g 0.5\n", q.x(), q.y(), q.z());
      ptx += line;
    }
    if (dirty) ptx += "nan nan nan 0.5\n0 inf 1 0.5\n-inf nan 2 0.5\n";
    // One file name for both, which names the scan.
    std::filesystem::create_directories(dir.file(name));
    write_text(dir.file(name + "/s.ptx"), ptx);
    options.inputs = {dir.file(name + "/s.ptx")};
    options.out_dir = dir.file("ptx-" + name);
    run_scans(options);
  }
  expect_only_more_skipped(dir.file("ptx-clean"), dir.file("ptx-dirty"), 3);
}

}  // namespace
}  // namespace aoscan
