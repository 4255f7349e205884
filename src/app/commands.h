/// @file commands.h
/// @brief The subcommands of the aoscan executable.
#pragma once

#include <atomic>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "core/status.h"

namespace aoscan {

/// Options of `replay` and `scan`.
struct RunArgs {
  std::string source;
  std::string out_dir = "aoscan-out";
  std::string config_file;
  std::vector<std::string> sets;
  std::optional<std::size_t> max_frames;
  std::optional<int> threads;
  bool headless = false;
  bool realtime = false;
  bool strict = false;
  bool no_progress = false;
  bool save_volume = false;         ///< --save-volume: also write OUT/volume.vdb
  bool live = false;                ///< scan: a live camera is required
  std::string snapshot_dir;         ///< --snapshot: CPU-composited PNGs of the views go here
  std::size_t snapshot_every = 30;  ///< --snapshot-every: every N-th fused frame (and the last)
};

struct RecordArgs {
  std::string source;
  std::string dir;
  std::optional<std::size_t> max_frames;
};

/// Each returns the process exit code; set-up failures are thrown as aoscan::Error.
ExitCode run_replay(const RunArgs& args, const std::atomic<bool>& stop_requested);
ExitCode run_record(const RecordArgs& args, const std::atomic<bool>& stop_requested);
ExitCode run_devices();
ExitCode run_print_config(const RunArgs& args);

}  // namespace aoscan
