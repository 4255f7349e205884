/// @file fuzz_input.h
/// @brief What every fuzz target shares: the input bytes as a file the parser opens by path (an
/// in-memory memfd, nothing written to disk per input), and the rule that a parser may fail only
/// with its documented error, naming the file.
#pragma once

#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "core/pose.h"
#include "core/status.h"

namespace aoscan::fuzz {

/// Aborts (libFuzzer reports a crash and keeps the input) with `what`.
[[noreturn]] inline void bug(const std::string& what) {
  std::fprintf(stderr, "fuzz: %s\n", what.c_str());
  std::abort();
}

/// The fuzz input as a file. The bytes live in a memfd; the parser opens `path()`, a symbolic
/// link named `name` (the extension some parsers look at) in a private temporary folder that
/// points at the memfd. `siblings` are empty files made once beside it, for inputs that name
/// other files (a manifest's scans). The folder is removed at exit.
class InputFile {
 public:
  explicit InputFile(const std::string& name, const std::vector<std::string>& siblings = {}) {
    fd_ = memfd_create("aoscan-fuzz", MFD_CLOEXEC);
    if (fd_ < 0) bug(std::string("memfd_create: ") + std::strerror(errno));
    const char* tmp = std::getenv("TMPDIR");
    std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/aoscan-fuzz-XXXXXX";
    if (mkdtemp(pattern.data()) == nullptr) bug(std::string("mkdtemp: ") + std::strerror(errno));
    dir_ = pattern;
    path_ = dir_ + "/" + name;
    const std::string target = "/proc/self/fd/" + std::to_string(fd_);
    if (symlink(target.c_str(), path_.c_str()) != 0)
      bug(std::string("symlink: ") + std::strerror(errno));
    made_.push_back(path_);
    for (const std::string& s : siblings) {
      const std::string p = dir_ + "/" + s;
      std::FILE* f = std::fopen(p.c_str(), "wb");
      if (f == nullptr || std::fclose(f) != 0) bug("cannot create " + p);
      made_.push_back(p);
    }
  }
  ~InputFile() {
    for (const std::string& p : made_) unlink(p.c_str());
    rmdir(dir_.c_str());
    close(fd_);
  }
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;

  /// Replaces the file's content with `data`; returns path().
  const std::string& write(const std::uint8_t* data, std::size_t size) {
    if (ftruncate(fd_, 0) != 0) bug(std::string("ftruncate: ") + std::strerror(errno));
    std::size_t done = 0;
    while (done < size) {
      const ssize_t n = pwrite(fd_, data + done, size - done, static_cast<off_t>(done));
      if (n <= 0) bug(std::string("pwrite: ") + std::strerror(errno));
      done += static_cast<std::size_t>(n);
    }
    return path_;
  }

  const std::string& path() const { return path_; }

 private:
  int fd_ = -1;
  std::string dir_;
  std::string path_;
  std::vector<std::string> made_;
};

/// Aborts unless `pose` is a finite rigid transform (what every parser promises of its poses).
inline void check_rigid(const Pose& pose, const char* what) {
  const Eigen::Matrix3d& R = pose.rotation();
  if (!R.allFinite() || !pose.translation().allFinite() ||
      !((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-6) || !(R.determinant() > 0))
    bug(std::string(what) + " is not a finite rigid transform");
}

/// Checks a parser's error message: it names `name` (the file, or `--set`). Line breaks quoted
/// from the input are allowed: main() prints every message through one_line().
inline void check_message(const std::string& message, const std::string& name) {
  if (message.find(name) == std::string::npos)
    bug("error message does not name " + name + ": " + message);
}

/// Runs `parse`; aoscan's Error (usage or bad input, its message naming `name`) is an expected outcome,
/// any other exception escapes and ends the run as a crash. Returns true when `parse` succeeded.
template <class F>
bool expect_errors(const std::string& name, F&& parse) {
  try {
    parse();
    return true;
  } catch (const Error& e) {
    if (e.code() != ExitCode::kUsage && e.code() != ExitCode::kBadInput)
      bug("unexpected exit code " + std::to_string(static_cast<int>(e.code())) + ": " + e.what());
    check_message(e.what(), name);
    return false;
  }
}

}  // namespace aoscan::fuzz
