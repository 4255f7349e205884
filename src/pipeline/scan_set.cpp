/// @file scan_set.cpp
/// @brief `aoscan scans`: loading scan sets, per-scan SSAO, multi-view integration, outputs.
#include "pipeline/scan_set.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "ao/jump_flood.h"
#include "ao/multiscan.h"
#include "ao/scan_ssao.h"
#include "capture/png_depth.h"
#include "capture/tum_source.h"
#include "core/status.h"
#include "fusion/preprocess/preprocess.h"
#include "io/meshlab_project.h"
#include "io/ply.h"
#include "io/ptx.h"
#include "io/scan_manifest.h"
#include "io/tum.h"
#include "pipeline/session.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

/// Poses of frames whose timestamps are within this of a trajectory's (the TUM tools' 20 ms).
constexpr double kPoseMatchS = 0.02;
/// border_distance(): a Laplacian edge must exceed this share of the pixel's depth.
constexpr float kMinEdgeRatio = 0.01f;

/// A pinhole range map of a raw depth frame: metres, range-clipped and border outliers removed
/// as the real-time path does.
void depth_scan(const DepthFrame& frame, const PreprocessConfig& preprocess, RangeMap& map) {
  Image<float> depth_m;
  preprocess_depth(frame, preprocess, depth_m);
  range_map_from_depth(depth_m, frame.intrinsics, map);
}

/// A scanner-frame point cloud (normals optional) as the equirectangular map of Sec. 7.
void cloud_scan(const std::vector<Eigen::Vector3f>& points,
                const std::vector<Eigen::Vector3f>& normals, RangeMap& map, ScanSummary& summary) {
  map.camera = ScanCamera::equirectangular_for_points(static_cast<long long>(points.size()));
  summary.skipped = rasterize_points(points, normals, map);
}

void load_manifest_scan(const ScanEntry& e, const Config& config, ScanAo& scan,
                        ScanSummary& summary) {
  RangeMap& map = scan.map;
  map.name = e.name;
  summary.source = e.path;
  if (e.kind == ScanEntry::Kind::kDepthImage) {
    DepthFrame frame;
    const Status status = read_depth_png(e.path, frame.depth);
    if (!status.is_ok()) throw input_error(status.message());
    frame.depth_scale = e.depth_scale;
    frame.intrinsics = e.intrinsics;
    frame.intrinsics.width = frame.depth.width();
    frame.intrinsics.height = frame.depth.height();
    frame.origin = e.path;
    depth_scan(frame, config.preprocess, map);
    map.T_world_scanner = e.T_world_scan;
    return;
  }
  const TriangleMesh cloud = read_ply(e.path);
  if (cloud.vertices.empty()) throw input_error(e.path + ": the point cloud is empty");
  std::vector<Eigen::Vector3f> points(cloud.vertices.size());
  const Eigen::Vector3f scanner = e.scanner.cast<float>();
  for (std::size_t i = 0; i < points.size(); ++i) points[i] = cloud.vertices[i] - scanner;
  cloud_scan(points, cloud.normals, map, summary);
  map.T_world_scanner = e.T_world_scan * Pose(Eigen::Matrix3d::Identity(), e.scanner);
}

/// Every scan of a PTX file, named by the file's stem (and its index when there are several).
void load_ptx(const std::string& path, std::vector<ScanAo>& scans,
              std::vector<ScanSummary>& summaries) {
  std::vector<PtxScan> ptx = read_ptx(path);
  const std::string stem = fs::path(path).stem().string();
  for (std::size_t k = 0; k < ptx.size(); ++k) {
    scans.emplace_back();
    summaries.emplace_back();
    RangeMap& map = scans.back().map;
    map.name = ptx.size() == 1 ? stem : stem + "-" + std::to_string(k + 1);
    summaries.back().source = path;
    if (ptx[k].points.empty())
      throw input_error(path + ": scan " + std::to_string(k + 1) + " has no point");
    cloud_scan(ptx[k].points, {}, map, summaries.back());
    map.T_world_scanner = ptx[k].T_world_scanner;
  }
}

