/// @file pipeline.h
/// @brief The stage thread chain: capture → preprocess → … with bounded queues between stages.
///
/// Replay blocks at every queue (every frame once, in order, deterministic). Live sources and
/// `--realtime` replay keep only the newest waiting frame at the capture edge and at the input of
/// a stage that takes the newest frame (the track stage): the stages in front of it keep up with
/// the camera, so the capture edge never waits behind them. The first error in any stage stops
/// the whole chain: upstream stops producing, downstream finishes what it has.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "capture/source.h"
#include "core/depth_frame.h"
#include "core/image.h"
#include "core/mesh.h"
#include "core/status.h"
#include "fusion/preprocess/preprocess.h"
#include "fusion/reconstruction.h"
#include "io/tum.h"
#include "pipeline/config.h"
#include "pipeline/stage_stats.h"

namespace aoscan {

/// Everything one frame accumulates on its way through the chain; recycled between frames.
struct FrameWork {
  DepthFrame raw;         ///< as read from the source
  PreprocessedFrame pre;  ///< metres, outliers removed, filtered, tracking pyramid
  FusionStep fusion;      ///< tracking status and pose
  std::shared_ptr<const RaycastResult>
      raycast;               ///< the model seen from this frame's pose, when tracked
  PointMaps raw_maps;        ///< camera-frame maps of pre.depth_m (only with ao.input=raw)
  Image<float> ssao;         ///< screen-space AO of this view, 1 = open (empty when not tracked)
  Image<float> ssao_weight;  ///< per-pixel view weight w_d * w_n

  /// Milliseconds this frame spent in each step: [0] = capture (read), [i] = the i-th StageDef,
  /// filled as it passes (for the HUD; StageStats keep the run's statistics).
  std::vector<double> stage_ms;
  std::size_t frames_dropped_before = 0;  ///< live drops counted when this frame was queued
  bool integration_paused = false;  ///< the track stage tracked this frame without integrating it
  bool model_reset = false;         ///< the track stage started a new model with this frame
  /// Only while a view consumer exists: AO from the MVAO grid at each raycast pixel's world point,
  /// in [0, 1], NaN = unobserved cell or no surface (filled by the mvao stage after integrating).
  Image<float> mvao;
  /// The mvao stage built this frame's view products (mvao): the view stage shows only such frames.
  bool view_products = false;
  /// `s` (write outputs now): the surface extracted by the track stage after this frame (world
  /// frame, no AO yet) and the trajectory so far; the mvao stage adds the AO and writes both.
  std::shared_ptr<TriangleMesh> export_mesh;
  std::shared_ptr<const std::vector<StampedPose>> export_trajectory;
};

/// A processing step of the chain. It runs on its own thread; `process` returns ok to pass the
/// frame on, corrupt_frame to skip it (counted), anything else to stop the chain.
struct StageDef {
  std::string name;
  std::function<Status(FrameWork&)> process;
  /// Live (live source or `--realtime`): the stage's input holds one frame, and a newer frame
  /// replaces a waiting one (counted in frames_dropped). For the stage that cannot keep up with
  /// the camera: frames are dropped in front of it rather than at the capture edge, so the faster
  /// stages before it go on taking every frame as it arrives. The first stage's input, the capture
  /// edge, always works this way in live mode.
  bool takes_newest = false;
};

/// Counts over one run.
struct PipelineCounters {
  std::size_t frames_read = 0;       ///< frames the source delivered
  std::size_t frames_processed = 0;  ///< frames that went through every stage
  std::size_t frames_dropped = 0;    ///< dropped live: at the capture edge and takes_newest inputs
  /// Per stage (in chain order): frames dropped at its input; only live inputs drop.
  std::vector<std::size_t> frames_dropped_at;
  std::size_t frames_corrupt = 0;    ///< unreadable frames skipped
  std::size_t frames_tracking_lost = 0;
};

/// Progress as seen by the last stage.
struct Progress {
  std::size_t frames_processed = 0;
  std::optional<std::size_t> frames_expected;  ///< when the source knows its length
  double elapsed_s = 0.0;
};

/// Frames a live input holds (the capture edge and a takes_newest stage's input; drop-oldest).
constexpr std::size_t kLiveEdgeCapacity = 1;

struct PipelineOptions {
  std::optional<std::size_t> max_frames;  ///< stop after this many frames read
  bool realtime = false;  ///< pace replay by the recorded timestamps and drop like a live camera
  bool strict = false;    ///< a corrupt frame ends the run with exit 3 instead of a counted skip
  /// Frames buffered between two stages, and at the capture edge of a replay without
  /// `--realtime` (blocking). A live input always holds kLiveEdgeCapacity.
  std::size_t queue_capacity = 4;
  std::function<void(const Progress&)> on_progress;  ///< called by the last stage, may be empty
};

struct PipelineResult {
  Status status;  ///< ok, or the first error that stopped the chain
  PipelineCounters counters;
  double wall_s = 0.0;             ///< first frame read to last frame through the chain
  std::vector<StageStats> stages;  ///< "capture" first, then each StageDef in order
  /// Capture-to-pipeline latency of every frame the first stage took: from the frame's arrival
  /// (DepthFrame::arrived_at: a live camera's driver callback; for recordings the end of read(),
  /// with --realtime the paced delivery time) to the first stage taking it from the capture edge.
  /// Includes the rest of read(), the hand-over and any wait in the queue; dropped frames have
  /// none.
  StageStats capture_latency{"capture_latency"};
  /// From the frame's arrival (as above) to the last stage finishing it, for every processed
  /// frame: the age of the newest result, which grows with the frames queued between stages.
  StageStats end_to_end_latency{"end_to_end_latency"};
  /// CPU time of the capture thread (reading, decoding, pacing excluded as it sleeps) over the
  /// run's wall time, in percent of one core.
  double capture_cpu_percent = 0.0;
};

/// Runs `source` through `stages` until the source ends, `max_frames` are read, `stop_requested`
/// becomes true (SIGINT/SIGTERM: frames in flight are finished), or a stage fails.
PipelineResult run_pipeline(Source& source, const std::vector<StageDef>& stages,
                            const PipelineOptions& options,
                            const std::atomic<bool>& stop_requested);

}  // namespace aoscan
