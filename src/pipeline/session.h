/// @file session.h
/// @brief One replay or scan: runs the chain on a source and writes every output to --out.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "capture/source.h"
#include "pipeline/config.h"
#include "pipeline/output_folder.h"
#include "pipeline/pipeline.h"
#include "pipeline/processing.h"
#include "render/view_commands.h"

namespace aoscan {

class ViewStage;

/// The options of one run (`replay`, `scan`), filled by the command line. The session reads its
/// own parts and hands `chain` to the stage chain.
struct RunOptions {
  Config config;
  std::string out_dir = "aoscan-out";
  /// Frames, pacing and corrupt frames (max_frames, realtime, strict). The session sets its
  /// queue_capacity (pipeline.queue_capacity of `config`) and on_progress.
  PipelineOptions chain;
  int threads = 0;  ///< worker threads for data-parallel kernels; 0 = all cores
  bool show_progress = false;  ///< a progress line on stderr (when it is a terminal)
  /// Also write the TSDF as out_dir/volume.vdb (OpenVDB float grids `tsdf` and `weight`). Checked
  /// before the run: an out_dir where volume.vdb cannot be created is a usage error.
  bool save_volume = false;
  /// Also write what is needed to continue later into out_dir/session/ (pipeline/saved_session.h).
  bool save_session = false;
  /// The colour of mesh.ply and mesh.glb multiplied by the AO (for viewers that ignore the AO).
  bool bake_ao = false;
  /// Also write out_dir/points.ply: the fused surface as points (the mesh's vertices with their
  /// normals, AO and colour, no faces) for point-cloud tools.
  bool points = false;
  /// Non-empty: continue the session saved in resume_dir/session/ (read and checked before the
  /// output folder is touched: a session that cannot be continued is an error, exit 2 or 3).
  std::string resume_dir;

  /// Open the live view on its own thread. When no window can be made (no display, GL too old,
  /// shader failure) one warning line is logged and the run goes on headless.
  bool live_view = false;
  std::string snapshot_dir;           ///< non-empty: PNGs of the views (CPU composited) go here
  std::uint64_t snapshot_every = 30;  ///< snapshots of every N-th processed frame, and the last
  /// The user's commands (keys of the live view). Null: the session's own queue, which only the
  /// window feeds. Polled every few milliseconds while the chain runs: reset, pause/resume,
  /// write outputs now, quit (= SIGINT: stop capture, finish the frames in flight, write outputs).
  ViewCommandQueue* commands = nullptr;
  /// A consumer of the view frames besides the window (the service's live stream): called with
  /// the view stage once the chain is built and with null once the chain has stopped. It takes
  /// frames with ViewStage::take_latest() from its own thread; frames are built only as fast as
  /// it takes them (with the window: as fast as the slower of the two). When the call with null
  /// returns, the consumer must hold no frame (they return to the stage's pool).
  std::function<void(ViewStage*)> remote_view;
  /// Told where the export stands (may be null): the signal handling reports it.
  ExportProgress* export_progress = nullptr;
};

/// What the session itself measured and saw (stats.json top-level keys).
struct SessionStats {
  int threads = 0;       ///< the thread budget of the run
  double export_s = 0.0;  ///< writing the outputs (volume.vdb included)
  /// Share of the machine's CPU time the hypervisor took while the chain ran (core/host_cpu.h);
  /// nothing where /proc/stat cannot tell.
  std::optional<double> host_steal_percent;
  std::size_t snapshot_files = 0;  ///< PNGs written by --snapshot
  bool quit_by_user = false;       ///< `q`, Esc or the window closed
  bool live_view_shown = false;    ///< a window was open during the run
  bool live_view_lost = false;     ///< the display went away mid-run; the run went on headless
  /// Its stats.json entries, with "peak_rss_mb": the peak RSS so far (read when called).
  nlohmann::json to_json() const;
};

struct SessionResult {
  ExitCode exit_code = ExitCode::kOk;
  std::string error;  ///< one line when exit_code != kOk
  PipelineResult pipeline;
  ProcessingStats processing;
  MeshStats mesh;
  GridStats grid;
  TsdfStats tsdf;
  std::optional<VolumeStats> volume;  ///< with --save-volume
  SessionStats session;
  /// A recording or synthetic stream stopped (signal, quit) before its end.
  bool interrupted = false;
  std::string stopped_by;  ///< "signal" or "quit" when the run was stopped; else empty
  nlohmann::json calibration;  ///< the intrinsics and depth scale used, with their origin
  nlohmann::json files;           ///< the outputs written, with their sizes (stats.json "files")
  nlohmann::json failed_outputs;  ///< the outputs that could not be written, with their errors

  /// "complete", "interrupted" (exit 0, stopped before the end of a recording) or "failed".
  const char* status() const;
  /// stats.json: every part's entries, "status", "error", "stopped_by", "files" and
  /// "failed_outputs".
  nlohmann::json to_json() const;
};

/// Runs `source` through the chain (plus a "view" stage when a window or snapshots are wanted),
/// then writes trajectory.txt, mesh.ply (and, with save_volume, volume.vdb) and last stats.json
/// into options.out_dir — also when the run stopped on an error, a signal or the user's quit, so
/// nothing already fused is lost. Every file is written atomically; one that cannot be written
/// is listed in stats.json's "failed_outputs", the others are still written, and the run ends
/// with that error (exit code 1). Before the run the output folder is checked and an earlier
/// run's files in it are moved to `previous/` (OutputFolder::prepare). Throws Error only when the
/// output or snapshot folder cannot be created or written.
SessionResult run_session(Source& source, const RunOptions& options,
                          const std::atomic<bool>& stop_requested);

/// Peak resident set size of this process so far (MB).
double peak_rss_mb();

/// Hands the colour choice of `config` (fusion.colour, fusion.colour_every) to `source` before
/// its first read, so that colour a run does not fuse is not decoded either.
void want_configured_colour(Source& source, const Config& config);

}  // namespace aoscan
