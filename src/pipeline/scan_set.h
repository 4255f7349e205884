/// @file scan_set.h
/// @brief `aoscan scans`: the offline multi-scan MVAO of a set of registered scans (Sabbadin et
/// al. 2016 Sec. 5): load the scans as range maps, compute each one's SSAO and border distance,
/// integrate them (Eq. 6-12), and write every scan's points with their AO.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <utility>
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
  /// The peak memory the run plans for (bytes): scans beyond it stay in their scratch files.
  std::uint64_t memory_limit = kDefaultMemoryLimit;
  static constexpr std::uint64_t kDefaultMemoryLimit = 2ull << 30;
  /// Where each scan's maps, SSAO and MVAO wait between the stages; empty: `out_dir/scratch`.
  std::string scratch_dir;
  /// Continue the run whose scratch folder this is: scans and integrations already done there
  /// (with the same inputs and settings) are not computed again.
  bool resume = false;
  /// Keep the scratch folder after a complete run (it is removed otherwise).
  bool keep_scratch = false;
  /// Print a progress line with the time left every few seconds.
  bool show_progress = true;
  /// Also write mesh.ply: the scans fused into a TSDF (tsdf.* keys), each vertex with the AO of
  /// the nearest scan point (pipeline/scan_mesh.h).
  bool mesh = false;
  /// Set by a stop request (a signal): the run stops before the next scan of the SSAO or MVAO
  /// stage, keeps its scratch folder (so that --resume continues from there), writes stats.json
  /// with status "interrupted" and returns with ScansResult::interrupted; once the outputs are
  /// being written they are finished. Under several ranks the job is aborted instead (the scratch
  /// folder is kept alike). Null: not stoppable.
  const std::atomic<bool>* stop = nullptr;
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
  bool interrupted = false;  ///< stopped by ScansOptions::stop before the outputs (none written)
  std::vector<ScanSummary> scans;
  long long points = 0;
  long long frames_without_pose = 0;  ///< recording frames skipped for want of a pose
  long long frames_corrupt = 0;       ///< unreadable recording frames skipped (with a warning)
  long long pairs_tested = 0;
  long long pairs_skipped = 0;
  long long points_shared = 0;
  std::vector<std::string> isolated_scans;  ///< scans that overlap no other scan
  double d_max_m = 0.0;                     ///< Eq. 10's d_max: the largest depth of the scans
  long long scans_resumed = 0;        ///< scans whose SSAO an earlier run had computed (--resume)
  long long integrations_resumed = 0;  ///< scans whose MVAO an earlier run had computed
  long long scan_loads = 0;  ///< scans read back from the scratch folder (beyond the budget)
  double memory_before_mb = 0.0;  ///< resident memory before the run, outside the budget
  /// load: reading the inputs; ssao: normals, SSAO and border distances (with load, per scan,
  /// the first stage); integrate: the MVAO; write: the outputs.
  double load_s = 0.0, ssao_s = 0.0, integrate_s = 0.0, write_s = 0.0, wall_s = 0.0;
  /// --mesh: what the mesh took.
  long long mesh_vertices = 0, mesh_faces = 0, mesh_vertices_without_ao = 0;
  int mesh_tsdf_blocks = 0;
  bool mesh_capacity_reached = false;
  double mesh_s = 0.0;
  /// The outputs that could not be written (file name, one-line error); the run's exit code is
  /// then 1.
  std::vector<std::pair<std::string, std::string>> failed_outputs;
};

/// Runs the whole job, out of core: every input is read one scan at a time, and each scan's
/// normals, SSAO and border distance go to its file in the scratch folder (pipeline/scan_store.h);
/// the integration then takes scan after scan with the scans it overlaps, read back within
/// `memory_limit`, and writes each scan's MVAO there too. Then `out_dir/scans/<name>.ply` for each
/// scan and `out_dir/points.ply` (all scans' points in the world frame of the poses, normals,
/// quality = MVAO or, with ssao_only, the scan's own SSAO; binary little-endian PLY as mesh.ply,
/// without faces), each written atomically, then `out_dir/stats.json`. Eq. 10's d_min is
/// ao.d_min_m and its d_max the largest depth in the scans (the paper's advice). The outputs do
/// not depend on the memory limit, the thread count or on resuming. Throws Error: usage_error for
/// bad options (a memory limit too small for the largest scans), input_error naming the file (and
/// frame) for bad input data, with no output written.
ScansResult run_scans(const ScansOptions& options);

class Ranks;

/// The same job shared by the ranks of an MPI job (pipeline/ranks.h), which must all call it
/// with the same options and see the same scratch folder: each rank computes the first stage of
/// its share of the scans (scan k of input unit u goes to rank (u + k) mod N) and the MVAO of every
/// N-th scan, each with its own memory limit; the first rank prepares the folders and writes the
/// outputs, the same bytes as one process. Ranks other than the first return without outputs.
ScansResult run_scans(const ScansOptions& options, Ranks& ranks);

}  // namespace aoscan
