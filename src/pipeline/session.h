/// @file session.h
/// @brief One replay or scan: runs the chain on a source and writes every output to --out.
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>
#include <string>

#include "capture/source.h"
#include "pipeline/config.h"
#include "pipeline/pipeline.h"
#include "render/view_commands.h"

namespace aoscan {

struct SessionOptions {
  Config config;
  std::string out_dir = "aoscan-out";
  std::optional<std::size_t> max_frames;
  int threads = 0;  ///< worker threads for data-parallel kernels; 0 = all cores
  bool realtime = false;
  bool strict = false;
  bool show_progress = false;  ///< a progress line on stderr (when it is a terminal)
  /// Also write the TSDF as out_dir/volume.vdb (OpenVDB float grids `tsdf` and `weight`). Checked
  /// before the run: an out_dir where volume.vdb cannot be created is a usage error.
  bool save_volume = false;

  /// Open the live view on its own thread. When no window can be made (no display, GL too old,
  /// shader failure) one warning line is logged and the run goes on headless.
  bool live_view = false;
  std::string snapshot_dir;           ///< non-empty: PNGs of the views (CPU composited) go here
  std::uint64_t snapshot_every = 30;  ///< snapshots of every N-th processed frame, and the last
  /// The user's commands (keys of the live view). Null: the session's own queue, which only the
  /// window feeds. Polled every few milliseconds while the chain runs: reset, pause/resume,
  /// write outputs now, quit (= SIGINT: stop capture, finish the frames in flight, write outputs).
  ViewCommandQueue* commands = nullptr;
};

struct SessionResult {
  ExitCode exit_code = ExitCode::kOk;
  std::string error;  ///< one line when exit_code != kOk
  PipelineResult pipeline;
  double export_s = 0.0;
  std::size_t mesh_vertices = 0;
  std::size_t mesh_faces = 0;
  std::size_t ao_unobserved_vertices = 0;
  std::size_t ao_frames_skipped_live = 0;  ///< tracked frames without SSAO under live load
  /// Share of the machine's CPU time the hypervisor took while the chain ran (core/host_cpu.h);
  /// nothing where /proc/stat cannot tell.
  std::optional<double> host_steal_percent;
  std::size_t grid_cells = 0;
  std::uint64_t grid_points_out_of_range = 0;
  std::size_t grid_bricks = 0;  ///< the MVAO grid's bricks of 4^3 cells
  double grid_memory_mb = 0.0;
  std::size_t tsdf_blocks = 0;
  double tsdf_memory_mb = 0.0;
  bool tsdf_capacity_reached = false;
  bool volume_requested = false;         ///< --save-volume was given
  bool volume_written = false;           ///< --save-volume: volume.vdb was written
  std::size_t volume_bricks = 0;         ///< its 8^3 bricks (OpenVDB leaves) with observed voxels
  std::size_t volume_active_voxels = 0;  ///< its observed voxels
  std::uintmax_t volume_bytes = 0;       ///< its size
  double volume_export_s = 0.0;          ///< time to write it (also part of export_s)
  std::size_t snapshot_files = 0;        ///< PNGs written by --snapshot
  std::size_t model_resets = 0;          ///< `r` commands carried out
  std::size_t outputs_written_on_request = 0;  ///< `s` commands carried out
  bool quit_by_user = false;                   ///< `q`, Esc or the window closed
  bool live_view_shown = false;                ///< a window was open during the run
  bool live_view_lost = false;  ///< the display went away mid-run; the run went on headless
};

/// Runs `source` through the chain (plus a "view" stage when a window or snapshots are wanted),
/// then writes trajectory.txt, mesh.ply and stats.json into options.out_dir — also when the run
/// stopped on an error, a signal or the user's quit, so nothing already fused is lost. With
/// save_volume, volume.vdb is written after mesh.ply; when that fails the run ends with that
/// error (exit code 1) but stats.json is still written. Throws Error only when the output or
/// snapshot folder (or, with save_volume, volume.vdb in it) cannot be created.
SessionResult run_session(Source& source, const SessionOptions& options,
                          const std::atomic<bool>& stop_requested);

/// Peak resident set size of this process so far (MB).
double peak_rss_mb();

}  // namespace aoscan
