/// @file service.h
/// @brief `aoscan serve`: the sessions, the HTTP API, the live view over WebSocket and the web
/// page, on one listening address.
#pragma once

#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/status.h"

namespace aoscan {

struct ServiceOptions {
  std::string listen = "127.0.0.1:8080";  ///< ADDR:PORT (IPv4); port 0 = any free port
  std::string data_dir = "aoscan-data";    ///< recordings to replay and sessions/
  std::string token_file;                  ///< "" = no token (loopback only)
  std::string config_file;                 ///< the sessions' configuration file ("" = defaults)
  std::vector<std::string> sets;           ///< KEY=VALUE for every session
  int threads = 0;                         ///< worker threads of a session (0 = all cores)
  std::string version;
};

/// ADDR:PORT as address and port; throws usage_error naming the option for anything else.
std::pair<std::string, int> parse_listen_address(const std::string& listen);
/// True for an address of the loopback range (127.0.0.0/8, "localhost").
bool loopback_address(const std::string& address);
/// The token of `path`: its first line without surrounding blanks. Throws usage_error naming the
/// file when it cannot be read, is empty or is shorter than 16 characters.
std::string read_token_file(const std::string& path);

class Service {
 public:
  /// Checks the options (usage_error: a bad address, a non-loopback address without a token, an
  /// unreadable token file, a bad configuration, an unwritable data folder) and starts listening.
  explicit Service(const ServiceOptions& options);
  ~Service();
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;

  int port() const;
  /// Stops the running session (its outputs are written) and refuses new ones.
  void shutdown();

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

/// Runs the service until `stop_requested`; then stops the running session, writing its outputs.
ExitCode run_service(const ServiceOptions& options, const std::atomic<bool>& stop_requested);

}  // namespace aoscan
