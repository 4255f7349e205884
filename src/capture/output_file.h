/// @file output_file.h
/// @brief Writing files of a recording or dump: an owned FILE* whose close is checked, so that a
/// full disk is an error naming the file rather than a silently short file.
#pragma once

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>

#include "core/status.h"

namespace aoscan {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using OutputFile = std::unique_ptr<std::FILE, FileCloser>;

/// Throws Error(kFailure) "PATH: cannot write: <errno text>".
[[noreturn]] inline void throw_write_failed(const std::string& path) {
  throw Error(ExitCode::kFailure, path + ": cannot write: " + std::strerror(errno ? errno : EIO));
}

/// Opens `path` for writing; throws naming the file when it cannot.
inline OutputFile open_output(const std::string& path, const char* mode = "wb") {
  OutputFile file(std::fopen(path.c_str(), mode));
  if (!file) throw_write_failed(path);
  return file;
}

/// Closes `file`, throwing when buffered data could not be written.
inline void close_checked(OutputFile& file, const std::string& path) {
  if (!file) return;
  const bool failed = std::ferror(file.get()) != 0;
  const int rc = std::fclose(file.release());
  if (failed || rc != 0) throw_write_failed(path);
}

/// Throws the Error matching a stream-ending status (bad input: exit 3, device lost: exit 4).
[[noreturn]] inline void throw_for_status(const Status& status) {
  switch (status.code()) {
    case Status::Code::kBadInput:
      throw input_error(status.message());
    case Status::Code::kDeviceLost:
      throw device_error(status.message());
    default:
      throw Error(ExitCode::kFailure, status.message());
  }
}

}  // namespace aoscan
