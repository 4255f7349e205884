/// @file commands.h
/// @brief The subcommands of the aoscan executable.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/status.h"
#include "pipeline/scan_set.h"
#include "pipeline/session.h"

namespace aoscan {

/// The command line of `replay` and `scan`: the run's options, and what the command makes of
/// them (the source to open, the configuration to load, the negated flags).
struct RunArgs {
  RunOptions run;  ///< filled by the options that map one to one
  std::string source;
  std::string config_file;
  std::vector<std::string> sets;
  bool headless = false;     ///< --headless: no live view
  bool no_progress = false;  ///< --no-progress: no progress line
  /// --progress-every S: a progress line every S seconds on stderr, one line each (for logs),
  /// instead of the terminal's progress line.
  std::optional<double> progress_every_s;
  std::optional<std::int64_t> loop;  ///< replay --loop N: play the source N times (ping-pong)
  bool live = false;         ///< scan: a live camera is required
  /// scan --camera FILE: a camera.json replacing the camera's nominal calibration ("" = none).
  std::string camera_file;
};

struct RecordArgs {
  std::string source;
  std::string dir;
  std::optional<std::size_t> max_frames;
  /// --camera FILE: a camera.json replacing the source's calibration ("" = none); the recording's
  /// camera.json is then this calibration.
  std::string camera_file;
};

/// The command line of `scans`.
struct ScansArgs {
  ScansOptions scans;  ///< filled by the options that map one to one
  std::string config_file;
  std::vector<std::string> sets;
  int threads = 0;  ///< 0: all cores
  bool no_progress = false;
};

/// Each returns the process exit code; set-up failures are thrown as aoscan::Error.
ExitCode run_replay(const RunArgs& args, const std::atomic<bool>& stop_requested);
ExitCode run_record(const RecordArgs& args, const std::atomic<bool>& stop_requested);
ExitCode run_devices();
ExitCode run_print_config(const RunArgs& args);
ExitCode run_scans_command(const ScansArgs& args, const std::atomic<bool>& stop_requested);

}  // namespace aoscan
