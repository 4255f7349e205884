/// @file pipeline.cpp
/// @brief Stage threads, queues between them, first-error shutdown.
#include "pipeline/pipeline.h"

#include <time.h>

#include <chrono>
#include <exception>
#include <mutex>
#include <numeric>
#include <thread>

#include "core/log.h"
#include "pipeline/bounded_queue.h"
#include "pipeline/frame_pool.h"

namespace aoscan {
namespace {

using Clock = std::chrono::steady_clock;
using FramePtr = std::shared_ptr<FrameWork>;
using FrameQueue = BoundedQueue<FramePtr>;

/// State shared by the stage threads of one run.
class ChainState {
 public:
  /// Records the first error; later ones are only logged.
  void fail(const Status& status) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (failed_.exchange(true)) {
      spdlog::debug("later error ignored: {}", status.message());
      return;
    }
    first_error_ = status;
  }
  bool failed() const { return failed_.load(); }
  Status first_error() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return first_error_;
  }

  std::atomic<std::size_t> frames_read{0};
  std::atomic<std::size_t> frames_processed{0};
  std::atomic<std::size_t> frames_corrupt{0};
  Clock::time_point start;
  std::atomic<std::int64_t> last_done_ns{0};  ///< since `start`
  std::vector<const FrameQueue*> live_inputs;  ///< the queues that drop (set before the threads)

  std::size_t frames_dropped() const {
    std::size_t n = 0;
    for (const FrameQueue* q : live_inputs) n += q->dropped();
    return n;
  }

 private:
  mutable std::mutex mutex_;
  std::atomic<bool> failed_{false};
  Status first_error_;
};

/// Runs `stage.process` guarded: exceptions become statuses, nothing crosses the thread.
Status run_guarded(const StageDef& stage, FrameWork& frame) {
  try {
    return stage.process(frame);
  } catch (const Error& e) {
    if (e.code() == ExitCode::kBadInput) return Status::bad_input(e.what());
    if (e.code() == ExitCode::kDevice) return Status::device_lost(e.what());
    return Status::internal(stage.name + ": " + e.what());
  } catch (const std::exception& e) {
    return Status::internal(stage.name + ": " + e.what());
  }
}

/// CPU time the calling thread has used so far (seconds).
double thread_cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/// Reads the source until it ends, the stop flag is set, max_frames are read or the chain fails;
/// returns the capture thread's CPU use over that time in percent of one core.
double capture_loop(Source& source, std::size_t stage_count, const PipelineOptions& options,
                    const std::atomic<bool>& stop_requested, ObjectPool<FrameWork>& pool,
                    FrameQueue& out, StageStats& stats, ChainState& state) {
  const double cpu_start_s = thread_cpu_s();
  const auto wall_start = Clock::now();
  std::optional<double> first_timestamp;
  Clock::time_point pace_start;
  while (!stop_requested.load() && !state.failed()) {
    if (options.max_frames && state.frames_read.load() >= *options.max_frames) break;
    FramePtr frame = pool.acquire();
    frame->stage_ms.assign(stage_count + 1, 0.0);  // keeps its capacity: no allocation
    frame->export_mesh.reset();
    frame->export_trajectory.reset();
    frame->raw.arrived_at = {};  // a live source stamps it; otherwise set below
    const auto t0 = Clock::now();
    Status status;
    try {
      status = source.read(frame->raw);
    } catch (const std::exception& e) {
      status = Status::internal(std::string("reading ") + source.name() + ": " + e.what());
    }
    if (status.code() == Status::Code::kEndOfStream) break;
    if (status.code() == Status::Code::kCorruptFrame) {
      if (options.strict) {
        state.fail(Status::bad_input(status.message()));
        break;
      }
      ++state.frames_corrupt;
      spdlog::warn("skipped: {}", status.message());
      continue;
    }
    if (!status.is_ok()) {
      state.fail(status);
      break;
    }
    frame->stage_ms[0] = ms_since(t0);
    stats.add_ms(frame->stage_ms[0]);
    ++state.frames_read;
    if (options.realtime && !source.live()) {
      // Hold each frame until its recorded time, as a camera would deliver it.
      if (!first_timestamp) {
        first_timestamp = frame->raw.timestamp_s;
        pace_start = Clock::now();
      }
      const double offset_s = frame->raw.timestamp_s - *first_timestamp;
      if (offset_s > 0)
        std::this_thread::sleep_until(pace_start + std::chrono::duration_cast<Clock::duration>(
                                                       std::chrono::duration<double>(offset_s)));
    }
    // A recording's frame arrives when it is delivered: now (after the pacing, with --realtime).
    if (frame->raw.arrived_at == Clock::time_point{}) frame->raw.arrived_at = Clock::now();
    frame->frames_dropped_before = state.frames_dropped();
    if (!out.push(std::move(frame))) break;
  }
  out.close();
  const double wall_s = std::chrono::duration<double>(Clock::now() - wall_start).count();
  return wall_s > 0 ? 100.0 * (thread_cpu_s() - cpu_start_s) / wall_s : 0.0;
}

