/// @file sessions.cpp
/// @brief The service's sessions, one at a time, with their records on disk.
#include "serve/sessions.h"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <fstream>
#include <sstream>

#include <spdlog/spdlog.h>

#include "capture/loop_source.h"
#include "capture/source.h"
#include "core/status.h"
#include "io/atomic_write.h"
#include "pipeline/config.h"
#include "pipeline/session.h"

namespace aoscan {

namespace fs = std::filesystem;

namespace {

std::string utc_now(const char* format) {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[64];
  std::strftime(text, sizeof(text), format, &tm);
  return text;
}

int http_status_of(ExitCode code) {
  switch (code) {
    case ExitCode::kUsage:
      return 400;
    case ExitCode::kBadInput:
      return 422;
    case ExitCode::kDevice:
      return 503;
    default:
      return 500;
  }
}

std::optional<nlohmann::json> read_json(const fs::path& path) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception&) {
    return std::nullopt;
  }
}

/// "running", "finished", "failed" or "interrupted" from stats.json's status.
const char* state_of_status(const std::string& status) {
  if (status == "complete") return "finished";
  if (status == "interrupted") return "interrupted";
  return "failed";
}

/// A recording path relative to the data folder: no absolute path, no "..", nothing hidden.
bool safe_relative(const std::string& source) {
  if (source.empty() || source.front() == '/' || source.size() > 1024) return false;
  for (const fs::path& part : fs::path(source)) {
    const std::string s = part.string();
    if (s == ".." || (!s.empty() && s.front() == '.' && s != ".")) return false;
  }
  return true;
}

}  // namespace

bool plain_file_name(const std::string& name) {
  if (name.empty() || name.size() > 128 || name.front() == '.') return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
           c == '.' || c == '-' || c == '_';
  });
}

bool plausible_session_id(const std::string& id) {
  return !id.empty() && id.size() <= 64 && id.front() != '-' &&
         std::all_of(id.begin(), id.end(), [](char c) {
           return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                  c == '-';
         });
}

struct SessionManager::Running {
  std::string id;
  nlohmann::json record;  ///< guarded by the manager's mutex
  std::unique_ptr<Source> source;
  ViewCommandQueue commands;
  std::atomic<bool> stop{false};
  std::atomic<bool> done{false};
  mutable std::mutex progress_mutex;
  Progress progress;
  std::thread thread;
};

SessionManager::SessionManager(SessionManagerOptions options)
    : options_(std::move(options)), sessions_dir_(options_.data_dir / "sessions") {
  require_writable_folder(sessions_dir_.string(), "--data " + options_.data_dir.string());
  std::error_code ec;
  for (const fs::directory_entry& entry : fs::directory_iterator(sessions_dir_, ec)) {
    if (entry.path().extension() != ".json" || !entry.is_regular_file()) continue;
    std::optional<nlohmann::json> record = read_json(entry.path());
    if (!record || !record->is_object() || record->value("state", "") != "running") continue;
    // The process that ran it ended first (killed, crashed, powered off).
    const std::string id = record->value("id", "");
    const std::optional<nlohmann::json> stats =
        plausible_session_id(id) ? read_json(sessions_dir_ / id / "stats.json") : std::nullopt;
    if (stats && stats->contains("status")) {
      (*record)["state"] = state_of_status(stats->value("status", ""));
    } else {
      (*record)["state"] = "interrupted";
      (*record)["error"] = "the service ended while this session ran; its outputs were not written";
    }
    spdlog::warn("serve: session {} was cut short by the end of an earlier service; marked {}",
                 id, (*record)["state"].get<std::string>());
    write_record(*record);
  }
}

SessionManager::~SessionManager() { shutdown(); }

fs::path SessionManager::record_path(const std::string& id) const {
  return sessions_dir_ / (id + ".json");
}

void SessionManager::write_record(const nlohmann::json& record) const {
  const std::string text = record.dump(2) + "\n";
  write_atomically(record_path(record.at("id").get<std::string>()).string(),
                   [&text](const std::string& partial) {
                     std::ofstream out(partial, std::ios::binary);
                     out << text;
                     out.close();
                     if (!out) throw_write_failed(partial);
                   });
}

std::string SessionManager::new_id() {
  const std::string base = utc_now("%Y%m%d-%H%M%S");
  std::string id = base;
  for (int n = 2; fs::exists(record_path(id)) || fs::exists(sessions_dir_ / id); ++n)
    id = base + "-" + std::to_string(n);
  return id;
}