/// Every `every`-th frame of a recording folder, posed by `poses_path` or the folder's own
/// trajectory.
void load_recording(const std::string& folder, const ScansOptions& options,
                    std::vector<ScanAo>& scans, ScansResult& result) {
  std::string poses_path = options.poses;
  if (poses_path.empty()) {
    for (const char* name : {"trajectory.txt", "groundtruth.txt"})
      if (fs::is_regular_file(fs::path(folder) / name)) {
        poses_path = (fs::path(folder) / name).string();
        break;
      }
    if (poses_path.empty())
      throw input_error(folder +
                        ": no trajectory.txt or groundtruth.txt to pose its frames "
                        "(give --poses FILE)");
  }
  const std::vector<StampedPose> poses = read_trajectory(poses_path);
  const std::unique_ptr<Source> source = open_tum_folder(folder);
  const std::string stem = fs::path(folder).lexically_normal().filename().string();
  DepthFrame frame;
  for (long long index = 0;; ++index) {
    const Status status = source->read(frame);
    if (status.code() == Status::Code::kEndOfStream) break;
    if (status.code() == Status::Code::kCorruptFrame) {
      spdlog::warn("skipping corrupt frame: {}", status.message());
      ++result.frames_corrupt;
      continue;
    }
    if (!status.is_ok()) throw input_error(status.message());
    if (index % options.every != 0) continue;
    const std::optional<Pose> pose = associate(poses, frame.timestamp_s, kPoseMatchS);
    if (!pose) {
      ++result.frames_without_pose;
      continue;
    }
    ScanAo scan;
    scan.map.name = stem + "-" + std::to_string(frame.sequence);
    depth_scan(frame, options.config.preprocess, scan.map);
    scan.map.T_world_scanner = *pose;
    ScanSummary summary;
    summary.source = frame.origin;
    scans.push_back(std::move(scan));
    result.scans.push_back(summary);
  }
}

std::string extension(const std::string& path) { return fs::path(path).extension().string(); }

bool is_manifest(const std::string& path) {
  const std::string ext = extension(path);
  return ext == ".json" || ext == ".yaml" || ext == ".yml";
}

/// The points of scan `s` in the world frame with `ao` as their quality.
TriangleMesh world_points(const ScanAo& s, const Image<float>& ao) {
  TriangleMesh out;
  const RangeMap& map = s.map;
  const Eigen::Matrix3f R = map.T_world_scanner.rotation().cast<float>();
  const Eigen::Vector3f t = map.T_world_scanner.translation().cast<float>();
  for (int y = 0; y < map.camera.height; ++y)
    for (int x = 0; x < map.camera.width; ++x) {
      if (!map.has_point(x, y)) continue;
      out.vertices.push_back(R * map.points(x, y) + t);
      out.normals.push_back(R * map.normals(x, y));
      out.quality.push_back(ao(x, y));
    }
  return out;
}

void write_stats(const std::string& path, const ScansResult& r, const ScansOptions& options) {
  nlohmann::json j;
  j["scans"] = r.scans.size();
  j["points"] = r.points;
  j["wall_s"] = r.wall_s;
  j["peak_rss_mb"] = peak_rss_mb();
  j["neighbourhood"] = options.neighbourhood;
  j["quality"] = options.ssao_only ? "ssao" : "mvao";
  j["frames_without_pose"] = r.frames_without_pose;
  j["frames_corrupt"] = r.frames_corrupt;
  j["pairs_tested"] = r.pairs_tested;
  j["pairs_skipped"] = r.pairs_skipped;
  j["points_shared"] = r.points_shared;
  j["isolated_scans"] = r.isolated_scans;
  j["d_max_m"] = r.d_max_m;
  j["stages_s"] = {
      {"load", r.load_s}, {"ssao", r.ssao_s}, {"integrate", r.integrate_s}, {"write", r.write_s}};
  nlohmann::json per_scan = nlohmann::json::array();
  for (const ScanSummary& s : r.scans)
    per_scan.push_back({{"name", s.name},
                        {"source", s.source},
                        {"width", s.width},
                        {"height", s.height},
                        {"points", s.points},
                        {"points_skipped", s.skipped}});
  j["per_scan"] = per_scan;
  std::ofstream out(path);
  out << j.dump(2) << "\n";
  if (!out.flush()) throw Error(ExitCode::kFailure, path + ": cannot write");
}

}  // namespace

