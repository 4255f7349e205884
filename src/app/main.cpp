/// @file main.cpp
/// @brief aoscan command line: replay, scan, record, devices, config, scans.
#include <pthread.h>
#include <signal.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <thread>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "app/commands.h"
#include "core/log.h"
#include "core/status.h"
#include "pipeline/output_folder.h"
#include "serve/service.h"

namespace aoscan {
namespace {

/// The signals that stop a run: Ctrl-C, `kill`, and a closed terminal.
constexpr int kStopSignals[] = {SIGINT, SIGTERM, SIGHUP};

sigset_t stop_signal_set() {
  sigset_t set;
  sigemptyset(&set);
  for (int signo : kStopSignals) sigaddset(&set, signo);
  return set;
}

/// The thread that takes the stop signals (0 before it runs).
std::atomic<pid_t> g_signal_thread{0};

/// Threads that libraries started before main() (a logging pool of a camera SDK, say) do not
/// block the stop signals, and the kernel may pick one of them for a signal sent to the process.
/// This handler, running there, passes the signal on to the signal thread.
extern "C" void forward_stop_signal(int signo) {
  const pid_t target = g_signal_thread.load();
  if (target != 0) syscall(SYS_tgkill, getpid(), target, signo);
}

/// Takes the stop signals on a thread of its own (they are blocked in every other thread, so
/// none is ever interrupted by one): the first asks the run to stop, finish the frames in flight
/// and write the outputs; a second, during the export, says how far it is and still lets it
/// finish; a third abandons the outputs, says which are not written, and ends the process.
class StopSignals {
 public:
  /// `stopping`: what the first signal does, as the message says it.
  StopSignals(std::atomic<bool>& stop_requested, const ExportProgress& progress,
              const char* stopping = "stopping; the frames in flight are finished and the "
                                     "outputs written")
      : stop_requested_(stop_requested), progress_(progress), stopping_(stopping) {
    const sigset_t set = stop_signal_set();
    pthread_sigmask(SIG_BLOCK, &set, nullptr);  // before any other thread starts: all inherit it
    std::atomic<bool> started{false};
    thread_ = std::thread([this, set, &started] {
      g_signal_thread.store(static_cast<pid_t>(syscall(SYS_gettid)));
      started.store(true);
      take_signals(set);
    });
    while (!started.load()) std::this_thread::yield();
    struct sigaction action {};
    action.sa_handler = forward_stop_signal;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESTART;
    for (int signo : kStopSignals) sigaction(signo, &action, nullptr);
  }
  ~StopSignals() {
    done_.store(true);
    thread_.join();
    g_signal_thread.store(0);
  }
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

 private:
  void take_signals(const sigset_t& set) {
    int count = 0;
    while (!done_.load()) {
      const timespec poll_interval{0, 100'000'000};
      siginfo_t info{};
      const int signo = sigtimedwait(&set, &info, &poll_interval);
      if (signo < 0) continue;
      ++count;
      const char* name = sigabbrev_np(signo);
      if (count == 1) {
        stop_requested_.store(true);
        std::fprintf(stderr, "aoscan: SIG%s: %s (a third signal abandons them)\n", name,
                     stopping_);
      } else if (count == 2) {
        const std::string where = progress_.describe();
        std::fprintf(stderr, "aoscan: SIG%s: finishing the outputs%s; a third signal abandons them\n",
                     name, where.empty() ? " after the frames in flight" : (" (" + where + ")").c_str());
      } else {
        abandon(name);
      }
    }
  }

  /// Says what stays unwritten and ends the process at once.
  [[noreturn]] void abandon(const char* name) {
    std::string missing;
    if (!progress_.exporting()) {
      missing = "no output was written";
    } else {
      for (const std::string& file : progress_.pending())
        missing += (missing.empty() ? "not written: " : ", ") + file;
      if (missing.empty()) missing = "every output was written";
    }
    std::fprintf(stderr, "aoscan: error: SIG%s: outputs abandoned: %s\n", name, missing.c_str());
    std::_Exit(static_cast<int>(ExitCode::kFailure));
  }

