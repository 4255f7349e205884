/// @file sessions.h
/// @brief The service's sessions: one scan or replay at a time through the same session as
/// `aoscan replay`/`scan` (same outputs, same stats.json), each in `DATA/sessions/ID/` with its
/// record `DATA/sessions/ID.json` (source, settings, state), so that finished sessions outlive the
/// process and a session cut short by a crash is found and marked `interrupted` on restart.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "render/view_commands.h"
#include "serve/live_stream.h"
#include "serve/session_request.h"

namespace aoscan {

struct SessionManagerOptions {
  std::filesystem::path data_dir;    ///< recordings (relative sources) and sessions/
  std::string config_file;           ///< the service's --config ("" = none)
  std::vector<std::string> sets;     ///< the service's --set KEY=VALUE, before a session's own
  int threads = 0;                   ///< worker threads of a session; 0 = all cores
};

class SessionManager {
 public:
  /// Reads the records under data_dir/sessions/ (creating it), marking a record left `running` by
  /// a process that ended without finishing it as `interrupted`. Throws usage_error when data_dir
  /// cannot be created or written.
  explicit SessionManager(SessionManagerOptions options);
  /// Stops a running session as a signal would (its outputs are written) and waits for it.
  ~SessionManager();
  SessionManager(const SessionManager&) = delete;
  SessionManager& operator=(const SessionManager&) = delete;

  /// Checks the request (source, configuration), opens the source and starts the session on its
  /// own thread; returns its id. Throws ServiceError: 400 for a bad source or setting, 404 for a
  /// recording that does not exist, 409 while another session runs, 503 for a camera that cannot
  /// be opened.
  std::string start(const SessionRequest& request);
  /// Every session, newest first (their records).
  nlohmann::json list() const;
  /// One session's record; while it runs also its live figures; once finished its stats.json.
  /// Throws ServiceError 404 for an unknown id.
  nlohmann::json describe(const std::string& id) const;
  /// pause, resume, reset, save or stop (the window's space, r, s and q). Throws ServiceError 404
  /// (unknown id or action), 409 (the session is not running).
  void control(const std::string& id, const std::string& action);
  /// The path of output file `name` of a finished session. Throws ServiceError 400 for a name that
  /// is not a plain file name, 404 for an unknown session or file, 409 while the session runs.
  std::filesystem::path file(const std::string& id, const std::string& name) const;
  /// The running session's id, or nullopt.
  std::optional<std::string> running() const;
  /// The recordings under data_dir (TUM folders with depth.txt, .oni files), relative paths.
  nlohmann::json recordings() const;
  /// Stops the running session (outputs written) and waits for it; new sessions are refused.
  void shutdown();

  LiveStream& stream() { return stream_; }

 private:
  struct Running;
  void write_record(const nlohmann::json& record) const;
  std::filesystem::path record_path(const std::string& id) const;
  std::string new_id();

  SessionManagerOptions options_;
  std::filesystem::path sessions_dir_;
  mutable std::mutex mutex_;
  std::unique_ptr<Running> running_;  ///< the session on its thread (or the last one, joined)
  bool shut_down_ = false;
  LiveStream stream_;
};

/// True for `name` as a file name of a session's folder that may be served: letters, digits,
/// '.', '-', '_', not starting with '.', at most 128 characters.
bool plain_file_name(const std::string& name);

/// True for a session id as the service makes them (digits, letters and '-').
bool plausible_session_id(const std::string& id);

}  // namespace aoscan
