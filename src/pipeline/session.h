/// @file session.h
/// @brief One replay or scan: runs the chain on a source and writes every output to --out.
#pragma once

#include <atomic>
#include <optional>
#include <string>

#include "capture/source.h"
#include "core/config.h"
#include "pipeline/pipeline.h"

namespace aoscan {

struct SessionOptions {
  Config config;
  std::string out_dir = "aoscan-out";
  std::optional<std::size_t> max_frames;
  int threads = 0;  ///< worker threads for data-parallel kernels; 0 = all cores
  bool realtime = false;
  bool strict = false;
  bool show_progress = false;  ///< a progress line on stderr (when it is a terminal)
};

struct SessionResult {
  ExitCode exit_code = ExitCode::kOk;
  std::string error;  ///< one line when exit_code != kOk
  PipelineResult pipeline;
  double export_s = 0.0;
  std::size_t mesh_vertices = 0;
  std::size_t mesh_faces = 0;
  std::size_t ao_unobserved_vertices = 0;
  std::size_t grid_cells = 0;
  std::uint64_t grid_points_out_of_range = 0;
  std::size_t tsdf_blocks = 0;
  double tsdf_memory_mb = 0.0;
  bool tsdf_capacity_reached = false;
};

/// Runs `source` through the chain, then writes trajectory.txt, mesh.ply and stats.json into
/// options.out_dir — also when the run stopped on an error or a signal, so nothing
/// already fused is lost. Throws Error only when the output folder cannot be created.
SessionResult run_session(Source& source, const SessionOptions& options,
                          const std::atomic<bool>& stop_requested);

/// Peak resident set size of this process so far (MB).
double peak_rss_mb();

}  // namespace aoscan