std::string SessionManager::start(const SessionRequest& request) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (shut_down_) throw ServiceError(503, "the service is stopping");
  if (running_ && !running_->done.load())
    throw ServiceError(409, "session " + running_->id + " is running; stop it first");
  if (running_) {
    running_->thread.join();
    running_.reset();
  }

  // The source: synthetic scenes and cameras as they are, recordings under the data folder.
  std::string spec = request.source;
  const bool synthetic = spec.rfind("synth:", 0) == 0;
  if (!synthetic && !is_camera_spec(spec)) {
    if (!safe_relative(spec))
      throw ServiceError(400, "source '" + spec +
                                  "': a recording is named by its path under the data folder "
                                  "(no absolute path, no '..')");
    const fs::path path = options_.data_dir / spec;
    std::error_code ec;
    if (!fs::exists(path, ec))
      throw ServiceError(404, "source '" + spec + "': no such recording in the data folder");
    spec = path.string();
  }
  std::vector<std::string> sets = options_.sets;
  sets.insert(sets.end(), request.sets.begin(), request.sets.end());
  Config config;
  try {
    config = load_config(options_.config_file, sets);
  } catch (const Error& e) {
    std::string message = one_line(e.what());
    if (message.rfind("--set: ", 0) == 0) message = "\"set\": " + message.substr(7);
    throw ServiceError(http_status_of(e.code()), message);
  }
  std::unique_ptr<Source> source;
  try {
    source = open_source(spec);
    if (request.loop) source = make_loop_source(std::move(source), *request.loop);
  } catch (const Error& e) {
    // Name the source as the client gave it, not the service's path of it.
    std::string message = one_line(e.what());
    if (spec != request.source)
      for (std::size_t at; (at = message.find(spec)) != std::string::npos;)
        message.replace(at, spec.size(), request.source);
    throw ServiceError(http_status_of(e.code()), message);
  }

  auto running = std::make_unique<Running>();
  running->id = new_id();
  running->source = std::move(source);
  nlohmann::json set = nlohmann::json::object();
  for (const std::string& kv : request.sets) {
    const std::size_t eq = kv.find('=');
    set[kv.substr(0, eq)] = eq == std::string::npos ? "" : kv.substr(eq + 1);
  }
  running->record = {{"id", running->id},
                     {"source", request.source},
                     {"set", set},
                     {"realtime", request.realtime},
                     {"state", "running"},
                     {"started", utc_now("%Y-%m-%dT%H:%M:%SZ")}};
  if (request.max_frames) running->record["frames"] = *request.max_frames;
  if (request.loop) running->record["loop"] = *request.loop;
  try {
    write_record(running->record);
  } catch (const Error& e) {
    throw ServiceError(500, one_line(e.what()));
  }

  RunOptions options;
  options.config = config;
  options.out_dir = (sessions_dir_ / running->id).string();
  options.threads = options_.threads;
  options.chain.realtime = request.realtime;
  options.chain.max_frames = request.max_frames;
  options.commands = &running->commands;
  options.remote_view = [this](ViewStage* stage) { stream_.attach(stage); };
  Running* r = running.get();
  options.chain.on_progress = [r](const Progress& p) {
    std::lock_guard<std::mutex> progress_lock(r->progress_mutex);
    r->progress = p;
  };
  running_ = std::move(running);
  const std::string id = r->id;
  spdlog::info("serve: session {} started: {}", id, request.source);
  r->thread = std::thread([this, r, options] {
    nlohmann::json ended;
    try {
      const SessionResult result = run_session(*r->source, options, r->stop);
      ended["state"] = state_of_status(result.status());
      ended["exit_code"] = static_cast<int>(result.exit_code);
      if (!result.error.empty()) ended["error"] = one_line(result.error);
    } catch (const std::exception& e) {
      ended["state"] = "failed";
      ended["exit_code"] = static_cast<int>(ExitCode::kFailure);
      ended["error"] = one_line(e.what());
    }
    ended["ended"] = utc_now("%Y-%m-%dT%H:%M:%SZ");
    r->source.reset();  // a camera is free for the next session
    // The record on disk and in memory change together: once a client sees the session ended,
    // the next one can start.
    std::lock_guard<std::mutex> lock(mutex_);
    r->record.update(ended);
    try {
      write_record(r->record);
    } catch (const std::exception& e) {
      spdlog::error("serve: session {}: {}", r->id, e.what());
    }
    spdlog::info("serve: session {} {}", r->id, r->record.value("state", ""));
    r->done.store(true);
  });
  return id;
}

nlohmann::json SessionManager::list() const {
  std::vector<nlohmann::json> records;
  std::error_code ec;
  for (const fs::directory_entry& entry : fs::directory_iterator(sessions_dir_, ec)) {
    if (entry.path().extension() != ".json") continue;
    const std::string id = entry.path().stem().string();
    if (!plausible_session_id(id)) continue;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (running_ && running_->id == id) {
        records.push_back(running_->record);
        continue;
      }
    }
    if (std::optional<nlohmann::json> record = read_json(entry.path()); record && record->is_object())
      records.push_back(*record);
  }
  std::sort(records.begin(), records.end(), [](const nlohmann::json& a, const nlohmann::json& b) {
    return a.value("id", "") > b.value("id", "");
  });
  return records;
}

