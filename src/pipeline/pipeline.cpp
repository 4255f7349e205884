/// @file pipeline.cpp
/// @brief The chain's parts that do not depend on the frame type: first-error shutdown, replay
/// pacing, the run's counters and their stats.json entries.
#include "pipeline/pipeline.h"

#include <time.h>

#include <nlohmann/json.hpp>

#include "core/log.h"
#include "pipeline/pipeline_impl.h"

namespace aoscan {
namespace chain_detail {

void ChainState::fail(const Status& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (failed_.exchange(true)) {
    spdlog::debug("later error ignored: {}", status.message());
    return;
  }
  first_error_ = status;
}

Status ChainState::first_error() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return first_error_;
}

Status status_of_exception(const std::string& stage, const std::exception& e) {
  if (const auto* error = dynamic_cast<const Error*>(&e)) {
    if (error->code() == ExitCode::kBadInput) return Status::bad_input(e.what());
    if (error->code() == ExitCode::kDevice) return Status::device_lost(e.what());
  }
  return Status::internal(stage + ": " + e.what());
}

double thread_cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

void ReplayPacer::wait_for(double timestamp_s, const std::atomic<bool>& stop) {
  if (!first_timestamp_) {
    first_timestamp_ = timestamp_s;
    start_ = Clock::now();
  }
  const double offset_s = timestamp_s - *first_timestamp_;
  if (!(offset_s > 0)) return;
  // Beyond about 292 years the duration cast would overflow: such a gap is waited out until stop.
  const double capped_s = std::min(offset_s, 1e9);
  const Clock::time_point due =
      start_ + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(capped_s));
  while (!stop.load()) {
    const Clock::time_point now = Clock::now();
    if (now >= due) return;
    std::this_thread::sleep_for(std::min<Clock::duration>(due - now, kStopPollInterval));
  }
}

void finish_result(const ChainState& state, std::vector<std::size_t> dropped_at,
                   PipelineResult& result) {
  result.status = state.failed() ? state.first_error() : Status::ok();
  result.counters.frames_read = state.frames_read.load();
  result.counters.frames_processed = state.frames_processed.load();
  result.counters.frames_corrupt = state.frames_corrupt.load();
  result.counters.frames_out_of_order = state.frames_out_of_order.load();
  if (result.counters.frames_out_of_order > 1)
    spdlog::warn("{} frames dropped: their timestamps repeat or go back in time",
                 result.counters.frames_out_of_order);
  result.counters.frames_dropped_at = std::move(dropped_at);
  result.counters.frames_dropped =
      std::accumulate(result.counters.frames_dropped_at.begin(),
                      result.counters.frames_dropped_at.end(), std::size_t{0});
  result.wall_s = static_cast<double>(state.last_done_ns.load()) * 1e-9;
}

}  // namespace chain_detail

nlohmann::json PipelineResult::to_json() const {
  const PipelineCounters& c = counters;
  nlohmann::json j;
  j["frames_read"] = c.frames_read;
  j["frames_processed"] = c.frames_processed;
  j["frames_dropped"] = c.frames_dropped;
  // Where the live drops happened: at the input of each stage (the capture edge is the first's).
  nlohmann::json dropped_at = nlohmann::json::object();
  for (std::size_t i = 0; i < c.frames_dropped_at.size() && i + 1 < stages.size(); ++i)
    dropped_at[stages[i + 1].name()] = c.frames_dropped_at[i];
  j["frames_dropped_at"] = dropped_at;
  j["frames_corrupt"] = c.frames_corrupt;
  j["frames_out_of_order"] = c.frames_out_of_order;
  j["wall_s"] = wall_s;
  j["fps"] = wall_s > 0 ? static_cast<double>(c.frames_processed) / wall_s : 0.0;
  nlohmann::json stage_times = nlohmann::json::object();
  for (const StageStats& s : stages) stage_times[s.name()] = s.summary().to_json("ms_");
  j["stages"] = stage_times;
  j["capture_latency_ms"] = capture_latency.summary().to_json("");
  j["end_to_end_latency_ms"] = end_to_end_latency.summary().to_json("");
  j["capture_cpu_percent"] = capture_cpu_percent;
  return j;
}

}  // namespace aoscan