void stage_loop(const StageDef& stage, std::size_t index, FrameQueue& in, FrameQueue* out,
                StageStats& stats, StageStats* latency, StageStats* end_to_end, ChainState& state,
                const PipelineOptions& options, const std::optional<std::size_t>& expected) {
  while (std::optional<FramePtr> item = in.pop()) {
    FrameWork& frame = **item;
    const auto t0 = Clock::now();
    if (latency)
      latency->add_ms(std::chrono::duration<double, std::milli>(t0 - frame.raw.arrived_at).count());
    const Status status = run_guarded(stage, frame);
    const double ms = ms_since(t0);
    stats.add_ms(ms);
    if (index < frame.stage_ms.size()) frame.stage_ms[index] = ms;
    if (status.code() == Status::Code::kCorruptFrame) {
      if (options.strict) {
        state.fail(Status::bad_input(status.message()));
        in.close_and_clear();
        break;
      }
      ++state.frames_corrupt;
      spdlog::warn("skipped: {}", status.message());
      continue;
    }
    if (!status.is_ok()) {
      state.fail(status);
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
    if (end_to_end)
      end_to_end->add_ms(
          std::chrono::duration<double, std::milli>(now - frame.raw.arrived_at).count());
    state.last_done_ns.store(
        std::chrono::duration_cast<std::chrono::nanoseconds>(now - state.start).count());
    if (options.on_progress) {
      options.on_progress(
          {done, expected, std::chrono::duration<double>(now - state.start).count()});
    }
  }
  if (out) out->close();
}

}  // namespace

PipelineResult run_pipeline(Source& source, const std::vector<StageDef>& stages,
                            const PipelineOptions& options,
                            const std::atomic<bool>& stop_requested) {
  ObjectPool<FrameWork> pool;  // declared first: outlives every queue and frame
  ChainState state;
  const bool live = source.live() || options.realtime;

  // queues[0] is the capture edge; queues[i] feeds stages[i]. A live input holds at most one
  // waiting frame, the newest: a frame never waits behind older ones. At the capture edge that
  // keeps the capture latency within about one camera period (plus scheduling delays); in front of
  // the slowest stage it keeps the stages before it, and so the capture edge, from blocking on it.
  std::vector<std::unique_ptr<FrameQueue>> queues;
  for (std::size_t i = 0; i < stages.size(); ++i) {
    const bool live_input = live && (i == 0 || stages[i].takes_newest);
    queues.push_back(std::make_unique<FrameQueue>(
        live_input ? kLiveEdgeCapacity : options.queue_capacity,
        live_input ? OverflowPolicy::kDropOldest : OverflowPolicy::kBlock));
    if (live_input) state.live_inputs.push_back(queues.back().get());
  }

  std::optional<std::size_t> expected = source.size();
  if (options.max_frames)
    expected = expected ? std::min(*expected, *options.max_frames) : *options.max_frames;

  PipelineResult result;
  result.stages.emplace_back("capture");
  for (const StageDef& stage : stages) result.stages.emplace_back(stage.name);

  state.start = Clock::now();
  {
    std::vector<std::thread> threads;
    for (std::size_t i = 0; i < stages.size(); ++i) {
      FrameQueue* out = i + 1 < stages.size() ? queues[i + 1].get() : nullptr;
      threads.emplace_back(stage_loop, std::cref(stages[i]), i + 1, std::ref(*queues[i]), out,
                           std::ref(result.stages[i + 1]),
                           i == 0 ? &result.capture_latency : nullptr,
                           i + 1 == stages.size() ? &result.end_to_end_latency : nullptr,
                           std::ref(state), std::cref(options), std::cref(expected));
    }
    if (stages.empty()) {
      state.fail(Status::internal("pipeline has no stages"));
    } else {
      result.capture_cpu_percent = capture_loop(source, stages.size(), options, stop_requested,
                                                pool, *queues[0], result.stages[0], state);
    }
    for (std::thread& t : threads) t.join();
  }

  result.status = state.failed() ? state.first_error() : Status::ok();
  result.counters.frames_read = state.frames_read.load();
  result.counters.frames_processed = state.frames_processed.load();
  result.counters.frames_corrupt = state.frames_corrupt.load();
  for (const auto& q : queues) result.counters.frames_dropped_at.push_back(q->dropped());
  result.counters.frames_dropped =
      std::accumulate(result.counters.frames_dropped_at.begin(),
                      result.counters.frames_dropped_at.end(), std::size_t{0});
  result.wall_s = static_cast<double>(state.last_done_ns.load()) * 1e-9;
  return result;
}

}  // namespace aoscan
