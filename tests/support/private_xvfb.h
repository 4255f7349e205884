/// @file private_xvfb.h
/// @brief A private Xvfb X server for tests that need a display they can take away mid-run
/// (start, ask its display name, stop it while clients are connected).
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>

extern char** environ;

namespace aoscan::testing {

/// Full path of `program` on PATH, or empty.
inline std::string find_on_path(const std::string& program) {
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path ? path : "");
  for (std::string dir; std::getline(dirs, dir, ':');) {
    const std::filesystem::path candidate = std::filesystem::path(dir) / program;
    if (!dir.empty() && access(candidate.c_str(), X_OK) == 0) return candidate.string();
  }
  return {};
}

/// An Xvfb on the first free display number (chosen by Xvfb itself through -displayfd, so tests
/// running in parallel do not collide). Stopped by stop() or the destructor.
class PrivateXvfb {
 public:
  /// Starts Xvfb with one 1280x1024x24 screen and waits up to 10 s for it to accept clients.
  /// On failure running() is false and error() says why (e.g. Xvfb is not installed).
  PrivateXvfb() {
    const std::string xvfb = find_on_path("Xvfb");
    if (xvfb.empty()) {
      error_ = "Xvfb is not installed";
      return;
    }
    int fds[2];
    if (pipe(fds) != 0) {
      error_ = "pipe() failed";
      return;
    }
    const std::string fd_text = std::to_string(fds[1]);
    const char* argv[] = {xvfb.c_str(),   "-displayfd", fd_text.c_str(), "-screen",  "0",
                          "1280x1024x24", "-nolisten",  "tcp",           "-noreset", nullptr};
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addclose(&actions, fds[0]);
    posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
    const int rc =
        posix_spawn(&pid_, xvfb.c_str(), &actions, nullptr, const_cast<char**>(argv), environ);
    posix_spawn_file_actions_destroy(&actions);
    close(fds[1]);
    if (rc != 0) {
      pid_ = -1;
      close(fds[0]);
      error_ = "cannot start " + xvfb;
      return;
    }
    // Xvfb writes its display number and a newline once it accepts connections.
    std::string number;
    pollfd pfd{fds[0], POLLIN, 0};
    char c = 0;
    while (poll(&pfd, 1, 10000) > 0 && read(fds[0], &c, 1) == 1 && c != '\n') number += c;
    close(fds[0]);
    if (number.empty() || c != '\n') {
      error_ = "Xvfb did not report a display within 10 s";
      stop();
      return;
    }
    display_ = ":" + number;
  }
  ~PrivateXvfb() { stop(); }
  PrivateXvfb(const PrivateXvfb&) = delete;
  PrivateXvfb& operator=(const PrivateXvfb&) = delete;

  bool running() const { return pid_ > 0 && !display_.empty(); }
  const std::string& error() const { return error_; }
  /// e.g. ":1"
  const std::string& display() const { return display_; }

  /// Ends the server (SIGTERM: it closes every client's connection) and reaps it.
  void stop() {
    if (pid_ <= 0) return;
    kill(pid_, SIGTERM);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
  }

 private:
  pid_t pid_ = -1;
  std::string display_;
  std::string error_;
};

}  // namespace aoscan::testing
