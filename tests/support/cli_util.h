/// @file cli_util.h
/// @brief Helpers of the end-to-end tests: run the aoscan executable (to completion, or in the
/// background to act on it mid-run), fresh scratch folders, reading its outputs.
#pragma once

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstddef>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

extern char** environ;

namespace aoscan::testing {

namespace fs = std::filesystem;

/// What one run of the executable left: its exit code (128 + signal when killed) and output.
struct CliRun {
  int exit_code = -1;
  std::string out;
  std::string err;
};

inline std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// `s` in single quotes for the shell (no quote inside: test paths never have one).
inline std::string quote(const std::string& s) {
  return "'" + s + "'";
}

/// Occurrences of `needle` in `text`.
inline std::size_t count(const std::string& text, const std::string& needle) {
  std::size_t n = 0;
  for (auto at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1)) ++n;
  return n;
}

inline nlohmann::json read_stats(const fs::path& out_dir) {
  return nlohmann::json::parse(read_text(out_dir / "stats.json"));
}

/// The shell command that runs `env aoscan args` with stdout and stderr in `scratch` and no stdin.
/// `env` is a prefix such as "FOO=1 BAR=2" or "env -u DISPLAY" (may be empty).
inline std::string aoscan_command(const std::string& args, const fs::path& scratch,
                                  const std::string& env) {
  return env + " " + quote(AOSCAN_BINARY) + " " + args + " > " +
         quote((scratch / "stdout.txt").string()) + " 2> " +
         quote((scratch / "stderr.txt").string()) + " < /dev/null";
}

inline int exit_code_of(int wait_status) {
  return WIFEXITED(wait_status) ? WEXITSTATUS(wait_status) : 128 + WTERMSIG(wait_status);
}

inline CliRun collect(int exit_code, const fs::path& scratch) {
  CliRun r;
  r.exit_code = exit_code;
  r.out = read_text(scratch / "stdout.txt");
  r.err = read_text(scratch / "stderr.txt");
  return r;
}

/// Runs aoscan to completion (see aoscan_command).
inline CliRun run_aoscan(const std::string& args, const fs::path& scratch,
                         const std::string& env = "") {
  return collect(exit_code_of(std::system(aoscan_command(args, scratch, env).c_str())), scratch);
}

/// Records `frames` frames of `synth:corner` (width x height, `extra` parameters such as
/// "&noise=kinect") into dir/rec with `aoscan record`; returns dir/rec.
inline fs::path record_corner(const fs::path& dir, int frames, int width = 64, int height = 48,
                              const std::string& extra = "") {
  const fs::path rec = dir / "rec";
  const CliRun r = run_aoscan("record " +
                                  quote("synth:corner?frames=" + std::to_string(frames) +
                                        "&width=" + std::to_string(width) +
                                        "&height=" + std::to_string(height) + extra) +
                                  " " + quote(rec.string()),
                              dir);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return rec;
}

/// Rewrites the timestamps of recording `rec`'s depth.txt, one per frame in order.
inline void set_timestamps(const fs::path& rec, const std::vector<std::string>& stamps) {
  std::istringstream in(read_text(rec / "depth.txt"));
  std::ostringstream out;
  std::size_t i = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    ASSERT_LT(i, stamps.size());
    out << stamps[i++] << line.substr(line.find(' ')) << "\n";
  }
  ASSERT_EQ(i, stamps.size());
  std::ofstream(rec / "depth.txt") << out.str();
}

#ifdef AOSCAN_FAKENECT_DIR
/// Environment that makes aoscan's libfreenect the fakenect replay of `dump`.
inline std::string fakenect_env(const fs::path& dump) {
  return "LD_LIBRARY_PATH='" AOSCAN_FAKENECT_DIR "' FAKENECT_PATH='" + dump.string() + "'";
}

/// A fakenect dump (dir/dump) of `frames` synthetic frames (`extra` parameters of synth:corner);
/// an empty path when fakenect or aoscan-fakenect-dump is not there. The dump's end is the
/// camera's unplug.
inline fs::path make_fakenect_dump(const fs::path& dir, int frames, const std::string& extra = "") {
  if (!fs::exists(fs::path(AOSCAN_FAKENECT_DIR) / "libfreenect.so")) return {};
  const fs::path rec = dir / "rec";
  const fs::path dump = dir / "dump";
  const CliRun r = run_aoscan(
      "record 'synth:corner?frames=" + std::to_string(frames) + extra + "' '" + rec.string() + "'",
      dir);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  const fs::path tool = fs::path(AOSCAN_BINARY).parent_path() / "aoscan-fakenect-dump";
  if (!fs::exists(tool)) return {};
  const std::string cmd =
      "'" + tool.string() + "' '" + rec.string() + "' '" + dump.string() + "' 2>/dev/null";
  EXPECT_EQ(std::system(cmd.c_str()), 0);
  return dump;
}
#endif

/// aoscan running in the background, for tests that act while it runs. Killed (SIGKILL) and
/// reaped by the destructor if still running.
class AoscanProcess {
 public:
  AoscanProcess(const std::string& args, const fs::path& scratch, const std::string& env = "")
      : scratch_(scratch) {
    // `exec` makes the shell become aoscan: pid_ is aoscan itself, so signals reach it.
    const std::string command = "exec env " + aoscan_command(args, scratch, env);
    const char* argv[] = {"/bin/sh", "-c", command.c_str(), nullptr};
    if (posix_spawn(&pid_, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ) != 0)
      pid_ = -1;
  }
  ~AoscanProcess() {
    if (pid_ > 0 && !exit_code_) {
      ::kill(pid_, SIGKILL);
      int status = 0;
      waitpid(pid_, &status, 0);
    }
  }
  AoscanProcess(const AoscanProcess&) = delete;
  AoscanProcess& operator=(const AoscanProcess&) = delete;

  bool started() const { return pid_ > 0; }
  pid_t pid() const { return pid_; }
  /// The exit code once it has ended (polls, never blocks).
  std::optional<int> poll() {
    if (!exit_code_ && pid_ > 0) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) exit_code_ = exit_code_of(status);
    }
    return exit_code_;
  }
  /// Waits up to `timeout` for the end; nullopt when it is still running.
  std::optional<int> wait_for(std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!poll() && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    return exit_code_;
  }
  /// stdout and stderr so far (all of it after the end).
  CliRun output() const { return collect(exit_code_.value_or(-1), scratch_); }

 private:
  fs::path scratch_;
  pid_t pid_ = -1;
  std::optional<int> exit_code_;
};

}  // namespace aoscan::testing
