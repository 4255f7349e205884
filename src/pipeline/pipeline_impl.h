/// @file pipeline_impl.h
/// @brief The definition of run_chain(): the stage threads and the queues between them. Included
/// only by the code that instantiates the chain for its frame type (explicit instantiation).
#pragma once

#include <algorithm>
#include <chrono>
#include <exception>
#include <memory>
#include <mutex>
#include <numeric>
#include <thread>

#include "capture/read_status.h"
#include "capture/timestamp_order.h"
#include "pipeline/bounded_queue.h"
#include "pipeline/frame_pool.h"
#include "pipeline/pipeline.h"

namespace aoscan {
namespace chain_detail {

using Clock = std::chrono::steady_clock;

/// The skipped-frame warning of the capture edge and the stages.
constexpr const char* kSkipWarning = "skipped: ";

/// State shared by the stage threads of one run (pipeline.cpp).
class ChainState {
 public:
  /// Records the first error; later ones are only logged.
  void fail(const Status& status);
  bool failed() const { return failed_.load(); }
  Status first_error() const;

  std::atomic<std::size_t> frames_read{0};
  std::atomic<std::size_t> frames_processed{0};
  std::atomic<std::size_t> frames_corrupt{0};
  std::atomic<std::size_t> frames_out_of_order{0};
  Clock::time_point start;
  std::atomic<std::int64_t> last_done_ns{0};  ///< since `start`
  /// Counts of the inputs that drop (set before the threads start).
  std::vector<std::function<std::size_t()>> live_inputs_dropped;

  std::size_t frames_dropped() const {
    std::size_t n = 0;
    for (const auto& dropped : live_inputs_dropped) n += dropped();
    return n;
  }

 private:
  mutable std::mutex mutex_;
  std::atomic<bool> failed_{false};
  Status first_error_;
};

/// The status of a stage's exception (`stage`: its name): nothing crosses the thread.
Status status_of_exception(const std::string& stage, const std::exception& e);

/// CPU time the calling thread has used so far (seconds).
double thread_cpu_s();

/// Holds a replayed frame until its recorded time, as a camera would deliver it (`--realtime`).
class ReplayPacer {
 public:
  /// Waits until `timestamp_s` is due; returns early (within kStopPollInterval) when `stop` is
  /// set, so that a long gap in a recording never delays a stop.
  void wait_for(double timestamp_s, const std::atomic<bool>& stop);

