/// @file api.h
/// @brief The service's HTTP API and web page as a function of a request (README, "The service";
/// the paths scripts rely on are the contract's): authorisation, routing, JSON in and out,
/// errors as {"error": "one line"} with a 4xx/5xx status, and the one controlling client.
#pragma once

#include <chrono>
#include <mutex>
#include <optional>
#include <string>

#include "serve/http_server.h"
#include "serve/sessions.h"

namespace aoscan {

/// The name of the cookie the login page sets.
inline constexpr const char* kTokenCookie = "aoscan_token";
/// The header a client names itself with (the web page sends a random id). Requests that
/// change the service (starting or controlling a session) come from one client at a time.
inline constexpr const char* kClientHeader = "X-Aoscan-Client";

struct ApiOptions {
  std::optional<std::string> token;  ///< required on every request when set (non-loopback)
  std::string version;
  /// The controlling client keeps control while it sends a changing request at least this often.
  std::chrono::milliseconds controller_idle{std::chrono::seconds(30)};
};

/// A file of the web page, embedded in the binary at build time.
struct WebAsset {
  const char* path;  ///< "/", "/app.js", ...
  const char* content_type;
  const unsigned char* data;
  std::size_t size;
};
/// The embedded web page's files (generated from src/serve/web/ by CMake).
const std::vector<WebAsset>& web_assets();

class Api {
 public:
  Api(SessionManager& sessions, ApiOptions options);

  /// Answers one request (thread-safe).
  HttpResponse handle(const HttpRequest& request);
  /// True when the request carries the token (header `Authorization: Bearer TOKEN` or the login
  /// cookie), or when the service needs none.
  bool authorised(const HttpRequest& request) const;
  /// The service's status (GET /api/status; also sent to live viewers).
  nlohmann::json status() const;

 private:
  HttpResponse route(const HttpRequest& request);
  HttpResponse session_route(const HttpRequest& request, const std::string& rest);
  HttpResponse login(const HttpRequest& request);
  /// Makes the request's client the controller when nobody else controls the service; false
  /// (with `refusal` filled) when another client does.
  bool take_control(const HttpRequest& request, HttpResponse& refusal);

  SessionManager& sessions_;
  ApiOptions options_;
  std::chrono::steady_clock::time_point started_;
  std::mutex control_mutex_;
  std::optional<std::string> controller_;
  std::chrono::steady_clock::time_point controller_seen_;
};

/// {"error": message} with `status`.
HttpResponse error_response(int status, const std::string& message);
/// `value` as a 200 JSON response.
HttpResponse json_response(const nlohmann::json& value, int status = 200);

/// Compares a presented token with the service's in time independent of where they differ.
bool token_matches(const std::string& presented, const std::string& token);

}  // namespace aoscan
