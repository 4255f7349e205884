/// @file service.cpp
/// @brief The service: sessions, API, live viewers and the server, wired together.
#include "serve/service.h"

#include <arpa/inet.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <thread>

#include <spdlog/spdlog.h>

#include "core/host_cpu.h"
#include "pipeline/config.h"
#include "serve/api.h"
#include "serve/http_server.h"
#include "serve/live_stream.h"
#include "serve/sessions.h"

namespace aoscan {

namespace {

constexpr std::size_t kMinTokenLength = 16;
/// How often a viewer is sent the status (text messages beside the frames).
constexpr std::chrono::milliseconds kStatusInterval{500};

/// One WebSocket viewer: its slot in the stream and the thread that sends to it.
struct ViewerConnection {
  std::shared_ptr<LiveViewer> viewer;
  std::string session;  ///< the session it asked for ("current": whichever runs)
  std::atomic<bool> done{false};
  std::thread sender;
};

/// ID of a path /api/sessions/ID/live, or nullopt for any other path.
std::optional<std::string> live_session_of(const std::string& path) {
  const std::string prefix = "/api/sessions/";
  const std::string suffix = "/live";
  if (path.rfind(prefix, 0) != 0 || path.size() <= prefix.size() + suffix.size() ||
      path.compare(path.size() - suffix.size(), suffix.size(), suffix) != 0)
    return std::nullopt;
  return path.substr(prefix.size(), path.size() - prefix.size() - suffix.size());
}

}  // namespace

std::pair<std::string, int> parse_listen_address(const std::string& listen) {
  const std::size_t colon = listen.rfind(':');
  const std::string bad = "--listen " + listen + ": expected ADDR:PORT, e.g. 127.0.0.1:8080";
  if (colon == std::string::npos || colon == 0) throw usage_error(bad);
  std::string address = listen.substr(0, colon);
  const std::string port_text = listen.substr(colon + 1);
  if (port_text.empty() || port_text.size() > 5 ||
      port_text.find_first_not_of("0123456789") != std::string::npos)
    throw usage_error(bad);
  const int port = std::stoi(port_text);
  if (port > 65535) throw usage_error("--listen " + listen + ": the port is 0 to 65535");
  if (address == "localhost") address = "127.0.0.1";
  in_addr parsed{};
  if (inet_pton(AF_INET, address.c_str(), &parsed) != 1)
    throw usage_error("--listen " + listen + ": '" + address +
                      "' is not an IPv4 address (e.g. 127.0.0.1, 0.0.0.0)");
  return {address, port};
}

bool loopback_address(const std::string& address) {
  if (address == "localhost") return true;
  in_addr parsed{};
  if (inet_pton(AF_INET, address.c_str(), &parsed) != 1) return false;
  return (ntohl(parsed.s_addr) >> 24) == 127;
}

std::string read_token_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw usage_error("--token-file " + path + ": cannot be read");
  std::string line;
  std::getline(in, line);
  const std::size_t first = line.find_first_not_of(" \t\r");
  const std::size_t last = line.find_last_not_of(" \t\r");
  const std::string token = first == std::string::npos ? "" : line.substr(first, last - first + 1);
  if (token.size() < kMinTokenLength)
    throw usage_error("--token-file " + path + ": the token (its first line) must be at least " +
                      std::to_string(kMinTokenLength) + " characters");
  if (token.find_first_of(" ;,\"\\") != std::string::npos)
    throw usage_error("--token-file " + path +
                      ": the token may not hold spaces, quotes, ';', ',' or backslashes");
  return token;
}

struct Service::Impl {
  std::unique_ptr<SessionManager> sessions;
  std::unique_ptr<Api> api;
  std::unique_ptr<HttpServer> server;  ///< last: stopped first

  nlohmann::json viewer_status(const std::string& session) {
    nlohmann::json status = api->status();
    const std::optional<std::string> running = sessions->running();
    const std::string id = session == "current" ? running.value_or("") : session;
    if (!id.empty()) {
      try {
        status["state"] = sessions->describe(id);
      } catch (const ServiceError&) {
      }
    }
    return status;
  }