  std::atomic<bool>& stop_requested_;
  const ExportProgress& progress_;
  const char* stopping_;
  std::atomic<bool> done_{false};
  std::thread thread_;
};

/// Whole numbers from `lo` to `hi`: a message that names the range in plain numbers, also for a
/// number too large for any integer type (CLI11's own checks print the range of a double).
CLI::Validator whole_number(std::uint64_t lo, std::uint64_t hi) {
  const std::string range = "a whole number from " + std::to_string(lo) + " to " + std::to_string(hi);
  return CLI::Validator(
      [lo, hi, range](std::string& text) -> std::string {
        if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos)
          return "'" + text + "' is not " + range;
        errno = 0;
        const unsigned long long v = std::strtoull(text.c_str(), nullptr, 10);
        if (errno == ERANGE || v < lo || v > hi) return text + " is out of range: " + range;
        return "";
      },
      "INT " + std::to_string(lo) + ".." + std::to_string(hi));
}

/// Frames of one run: at most this many (about 19 years at 30 frames a second).
constexpr std::uint64_t kMaxFrames = 1ULL << 34;
/// Worker threads: more than any machine aoscan runs on has cores.
constexpr std::uint64_t kMaxThreads = 1024;

/// Options shared by replay and scan.
void add_run_options(CLI::App& cmd, RunArgs& args) {
  cmd.add_option("--out", args.run.out_dir, "folder for the outputs (created if missing)")
      ->capture_default_str();
  cmd.add_option("--config", args.config_file, "configuration file (YAML or JSON)")
      ->check(CLI::ExistingFile);
  cmd.add_option("--set", args.sets, "override one configuration key: KEY=VALUE (repeatable)")
      ->allow_extra_args(false);
  cmd.add_option("--frames", args.run.chain.max_frames, "process at most N frames")
      ->check(whole_number(1, kMaxFrames));
  cmd.add_option("--threads", args.run.threads, "worker threads (default: all cores)")
      ->check(whole_number(1, kMaxThreads));
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
  cmd.add_flag("--bake-ao", args.run.bake_ao,
               "multiply the colour of mesh.ply and mesh.glb by the AO (for viewers that ignore "
               "the AO attribute)");
  cmd.add_flag("--points", args.run.points,
               "also write OUT/points.ply: the fused surface as points with normals, AO "
               "(quality) and colour, mesh.ply's layout without faces");
  cmd.add_flag("--save-session", args.run.save_session,
               "also write what is needed to continue this session later into OUT/session/ "
               "(TSDF, MVAO grid, keyframes, trajectory, configuration)");
  cmd.add_option("--resume", args.run.resume_dir,
                 "continue the session saved in DIR/session/: the new frames are relocalised "
                 "against it and fused in its world frame; the outputs cover every take")
      ->type_name("DIR");
  CLI::Option* snapshot =
      cmd.add_option("--snapshot", args.run.snapshot_dir,
                     "write PNGs of the views (shaded, ssao, ..., orbit, splats) to DIR; "
                     "composited on the CPU, so also with --headless");
  cmd.add_option("--snapshot-every", args.run.snapshot_every,
                 "with --snapshot: every N-th fused frame, and the last one")
      ->check(whole_number(1, kMaxFrames))
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
      ->check(whole_number(1, kMaxFrames))
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
      ->check(whole_number(1, kMaxThreads));
  cmd.add_option("--memory-limit", o.memory_limit,
                 "peak memory to plan for: scans beyond it wait in the scratch folder (e.g. 2G, "
                 "512M)")
      ->transform(CLI::AsSizeValue(false))
      ->check(CLI::Range(std::uint64_t{1} << 20, std::uint64_t{1} << 50))
      ->default_str("2G");
  cmd.add_option("--scratch", o.scratch_dir,
                 "folder for each scan's maps, SSAO and MVAO between the stages (default: "
                 "OUT/scratch; removed after a complete run)");
  cmd.add_flag("--resume", o.resume,
               "continue an interrupted run: scans and integrations its scratch folder holds are "
               "not computed again");
  cmd.add_flag("--keep-scratch", o.keep_scratch, "keep the scratch folder after a complete run");
  cmd.add_flag("--no-progress", args.no_progress, "no progress lines on stderr");
  cmd.add_flag("--mesh", o.mesh,
               "also write mesh.ply: the scans fused into a TSDF (tsdf.* keys), each vertex with "
               "the AO of the nearest scan point");
}

/// `scans` works through range maps of hundreds of megabytes. With transparent huge pages in
/// "madvise" mode (Debian's default) they take one page fault per 2 MiB instead of per 4 KiB,
/// which on a virtual machine, where a fault costs microseconds, halves a run (BENCHMARKS.md,
/// multi-scan speed). glibc hands malloc's large blocks to huge pages only when told so at start
/// (the glibc.malloc.hugetlb tunable), so the process runs itself again with it set. Nothing
/// changes when the tunable is already given (by the user, or by this) or the exec fails.
void rerun_with_huge_pages(char** argv) {
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  const std::string current = tunables ? tunables : "";
  if (current.find("glibc.malloc.hugetlb") != std::string::npos) return;
  const std::string value =
      current.empty() ? "glibc.malloc.hugetlb=1" : current + ":glibc.malloc.hugetlb=1";
  if (setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
  execv("/proc/self/exe", argv);
  // The exec failed: carry on as we are.
  if (tunables)
    setenv("GLIBC_TUNABLES", current.c_str(), 1);
  else
    unsetenv("GLIBC_TUNABLES");
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
                                                 "v4l2:/dev/videoN[?colour=/dev/videoM]) or auto")->capture_default_str();
  add_run_options(*scan, scan_args);
  scan->add_option("--camera", scan_args.camera_file,
                   "camera.json replacing the camera's nominal calibration: depth intrinsics, "
                   "depth_scale and an optional colour camera (as in a recording folder)")
      ->type_name("FILE");

  RecordArgs record_args;
  CLI::App* record = app.add_subcommand("record", "write any source to a TUM-layout recording folder");
  record->add_option("SOURCE", record_args.source, "recording folder, synth: scene or camera")->required();
  record->add_option("DIR", record_args.dir, "recording folder to create")->required();
  record->add_option("--frames", record_args.max_frames, "record at most N frames")
      ->check(whole_number(1, kMaxFrames));
  record->add_option("--camera", record_args.camera_file,
                     "camera.json replacing the source's calibration (depth intrinsics, "
                     "depth_scale, optional colour camera); written as the recording's camera.json")
      ->type_name("FILE");

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

  // An unknown word where the subcommand belongs: say so (CLI11 would say that one is missing).
  ServiceOptions serve_args;
  serve_args.version = AOSCAN_VERSION;
  CLI::App* serve = app.add_subcommand(
      "serve", "the capture and fusion service: HTTP/JSON API, live view and web page");
  serve->add_option("--listen", serve_args.listen,
                    "ADDR:PORT to listen on (IPv4); beyond 127.x.x.x it needs --token-file")
      ->capture_default_str();
  serve->add_option("--data", serve_args.data_dir,
                    "folder of the recordings to replay and of the sessions (sessions/)")
      ->capture_default_str();
  serve->add_option("--token-file", serve_args.token_file,
                    "file whose first line is the token every request must carry (Authorization: "
                    "Bearer TOKEN, or the login page's cookie)")
      ->check(CLI::ExistingFile);
  serve->add_option("--config", serve_args.config_file,
                    "configuration file (YAML or JSON) of every session")
      ->check(CLI::ExistingFile);
  serve->add_option("--set", serve_args.sets,
                    "override one configuration key of every session: KEY=VALUE (repeatable)")
      ->allow_extra_args(false);
  serve->add_option("--threads", serve_args.threads, "worker threads of a session (default: all cores)")
      ->check(whole_number(1, kMaxThreads));

  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--log-level") {
      ++i;
      continue;
    }
    if (arg.empty() || arg[0] == '-') continue;
    const std::vector<CLI::App*> named =
        app.get_subcommands([&arg](CLI::App* sub) { return sub->get_name() == arg; });
    if (named.empty())
      return report(ExitCode::kUsage, "unknown subcommand '" + arg +
                                           "' (replay, scan, record, devices, config, scans or "
                                           "serve; "
                                           "see aoscan --help)");
    break;
  }
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

  if (*scans) rerun_with_huge_pages(argv);

  // A write past a file size limit fails with EFBIG (an error naming the file) instead of
  // killing the process; a closed stderr pipe is a failed write, not a death.
  std::signal(SIGXFSZ, SIG_IGN);
  std::signal(SIGPIPE, SIG_IGN);
  try {
    configure_logging(log_level);
    std::atomic<bool> stop_requested{false};
    ExportProgress export_progress;
    if (*replay || *scan) {
      const StopSignals signals(stop_requested, export_progress);
      RunArgs& args = *replay ? replay_args : scan_args;
      args.live = static_cast<bool>(*scan);
      args.run.export_progress = &export_progress;
      return static_cast<int>(run_replay(args, stop_requested));
    }
    if (*record) {
      const StopSignals signals(stop_requested, export_progress);
      return static_cast<int>(run_record(record_args, stop_requested));
    }
    if (*devices) return static_cast<int>(run_devices());
    if (*config) return static_cast<int>(run_print_config(config_args));
    if (*scans) {
      const StopSignals signals(stop_requested, export_progress,
                                "stopping before the next scan; the scratch folder keeps the "
                                "finished ones for --resume");
      return static_cast<int>(run_scans_command(scans_args, stop_requested));
    }
    if (*serve) {
      const StopSignals signals(stop_requested, export_progress);
      return static_cast<int>(run_service(serve_args, stop_requested));
    }
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
