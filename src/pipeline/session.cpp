/// @file session.cpp
/// @brief Session: thread budget, the chain, progress line, outputs.
#include "pipeline/session.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>
#include <memory>
#include <thread>

#include <tbb/global_control.h>
#include <nlohmann/json.hpp>

#include "core/host_cpu.h"
#include "core/log.h"
#include "io/atomic_write.h"
#include "io/gltf.h"
#include "io/ply.h"
#include "pipeline/output_folder.h"
#include "pipeline/processing.h"
#include "pipeline/saved_session.h"
#include "pipeline/view_stage.h"
#include "render/live_view.h"

namespace aoscan {
namespace {

using Clock = std::chrono::steady_clock;

/// Every file a replay or scan may leave in --out: those of an earlier run are moved aside first.
const std::vector<std::string> kRunOutputs = {"trajectory.txt", "mesh.ply",   "mesh.glb",
                                              "stats.json",     "volume.vdb", "points.ply",
                                              "session/"};

/// The files this run writes, in the order it writes them (stats.json last).
std::vector<std::string> outputs_of(const RunOptions& options) {
  std::vector<std::string> files = {"trajectory.txt", "mesh.ply", "mesh.glb"};
  if (options.points) files.push_back("points.ply");
  if (options.save_volume) files.push_back("volume.vdb");
  if (options.save_session)
    for (const std::string& f : session_outputs()) files.push_back(f);
  files.push_back("stats.json");
  return files;
}

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
      if (!lower_thread_priority(kWindowNice))
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

/// The chain of one run: processing's stages, and the view stage when something consumes its
/// frames (a window or snapshots).
struct ChainSetup {
  std::vector<StageDef> stages;
  std::unique_ptr<ViewStage> view;
};

ChainSetup build_stages(const RunOptions& options, Processing& processing) {
  ChainSetup chain{processing.stages(), nullptr};
  const bool remote = static_cast<bool>(options.remote_view);
  if (!options.live_view && options.snapshot_dir.empty() && !remote) return chain;
  ViewStageOptions vopts;
  vopts.stage_names.push_back("capture");
  for (const StageDef& stage : chain.stages) vopts.stage_names.push_back(stage.name);
  vopts.publish = options.live_view || remote;
  // Only the remote view alone may ask for some views (ViewStage::set_views).
  vopts.publish_all_views = options.live_view || !options.snapshot_dir.empty();
  vopts.on_colour_needed = [&processing](bool needed) { processing.set_view_colour(needed); };
  if (!options.snapshot_dir.empty()) {
    SnapshotOptions snapshots;
    snapshots.dir = options.snapshot_dir;
    snapshots.every_n = options.snapshot_every;
    vopts.snapshots = snapshots;
  }
  chain.view = std::make_unique<ViewStage>(vopts);  // usage_error for a bad snapshot folder
  processing.set_view_products(true);
  ViewStage* stage = chain.view.get();
  // With the window (or the remote view) alone, view products (the MVAO image, a grid lookup
  // per raycast pixel, and the view frame) are built only once the window has taken the last
  // one: it draws on CPU time fusion leaves, and products it would never show would take that
  // time from fusion. Snapshots need every frame's.
  if (options.snapshot_dir.empty())
    processing.set_view_demand([stage](std::uint64_t built) { return stage->caught_up(built); });
  chain.stages.push_back({"view", [stage](FrameWork& frame) { return stage->process(frame); }});
  return chain;
}

/// Runs the chain with the user's commands applied and, with live_view, the window open; fills
/// result.pipeline, .processing and the session's window and quit entries. Returns true when
/// the chain was asked to stop (signal or quit).
bool run_with_controls(Source& source, const RunOptions& options, Processing& processing,
                       const ChainSetup& chain, const std::atomic<bool>& stop_requested,
                       SessionResult& result) {
  PipelineOptions popts = options.chain;
  popts.queue_capacity = static_cast<std::size_t>(options.config.pipeline.queue_capacity);
  ProgressLine progress;
  if (options.show_progress && isatty(STDERR_FILENO))
    popts.on_progress = [&progress](const Progress& p) { progress.update(p); };

  ViewCommandQueue own_commands;
  ViewCommandQueue& commands = options.commands ? *options.commands : own_commands;
  std::atomic<bool> chain_stop{false};
  CommandPump pump(commands, processing, stop_requested, chain_stop);
  pump.apply_pending();  // commands queued before the start apply from the first frame
  std::unique_ptr<WindowThread> window;
  if (options.live_view) {
    const bool snapshots = !options.snapshot_dir.empty();
    const bool remote = static_cast<bool>(options.remote_view);
    ViewStage* stage = chain.view.get();
    window = std::make_unique<WindowThread>(
        *chain.view, commands, "aoscan: " + source.name(), [stage, snapshots, remote, &processing] {
          if (remote) return;  // the remote view goes on taking the frames
          stage->set_publish(false);  // nothing shows the frames: stop building them for it
          if (!snapshots) processing.set_view_products(false);
        });
  }
  if (options.remote_view) options.remote_view(chain.view.get());
  pump.start();
  const std::optional<HostCpuTimes> host_before = read_host_cpu_times();
  result.pipeline = run_pipeline(source, chain.stages, popts, chain_stop);
  result.session.host_steal_percent = steal_percent(host_before, read_host_cpu_times());
  pump.stop();
  if (options.remote_view) options.remote_view(nullptr);
  if (window) {
    window->stop();
    result.session.live_view_shown = window->shown();
    result.session.live_view_lost = window->display_lost();
  }
  result.processing = processing.stats();
  if (result.processing.ao_frames_skipped_live > 0)
    spdlog::info(
        "SSAO skipped on {} tracked frames to keep up with the camera "
        "(ao.live_max_interval)",
        result.processing.ao_frames_skipped_live);
  result.session.quit_by_user = pump.quit();
  progress.finish();
  return chain_stop.load();
}

/// The run's exit code and error: the chain's, or bad input when no frame was usable (and the
/// run was not stopped before one came).
void set_outcome(const Source& source, bool stopped, SessionResult& result) {
  const Status& status = result.pipeline.status;
  result.exit_code = status.exit_code();
  if (result.exit_code != ExitCode::kOk) {
    result.error = status.message();
  } else if (result.pipeline.counters.frames_processed == 0 && !stopped) {
    result.exit_code = ExitCode::kBadInput;
    result.error = source.name() + ": no usable frame (" +
                   std::to_string(result.pipeline.counters.frames_corrupt) + " unreadable)";
  }
}

/// While the export runs, says every few seconds how far it is, once it takes longer than that:
/// a costly configuration can make it take minutes.
class ExportTicker {
 public:
  explicit ExportTicker(const ExportProgress& progress) {
    thread_ = std::thread([this, &progress] {
      constexpr auto kEvery = std::chrono::seconds(5);
      auto next = Clock::now() + kEvery;
      while (!done_.load()) {
        std::this_thread::sleep_for(kStopPollInterval);
        if (Clock::now() < next) continue;
        next += kEvery;
        std::fprintf(stderr, "aoscan: writing the outputs: %s\n", progress.describe().c_str());
      }
    });
  }
  ~ExportTicker() {
    done_.store(true);
    thread_.join();
  }
  ExportTicker(const ExportTicker&) = delete;
  ExportTicker& operator=(const ExportTicker&) = delete;