  WebSocketHandler websocket() {
    WebSocketHandler handler;
    handler.accept = [this](const HttpRequest& request, HttpResponse& refusal) {
      if (!api->authorised(request)) {
        refusal = error_response(401, "the live view needs the service's token");
        return false;
      }
      const std::optional<std::string> id = live_session_of(request.path);
      if (!id) {
        refusal = error_response(404, "no WebSocket at " + request.path);
        return false;
      }
      if (*id != "current" && !plausible_session_id(*id)) {
        refusal = error_response(404, "no session '" + *id + "'");
        return false;
      }
      return true;
    };
    handler.opened = [this](const HttpRequest& request,
                            WebSocketPeer& peer) -> std::shared_ptr<void> {
      auto connection = std::make_shared<ViewerConnection>();
      connection->session = live_session_of(request.path).value_or("current");
      View view = View::kShaded;
      if (const std::optional<std::string> name = form_value(request.query, "view"))
        view = view_named(*name).value_or(View::kShaded);
      connection->viewer = sessions->stream().add_viewer(view);
      if (!connection->viewer) {
        const std::string full =
            R"({"error": "too many viewers; close another live view first"})";
        peer.send(reinterpret_cast<const std::uint8_t*>(full.data()), full.size(), false);
        return connection;  // no sender: the client closes
      }
      ViewerConnection* c = connection.get();
      c->sender = std::thread([this, c, &peer] {
        lower_thread_priority(kViewerNice);  // sending yields to fusion too
        auto next_status = std::chrono::steady_clock::now();
        while (!c->done.load()) {
          if (std::chrono::steady_clock::now() >= next_status) {
            const std::string text = viewer_status(c->session).dump(
                -1, ' ', false, nlohmann::json::error_handler_t::replace);
            if (!peer.send(reinterpret_cast<const std::uint8_t*>(text.data()), text.size(), false))
              break;
            next_status += kStatusInterval;
          }
          const std::shared_ptr<const EncodedFrame> frame =
              c->viewer->next(std::chrono::milliseconds(100));
          if (frame && !peer.send(frame->jpeg.data(), frame->jpeg.size(), true)) break;
        }
      });
      return connection;
    };
    handler.received = [this](const std::shared_ptr<void>& token, const std::string& text) {
      auto* c = static_cast<ViewerConnection*>(token.get());
      if (!c->viewer) return;
      try {
        const nlohmann::json message = nlohmann::json::parse(text);
        if (message.is_object() && message.contains("view") && message["view"].is_string())
          if (const std::optional<View> view = view_named(message["view"].get<std::string>())) {
            c->viewer->set_view(*view);
            sessions->stream().refresh();
          }
      } catch (const nlohmann::json::exception&) {
        // garbage from a client changes nothing
      }
    };
    handler.closed = [this](const std::shared_ptr<void>& token) {
      auto* c = static_cast<ViewerConnection*>(token.get());
      c->done.store(true);
      if (c->viewer) sessions->stream().remove_viewer(c->viewer);  // wakes the sender
      if (c->sender.joinable()) c->sender.join();
    };
    return handler;
  }
};

Service::Service(const ServiceOptions& options) : impl_(std::make_unique<Impl>()) {
  const auto [address, port] = parse_listen_address(options.listen);
  std::optional<std::string> token;
  if (!options.token_file.empty()) token = read_token_file(options.token_file);
  if (!loopback_address(address) && !token)
    throw usage_error("--listen " + options.listen +
                      ": listening beyond this machine (not 127.x.x.x) needs --token-file");
  load_config(options.config_file, options.sets);  // a bad configuration: usage_error now

  SessionManagerOptions session_options;
  session_options.data_dir = options.data_dir;
  session_options.config_file = options.config_file;
  session_options.sets = options.sets;
  session_options.threads = options.threads;
  impl_->sessions = std::make_unique<SessionManager>(session_options);
  ApiOptions api_options;
  api_options.token = token;
  api_options.version = options.version;
  impl_->api = std::make_unique<Api>(*impl_->sessions, api_options);

  HttpServerOptions server_options;
  server_options.address = address;
  server_options.port = port;
  Api* api = impl_->api.get();
  impl_->server = std::make_unique<HttpServer>(
      server_options, [api](const HttpRequest& request) { return api->handle(request); },
      impl_->websocket());
}

Service::~Service() {
  shutdown();
  impl_->server.reset();  // closes the viewers before the sessions and their stream go
}

int Service::port() const { return impl_->server->port(); }

void Service::shutdown() { impl_->sessions->shutdown(); }

ExitCode run_service(const ServiceOptions& options, const std::atomic<bool>& stop_requested) {
  Service service(options);
  std::fprintf(stderr, "aoscan: serving on http://%s:%d/ (data: %s)\n",
               parse_listen_address(options.listen).first.c_str(), service.port(),
               options.data_dir.c_str());
  std::fflush(stderr);
  while (!stop_requested.load()) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::fprintf(stderr, "aoscan: stopping the service; a running session writes its outputs\n");
  service.shutdown();
  return ExitCode::kOk;
}

}  // namespace aoscan
