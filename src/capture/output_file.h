/// @file output_file.h
/// @brief Writing files of a recording or dump: an owned FILE* whose close is checked, so that a
/// full disk is an error naming the file rather than a silently short file.
#pragma once

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>

#include "core/checked_close.h"
#include "core/status.h"
#include "io/atomic_write.h"

namespace aoscan {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using OutputFile = std::unique_ptr<std::FILE, FileCloser>;

/// Opens `path` for writing; throws naming the file when it cannot.
inline OutputFile open_output(const std::string& path, const char* mode = "wb") {
  OutputFile file(std::fopen(path.c_str(), mode));
  if (!file) throw_write_failed(path);
  return file;
}

/// Closes `file`, throwing when buffered data could not be written.
inline void close_checked(OutputFile& file, const std::string& path) {
  std::FILE* f = file.release();
  close_checked(f, path);
}

/// Readies `dir` for a new recording or dump and returns it without trailing slashes: refuses
/// (usage_error) a folder that already holds `marker` (e.g. depth.txt), so nothing is overwritten,
/// and creates `dir/subdir` (or `dir` when subdir is empty) with its parents.
inline std::string prepare_output_folder(std::string dir, const std::string& marker,
                                         const std::string& what, const std::string& subdir = "") {
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  std::error_code ec;
  if (std::filesystem::exists(dir + "/" + marker, ec))
    throw usage_error(dir + ": already holds " + what + " (" + marker + "); choose another folder");
  const std::string create = subdir.empty() ? dir : dir + "/" + subdir;
  require_writable_folder(create, create);
  return dir;
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
