/// @file output_folder.h
/// @brief The output folder of one run: checked before the run, cleared of an earlier run's
/// files, then written file by file (each atomically, io/atomic_write.h), recording what was
/// written and what failed; and where the export stands, for the signal handling thread.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace aoscan {

/// Where the export of a run stands, read from any thread: a second stop signal during the export
/// reports it, a third says what stays unwritten.
class ExportProgress {
 public:
  /// The export starts; `pending` are the files it will write, in order.
  void start(std::vector<std::string> pending);
  /// Now working on `what` (a file name, or a step such as "extracting the mesh").
  void step(const std::string& what);
  /// `name` is complete (written or given up): no longer pending.
  void done(const std::string& name);
  bool exporting() const;
  /// "writing mesh.ply, 3 s so far" (empty before the export).
  std::string describe() const;
  /// The files not yet complete, in order.
  std::vector<std::string> pending() const;

 private:
  using Clock = std::chrono::steady_clock;
  mutable std::mutex mutex_;
  bool started_ = false;
  Clock::time_point start_;
  std::string step_;
  std::vector<std::string> pending_;
};

/// One run's output folder.
class OutputFolder {
 public:
  /// `progress` (may be null) is told about every file written.
  OutputFolder(std::string dir, ExportProgress* progress);

  /// Before the run: creates the folder, checks that a file can be created in it (usage_error,
  /// exit 2, naming the folder), and moves the files of an earlier run that it holds — regular
  /// files named in `names` (a name ending in '/' names a folder of outputs, moved whole) and any
  /// unfinished `*.partial` — into `previous/` inside it
  /// (replacing what an older run left there), so that the folder only ever holds this run's
  /// outputs. Something other than a file (a folder) under a name in `writes`, the files this run
  /// will write, is a usage error; under other names it is left alone. Returns the names moved.
  std::vector<std::string> prepare(const std::vector<std::string>& names,
                                   const std::vector<std::string>& writes);

  const std::string& dir() const { return dir_; }
  std::string path(const std::string& name) const;

  /// Writes output `name` by `write(path)`. A failure (any exception) is recorded with its
  /// one-line message and logged, and false returned: the other outputs are still written.
  bool write(const std::string& name, const std::function<void(const std::string& path)>& write);

  /// stats.json's "files": the outputs written, each with its size in bytes.
  nlohmann::json files_json() const;
  /// stats.json's "failed_outputs": each failed output's one-line error.
  nlohmann::json failures_json() const;
  /// The first failure's one-line error, which names the file (empty when none).
  std::string first_failure() const;

 private:
  std::string dir_;
  ExportProgress* progress_;
  std::vector<std::pair<std::string, std::uintmax_t>> written_;
  std::vector<std::pair<std::string, std::string>> failed_;
};

}  // namespace aoscan
