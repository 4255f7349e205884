/// @file scan_set.h
/// @brief `aoscan scans`: the offline multi-scan MVAO of a set of registered scans (Sabbadin et
/// al. 2016 Sec. 5): load the scans as range maps, compute each one's SSAO and border distance,
/// integrate them (Eq. 6-12), and write every scan's points with their AO.
#pragma once

#include <string>
#include <vector>

#include "pipeline/config.h"

namespace aoscan {

/// What `aoscan scans` was asked to do.
struct ScansOptions {
  /// Scan manifests (`*.json`, `*.yaml`, `*.yml`; io/scan_manifest.h), MeshLab projects
  /// (`*.mlp`), PTX files (`*.ptx`, every scan in them) and recording folders (TUM layout: every
  /// `every`-th frame is a pinhole scan). Point clouds become the equirectangular map of Sec. 7
  /// around their scanner.
  std::vector<std::string> inputs;
  std::string out_dir = "aoscan-out";
  int every = 10;
  /// A TUM trajectory posing the recording folders' frames; empty: each folder's trajectory.txt,
  /// else its groundtruth.txt.
  std::string poses;
  int neighbourhood = 1;   ///< N of the N x N samples (1, 3, 5, 7, 9)
  bool ssao_only = false;  ///< write each scan's own SSAO instead of the MVAO
  Config config;           ///< the ao.* keys (and preprocess.* for depth images)
};

/// One scan of the set, as loaded.
struct ScanSummary {
  std::string name;
  std::string source;  ///< the file or frame it came from
  int width = 0;
  int height = 0;
  long long points = 0;
  long long skipped = 0;  ///< point-cloud points that did not fit the map (not finite, ...)
};

/// What run_scans() did; written as stats.json.
struct ScansResult {
  std::vector<ScanSummary> scans;
  long long points = 0;
  long long frames_without_pose = 0;  ///< recording frames skipped for want of a pose
  long long frames_corrupt = 0;       ///< unreadable recording frames skipped (with a warning)
  long long pairs_tested = 0;
  long long pairs_skipped = 0;
  long long points_shared = 0;
  std::vector<std::string> isolated_scans;  ///< scans that overlap no other scan
  double d_max_m = 0.0;                     ///< Eq. 10's d_max: the largest depth of the scans
  double load_s = 0.0, ssao_s = 0.0, integrate_s = 0.0, write_s = 0.0, wall_s = 0.0;
};

/// Runs the whole job: loads every input, writes `out_dir/scans/<name>.ply` for each scan and
/// `out_dir/points.ply` (all scans' points in the world frame of the poses, normals, quality =
/// MVAO or, with ssao_only, the scan's own SSAO; binary little-endian PLY as mesh.ply, without
/// faces), then `out_dir/stats.json`. Eq. 10's d_min is ao.d_min_m and its d_max the largest depth
/// in the scans (the paper's advice). Throws Error: usage_error for bad options, input_error
/// naming the file (and frame) for bad input data, with nothing written.
ScansResult run_scans(const ScansOptions& options);

}  // namespace aoscan