ScansResult run_scans(const ScansOptions& options) {
  const Clock::time_point start = Clock::now();
  if (options.inputs.empty()) throw usage_error("scans: give at least one INPUT");
  if (options.every < 1) throw usage_error("scans: --every must be at least 1");
  ScansResult result;
  std::vector<ScanAo> scans;
  for (const std::string& input : options.inputs) {
    if (is_manifest(input) || extension(input) == ".mlp") {
      const std::vector<ScanEntry> entries =
          is_manifest(input) ? read_scan_manifest(input) : read_meshlab_project(input);
      for (const ScanEntry& e : entries) {
        scans.emplace_back();
        result.scans.emplace_back();
        load_manifest_scan(e, options.config, scans.back(), result.scans.back());
      }
    } else if (extension(input) == ".ptx") {
      load_ptx(input, scans, result.scans);
    } else if (fs::is_directory(input)) {
      load_recording(input, options, scans, result);
    } else if (!fs::exists(input)) {
      throw input_error(input + ": no such file or folder");
    } else {
      throw input_error(input + ": not a scan manifest (.json, .yaml), a MeshLab project (.mlp), "
                                "a PTX file (.ptx) or a recording folder");
    }
  }
  if (scans.empty()) throw input_error("scans: the inputs hold no scan");
  for (std::size_t i = 0; i < scans.size(); ++i) {
    for (std::size_t k = 0; k < i; ++k)
      if (scans[k].map.name == scans[i].map.name)
        throw input_error(result.scans[i].source + ": a second scan named " + scans[i].map.name);
    ScanSummary& s = result.scans[i];
    s.name = scans[i].map.name;
    s.width = scans[i].map.camera.width;
    s.height = scans[i].map.camera.height;
    s.points = scans[i].map.count_points();
    if (s.points == 0) throw input_error(s.source + ": scan " + s.name + " has no valid point");
    result.points += s.points;
  }
  result.load_s = seconds_since(start);

  const Clock::time_point ssao_start = Clock::now();
  float d_max = 0.0f;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    RangeMap& map = scans[i].map;
    compute_range_map_normals(map);
    compute_scan_ssao(map, options.config.ao, i, scans[i].ssao);
    border_distance(map, kMinEdgeRatio, scans[i].border_px);
    for (int y = 0; y < map.camera.height; ++y)
      for (int x = 0; x < map.camera.width; ++x)
        if (map.has_point(x, y)) d_max = std::max(d_max, map.camera.depth(map.points(x, y)));
  }
  result.ssao_s = seconds_since(ssao_start);
  result.d_max_m = d_max;

  const Clock::time_point integrate_start = Clock::now();
  std::vector<Image<float>> mvao;
  if (!options.ssao_only) {
    MultiScanParams params;
    params.d_min_m = static_cast<float>(options.config.ao.d_min_m);
    params.d_max_m = std::max(d_max, params.d_min_m + 1e-3f);
    params.neighbourhood = options.neighbourhood;
    const MultiScanStats stats = integrate_scans(scans, params, mvao);
    result.pairs_tested = stats.pairs_tested;
    result.pairs_skipped = stats.pairs_skipped;
    result.points_shared = stats.points_shared;
    if (scans.size() > 1)
      for (int i : stats.isolated_scans) result.isolated_scans.push_back(scans[i].map.name);
  }
  result.integrate_s = seconds_since(integrate_start);

  const Clock::time_point write_start = Clock::now();
  const fs::path out(options.out_dir);
  fs::create_directories(out / "scans");
  TriangleMesh all;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const TriangleMesh points = world_points(scans[i], options.ssao_only ? scans[i].ssao : mvao[i]);
    write_ply((out / "scans" / (scans[i].map.name + ".ply")).string(), points);
    all.vertices.insert(all.vertices.end(), points.vertices.begin(), points.vertices.end());
    all.normals.insert(all.normals.end(), points.normals.begin(), points.normals.end());
    all.quality.insert(all.quality.end(), points.quality.begin(), points.quality.end());
  }
  write_ply((out / "points.ply").string(), all);
  for (const std::string& name : result.isolated_scans)
    spdlog::warn("scan {} overlaps no other scan: its points keep their own SSAO", name);
  result.write_s = seconds_since(write_start);
  result.wall_s = seconds_since(start);
  write_stats((out / "stats.json").string(), result, options);
  return result;
}

}  // namespace aoscan