 private:
  std::optional<double> first_timestamp_;
  Clock::time_point start_;
};

template <typename Frame>
using FramePtr = std::shared_ptr<Frame>;
template <typename Frame>
using FrameQueue = BoundedQueue<FramePtr<Frame>>;

/// Runs `stage.process` guarded: exceptions become statuses.
template <typename Frame>
Status run_guarded(const ChainStage<Frame>& stage, Frame& frame) {
  try {
    return stage.process(frame);
  } catch (const std::exception& e) {
    return status_of_exception(stage.name, e);
  }
}

/// Reads the source until it ends, the stop flag is set, max_frames are read or the chain fails;
/// returns the capture thread's CPU use over that time in percent of one core.
template <typename Frame>
double capture_loop(Source& source, std::size_t stage_count, const PipelineOptions& options,
                    const std::function<void(Frame&)>& recycle,
                    const std::atomic<bool>& stop_requested, ObjectPool<Frame>& pool,
                    FrameQueue<Frame>& out, StageStats& stats, ChainState& state) {
  const double cpu_start_s = thread_cpu_s();
  const auto wall_start = Clock::now();
  const ReadPolicy policy{options.strict, kSkipWarning};
  ReplayPacer pacer;
  source.watch_stop(&stop_requested);  // a camera's wait for its next frame ends on a stop
  TimestampOrder order;
  while (!stop_requested.load() && !state.failed()) {
    if (options.max_frames && state.frames_read.load() >= *options.max_frames) break;
    FramePtr<Frame> frame = pool.acquire();
    frame->stage_ms.assign(stage_count + 1, 0.0);  // keeps its capacity: no allocation
    if (recycle) recycle(*frame);
    frame->raw.arrived_at = {};  // a live source stamps it; otherwise set below
    const auto t0 = Clock::now();
    Status stopped_by;
    const ReadStep step =
        handle_read_status(source.read(frame->raw), policy, state.frames_corrupt, stopped_by);
    if (step == ReadStep::kSkip) continue;
    if (step == ReadStep::kStop) {
      if (!stopped_by.is_ok()) state.fail(stopped_by);
      break;
    }
    if (const std::optional<std::string> why = order.out_of_order(source, frame->raw)) {
      if (options.strict) {
        state.fail(Status::bad_input(*why));
        break;
      }
      if (state.frames_out_of_order++ == 0) warn_first_out_of_order(*why);
      continue;
    }
    frame->stage_ms[0] = ms_since(t0);
    stats.add_ms(frame->stage_ms[0]);
    ++state.frames_read;
    if (options.realtime && !source.live()) pacer.wait_for(frame->raw.timestamp_s, stop_requested);
    // A recording's frame arrives when it is delivered: now (after the pacing, with --realtime).
    if (frame->raw.arrived_at == Clock::time_point{}) frame->raw.arrived_at = Clock::now();
    frame->frames_dropped_before = state.frames_dropped();
    if (!out.push(std::move(frame))) break;
  }
  out.close();
  const double wall_s = std::chrono::duration<double>(Clock::now() - wall_start).count();
  return wall_s > 0 ? 100.0 * (thread_cpu_s() - cpu_start_s) / wall_s : 0.0;
}

/// Where a stage thread records its timings.
struct StageTimings {
  StageStats* stage = nullptr;
  StageStats* capture_latency = nullptr;  ///< the first stage only
  StageStats* end_to_end = nullptr;       ///< the last stage only
};

template <typename Frame>
void stage_loop(const ChainStage<Frame>& stage, std::size_t index, FrameQueue<Frame>& in,
                FrameQueue<Frame>* out, StageTimings timings, ChainState& state,
                const PipelineOptions& options, const std::optional<std::size_t>& expected) {
  const ReadPolicy policy{options.strict, kSkipWarning};
  while (std::optional<FramePtr<Frame>> item = in.pop()) {
    Frame& frame = **item;
    const auto t0 = Clock::now();
    if (timings.capture_latency)
      timings.capture_latency->add_ms(
          std::chrono::duration<double, std::milli>(t0 - frame.raw.arrived_at).count());
    const Status status = run_guarded(stage, frame);
    const double ms = ms_since(t0);
    timings.stage->add_ms(ms);
    if (index < frame.stage_ms.size()) frame.stage_ms[index] = ms;
    Status stopped_by;
    const ReadStep step = handle_read_status(status, policy, state.frames_corrupt, stopped_by);
    if (step == ReadStep::kSkip) continue;
    if (step == ReadStep::kStop) {
      if (!stopped_by.is_ok()) state.fail(stopped_by);
      in.close_and_clear();  // upstream's next push fails, so it stops producing
      break;
    }
    if (out) {
      if (!out->push(std::move(*item))) {
        in.close_and_clear();
        break;
      }
      continue;
    }
    // Last stage: the frame is done.
    const std::size_t done = ++state.frames_processed;
    const auto now = Clock::now();
    if (timings.end_to_end)
      timings.end_to_end->add_ms(
          std::chrono::duration<double, std::milli>(now - frame.raw.arrived_at).count());
    state.last_done_ns.store(
        std::chrono::duration_cast<std::chrono::nanoseconds>(now - state.start).count());
    if (options.on_progress) {
      options.on_progress(
          {done, expected, std::chrono::duration<double>(now - state.start).count(),
           state.frames_read.load(), state.frames_dropped()});
    }
  }
  if (out) out->close();
}

/// Fills the counters and the wall time of `result` once every thread has joined.
void finish_result(const ChainState& state, std::vector<std::size_t> dropped_at,
                   PipelineResult& result);

}  // namespace chain_detail

template <typename Frame>
PipelineResult run_chain(Source& source, const std::vector<ChainStage<Frame>>& stages,
                         const PipelineOptions& options, const std::atomic<bool>& stop_requested,
                         const std::function<void(Frame&)>& recycle) {
  using namespace chain_detail;
  ObjectPool<Frame> pool;  // declared first: outlives every queue and frame
  ChainState state;
  const bool live = source.live() || options.realtime;

  // queues[0] is the capture edge; queues[i] feeds stages[i]. A live input holds at most one
  // waiting frame, the newest: a frame never waits behind older ones. At the capture edge that
  // keeps the capture latency within about one camera period (plus scheduling delays); in front of
  // the slowest stage it keeps the stages before it, and so the capture edge, from blocking on it.
  std::vector<std::unique_ptr<FrameQueue<Frame>>> queues;
  for (std::size_t i = 0; i < stages.size(); ++i) {
    const bool live_input = live && (i == 0 || stages[i].takes_newest);
    queues.push_back(std::make_unique<FrameQueue<Frame>>(
        live_input ? kLiveEdgeCapacity : options.queue_capacity,
        live_input ? OverflowPolicy::kDropOldest : OverflowPolicy::kBlock));
    if (live_input) {
      const FrameQueue<Frame>* queue = queues.back().get();
      state.live_inputs_dropped.push_back([queue] { return queue->dropped(); });
    }
  }

  std::optional<std::size_t> expected = source.size();
  if (options.max_frames)
    expected = expected ? std::min(*expected, *options.max_frames) : *options.max_frames;

  PipelineResult result;
  result.stages.emplace_back("capture");
  for (const ChainStage<Frame>& stage : stages) result.stages.emplace_back(stage.name);

  state.start = Clock::now();
  {
    std::vector<std::thread> threads;
    for (std::size_t i = 0; i < stages.size(); ++i) {
      FrameQueue<Frame>* out = i + 1 < stages.size() ? queues[i + 1].get() : nullptr;
      const StageTimings timings{&result.stages[i + 1],
                                 i == 0 ? &result.capture_latency : nullptr,
                                 i + 1 == stages.size() ? &result.end_to_end_latency : nullptr};
      threads.emplace_back(stage_loop<Frame>, std::cref(stages[i]), i + 1, std::ref(*queues[i]),
                           out, timings, std::ref(state), std::cref(options), std::cref(expected));
    }
    if (stages.empty()) {
      state.fail(Status::internal("pipeline has no stages"));
    } else {
      result.capture_cpu_percent =
          capture_loop<Frame>(source, stages.size(), options, recycle, stop_requested, pool,
                              *queues[0], result.stages[0], state);
    }
    for (std::thread& t : threads) t.join();
  }

  std::vector<std::size_t> dropped_at;
  for (const auto& q : queues) dropped_at.push_back(q->dropped());
  finish_result(state, std::move(dropped_at), result);
  return result;
}

}  // namespace aoscan
