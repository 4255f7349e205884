/// @file bench.cpp
/// @brief aoscan-bench: per-stage milliseconds and frames per second of the pipeline's stages on a
/// recording, either serially on one thread (what each stage costs) or as the threaded chain.
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>

#include "capture/source.h"
#include "core/config.h"
#include "core/log.h"
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
    std::printf("  %-12s %9.3f %9.3f %9.3f %9.3f\n", s.name().c_str(), t.ms_mean, t.ms_p50, t.ms_p95,
                t.ms_max);
  }
  std::printf("  %-12s %9.3f   (sum of stage means: %.1f fps if run back to back)\n", "sum",
              sum_mean, sum_mean > 0 ? 1000.0 / sum_mean : 0.0);
  std::printf("  frames %zu in %.3f s: %.1f fps\n", frames, wall_s,
              wall_s > 0 ? static_cast<double>(frames) / wall_s : 0.0);
}

/// Every stage in turn on one thread, frame by frame.
/// The first `count` processing stages (all when count is 0).
std::vector<StageDef> first_stages(Processing& processing, std::size_t count) {
  std::vector<StageDef> stages = processing.stages();
  if (count > 0 && count < stages.size()) stages.resize(count);
  return stages;
}

int run_serial(const std::string& spec, const Config& config, std::optional<std::size_t> max_frames,
               int repeat, std::size_t stage_count) {
  std::vector<StageStats> stats;
  std::size_t frames = 0, lost = 0;
  double wall_s = 0;
  for (int r = 0; r < repeat; ++r) {
    Processing processing(config);  // every pass starts a new model
    const std::vector<StageDef> stages = first_stages(processing, stage_count);
    if (stats.empty()) {
      stats.emplace_back("capture");
      for (const StageDef& s : stages) stats.emplace_back(s.name);
    }
    FrameWork frame;
    std::unique_ptr<Source> source = open_source(spec);
    const auto start = Clock::now();
    for (std::size_t i = 0; !max_frames || i < *max_frames; ++i) {
      auto t0 = Clock::now();
      const Status read = source->read(frame.raw);
      if (read.code() == Status::Code::kEndOfStream) break;
      if (read.code() == Status::Code::kCorruptFrame) continue;
      if (!read.is_ok()) throw Error(read.exit_code(), read.message());
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
  print_table(spec + " (serial, one thread)", stats, wall_s, frames);
  std::printf("  tracking lost on %zu frames; peak RSS %.0f MB\n", lost, peak_rss_mb());
  return 0;
}

/// The threaded chain as replay runs it.
int run_chain(const std::string& spec, const Config& config, std::optional<std::size_t> max_frames,
              int repeat, std::size_t stage_count) {
  std::vector<StageStats> all;
  double wall_s = 0;
  std::size_t frames = 0, lost = 0;
  for (int r = 0; r < repeat; ++r) {
    std::unique_ptr<Source> source = open_source(spec);
    PipelineOptions options;
    options.max_frames = max_frames;
    options.queue_capacity = static_cast<std::size_t>(config.pipeline.queue_capacity);
    std::atomic<bool> stop{false};
    Processing processing(config);
    PipelineResult result = run_pipeline(*source, first_stages(processing, stage_count), options, stop);
    if (!result.status.is_ok()) throw Error(result.status.exit_code(), result.status.message());
    if (all.empty()) {
      all = std::move(result.stages);
    } else {
      for (std::size_t s = 0; s < all.size(); ++s)
        for (double ms : result.stages[s].samples_ms()) all[s].add_ms(ms);
    }
    wall_s += result.wall_s;
    frames += result.counters.frames_processed;
    lost += processing.frames_tracking_lost();
  }
  print_table(spec + " (threaded chain)", all, wall_s, frames);
  std::printf("  tracking lost on %zu frames; peak RSS %.0f MB\n", lost, peak_rss_mb());
  return 0;
}

int run(int argc, char** argv) {
  CLI::App app{"aoscan-bench: per-stage timings of the aoscan pipeline on a recording"};
  std::string spec;
  std::string config_file;
  std::vector<std::string> sets;
  std::optional<std::size_t> max_frames;
  int threads = 1;
  int repeat = 1;
  bool chain = false;
  app.add_option("SOURCE", spec, "recording folder or synth: scene")->required();
  std::size_t stage_count = 0;
  app.add_option("--frames", max_frames, "at most N frames per pass");
  app.add_option("--stages", stage_count,
                 "run only the first N processing stages (1 = read + decode + border outliers)");
  app.add_option("--repeat", repeat, "passes over the source")->check(CLI::PositiveNumber);
  app.add_option("--threads", threads, "threads for data-parallel kernels")->capture_default_str();
  app.add_option("--config", config_file, "configuration file");
  app.add_option("--set", sets, "KEY=VALUE override");
  app.add_flag("--chain", chain, "run the threaded stage chain instead of one stage at a time");
  CLI11_PARSE(app, argc, argv);
  try {
    configure_logging("error");
    const Config config = load_config(config_file, sets);
    tbb::global_control budget(tbb::global_control::max_allowed_parallelism,
                               static_cast<std::size_t>(threads));
    return chain ? run_chain(spec, config, max_frames, repeat, stage_count)
                 : run_serial(spec, config, max_frames, repeat, stage_count);
  } catch (const Error& e) {
    std::fprintf(stderr, "aoscan-bench: error: %s\n", e.what());
    return static_cast<int>(e.code());
  }
}

}  // namespace
}  // namespace aoscan

int main(int argc, char** argv) { return aoscan::run(argc, argv); }
