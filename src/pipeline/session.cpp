/// @file session.cpp
/// @brief Session: thread budget, the chain, progress line, outputs.
#include "pipeline/session.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <thread>

#include <tbb/global_control.h>
#include <nlohmann/json.hpp>

#include "core/host_cpu.h"
#include "core/log.h"
#include "pipeline/processing.h"
#include "pipeline/view_stage.h"
#include "render/live_view.h"

namespace aoscan {
namespace {

using Clock = std::chrono::steady_clock;

/// Prints "frames done/total, fps, time left" on one rewritten stderr line, at most 5 times a
/// second.
class ProgressLine {
 public:
  void update(const Progress& p) {
    const auto now = Clock::now();
    if (printed_ && now - last_ < std::chrono::milliseconds(200)) return;
    last_ = now;
    printed_ = true;
    const double fps = p.elapsed_s > 0 ? static_cast<double>(p.frames_processed) / p.elapsed_s : 0;
    if (p.frames_expected && fps > 0) {
      const double left_s = static_cast<double>(*p.frames_expected -
                                                std::min(*p.frames_expected, p.frames_processed)) /
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

/// Carries out the user's commands while the chain runs: polls the queue and the signal flag
/// every few milliseconds on its own thread, so that neither the window nor a stage waits for it.
class CommandPump {
 public:
  CommandPump(ViewCommandQueue& commands, Processing& processing,
              const std::atomic<bool>& stop_requested, std::atomic<bool>& chain_stop)
      : commands_(commands),
        processing_(processing),
        stop_requested_(stop_requested),
        chain_stop_(chain_stop) {}

  /// Applies what is queued now (also called once before the chain starts).
  void apply_pending() {
    if (stop_requested_.load()) chain_stop_.store(true);
    while (const std::optional<ViewCommand> command = commands_.poll()) {
      spdlog::info("command: {}", command_name(*command));
      switch (*command) {
        case ViewCommand::kResetModel:
          processing_.request_reset();
          break;
        case ViewCommand::kPauseIntegration:
          processing_.set_paused(true);
          break;
        case ViewCommand::kResumeIntegration:
          processing_.set_paused(false);
          break;
        case ViewCommand::kWriteOutputs:
          processing_.request_write_outputs();
          break;
        case ViewCommand::kQuit:
          quit_ = true;
          chain_stop_.store(true);
          break;
      }
    }
    if (commands_.quit_requested()) {  // kept even when the queue was full
      quit_ = true;
      chain_stop_.store(true);
    }
  }

  void start() {
    thread_ = std::thread([this] {
      while (!done_.load()) {
        apply_pending();
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
    });
  }
  /// Stops the thread (idempotent).
  void stop() {
    done_.store(true);
    if (thread_.joinable()) thread_.join();
  }
  ~CommandPump() { stop(); }
  bool quit() const { return quit_.load(); }

 private:
  ViewCommandQueue& commands_;
  Processing& processing_;
  const std::atomic<bool>& stop_requested_;
  std::atomic<bool>& chain_stop_;
  std::atomic<bool> done_{false};
  std::atomic<bool> quit_{false};
  std::thread thread_;
};

/// Redraws per second of the live view (the camera delivers 30 frames a second), new frames per
/// second it shows when the GL renderer draws on the CPU, and the nice increment of its thread.
constexpr double kWindowRedrawHz = 30.0;
constexpr double kSoftwareGlFrameHz = 5.0;
constexpr int kWindowNice = 10;

/// The live view on its own thread; stopped and joined by stop() or the destructor.
class WindowThread {
 public:
  /// `on_unavailable` runs on the window thread when no window could be made, or when the
  /// display went away while it was open.
  WindowThread(ViewStage& view, ViewCommandQueue& commands, const std::string& title,
               std::function<void()> on_unavailable) {
    LiveViewOptions options;
    options.window.title = title;
    options.max_redraw_hz = kWindowRedrawHz;
    options.software_max_frame_hz = kSoftwareGlFrameHz;
    thread_ = std::thread([this, options, &view, &commands, on_unavailable] {
      // The window yields the CPU to fusion: a lower priority for this thread and the threads
      // the GL driver starts from it (software GL such as llvmpipe renders on the CPU).
      // Relative to the pipeline's own nice value, so that it stays below the pipeline when
      // aoscan itself runs under nice.
      const id_t tid = static_cast<id_t>(syscall(SYS_gettid));
      errno = 0;
      const int own_nice = getpriority(PRIO_PROCESS, tid);
      if (errno != 0 || setpriority(PRIO_PROCESS, tid, std::min(own_nice + kWindowNice, 19)) != 0)
        spdlog::debug("live view: could not lower the window thread's priority");
      const ViewFeed feed = [&view] { return view.take_latest(); };
      const LiveViewResult result = run_live_view(options, feed, commands, stop_);
      using Outcome = LiveViewResult::Outcome;
      if (result.outcome != Outcome::kUnavailable) shown_.store(true);
      if (result.outcome == Outcome::kUnavailable || result.outcome == Outcome::kDisplayLost) {
        display_lost_.store(result.outcome == Outcome::kDisplayLost);
        on_unavailable();  // the run goes on headless
      } else {
        spdlog::info("live view closed after {} redraws ({})", result.redraws, result.gl_renderer);
      }
    });
  }
  void stop() {
    stop_.store(true);
    if (thread_.joinable()) thread_.join();
  }
  ~WindowThread() { stop(); }
  bool shown() const { return shown_.load(); }
  bool display_lost() const { return display_lost_.load(); }

 private:
  std::atomic<bool> stop_{false};
  std::atomic<bool> shown_{false};
  std::atomic<bool> display_lost_{false};
  std::thread thread_;
};

void write_stats_json(const std::string& path, const SessionResult& r, int threads) {
  nlohmann::json j;
  const PipelineCounters& c = r.pipeline.counters;
  j["frames_read"] = c.frames_read;
  j["frames_processed"] = c.frames_processed;
  j["frames_dropped"] = c.frames_dropped;
  // Where the live drops happened: at the input of each stage (the capture edge is the first's).
  nlohmann::json dropped_at = nlohmann::json::object();
  for (std::size_t i = 0; i < c.frames_dropped_at.size() && i + 1 < r.pipeline.stages.size(); ++i)
    dropped_at[r.pipeline.stages[i + 1].name()] = c.frames_dropped_at[i];
  j["frames_dropped_at"] = dropped_at;
  j["frames_corrupt"] = c.frames_corrupt;
  j["frames_tracking_lost"] = c.frames_tracking_lost;
  j["ao_frames_skipped_live"] = r.ao_frames_skipped_live;
  j["wall_s"] = r.pipeline.wall_s;
  j["fps"] =
      r.pipeline.wall_s > 0 ? static_cast<double>(c.frames_processed) / r.pipeline.wall_s : 0.0;
  j["export_s"] = r.export_s;
  j["threads"] = threads;
  j["peak_rss_mb"] = peak_rss_mb();
  j["host_steal_percent"] =
      r.host_steal_percent ? nlohmann::json(*r.host_steal_percent) : nlohmann::json(nullptr);
  nlohmann::json stages = nlohmann::json::object();
  for (const StageStats& s : r.pipeline.stages) {
    const TimingSummary t = s.summary();
    stages[s.name()] = {
        {"ms_mean", t.ms_mean}, {"ms_p50", t.ms_p50}, {"ms_p95", t.ms_p95}, {"ms_max", t.ms_max}};
  }
  j["stages"] = stages;
  const TimingSummary latency = r.pipeline.capture_latency.summary();
  j["capture_latency_ms"] = {{"mean", latency.ms_mean},
                             {"p50", latency.ms_p50},
                             {"p95", latency.ms_p95},
                             {"max", latency.ms_max}};
  const TimingSummary end_to_end = r.pipeline.end_to_end_latency.summary();
  j["end_to_end_latency_ms"] = {{"mean", end_to_end.ms_mean},
                                {"p50", end_to_end.ms_p50},
                                {"p95", end_to_end.ms_p95},
                                {"max", end_to_end.ms_max}};
  j["capture_cpu_percent"] = r.pipeline.capture_cpu_percent;
  j["mesh"] = {{"vertices", r.mesh_vertices},
               {"faces", r.mesh_faces},
               {"ao_unobserved_vertices", r.ao_unobserved_vertices}};
  j["mvao_grid"] = {{"cells", r.grid_cells},
                    {"bricks", r.grid_bricks},
                    {"memory_mb", r.grid_memory_mb},
                    {"points_out_of_range", r.grid_points_out_of_range}};
  j["tsdf"] = {{"blocks", r.tsdf_blocks},
               {"memory_mb", r.tsdf_memory_mb},
               {"capacity_reached", r.tsdf_capacity_reached}};
  if (r.volume_requested)
    j["volume"] = {{"written", r.volume_written},
                   {"bricks", r.volume_bricks},
                   {"active_voxels", r.volume_active_voxels},
                   {"bytes", r.volume_bytes},
                   {"export_s", r.volume_export_s}};
  j["snapshot_files"] = r.snapshot_files;
  j["model_resets"] = r.model_resets;
  j["outputs_written_on_request"] = r.outputs_written_on_request;
  j["quit_by_user"] = r.quit_by_user;
  j["live_view"] = r.live_view_lost ? "display_lost" : r.live_view_shown ? "shown" : "none";
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
  if (options.save_volume) {  // fail now, not after the whole run
    const std::filesystem::path vdb = std::filesystem::path(options.out_dir) / "volume.vdb";
    const bool existed = std::filesystem::exists(vdb, ec);
    if (!std::ofstream(vdb, std::ios::binary | std::ios::app))
      throw usage_error("--out " + options.out_dir + ": cannot write " + vdb.string() + ": " +
                        std::strerror(errno));
    if (!existed) std::filesystem::remove(vdb, ec);  // a check only: no empty file left behind
  }

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
  Processing processing(options.config, options.out_dir);
  std::vector<StageDef> stages = processing.stages();

  // The view stage exists only when something consumes its frames.
  std::unique_ptr<ViewStage> view;
  if (options.live_view || !options.snapshot_dir.empty()) {
    ViewStageOptions vopts;
    vopts.stage_names.push_back("capture");
    for (const StageDef& stage : stages) vopts.stage_names.push_back(stage.name);
    vopts.publish = options.live_view;
    if (!options.snapshot_dir.empty()) {
      SnapshotOptions snapshots;
      snapshots.dir = options.snapshot_dir;
      snapshots.every_n = options.snapshot_every;
      vopts.snapshots = snapshots;
    }
    view = std::make_unique<ViewStage>(vopts);  // usage_error for a bad snapshot folder
    processing.set_view_products(true);
    ViewStage* stage = view.get();
    // With the window alone, view products (the MVAO image, a grid lookup per raycast pixel, and
    // the view frame) are built only once the window has taken the last one: it draws on CPU
    // time fusion leaves, and products it would never show would take that time from fusion.
    // Snapshots need every frame's.
    if (options.snapshot_dir.empty())
      processing.set_view_demand([stage](std::uint64_t built) { return stage->caught_up(built); });
    stages.push_back({"view", [stage](FrameWork& frame) { return stage->process(frame); }});
  }

  ViewCommandQueue own_commands;
  ViewCommandQueue& commands = options.commands ? *options.commands : own_commands;
  std::atomic<bool> chain_stop{false};
  CommandPump pump(commands, processing, stop_requested, chain_stop);
  pump.apply_pending();  // commands queued before the start apply from the first frame
  std::unique_ptr<WindowThread> window;
  if (options.live_view) {
    const bool snapshots = !options.snapshot_dir.empty();
    ViewStage* stage = view.get();
    window = std::make_unique<WindowThread>(
        *view, commands, "aoscan: " + source.name(), [stage, snapshots, &processing] {
          stage->set_publish(false);  // nothing shows the frames: stop building them for it
          if (!snapshots) processing.set_view_products(false);
        });
  }
  pump.start();
  const std::optional<HostCpuTimes> host_before = read_host_cpu_times();
  result.pipeline = run_pipeline(source, stages, popts, chain_stop);
  result.host_steal_percent = steal_percent(host_before, read_host_cpu_times());
  pump.stop();
  if (window) {
    window->stop();
    result.live_view_shown = window->shown();
    result.live_view_lost = window->display_lost();
  }
  result.pipeline.counters.frames_tracking_lost = processing.frames_tracking_lost();
  result.ao_frames_skipped_live = processing.ao_frames_skipped();
  if (result.ao_frames_skipped_live > 0)
    spdlog::info(
        "SSAO skipped on {} tracked frames to keep up with the camera "
        "(ao.live_max_interval)",
        result.ao_frames_skipped_live);
  result.model_resets = processing.model_resets();
  result.outputs_written_on_request = processing.outputs_written_on_request();
  result.quit_by_user = pump.quit();
  progress.finish();

  const Status& status = result.pipeline.status;
  result.exit_code = status.exit_code();
  if (result.exit_code != ExitCode::kOk) {
    result.error = status.message();
  } else if (result.pipeline.counters.frames_processed == 0 && !chain_stop.load()) {
    result.exit_code = ExitCode::kBadInput;
    result.error = source.name() + ": no usable frame (" +
                   std::to_string(result.pipeline.counters.frames_corrupt) + " unreadable)";
  }

  const auto export_start = Clock::now();
  const Processing::ExportStats exported = processing.write_outputs(options.out_dir);
  result.mesh_vertices = exported.mesh_vertices;
  result.mesh_faces = exported.mesh_faces;
  result.ao_unobserved_vertices = exported.ao_unobserved_vertices;
  result.volume_requested = options.save_volume;
  if (options.save_volume) {
    const auto volume_start = Clock::now();
    try {
      const VdbWriteStats written = processing.write_volume(options.out_dir);
      result.volume_written = true;
      result.volume_bricks = written.bricks;
      result.volume_active_voxels = written.active_voxels;
      result.volume_bytes = written.file_bytes;
    } catch (const Error& e) {  // mesh.ply and trajectory.txt are out: still write stats.json
      if (result.exit_code == ExitCode::kOk) {
        result.exit_code = e.code();
        result.error = e.what();
      }
    }
    result.volume_export_s = std::chrono::duration<double>(Clock::now() - volume_start).count();
  }
  result.export_s = std::chrono::duration<double>(Clock::now() - export_start).count();
  result.grid_cells = processing.grid().cell_count();
  result.grid_bricks = processing.grid().brick_count();
  result.grid_memory_mb = static_cast<double>(processing.grid().memory_bytes()) / (1024.0 * 1024.0);
  result.grid_points_out_of_range = processing.grid().points_out_of_range();
  if (result.grid_points_out_of_range > 0)
    spdlog::warn("{} points lay outside the MVAO grid's range and got no AO",
                 result.grid_points_out_of_range);
  const TsdfVolume& volume = processing.reconstruction().volume();
  result.tsdf_blocks = static_cast<std::size_t>(volume.block_count());
  const std::size_t tsdf_bytes =
      volume.memory_bytes() + processing.reconstruction().integrator().memory_bytes();
  result.tsdf_memory_mb = static_cast<double>(tsdf_bytes) / (1024.0 * 1024.0);
  result.tsdf_capacity_reached = volume.capacity_reached();
  if (view) {
    view->finish(exported.mesh);  // the last set of snapshots shows the final mesh in orbit
    result.snapshot_files = view->snapshot_files();
  }
  if (result.tsdf_capacity_reached)
    spdlog::warn(
        "the TSDF reached its capacity of {} blocks (fusion.max_blocks): surface beyond it "
        "was not fused",
        volume.max_blocks());
  write_stats_json((std::filesystem::path(options.out_dir) / "stats.json").string(), result,
                   threads);
  spdlog::info("{} frames processed in {:.2f} s", result.pipeline.counters.frames_processed,
               result.pipeline.wall_s);
  // Above this share of stolen CPU time the run's speed says more about the host than about it.
  constexpr double kNotableStealPercent = 5.0;
  if (result.host_steal_percent && *result.host_steal_percent > kNotableStealPercent)
    spdlog::info(
        "the hypervisor took {:.0f} % of this machine's CPU time during the run: "
        "the timings reflect a busy host",
        *result.host_steal_percent);
  return result;
}

}  // namespace aoscan
