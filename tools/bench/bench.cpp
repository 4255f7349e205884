/// @file bench.cpp
/// @brief aoscan-bench: per-stage milliseconds and frames per second of the pipeline's stages on a
/// recording, either one stage at a time (what each stage costs) or as the threaded chain.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <tbb/global_control.h>
#include <CLI/CLI.hpp>

#include "capture/read_status.h"
#include "capture/source.h"
#include "core/host_cpu.h"
#include "core/log.h"
#include "pipeline/config.h"
#include "pipeline/pipeline.h"
#include "pipeline/processing.h"
#include "pipeline/session.h"
#include "pipeline/stage_stats.h"

namespace aoscan {
namespace {

using Clock = std::chrono::steady_clock;

void print_table(const std::string& title, const std::vector<StageStats>& stages, double wall_s,
                 std::size_t frames) {
  std::printf("%s\n", title.c_str());
  std::printf("  %-12s %9s %9s %9s %9s\n", "stage", "ms_mean", "ms_p50", "ms_p95", "ms_max");
  double sum_mean = 0;
  for (const StageStats& s : stages) {
    const TimingSummary t = s.summary();
    sum_mean += t.ms_mean;
    std::printf("  %-12s %9.3f %9.3f %9.3f %9.3f\n", s.name().c_str(), t.ms_mean, t.ms_p50,
                t.ms_p95, t.ms_max);
  }
  std::printf("  %-12s %9.3f   (sum of stage means: %.1f fps if run back to back)\n", "sum",
              sum_mean, sum_mean > 0 ? 1000.0 / sum_mean : 0.0);
  std::printf("  frames %zu in %.3f s: %.1f fps\n", frames, wall_s,
              wall_s > 0 ? static_cast<double>(frames) / wall_s : 0.0);
}

/// What one benchmark measures.
struct BenchRun {
  std::string spec;  ///< recording folder or synth: scene
  Config config;
  std::optional<std::size_t> max_frames;  ///< at most this many frames per pass
  int repeat = 1;                         ///< passes over the source
  std::size_t stage_count = 0;            ///< the first N processing stages (0 = all)
  int view_every = 0;  ///< > 0: the mvao stage also builds the window's view products every N
  int threads = 1;     ///< threads of the data-parallel kernels
};

/// A new model with the run's view products, and its first `stage_count` stages (all when 0).
std::vector<StageDef> first_stages(Processing& processing, const BenchRun& run) {
  processing.set_view_products(run.view_every > 0, std::max(run.view_every, 1));
  std::vector<StageDef> stages = processing.stages();
  if (run.stage_count > 0 && run.stage_count < stages.size()) stages.resize(run.stage_count);
  return stages;
}

/// Tracking losses (when the track stage ran), the peak RSS and the CPU time the hypervisor took
/// during the run (`host_before`: read when the run started), under the table.
void print_footer(const std::vector<StageStats>& stages, std::size_t frames_lost,
                  const std::optional<HostCpuTimes>& host_before) {
  const bool tracked = std::any_of(stages.begin(), stages.end(),
                                   [](const StageStats& s) { return s.name() == "track"; });
  if (tracked) std::printf("  tracking lost on %zu frames\n", frames_lost);
  std::printf("  peak RSS %.0f MB\n", peak_rss_mb());
  if (const std::optional<double> steal = steal_percent(host_before, read_host_cpu_times()))
    std::printf("  host CPU time stolen by the hypervisor during the run: %.1f %%\n", *steal);
}

/// Every stage in turn, frame by frame (each stage's kernels on run.threads threads).
int run_serial(const BenchRun& run) {
  const std::optional<HostCpuTimes> host_before = read_host_cpu_times();
  const std::string& spec = run.spec;
  std::vector<StageStats> stats;
  std::size_t frames = 0, lost = 0, corrupt = 0;
  double wall_s = 0;
  for (int r = 0; r < run.repeat; ++r) {
    Processing processing(run.config);  // every pass starts a new model
    const std::vector<StageDef> stages = first_stages(processing, run);
    if (stats.empty()) {
      stats.emplace_back("capture");
      for (const StageDef& s : stages) stats.emplace_back(s.name);
    }
    FrameWork frame;
    std::unique_ptr<Source> source = open_source(spec);
    want_configured_colour(*source, run.config);
    const auto start = Clock::now();
    for (std::size_t i = 0; !run.max_frames || i < *run.max_frames; ++i) {
      auto t0 = Clock::now();
      Status stopped_by;
      const ReadStep step =
          handle_read_status(source->read(frame.raw), ReadPolicy{}, corrupt, stopped_by);
      if (step == ReadStep::kSkip) continue;
      if (step == ReadStep::kStop) {
        if (stopped_by.is_ok()) break;
        throw Error(stopped_by.exit_code(), stopped_by.message());
      }
      stats[0].add_ms(ms_since(t0));
      for (std::size_t s = 0; s < stages.size(); ++s) {
        t0 = Clock::now();
        const Status st = stages[s].process(frame);
        stats[s + 1].add_ms(ms_since(t0));
        if (!st.is_ok()) throw Error(st.exit_code(), st.message());
      }
      ++frames;
    }
    wall_s += std::chrono::duration<double>(Clock::now() - start).count();
    lost += processing.frames_tracking_lost();
  }
  print_table(spec + " (stages one at a time, " + std::to_string(run.threads) +
                  (run.threads == 1 ? " thread)" : " threads)"),
              stats, wall_s, frames);
  print_footer(stats, lost, host_before);
  return 0;
}

/// The threaded chain as replay runs it.
int run_chain(const BenchRun& run) {
  const std::optional<HostCpuTimes> host_before = read_host_cpu_times();
  const std::string& spec = run.spec;
  std::vector<StageStats> all;
  double wall_s = 0;
  std::size_t frames = 0, lost = 0;
  for (int r = 0; r < run.repeat; ++r) {
    std::unique_ptr<Source> source = open_source(spec);
    want_configured_colour(*source, run.config);
    PipelineOptions options;
    options.max_frames = run.max_frames;
    options.queue_capacity = static_cast<std::size_t>(run.config.pipeline.queue_capacity);
    std::atomic<bool> stop{false};
    Processing processing(run.config);
    PipelineResult result = run_pipeline(*source, first_stages(processing, run), options, stop);
    if (!result.status.is_ok()) throw Error(result.status.exit_code(), result.status.message());
    if (all.empty()) {
      all = std::move(result.stages);
    } else {
      for (std::size_t s = 0; s < all.size(); ++s) all[s].merge(result.stages[s]);
    }
    wall_s += result.wall_s;
    frames += result.counters.frames_processed;
    lost += processing.frames_tracking_lost();
  }
  print_table(spec + " (threaded chain)", all, wall_s, frames);
  print_footer(all, lost, host_before);
  return 0;
}

int run(int argc, char** argv) {
  CLI::App app{"aoscan-bench: per-stage timings of the aoscan pipeline on a recording"};
  BenchRun bench;
  std::string config_file;
  std::vector<std::string> sets;
  bool chain = false;
  app.add_option("SOURCE", bench.spec, "recording folder or synth: scene")->required();
  app.add_option("--frames", bench.max_frames, "at most N frames per pass");
  app.add_option("--stages", bench.stage_count,
                 "run only the first N processing stages (1 = read + decode + border outliers)");
  app.add_option("--repeat", bench.repeat, "passes over the source")->check(CLI::PositiveNumber);
  app.add_option("--view-every", bench.view_every,
                 "the mvao stage also builds the live view's MVAO image every N frames, as with "
                 "the window open (0 = headless)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--threads", bench.threads, "threads for data-parallel kernels")
      ->capture_default_str()
      ->check(CLI::Range(1, 1024));
  app.add_option("--config", config_file, "configuration file");
  app.add_option("--set", sets, "KEY=VALUE override");
  app.add_flag("--chain", chain, "run the threaded stage chain instead of one stage at a time");
  CLI11_PARSE(app, argc, argv);
  try {
    configure_logging("error");
    bench.config = load_config(config_file, sets);
    tbb::global_control budget(tbb::global_control::max_allowed_parallelism,
                               static_cast<std::size_t>(bench.threads));
    return chain ? run_chain(bench) : run_serial(bench);
  } catch (const Error& e) {
    std::fprintf(stderr, "aoscan-bench: error: %s\n", e.what());
    return static_cast<int>(e.code());
  }
}

}  // namespace
}  // namespace aoscan

int main(int argc, char** argv) {
  return aoscan::run(argc, argv);
}
