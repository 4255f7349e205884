/// @file checked_close.h
/// @brief Closing a file that was written to, with the write errors that only show then.
#pragma once

#include <cstdio>
#include <string>

#include "core/status.h"

namespace aoscan {

/// Closes `file` (a file written to; null afterwards, nothing when it is null already) and throws
/// throw_write_failed(path) when a write into it or the close failed.
inline void close_checked(std::FILE*& file, const std::string& path) {
  if (!file) return;
  const bool failed = std::ferror(file) != 0;
  const int rc = std::fclose(file);
  file = nullptr;
  if (failed || rc != 0) throw_write_failed(path);
}

}  // namespace aoscan