 private:
  std::atomic<bool> done_{false};
  std::thread thread_;
};

/// When frames were processed but no surface was fused: the run's error (bad input, exit 3) with
/// the likeliest reason.
void check_something_fused(const Source& source, const RunOptions& options,
                           SessionResult& result) {
  const std::size_t processed = result.pipeline.counters.frames_processed;
  if (result.exit_code != ExitCode::kOk || processed == 0 || result.tsdf.blocks > 0) return;
  const PreprocessConfig& pre = options.config.preprocess;
  std::ostringstream why;
  why << source.name() << ": nothing was fused from " << processed << " frames: ";
  if (result.processing.frames_without_depth == processed) {
    why << "no frame has valid depth (every raw value is 0, 65535, or outside "
        << pre.min_depth_m << " to " << pre.max_depth_m
        << " m at depth_scale " << source.depth_scale() << " units per metre)";
  } else {
    const Intrinsics& k = source.intrinsics();
    why << "every point lies outside the camera's view or the volume (calibration fx " << k.fx
        << ", fy " << k.fy << ", cx " << k.cx << ", cy " << k.cy << " for " << k.width << "x"
        << k.height << " from " << source.calibration_origin() << ")";
  }
  result.exit_code = ExitCode::kBadInput;
  result.error = why.str();
}

/// The calibration the run uses and where it comes from: logged (a warning for a generic
/// default) and kept for stats.json.
nlohmann::json report_calibration(const Source& source) {
  const Intrinsics& k = source.intrinsics();
  std::ostringstream text;
  text << "fx " << k.fx << ", fy " << k.fy << ", cx " << k.cx << ", cy " << k.cy << ", "
       << k.width << "x" << k.height << ", depth_scale " << source.depth_scale();
  if (source.calibration_is_default())
    spdlog::warn("{}: {}: {}; write camera.json beside depth.txt to give the camera's own",
                 source.name(), source.calibration_origin(), text.str());
  else
    spdlog::info("{}: calibration {} from {}", source.name(), text.str(), source.calibration_origin());
  nlohmann::json j = {{"fx", k.fx},         {"fy", k.fy},
                      {"cx", k.cx},         {"cy", k.cy},
                      {"width", k.width},   {"height", k.height},
                      {"depth_scale", source.depth_scale()},
                      {"origin", source.calibration_origin()}};
  // The colour camera's calibration is where it came from; "" = the source has no colour.
  j["colour_origin"] = source.colour_origin().empty() ? nlohmann::json(nullptr)
                                                      : nlohmann::json(source.colour_origin());
  return j;
}

/// Writes trajectory.txt, mesh.ply, volume.vdb (save_volume) and the last snapshots, each on its
/// own: a file that cannot be written is recorded and the others are still written. Fills the
/// mesh, volume, grid, TSDF and export entries of `result`; the first failed file becomes the
/// run's error when it had none.
void export_outputs(const RunOptions& options, const Processing& processing, ViewStage* view,
                    OutputFolder& outputs, ExportProgress& progress, const Intrinsics& camera,
                    int takes, SessionResult& result) {
  const auto export_start = Clock::now();
  progress.start(outputs_of(options));
  outputs.write("trajectory.txt",
                [&](const std::string& path) { processing.write_trajectory_file(path); });
  progress.step("extracting the mesh");
  const Processing::ExportResult exported = processing.final_mesh();
  result.mesh = exported.stats;
  const MeshWriteOptions mesh_options{options.bake_ao};
  outputs.write("mesh.ply",
                [&](const std::string& path) { write_ply(path, *exported.mesh, mesh_options); });
  outputs.write("mesh.glb",
                [&](const std::string& path) { write_glb(path, *exported.mesh, mesh_options); });
  if (options.points)
    outputs.write("points.ply", [&](const std::string& path) {
      write_points_ply(path, *exported.mesh, mesh_options);
    });
  if (options.save_volume) {
    const auto volume_start = Clock::now();
    result.volume = VolumeStats{};
    outputs.write("volume.vdb",
                  [&](const std::string& path) { result.volume = processing.write_volume(path); });
    result.volume->export_s = std::chrono::duration<double>(Clock::now() - volume_start).count();
  }
  if (options.save_session) save_session(outputs, processing, options.config, camera, takes);
  result.session.export_s = std::chrono::duration<double>(Clock::now() - export_start).count();
  result.grid = processing.grid_stats();
  if (result.grid.points_out_of_range > 0)
    spdlog::warn("{} points lay outside the MVAO grid's range and got no AO",
                 result.grid.points_out_of_range);
  result.tsdf = processing.tsdf_stats();
  if (view) {
    progress.step("writing the last snapshots");
    view->finish(exported.mesh);  // the last set of snapshots shows the final mesh in orbit
    result.session.snapshot_files = view->snapshot_files();
  }
  if (result.tsdf.capacity_reached)
    spdlog::warn(
        "the TSDF reached its capacity of {} blocks (fusion.max_blocks): surface beyond it "
        "was not fused",
        processing.reconstruction().volume().max_blocks());
  result.files = outputs.files_json();
  result.failed_outputs = outputs.failures_json();
  if (result.exit_code == ExitCode::kOk && !outputs.first_failure().empty()) {
    result.exit_code = ExitCode::kFailure;
    result.error = outputs.first_failure();
  }
}

}  // namespace

double peak_rss_mb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

void want_configured_colour(Source& source, const Config& config) {
  source.want_colour(config.fusion.colour == ColourFusion::kOn, config.fusion.colour_every);
}

nlohmann::json SessionStats::to_json() const {
  return {{"threads", threads},
          {"export_s", export_s},
          {"peak_rss_mb", peak_rss_mb()},
          {"host_steal_percent",
           host_steal_percent ? nlohmann::json(*host_steal_percent) : nlohmann::json(nullptr)},
          {"snapshot_files", snapshot_files},
          {"quit_by_user", quit_by_user},
          {"live_view", live_view_lost ? "display_lost" : live_view_shown ? "shown" : "none"}};
}

const char* SessionResult::status() const {
  if (exit_code != ExitCode::kOk) return "failed";
  return interrupted ? "interrupted" : "complete";
}

nlohmann::json SessionResult::to_json() const {
  nlohmann::json j = pipeline.to_json();
  j.update(processing.to_json());
  j.update(session.to_json());
  j["mesh"] = mesh.to_json();
  j["mvao_grid"] = grid.to_json();
  j["tsdf"] = tsdf.to_json();
  if (volume) j["volume"] = volume->to_json();
  j["status"] = status();
  j["error"] = exit_code == ExitCode::kOk ? nlohmann::json(nullptr) : nlohmann::json(error);
  j["stopped_by"] = stopped_by.empty() ? nlohmann::json(nullptr) : nlohmann::json(stopped_by);
  j["calibration"] = calibration;
  j["files"] = files;
  j["failed_outputs"] = failed_outputs;
  return j;
}

SessionResult run_session(Source& source, const RunOptions& options,
                          const std::atomic<bool>& stop_requested) {
  ExportProgress own_progress;
  ExportProgress& progress = options.export_progress ? *options.export_progress : own_progress;
  // A session to continue is read and checked first: a refused --resume leaves --out untouched
  // (and may read the session that --out holds, which prepare() then moves to previous/).
  std::optional<LoadedSession> resumed;
  if (!options.resume_dir.empty()) {
    resumed = load_session(options.resume_dir, options.config);
    check_session_camera(*resumed, source.intrinsics());
  }
  OutputFolder outputs(options.out_dir, &progress);
  outputs.prepare(kRunOutputs, outputs_of(options));
  for (const std::string& warning : costly_config_warnings(options.config))
    spdlog::warn("{}", warning);
  SessionResult result;
  result.calibration = report_calibration(source);
  want_configured_colour(source, options.config);
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  result.session.threads = options.threads > 0 ? std::min(options.threads, cores) : cores;
  if (options.threads > cores)
    spdlog::warn("--threads {}: this machine runs {} threads at once; {} are used",
                 options.threads, cores, cores);
  tbb::global_control thread_budget(tbb::global_control::max_allowed_parallelism,
                                    static_cast<std::size_t>(result.session.threads));

  Processing processing(options.config, options.out_dir, MeshWriteOptions{options.bake_ao});
  if (resumed) processing.restore(*resumed);
  const ChainSetup chain = build_stages(options, processing);
  const bool stopped =
      run_with_controls(source, options, processing, chain, stop_requested, result);
  set_outcome(source, stopped, result);
  if (stopped && result.exit_code == ExitCode::kOk) {
    result.stopped_by = result.session.quit_by_user ? "quit" : "signal";
    // A camera's stream ends when the user stops it; a recording stopped early is incomplete.
    result.interrupted = !source.live();
  }
  {
    std::optional<ExportTicker> ticker;
    if (options.show_progress) ticker.emplace(progress);
    export_outputs(options, processing, chain.view.get(), outputs, progress, source.intrinsics(),
                   resumed ? resumed->takes + 1 : 1, result);
  }
  check_something_fused(source, options, result);
  // Last, so that it vouches for the files written before it (stats.json's "files").
  const std::string stats_path = outputs.path("stats.json");
  write_atomically(stats_path, [&result](const std::string& partial) {
    std::ofstream out(partial);
    out << result.to_json().dump(2) << "\n";
    out.close();
    if (!out) throw_write_failed(partial);
  });
  progress.done("stats.json");
  spdlog::info("{} frames processed in {:.2f} s", result.pipeline.counters.frames_processed,
               result.pipeline.wall_s);
  // Above this share of stolen CPU time the run's speed says more about the host than about it.
  constexpr double kNotableStealPercent = 5.0;
  if (result.session.host_steal_percent &&
      *result.session.host_steal_percent > kNotableStealPercent)
    spdlog::info(
        "the hypervisor took {:.0f} % of this machine's CPU time during the run: "
        "the timings reflect a busy host",
        *result.session.host_steal_percent);
  return result;
}

}  // namespace aoscan
