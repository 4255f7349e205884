/// @file atomic_write.h
/// @brief Writing an output file so that it is never seen half-written: the data go to
/// `NAME.partial` in the same folder, are flushed to disk, and the file is then renamed to `NAME`.
/// A reader (or a later run) finds either the old file or the complete new one; an interrupted
/// write leaves only a `.partial` file, whose name says what it is.
#pragma once

#include <functional>
#include <string>

namespace aoscan {

/// What is appended to a file's name while it is being written.
inline constexpr const char* kPartialSuffix = ".partial";

/// Writes `path` by way of `path + kPartialSuffix`: `write(partial_path)` creates and fills the
/// partial file (throwing on failure), which is then flushed to disk (fsync) and renamed over
/// `path`. On any failure the partial file is removed, `path` is left as it was, and an Error
/// naming `path` (not the partial file) is thrown, with the code of the writer's error.
void write_atomically(const std::string& path,
                      const std::function<void(const std::string& partial_path)>& write);

/// Creates folder `dir` (with its parents) and checks that a file can be created in it, so that an
/// unwritable output folder is found before a run, not after it. Throws usage_error (exit 2)
/// beginning with `label` (e.g. "--out DIR") otherwise.
void require_writable_folder(const std::string& dir, const std::string& label);

}  // namespace aoscan