nlohmann::json SessionManager::describe(const std::string& id) const {
  if (!plausible_session_id(id)) throw ServiceError(404, "no session '" + id + "'");
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (running_ && running_->id == id && !running_->done.load()) {
      nlohmann::json out = running_->record;
      Progress p;
      {
        std::lock_guard<std::mutex> progress_lock(running_->progress_mutex);
        p = running_->progress;
      }
      nlohmann::json live = {{"frames_read", p.frames_read},
                             {"frames_processed", p.frames_processed},
                             {"frames_dropped", p.frames_dropped},
                             {"elapsed_s", p.elapsed_s},
                             {"frames_expected", nullptr},
                             {"integration_paused", running_->commands.integration_paused()}};
      if (p.frames_expected) live["frames_expected"] = *p.frames_expected;
      if (p.elapsed_s > 0) live["fps"] = static_cast<double>(p.frames_processed) / p.elapsed_s;
      live["view"] = stream_.figures().to_json();
      out["live"] = live;
      return out;
    }
  }
  std::optional<nlohmann::json> record = read_json(record_path(id));
  if (!record || !record->is_object()) throw ServiceError(404, "no session '" + id + "'");
  if (std::optional<nlohmann::json> stats = read_json(sessions_dir_ / id / "stats.json"))
    (*record)["stats"] = *stats;
  nlohmann::json files = nlohmann::json::array();
  std::error_code ec;
  std::vector<std::string> names;
  for (const fs::directory_entry& entry : fs::directory_iterator(sessions_dir_ / id, ec)) {
    const std::string name = entry.path().filename().string();
    if (plain_file_name(name) && entry.is_regular_file() && !entry.is_symlink())
      names.push_back(name);
  }
  std::sort(names.begin(), names.end());
  for (const std::string& name : names) files.push_back(name);
  (*record)["files"] = files;
  return *record;
}

void SessionManager::control(const std::string& id, const std::string& action) {
  std::optional<ViewCommand> command;
  if (action == "pause") command = ViewCommand::kPauseIntegration;
  if (action == "resume") command = ViewCommand::kResumeIntegration;
  if (action == "reset") command = ViewCommand::kResetModel;
  if (action == "save") command = ViewCommand::kWriteOutputs;
  if (action == "stop") command = ViewCommand::kQuit;
  if (!command)
    throw ServiceError(404, "unknown action '" + action +
                                "' (pause, resume, reset, save or stop)");
  std::lock_guard<std::mutex> lock(mutex_);
  if (!running_ || running_->id != id || running_->done.load()) {
    if (plausible_session_id(id) && fs::exists(record_path(id)))
      throw ServiceError(409, "session " + id + " is not running");
    throw ServiceError(404, "no session '" + id + "'");
  }
  if (!running_->commands.push(*command))
    throw ServiceError(503, "session " + id + " has too many commands waiting; try again");
}

fs::path SessionManager::file(const std::string& id, const std::string& name) const {
  if (!plain_file_name(name))
    throw ServiceError(400, "'" + name + "' is not a file name of a session");
  if (!plausible_session_id(id) || !fs::exists(record_path(id)))
    throw ServiceError(404, "no session '" + id + "'");
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (running_ && running_->id == id && !running_->done.load())
      throw ServiceError(409, "session " + id + " is still running; its files come at its end");
  }
  const fs::path path = sessions_dir_ / id / name;
  std::error_code ec;
  if (!fs::is_regular_file(fs::symlink_status(path, ec)))
    throw ServiceError(404, "session " + id + " has no file '" + name + "'");
  return path;
}

std::optional<std::string> SessionManager::running() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (running_ && !running_->done.load()) return running_->id;
  return std::nullopt;
}

nlohmann::json SessionManager::recordings() const {
  std::vector<std::string> found;
  std::error_code ec;
  const fs::directory_options opts = fs::directory_options::skip_permission_denied;
  for (fs::recursive_directory_iterator it(options_.data_dir, opts, ec), end; it != end;
       it.increment(ec)) {
    if (ec) break;
    const fs::path relative = it->path().lexically_relative(options_.data_dir);
    const std::string first = relative.begin()->string();
    if (it.depth() == 0 && first == "sessions") {
      it.disable_recursion_pending();
      continue;
    }
    const std::string name = it->path().filename().string();
    if (!name.empty() && name.front() == '.') {
      it.disable_recursion_pending();
      continue;
    }
    if (it->is_directory(ec)) {
      if (fs::exists(it->path() / "depth.txt", ec)) {
        found.push_back(relative.string());
        it.disable_recursion_pending();
      } else if (it.depth() >= 2) {
        it.disable_recursion_pending();
      }
    } else if (it->path().extension() == ".oni" && it->is_regular_file(ec)) {
      found.push_back(relative.string());
    }
  }
  std::sort(found.begin(), found.end());
  return found;
}

void SessionManager::shutdown() {
  Running* r = nullptr;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    shut_down_ = true;
    r = running_.get();
    if (r) r->stop.store(true);
  }
  if (r && r->thread.joinable()) r->thread.join();
}

}  // namespace aoscan
