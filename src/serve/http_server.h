/// @file http_server.h
/// @brief The service's HTTP and WebSocket server: civetweb (Debian's libcivetweb) behind plain
/// request and response values, so that the API itself (api.h) is a function of a request and is
/// tested without sockets. The only file that includes civetweb.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace aoscan {

/// One HTTP request as the API sees it.
struct HttpRequest {
  std::string method;  ///< "GET", "POST", ...
  std::string path;    ///< the URI's path, percent-decoded ("/api/sessions/ID")
  std::string query;   ///< after '?', undecoded; empty when none
  /// Header fields, names as sent (compare case-insensitively with header()).
  std::vector<std::pair<std::string, std::string>> headers;
  std::string body;
  std::string remote_address;  ///< the client's IP address

  /// The value of header `name` (case-insensitive), or nullopt.
  std::optional<std::string> header(const std::string& name) const;
  /// The value of cookie `name` of the Cookie header, or nullopt.
  std::optional<std::string> cookie(const std::string& name) const;
};

/// The answer to a request: a body held in memory, or a file streamed from disk.
struct HttpResponse {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::string file_path;  ///< non-empty: send this file as the body (`body` is ignored)
  std::vector<std::pair<std::string, std::string>> headers;  ///< more fields (Set-Cookie, ...)
};

/// A WebSocket client of the server (one live view), as the stream code sees it.
class WebSocketPeer {
 public:
  virtual ~WebSocketPeer() = default;
  /// Sends one message (binary or text); false once the connection is gone. Blocks only the
  /// calling thread (a slow client slows only its own sender).
  virtual bool send(const std::uint8_t* data, std::size_t size, bool binary) = 0;
};

/// What the server calls for the WebSocket endpoint of a path.
struct WebSocketHandler {
  /// Called for an upgrade request: true accepts it; a refused one is closed (its reason,
  /// `refusal`'s body, is logged).
  std::function<bool(const HttpRequest& request, HttpResponse& refusal)> accept;
  /// The connection is open: the handler may start sending to `peer` from any thread, until
  /// closed() returns. Returns an opaque token passed to the calls below.
  std::function<std::shared_ptr<void>(const HttpRequest& request, WebSocketPeer& peer)> opened;
  /// A text message from the client.
  std::function<void(const std::shared_ptr<void>& token, const std::string& text)> received;
  /// The connection is closing: once this returns nothing may use the peer any more.
  std::function<void(const std::shared_ptr<void>& token)> closed;
};

struct HttpServerOptions {
  std::string address = "127.0.0.1";  ///< IPv4 address to bind
  int port = 8080;                     ///< 0: any free port (see HttpServer::port())
  int threads = 64;  ///< worker threads; each open WebSocket holds one
  std::size_t max_header_bytes = 16 * 1024;  ///< request line and header fields, larger: refused
  std::size_t max_body_bytes = 64 * 1024;    ///< request bodies larger than this: 413
  /// A client silent this long while its request is due is dropped: a connection that sends
  /// nothing holds a worker thread this long.
  int request_timeout_ms = 3000;
  int websocket_timeout_ms = 10000;  ///< a silent viewer is pinged after this long
};

/// A running civetweb server. Every request goes to `handler` on one of the worker threads
/// (concurrently: the handler must be thread-safe), except requests to upgrade to a WebSocket,
/// which go to `websocket`.
class HttpServer {
 public:
  using Handler = std::function<HttpResponse(const HttpRequest&)>;

  /// Starts listening; throws usage_error naming the address when it cannot bind (in use, not an
  /// address of this machine).
  HttpServer(const HttpServerOptions& options, Handler handler, WebSocketHandler websocket);
  /// Stops accepting, closes every connection and joins the worker threads.
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  int port() const { return port_; }  ///< the port bound (the one chosen for port 0)

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
  int port_ = 0;
};

/// `text` with %XX escapes and '+' decoded (for form bodies and query strings).
std::string url_decode(const std::string& text, bool plus_is_space);

/// The value of `key` in a query string or an x-www-form-urlencoded body, decoded; nullopt when
/// absent.
std::optional<std::string> form_value(const std::string& form, const std::string& key);

}  // namespace aoscan
