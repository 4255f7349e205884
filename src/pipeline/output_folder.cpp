/// @file output_folder.cpp
/// @brief Output folder checks, the earlier run's files moved aside, per-file outcomes.
#include "pipeline/output_folder.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "core/log.h"
#include "core/status.h"
#include "io/atomic_write.h"

namespace aoscan {

namespace fs = std::filesystem;

namespace {

/// A name ending in '/' is an output folder (`scans/`), the others output files.
bool is_folder_name(const std::string& name) { return !name.empty() && name.back() == '/'; }

}  // namespace

void ExportProgress::start(std::vector<std::string> pending) {
  std::lock_guard<std::mutex> lock(mutex_);
  started_ = true;
  start_ = Clock::now();
  pending_ = std::move(pending);
}

void ExportProgress::step(const std::string& what) {
  std::lock_guard<std::mutex> lock(mutex_);
  step_ = what;
}

void ExportProgress::done(const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  pending_.erase(std::remove(pending_.begin(), pending_.end(), name), pending_.end());
}

bool ExportProgress::exporting() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return started_;
}

std::string ExportProgress::describe() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!started_) return "";
  const double s = std::chrono::duration<double>(Clock::now() - start_).count();
  return (step_.empty() ? std::string("starting") : step_) + ", " +
         std::to_string(static_cast<long long>(std::floor(s))) + " s so far";
}

std::vector<std::string> ExportProgress::pending() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return pending_;
}

OutputFolder::OutputFolder(std::string dir, ExportProgress* progress)
    : dir_(std::move(dir)), progress_(progress) {}

std::string OutputFolder::path(const std::string& name) const {
  return (fs::path(dir_) / name).string();
}

std::vector<std::string> OutputFolder::prepare(const std::vector<std::string>& names,
                                               const std::vector<std::string>& writes) {
  require_writable_folder(dir_, "--out " + dir_);
  std::error_code ec;
  std::vector<std::string> earlier;
  for (const std::string& name : names) {
    const fs::file_status status = fs::symlink_status(path(name), ec);
    if (!fs::exists(status)) continue;
    if (is_folder_name(name) ? fs::is_directory(status) : fs::is_regular_file(status)) {
      earlier.push_back(name);
    } else if (std::find(writes.begin(), writes.end(), name) != writes.end()) {
      throw usage_error("--out " + dir_ + ": cannot write " + path(name) +
                        ": something other than a file is in the way");
    }
  }
  for (const fs::directory_entry& entry : fs::directory_iterator(dir_, ec)) {
    const std::string name = entry.path().filename().string();
    const std::string suffix = kPartialSuffix;
    if (name.size() > suffix.size() &&
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0) earlier.push_back(name);
  }
  if (earlier.empty()) return earlier;
  const fs::path previous = fs::path(dir_) / "previous";
  fs::create_directories(previous, ec);
  if (ec) throw usage_error("--out " + dir_ + ": cannot create " + previous.string() + ": " + ec.message());
  for (const std::string& name : names) fs::remove_all(previous / name, ec);  // an older run's
  std::string list;
  for (const std::string& name : earlier) {
    fs::rename(path(name), previous / name, ec);
    if (ec)
      throw usage_error("--out " + dir_ + ": cannot move the earlier run's " + name + " to " +
                        previous.string() + ": " + ec.message());
    list += (list.empty() ? "" : ", ") + name;
  }
  spdlog::warn("{} holds an earlier run's {}: moved to {}", dir_, list, previous.string());
  return earlier;
}

bool OutputFolder::write(const std::string& name,
                         const std::function<void(const std::string& path)>& write) {
  if (progress_) progress_->step("writing " + name);
  const std::string file = path(name);
  bool ok = true;
  try {
    write(file);
    std::error_code ec;
    written_.emplace_back(name, fs::file_size(file, ec));
  } catch (const std::exception& e) {
    ok = false;
    failed_.emplace_back(name, one_line(e.what()));
    spdlog::warn("{} not written: {}", name, one_line(e.what()));
  }
  if (progress_) progress_->done(name);
  return ok;
}

nlohmann::json OutputFolder::files_json() const {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [name, bytes] : written_) j[name] = {{"bytes", bytes}};
  return j;
}

nlohmann::json OutputFolder::failures_json() const {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [name, error] : failed_) j[name] = error;
  return j;
}

std::string OutputFolder::first_failure() const {
  return failed_.empty() ? std::string() : failed_.front().second;
}

}  // namespace aoscan
