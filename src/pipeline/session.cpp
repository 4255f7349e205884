/// @file session.cpp
/// @brief Session: thread budget, the chain, progress line, outputs.
#include "pipeline/session.h"

#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>

#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "core/log.h"
#include "pipeline/processing.h"

namespace aoscan {
namespace {

using Clock = std::chrono::steady_clock;

/// Prints "frames done/total, fps, time left" on one rewritten stderr line, at most 5 times a second.
class ProgressLine {
 public:
  void update(const Progress& p) {
    const auto now = Clock::now();
    if (printed_ && now - last_ < std::chrono::milliseconds(200)) return;
    last_ = now;
    printed_ = true;
    const double fps = p.elapsed_s > 0 ? static_cast<double>(p.frames_processed) / p.elapsed_s : 0;
    if (p.frames_expected && fps > 0) {
      const double left_s =
          static_cast<double>(*p.frames_expected - std::min(*p.frames_expected, p.frames_processed)) /
          fps;
      std::fprintf(stderr, "\r  %zu/%zu frames  %.1f fps  %.0f s left   ", p.frames_processed,
                   *p.frames_expected, fps, left_s);
    } else {
      std::fprintf(stderr, "\r  %zu frames  %.1f fps   ", p.frames_processed, fps);
    }
    std::fflush(stderr);
  }
  void finish() {
    if (printed_) std::fputc('\n', stderr);
  }

 private:
  bool printed_ = false;
  Clock::time_point last_;
};

void write_stats_json(const std::string& path, const SessionResult& r, int threads) {
  nlohmann::json j;
  const PipelineCounters& c = r.pipeline.counters;
  j["frames_read"] = c.frames_read;
  j["frames_processed"] = c.frames_processed;
  j["frames_dropped"] = c.frames_dropped;
  j["frames_corrupt"] = c.frames_corrupt;
  j["frames_tracking_lost"] = c.frames_tracking_lost;
  j["wall_s"] = r.pipeline.wall_s;
  j["fps"] = r.pipeline.wall_s > 0 ? static_cast<double>(c.frames_processed) / r.pipeline.wall_s : 0.0;
  j["export_s"] = r.export_s;
  j["threads"] = threads;
  j["peak_rss_mb"] = peak_rss_mb();
  nlohmann::json stages = nlohmann::json::object();
  for (const StageStats& s : r.pipeline.stages) {
    const TimingSummary t = s.summary();
    stages[s.name()] = {{"ms_mean", t.ms_mean}, {"ms_p50", t.ms_p50}, {"ms_p95", t.ms_p95},
                        {"ms_max", t.ms_max}};
  }
  j["stages"] = stages;
  j["mesh"] = {{"vertices", r.mesh_vertices},
               {"faces", r.mesh_faces},
               {"ao_unobserved_vertices", r.ao_unobserved_vertices}};
  j["mvao_grid"] = {{"cells", r.grid_cells}, {"points_out_of_range", r.grid_points_out_of_range}};
  j["tsdf"] = {{"blocks", r.tsdf_blocks},
               {"memory_mb", r.tsdf_memory_mb},
               {"capacity_reached", r.tsdf_capacity_reached}};
  j["status"] = r.exit_code == ExitCode::kOk ? "ok" : r.error;
  std::ofstream out(path);
  out << j.dump(2) << "\n";
  if (!out) throw Error(ExitCode::kFailure, path + ": cannot write");
}

}  // namespace

double peak_rss_mb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

SessionResult run_session(Source& source, const SessionOptions& options,
                          const std::atomic<bool>& stop_requested) {
  std::error_code ec;
  std::filesystem::create_directories(options.out_dir, ec);
  if (ec || !std::filesystem::is_directory(options.out_dir))
    throw usage_error("--out " + options.out_dir + ": cannot create folder: " + ec.message());

  const int threads = options.threads > 0
                          ? options.threads
                          : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  tbb::global_control thread_budget(tbb::global_control::max_allowed_parallelism,
                                    static_cast<std::size_t>(threads));

  PipelineOptions popts;
  popts.max_frames = options.max_frames;
  popts.realtime = options.realtime;
  popts.strict = options.strict;
  popts.queue_capacity = static_cast<std::size_t>(options.config.pipeline.queue_capacity);
  ProgressLine progress;
  if (options.show_progress && isatty(STDERR_FILENO))
    popts.on_progress = [&progress](const Progress& p) { progress.update(p); };

  SessionResult result;
  Processing processing(options.config);
  result.pipeline = run_pipeline(source, processing.stages(), popts, stop_requested);
  result.pipeline.counters.frames_tracking_lost = processing.frames_tracking_lost();
  progress.finish();

  const Status& status = result.pipeline.status;
  result.exit_code = status.exit_code();
  if (result.exit_code != ExitCode::kOk) {
    result.error = status.message();
  } else if (result.pipeline.counters.frames_processed == 0 && !stop_requested.load()) {
    result.exit_code = ExitCode::kBadInput;
    result.error = source.name() + ": no usable frame (" +
                   std::to_string(result.pipeline.counters.frames_corrupt) + " unreadable)";
  }

  const auto export_start = Clock::now();
  const Processing::ExportStats exported = processing.write_outputs(options.out_dir);
  result.export_s = std::chrono::duration<double>(Clock::now() - export_start).count();
  result.mesh_vertices = exported.mesh_vertices;
  result.mesh_faces = exported.mesh_faces;
  result.ao_unobserved_vertices = exported.ao_unobserved_vertices;
  result.grid_cells = processing.grid().cell_count();
  result.grid_points_out_of_range = processing.grid().points_out_of_range();
  if (result.grid_points_out_of_range > 0)
    spdlog::warn("{} points lay outside the MVAO grid's range and got no AO",
                 result.grid_points_out_of_range);
  const TsdfVolume& volume = processing.reconstruction().volume();
  result.tsdf_blocks = static_cast<std::size_t>(volume.block_count());
  result.tsdf_memory_mb = static_cast<double>(volume.memory_bytes()) / (1024.0 * 1024.0);
  result.tsdf_capacity_reached = volume.capacity_reached();
  if (result.tsdf_capacity_reached)
    spdlog::warn("the TSDF reached its capacity of {} blocks (fusion.max_blocks): surface beyond it "
                 "was not fused", volume.max_blocks());
  write_stats_json((std::filesystem::path(options.out_dir) / "stats.json").string(), result,
                   threads);
  spdlog::info("{} frames processed in {:.2f} s", result.pipeline.counters.frames_processed,
               result.pipeline.wall_s);
  return result;
}

}  // namespace aoscan
