/// @file main.cpp
/// @brief aoscan command line: replay, scan, record, devices, config, scans.
#include <csignal>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "app/commands.h"
#include "core/log.h"
#include "core/status.h"

namespace aoscan {
namespace {

std::atomic<bool> g_stop_requested{false};

/// First SIGINT/SIGTERM asks for a clean stop; a second one kills the process the usual way.
extern "C" void on_stop_signal(int signo) {
  g_stop_requested.store(true);
  std::signal(signo, SIG_DFL);
}

void install_stop_handlers() {
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

/// Options shared by replay and scan.
void add_run_options(CLI::App& cmd, RunArgs& args) {
  cmd.add_option("--out", args.run.out_dir, "folder for the outputs (created if missing)")
      ->capture_default_str();
  cmd.add_option("--config", args.config_file, "configuration file (YAML or JSON)")
      ->check(CLI::ExistingFile);
  cmd.add_option("--set", args.sets, "override one configuration key: KEY=VALUE (repeatable)")
      ->allow_extra_args(false);
  cmd.add_option("--frames", args.run.chain.max_frames, "process at most N frames")
      ->check(CLI::PositiveNumber);
  cmd.add_option("--threads", args.run.threads, "worker threads (default: all cores)")
      ->check(CLI::PositiveNumber);
  cmd.add_flag("--headless", args.headless,
               "never open a window or touch a display (default: the live view, when a display "
               "is available)");
  cmd.add_flag("--realtime", args.run.chain.realtime,
               "pace replay by the recorded timestamps, dropping frames like a live camera");
  cmd.add_flag("--strict", args.run.chain.strict,
               "an unreadable frame is an error (exit 3), not a skip");
  cmd.add_flag("--no-progress", args.no_progress, "no progress line on stderr");
  cmd.add_flag("--save-volume", args.run.save_volume,
               "also write the TSDF to OUT/volume.vdb: OpenVDB float grids 'tsdf' (signed "
               "distance, m) and 'weight', voxel size fusion.voxel_size_m, trajectory.txt's world "
               "frame");
  CLI::Option* snapshot =
      cmd.add_option("--snapshot", args.run.snapshot_dir,
                     "write PNGs of the views (shaded, ssao, normals, depth, orbit) to DIR; "
                     "composited on the CPU, so also with --headless");
  cmd.add_option("--snapshot-every", args.run.snapshot_every,
                 "with --snapshot: every N-th fused frame, and the last one")
      ->check(CLI::PositiveNumber)
      ->capture_default_str()
      ->needs(snapshot);
}

/// Options of `scans` (the contract's command line).
void add_scans_options(CLI::App& cmd, ScansArgs& args) {
  ScansOptions& o = args.scans;
  cmd.add_option("INPUT", o.inputs,
                 "scan manifests (.json, .yaml), MeshLab projects (.mlp), PTX files (.ptx) or "
                 "recording folders")
      ->required();
  cmd.add_option("--out", o.out_dir, "folder for the outputs (created if missing)")
      ->capture_default_str();
  cmd.add_option("--every", o.every, "recording folders: every K-th frame is a scan")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd.add_option("--poses", o.poses,
                 "TUM trajectory posing the recording folders' frames (default: the folder's "
                 "trajectory.txt, else its groundtruth.txt)")
      ->check(CLI::ExistingFile);
  cmd.add_option("--neighbourhood", o.neighbourhood,
                 "N x N samples per corresponding point: 1, 3, 5, 7 or 9")
      ->check(CLI::IsMember({1, 3, 5, 7, 9}))
      ->capture_default_str();
  cmd.add_flag("--ssao-only", o.ssao_only, "write each scan's own SSAO instead of the MVAO");
  cmd.add_option("--config", args.config_file, "configuration file (YAML or JSON)")
      ->check(CLI::ExistingFile);
  cmd.add_option("--set", args.sets, "override one configuration key: KEY=VALUE (repeatable)")
      ->allow_extra_args(false);
  cmd.add_option("--threads", args.threads, "worker threads (default: all cores)")
      ->check(CLI::PositiveNumber);
  // In the contract, not implemented yet: refused with a clear message.
  for (const char* name : {"--memory-limit", "--resume", "--mesh"}) {
    CLI::Option* option = std::string(name) == "--memory-limit"
                              ? cmd.add_option(name, "not implemented yet")
                              : cmd.add_flag(name, "not implemented yet");
    option->each([&args, name](const std::string&) { args.unsupported.push_back(name); });
  }
}

int report(ExitCode code, const std::string& message) {
  std::fprintf(stderr, "aoscan: error: %s\n", one_line(message).c_str());
  return static_cast<int>(code);
}

int run(int argc, char** argv) {
  CLI::App app{"aoscan: real-time depth capture, KinectFusion-style fusion and multi-view "
               "ambient occlusion"};
  app.set_version_flag("--version", "aoscan " AOSCAN_VERSION);
  app.require_subcommand(1);
  std::string log_level = "warn";
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error or off")
      ->capture_default_str();

  RunArgs replay_args;
  CLI::App* replay = app.add_subcommand("replay", "run the whole pipeline on a recording or synth: scene");
  replay->add_option("SOURCE", replay_args.source,
                     "TUM-layout folder or synth:NAME[?key=value&...]")->required();
  add_run_options(*replay, replay_args);
  replay->add_option("--loop", replay_args.loop,
                     "play the source N times, alternately forward and backward, timestamps "
                     "continuing (1 to 100000; --frames caps the total)");
  replay->add_option("--progress-every", replay_args.progress_every_s,
                     "a progress line every SECONDS on stderr, one line each (for logs)")
      ->check(CLI::PositiveNumber);

  RunArgs scan_args;
  scan_args.source = "auto";
  CLI::App* scan = app.add_subcommand("scan", "run the whole pipeline on a live camera");
  scan->add_option("--device", scan_args.source, "camera URI (openni2[:URI], freenect[:INDEX], "
                                                 "v4l2:/dev/videoN) or auto")->capture_default_str();
  add_run_options(*scan, scan_args);

  RecordArgs record_args;
  CLI::App* record = app.add_subcommand("record", "write any source to a TUM-layout recording folder");
  record->add_option("SOURCE", record_args.source, "recording folder, synth: scene or camera")->required();
  record->add_option("DIR", record_args.dir, "recording folder to create")->required();
  record->add_option("--frames", record_args.max_frames, "record at most N frames")
      ->check(CLI::PositiveNumber);

  CLI::App* devices = app.add_subcommand("devices", "list the depth cameras this machine can see");

  RunArgs config_args;
  CLI::App* config = app.add_subcommand("config", "print the effective configuration with every key");
  config->add_option("--config", config_args.config_file, "configuration file (YAML or JSON)")
      ->check(CLI::ExistingFile);
  config->add_option("--set", config_args.sets, "override one configuration key: KEY=VALUE");

  ScansArgs scans_args;
  CLI::App* scans = app.add_subcommand(
      "scans", "offline multi-view AO of registered scans (Sabbadin et al. 2016 Sec. 5)");
  add_scans_options(*scans, scans_args);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return report(ExitCode::kUsage, e.what() + std::string(" (see aoscan --help)"));
  }

  try {
    configure_logging(log_level);
    if (*replay || *scan) {
      install_stop_handlers();
      RunArgs& args = *replay ? replay_args : scan_args;
      args.live = static_cast<bool>(*scan);
      return static_cast<int>(run_replay(args, g_stop_requested));
    }
    if (*record) {
      install_stop_handlers();
      return static_cast<int>(run_record(record_args, g_stop_requested));
    }
    if (*devices) return static_cast<int>(run_devices());
    if (*config) return static_cast<int>(run_print_config(config_args));
    if (*scans) return static_cast<int>(run_scans_command(scans_args));
  } catch (const Error& e) {
    return report(e.code(), e.what());
  } catch (const std::exception& e) {
    return report(ExitCode::kFailure, e.what());
  }
  return 0;
}

}  // namespace
}  // namespace aoscan

int main(int argc, char** argv) { return aoscan::run(argc, argv); }
