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
#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "capture/source.h"
#include "core/status.h"
#include "pipeline/stage_stats.h"

namespace aoscan {

/// A processing step of the chain over frames of type `Frame`. It runs on its own thread;
/// `process` returns ok to pass the frame on, corrupt_frame to skip it (counted), anything else to
/// stop the chain.
///
/// The chain knows nothing of what a frame carries beyond what it fills itself: `Frame` has the
/// members `DepthFrame raw` (read from the source), `std::vector<double> stage_ms` (milliseconds
/// of each step: [0] = capture, [i] = the i-th stage) and `std::size_t frames_dropped_before`
/// (live drops counted when the frame was queued). Frames are pooled and recycled; what the
/// domain needs cleared before a slot is read into again is its `recycle` callback's job.
template <typename Frame>
struct ChainStage {
  std::string name;
  std::function<Status(Frame&)> process;
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
  /// Recorded frames dropped because their timestamp repeats or goes back in time.
  std::size_t frames_out_of_order = 0;
};

/// Progress as seen by the last stage.
struct Progress {
  std::size_t frames_processed = 0;
  std::optional<std::size_t> frames_expected;  ///< when the source knows its length
  double elapsed_s = 0.0;
  std::size_t frames_read = 0;     ///< frames the source delivered so far
  std::size_t frames_dropped = 0;  ///< live drops so far (PipelineCounters::frames_dropped)
};

/// Frames a live input holds (the capture edge and a takes_newest stage's input; drop-oldest).
constexpr std::size_t kLiveEdgeCapacity = 1;

struct PipelineOptions {
  std::optional<std::size_t> max_frames;  ///< stop after this many frames read
  bool realtime = false;  ///< pace replay by the recorded timestamps and drop like a live camera
  bool strict = false;    ///< a corrupt frame ends the run with exit 3 instead of a counted skip
  /// Frames buffered between two stages, and at the capture edge of a replay without
  /// `--realtime` (blocking). A live input always holds kLiveEdgeCapacity.
  std::size_t queue_capacity = 2;
  std::function<void(const Progress&)> on_progress;  ///< called by the last stage, may be empty
};

struct PipelineResult {
  Status status;  ///< ok, or the first error that stopped the chain
  PipelineCounters counters;
  double wall_s = 0.0;             ///< first frame read to last frame through the chain
  std::vector<StageStats> stages;  ///< "capture" first, then each stage in order
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

  /// The counters, fps and timings as stats.json has them (top-level keys).
  nlohmann::json to_json() const;
};

/// Runs `source` through `stages` until the source ends, `max_frames` are read, `stop_requested`
/// becomes true (SIGINT/SIGTERM: frames in flight are finished), or a stage fails. `recycle`
/// (may be empty) readies a pooled frame of an earlier read before the source fills it again.
/// Defined in pipeline/pipeline_impl.h, which the code that picks `Frame` instantiates.
template <typename Frame>
PipelineResult run_chain(Source& source, const std::vector<ChainStage<Frame>>& stages,
                         const PipelineOptions& options, const std::atomic<bool>& stop_requested,
                         const std::function<void(Frame&)>& recycle);

}  // namespace aoscan
