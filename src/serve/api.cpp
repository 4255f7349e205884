/// @file api.cpp
/// @brief Routing of the service's HTTP API.
#include "serve/api.h"

#include <algorithm>

#include "capture/devices.h"

namespace aoscan {

namespace {

constexpr std::size_t kMaxClientId = 64;

/// The path's segments after `prefix` ("/api/sessions/ID/files/NAME" -> ID, files, NAME).
std::vector<std::string> segments(const std::string& path) {
  std::vector<std::string> out;
  std::size_t at = 0;
  while (at <= path.size()) {
    std::size_t end = path.find('/', at);
    if (end == std::string::npos) end = path.size();
    out.push_back(path.substr(at, end - at));
    at = end + 1;
  }
  return out;
}

/// The content type of a session's file by its extension.
std::string content_type_of(const std::string& name) {
  static const std::pair<const char*, const char*> kTypes[] = {
      {".json", "application/json"}, {".txt", "text/plain"}, {".png", "image/png"},
      {".glb", "model/gltf-binary"}, {".ply", "application/octet-stream"}};
  const std::size_t dot = name.rfind('.');
  const std::string extension = dot == std::string::npos ? "" : name.substr(dot);
  for (const auto& [ext, type] : kTypes)
    if (extension == ext) return type;
  return "application/octet-stream";
}

/// 303 See Other to `location`.
HttpResponse redirect(const std::string& location) {
  HttpResponse response;
  response.status = 303;
  response.content_type = "text/plain";
  response.headers.emplace_back("Location", location);
  return response;
}

HttpResponse method_not_allowed(const HttpRequest& request, const char* allowed) {
  HttpResponse response = error_response(405, request.method + " " + request.path +
                                                  ": not allowed here (" + allowed + ")");
  response.headers.emplace_back("Allow", allowed);
  return response;
}

std::string client_of(const HttpRequest& request) {
  std::string id = request.header(kClientHeader).value_or("");
  if (id.size() > kMaxClientId) id.resize(kMaxClientId);
  return id.empty() ? "anonymous" : id;
}

}  // namespace

HttpResponse error_response(int status, const std::string& message) {
  return json_response({{"error", one_line(message)}}, status);
}

HttpResponse json_response(const nlohmann::json& value, int status) {
  HttpResponse response;
  response.status = status;
  response.body = value.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  return response;
}

bool token_matches(const std::string& presented, const std::string& token) {
  unsigned char diff = presented.size() == token.size() ? 0 : 1;
  for (std::size_t i = 0; i < presented.size(); ++i)
    diff |= static_cast<unsigned char>(presented[i] ^ token[i % std::max<std::size_t>(token.size(), 1)]);
  return diff == 0 && !token.empty();
}

Api::Api(SessionManager& sessions, ApiOptions options)
    : sessions_(sessions), options_(std::move(options)), started_(std::chrono::steady_clock::now()) {}

bool Api::authorised(const HttpRequest& request) const {
  if (!options_.token) return true;
  if (const std::optional<std::string> header = request.header("Authorization")) {
    const std::string prefix = "Bearer ";
    if (header->rfind(prefix, 0) == 0 && token_matches(header->substr(prefix.size()), *options_.token))
      return true;
  }
  const std::optional<std::string> cookie = request.cookie(kTokenCookie);
  return cookie && token_matches(url_decode(*cookie, false), *options_.token);
}

nlohmann::json Api::status() const {
  const double uptime =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  const std::optional<std::string> running = sessions_.running();
  return {{"version", options_.version},
          {"uptime_s", uptime},
          {"session", running ? nlohmann::json(*running) : nlohmann::json(nullptr)},
          {"viewers", sessions_.stream().viewers()}};
}

bool Api::take_control(const HttpRequest& request, HttpResponse& refusal) {
  const std::string client = client_of(request);
  const auto now = std::chrono::steady_clock::now();
  std::lock_guard<std::mutex> lock(control_mutex_);
  if (controller_ && *controller_ != client && now - controller_seen_ < options_.controller_idle) {
    const auto idle_s = std::chrono::duration_cast<std::chrono::seconds>(options_.controller_idle);
    refusal = error_response(409, "another client controls the service; watch, or take control "
                                  "once it has been idle for " +
                                      std::to_string(idle_s.count()) + " s");
    return false;
  }
  controller_ = client;
  controller_seen_ = now;
  return true;
}

HttpResponse Api::login(const HttpRequest& request) {
  const std::optional<std::string> token = form_value(request.body, "token");
  if (!options_.token || (token && token_matches(*token, *options_.token))) {
    HttpResponse response = redirect("/");
    if (options_.token)
      response.headers.emplace_back("Set-Cookie", std::string(kTokenCookie) + "=" + *options_.token +
                                                      "; Path=/; HttpOnly; SameSite=Strict");
    return response;
  }
  return redirect("/login?failed=1");
}

HttpResponse Api::handle(const HttpRequest& request) {
  try {
    return route(request);
  } catch (const ServiceError& e) {
    return error_response(e.status(), e.what());
  } catch (const Error& e) {
    return error_response(500, e.what());
  }
}

HttpResponse Api::route(const HttpRequest& request) {
  const std::string& path = request.path;
  const bool get = request.method == "GET";
  if (path == "/login") {
    if (request.method == "POST") return login(request);
    if (!get) return method_not_allowed(request, "GET, POST");
  } else if (!authorised(request)) {
    if (path.rfind("/api/", 0) == 0) {
      HttpResponse response = error_response(
          401, "this service needs its token: send 'Authorization: Bearer TOKEN' or log in at "
               "/login");
      response.headers.emplace_back("WWW-Authenticate", "Bearer");
      return response;
    }
    return redirect("/login");  // a browser: the login page
  }

  if (path.rfind("/api/", 0) != 0) {  // the web page
    const std::string asset_path = path == "/index.html" ? "/" : path;
    for (const WebAsset& asset : web_assets()) {
      if (asset_path != asset.path) continue;
      if (!get) return method_not_allowed(request, "GET");
      HttpResponse response;
      response.content_type = asset.content_type;
      response.body.assign(reinterpret_cast<const char*>(asset.data), asset.size);
      return response;
    }
    return error_response(404, "no page " + path);
  }

  if (path == "/api/status") {
    if (!get) return method_not_allowed(request, "GET");
    return json_response(status());
  }
  if (path == "/api/devices") {
    if (!get) return method_not_allowed(request, "GET");
    nlohmann::json devices = nlohmann::json::array();
    for (const DeviceInfo& d : list_devices())
      devices.push_back({{"uri", d.uri}, {"description", d.description}});
    return json_response({{"devices", devices}, {"searched", devices_searched()}});
  }
  if (path == "/api/recordings") {
    if (!get) return method_not_allowed(request, "GET");
    return json_response({{"recordings", sessions_.recordings()}});
  }
  if (path == "/api/sessions") {
    if (get) return json_response({{"sessions", sessions_.list()}});
    if (request.method != "POST") return method_not_allowed(request, "GET, POST");
    const SessionRequest session = parse_session_request(request.body);
    HttpResponse refusal;
    if (!take_control(request, refusal)) return refusal;
    return json_response({{"id", sessions_.start(session)}}, 201);
  }
  const std::string prefix = "/api/sessions/";
  if (path.rfind(prefix, 0) == 0) return session_route(request, path.substr(prefix.size()));
  return error_response(404, "no endpoint " + path);
}

HttpResponse Api::session_route(const HttpRequest& request, const std::string& rest) {
  const std::vector<std::string> parts = segments(rest);
  const std::string& id = parts[0];
  const bool get = request.method == "GET";
  if (parts.size() == 1) {
    if (!get) return method_not_allowed(request, "GET");
    return json_response(sessions_.describe(id));
  }
  if (parts.size() == 2 && parts[1] == "live")
    return error_response(400, "/api/sessions/" + id + "/live is a WebSocket: open it with an "
                                                        "Upgrade request");
  if (parts.size() == 2) {
    if (request.method != "POST") return method_not_allowed(request, "POST");
    HttpResponse refusal;
    if (!take_control(request, refusal)) return refusal;
    sessions_.control(id, parts[1]);
    return json_response({{"id", id}, {"action", parts[1]}});
  }
  if (parts.size() == 3 && parts[1] == "files") {
    if (!get) return method_not_allowed(request, "GET");
    HttpResponse response;
    response.file_path = sessions_.file(id, parts[2]).string();
    response.content_type = content_type_of(parts[2]);
    response.headers.emplace_back("Content-Disposition",
                                  "attachment; filename=\"" + parts[2] + "\"");
    return response;
  }
  return error_response(404, "no endpoint /api/sessions/" + rest);
}

}  // namespace aoscan
