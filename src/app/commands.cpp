/// @file commands.cpp
/// @brief replay/scan, record, devices and config subcommands.
#include "app/commands.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <functional>
#include <memory>
#include <thread>

#include <tbb/global_control.h>

#include "capture/camera_file.h"
#include "capture/devices.h"
#include "capture/loop_source.h"
#include "capture/output_file.h"
#include "capture/recorder.h"
#include "capture/source.h"
#include "core/log.h"
#include "pipeline/config.h"
#include "pipeline/live_recorder.h"
#include "pipeline/ranks.h"

namespace aoscan {
namespace {

/// `--progress-every S`: one line on stderr whenever S seconds have passed since the last one
/// (checked as frames finish), e.g.
/// `aoscan: progress: 1200 frames processed, 1300 read, 95 dropped, 60.0 s`.
std::function<void(const Progress&)> progress_lines(double every_s) {
  auto next_s = std::make_shared<double>(every_s);
  return [every_s, next_s](const Progress& p) {
    if (p.elapsed_s < *next_s) return;
    while (*next_s <= p.elapsed_s) *next_s += every_s;
    std::fprintf(stderr, "aoscan: progress: %zu frames processed, %zu read, %zu dropped, %.1f s\n",
                 p.frames_processed, p.frames_read, p.frames_dropped, p.elapsed_s);
    std::fflush(stderr);
  };
}

}  // namespace

ExitCode run_replay(const RunArgs& args, const std::atomic<bool>& stop_requested) {
  RunOptions options = args.run;
  options.config = load_config(args.config_file, args.sets);  // exit 2 before touching input
  options.show_progress = !args.no_progress;
  options.live_view = !args.headless;  // falls back to headless with one warning

  if (args.live && !is_camera_spec(args.source))
    throw usage_error("--device " + args.source +
                      ": unknown camera (openni2[:URI], freenect[:INDEX], v4l2:/dev/videoN or "
                      "auto; aoscan devices lists them)");
  if (args.progress_every_s) {
    options.show_progress = false;
    options.chain.on_progress = progress_lines(*args.progress_every_s);
  }

  // A bad --camera file is refused before the camera is touched.
  std::optional<CameraInfo> camera;
  if (!args.camera_file.empty()) camera = read_camera_file(args.camera_file);
  std::unique_ptr<Source> source = open_source(args.source);
  if (camera) source = with_camera_file(std::move(source), *camera, args.camera_file);
  if (args.live && !source->live())
    throw usage_error(args.source + ": scan needs a live camera; use replay for recordings");
  if (args.loop) source = make_loop_source(std::move(source), *args.loop);
  const SessionResult result = run_session(*source, options, stop_requested);
  if (result.exit_code != ExitCode::kOk)
    std::fprintf(stderr, "aoscan: error: %s\n", result.error.c_str());
  return result.exit_code;
}

ExitCode run_record(const RecordArgs& args, const std::atomic<bool>& stop_requested) {
  std::optional<CameraInfo> camera;
  if (!args.camera_file.empty()) camera = read_camera_file(args.camera_file);
  std::unique_ptr<Source> source = open_source(args.source);
  if (camera) source = with_camera_file(std::move(source), *camera, args.camera_file);
  // A live camera is read on its own thread so a slow disk never stalls it; recordings and
  // synthetic scenes are simply read and written in turn.
  const RecordStats stats =
      source->live() ? record_live_source(*source, args.dir, args.max_frames, stop_requested)
                     : record_source(*source, args.dir, args.max_frames, &stop_requested);
  std::fprintf(stderr, "aoscan: recorded %zu frames to %s", stats.frames_written, args.dir.c_str());
  if (stats.frames_corrupt > 0)
    std::fprintf(stderr, " (%zu unreadable skipped)", stats.frames_corrupt);
  std::fputc('\n', stderr);
  if (stats.frames_out_of_order > 0)
    std::fprintf(stderr,
                 "aoscan: warning: %zu frames dropped: their timestamps repeat or go back in time\n",
                 stats.frames_out_of_order);
  if (stats.frames_dropped > 0)
    std::fprintf(stderr,
                 "aoscan: warning: %zu frames dropped: the disk could not keep up with %s\n",
                 stats.frames_dropped, source->name().c_str());
  if (!stats.stopped_by.is_ok()) throw_for_status(stats.stopped_by);  // e.g. unplugged: exit 4
  if (stats.frames_written == 0) throw input_error(args.source + ": no usable frame to record");
  return ExitCode::kOk;
}

ExitCode run_devices() {
  const std::vector<DeviceInfo> found = list_devices();
  for (const DeviceInfo& d : found) std::printf("%s\t%s\n", d.uri.c_str(), d.description.c_str());
  if (found.empty())
    std::fprintf(stderr, "aoscan: no depth camera found (%s)\n", devices_searched().c_str());
  return ExitCode::kOk;
}

ExitCode run_print_config(const RunArgs& args) {
  std::fputs(dump_config(load_config(args.config_file, args.sets)).c_str(), stdout);
  return ExitCode::kOk;
}

ExitCode run_scans_command(const ScansArgs& args, const std::atomic<bool>& stop_requested) {
  ScansOptions options = args.scans;
  options.stop = &stop_requested;
  options.config = load_config(args.config_file, args.sets);
  options.show_progress = !args.no_progress;
  const std::unique_ptr<Ranks> ranks = open_ranks();
  // Ranks on one machine share its cores unless told otherwise.
  int threads = args.threads;
  if (threads == 0 && ranks->local_size() > 1)
    threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()) / ranks->local_size());
  std::unique_ptr<tbb::global_control> control;
  if (threads > 0)
    control = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    static_cast<std::size_t>(threads));
  ScansResult r;
  try {
    r = run_scans(options, *ranks);
  } catch (const Error& e) {
    if (ranks->size() == 1) throw;
    // The other ranks may wait for this one: say why here, then end them all.
    std::fprintf(stderr, "aoscan: error: %s (rank %d of %d)\n", one_line(e.what()).c_str(),
                 ranks->rank(), ranks->size());
    ranks->abort(static_cast<int>(e.code()));
  }
  if (ranks->rank() != 0) return ExitCode::kOk;
  if (r.interrupted) {
    std::fprintf(stderr,
                 "aoscan: error: stopped before the outputs (stats.json says interrupted): the "
                 "same command with --resume continues from the scratch folder\n");
    return ExitCode::kFailure;
  }
  if (!r.failed_outputs.empty()) {
    std::fprintf(stderr, "aoscan: error: %s\n", one_line(r.failed_outputs.front().second).c_str());
    return ExitCode::kFailure;
  }
  std::fprintf(stderr, "aoscan: %zu scans, %lld points, %.1f s: %s/points.ply\n", r.scans.size(),
               r.points, r.wall_s, options.out_dir.c_str());
  return ExitCode::kOk;
}

}  // namespace aoscan
