/// @file http_server.cpp
/// @brief civetweb behind HttpRequest/HttpResponse.
#include "serve/http_server.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <mutex>

#include <civetweb.h>
#include <spdlog/spdlog.h>

#include "core/status.h"

namespace aoscan {

namespace {

bool iequals(const std::string& a, const char* b) {
  const std::size_t n = std::strlen(b);
  if (a.size() != n) return false;
  for (std::size_t i = 0; i < n; ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) != std::tolower(static_cast<unsigned char>(b[i])))
      return false;
  return true;
}

HttpRequest request_of(const mg_connection* conn) {
  const mg_request_info* info = mg_get_request_info(conn);
  HttpRequest request;
  request.method = info->request_method ? info->request_method : "";
  // local_uri is civetweb's percent-decoded path (without the query).
  request.path = info->local_uri ? info->local_uri : "";
  request.query = info->query_string ? info->query_string : "";
  request.remote_address = info->remote_addr;
  for (int i = 0; i < info->num_headers; ++i)
    request.headers.emplace_back(info->http_headers[i].name ? info->http_headers[i].name : "",
                                 info->http_headers[i].value ? info->http_headers[i].value : "");
  return request;
}

void send_headers(mg_connection* conn, const HttpResponse& response, long long length) {
  mg_response_header_start(conn, response.status);
  mg_response_header_add(conn, "Content-Type", response.content_type.c_str(), -1);
  mg_response_header_add(conn, "Content-Length", std::to_string(length).c_str(), -1);
  mg_response_header_add(conn, "Cache-Control", "no-store", -1);
  mg_response_header_add(conn, "X-Content-Type-Options", "nosniff", -1);
  for (const auto& [name, value] : response.headers)
    mg_response_header_add(conn, name.c_str(), value.c_str(), -1);
  mg_response_header_send(conn);
}

void send_body(mg_connection* conn, const HttpResponse& response) {
  send_headers(conn, response, static_cast<long long>(response.body.size()));
  if (!response.body.empty()) mg_write(conn, response.body.data(), response.body.size());
}

/// Streams a file; a file that cannot be opened is a 404 JSON error.
void send_file(mg_connection* conn, const HttpResponse& response) {
  const int fd = ::open(response.file_path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  struct stat st {};
  if (fd < 0 || ::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    if (fd >= 0) ::close(fd);
    HttpResponse missing;
    missing.status = 404;
    missing.body = R"({"error": "no such file"})";
    send_body(conn, missing);
    return;
  }
  send_headers(conn, response, static_cast<long long>(st.st_size));
  std::vector<char> buffer(1 << 16);
  long long left = st.st_size;
  while (left > 0) {
    const ssize_t n = ::read(fd, buffer.data(), buffer.size());
    if (n <= 0) break;  // the length was promised: the client sees a short body
    if (mg_write(conn, buffer.data(), static_cast<std::size_t>(n)) <= 0) break;
    left -= n;
  }
  ::close(fd);
}

HttpResponse json_error(int status, const std::string& message) {
  HttpResponse response;
  response.status = status;
  response.body = "{\"error\": \"" + message + "\"}";
  return response;
}

}  // namespace

std::optional<std::string> HttpRequest::header(const std::string& name) const {
  for (const auto& [key, value] : headers)
    if (iequals(key, name.c_str())) return value;
  return std::nullopt;
}

std::optional<std::string> HttpRequest::cookie(const std::string& name) const {
  const std::optional<std::string> cookies = header("Cookie");
  if (!cookies) return std::nullopt;
  std::size_t at = 0;
  while (at < cookies->size()) {
    std::size_t end = cookies->find(';', at);
    if (end == std::string::npos) end = cookies->size();
    std::string pair = cookies->substr(at, end - at);
    const std::size_t first = pair.find_first_not_of(' ');
    pair = first == std::string::npos ? "" : pair.substr(first);
    const std::size_t eq = pair.find('=');
    if (eq != std::string::npos && pair.substr(0, eq) == name) return pair.substr(eq + 1);
    at = end + 1;
  }
  return std::nullopt;
}

std::string url_decode(const std::string& text, bool plus_is_space) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '%' && i + 2 < text.size() && std::isxdigit(static_cast<unsigned char>(text[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(text[i + 2]))) {
      out.push_back(static_cast<char>(std::stoi(text.substr(i + 1, 2), nullptr, 16)));
      i += 2;
    } else if (c == '+' && plus_is_space) {
      out.push_back(' ');
    } else {
      out.push_back(c);
    }
  }
  return out;
}

std::optional<std::string> form_value(const std::string& form, const std::string& key) {
  std::size_t at = 0;
  while (at <= form.size()) {
    std::size_t end = form.find('&', at);
    if (end == std::string::npos) end = form.size();
    const std::string pair = form.substr(at, end - at);
    const std::size_t eq = pair.find('=');
    const std::string name = url_decode(pair.substr(0, eq), true);
    if (name == key) return eq == std::string::npos ? "" : url_decode(pair.substr(eq + 1), true);
    at = end + 1;
  }
  return std::nullopt;
}

/// One open WebSocket connection.
class CivetPeer final : public WebSocketPeer {
 public:
  explicit CivetPeer(mg_connection* conn) : conn_(conn) {}
  bool send(const std::uint8_t* data, std::size_t size, bool binary) override {
    if (closed_.load()) return false;
    const int opcode = binary ? MG_WEBSOCKET_OPCODE_BINARY : MG_WEBSOCKET_OPCODE_TEXT;
    // mg_websocket_write locks the connection: safe beside civetweb's own reading thread.
    const int written =
        mg_websocket_write(conn_, opcode, reinterpret_cast<const char*>(data), size);
    if (written <= 0) closed_.store(true);
    return written > 0;
  }
  void close() { closed_.store(true); }

 private:
  mg_connection* conn_;
  std::atomic<bool> closed_{false};
};

struct HttpServer::Impl {
  HttpServerOptions options;
  Handler handler;
  WebSocketHandler websocket;
  mg_context* context = nullptr;

  /// Per WebSocket connection, from the connect handler to the close handler.
  struct Connection {
    HttpRequest request;
    std::unique_ptr<CivetPeer> peer;
    std::shared_ptr<void> token;
  };

  static int on_request(mg_connection* conn, void* data) {
    Impl& self = *static_cast<Impl*>(data);
    HttpRequest request = request_of(conn);
    const mg_request_info* info = mg_get_request_info(conn);
    const long long declared = info->content_length;
    if (declared > static_cast<long long>(self.options.max_body_bytes)) {
      send_body(conn, json_error(413, "request body larger than " +
                                          std::to_string(self.options.max_body_bytes) + " bytes"));
      return 413;
    }
    if (declared != 0) {  // -1: unknown length (chunked): read up to the limit
      const std::size_t limit = self.options.max_body_bytes;
      std::vector<char> buffer(limit + 1);
      std::size_t got = 0;
      while (got < buffer.size()) {
        const int n = mg_read(conn, buffer.data() + got, buffer.size() - got);
        if (n <= 0) break;
        got += static_cast<std::size_t>(n);
      }
      if (got > limit) {
        send_body(conn, json_error(413, "request body larger than " + std::to_string(limit) +
                                            " bytes"));
        return 413;
      }
      request.body.assign(buffer.data(), got);
    }
    HttpResponse response;
    try {
      response = self.handler(request);
    } catch (const std::exception& e) {
      spdlog::warn("serve: {} {}: {}", request.method, request.path, e.what());
      response = json_error(500, "internal error");
    }
    if (response.file_path.empty())
      send_body(conn, response);
    else
      send_file(conn, response);
    return response.status;
  }

  static int on_ws_connect(const mg_connection* conn, void* data) {
    Impl& self = *static_cast<Impl*>(data);
    auto connection = std::make_unique<Connection>();
    connection->request = request_of(conn);
    HttpResponse refusal;
    if (!self.websocket.accept || !self.websocket.accept(connection->request, refusal)) {
      spdlog::info("serve: WebSocket {} refused: {}", connection->request.path,
                   one_line(refusal.body));
      return 1;  // civetweb closes the connection
    }
    mg_set_user_connection_data(conn, connection.release());
    return 0;
  }

  static void on_ws_ready(mg_connection* conn, void* data) {
    Impl& self = *static_cast<Impl*>(data);
    auto* connection = static_cast<Connection*>(mg_get_user_connection_data(conn));
    if (!connection) return;
    connection->peer = std::make_unique<CivetPeer>(conn);
    if (self.websocket.opened)
      connection->token = self.websocket.opened(connection->request, *connection->peer);
  }

  static int on_ws_data(mg_connection* conn, int bits, char* bytes, std::size_t size, void* data) {
    Impl& self = *static_cast<Impl*>(data);
    auto* connection = static_cast<Connection*>(mg_get_user_connection_data(conn));
    const int opcode = bits & 0x0f;
    if (opcode == MG_WEBSOCKET_OPCODE_CONNECTION_CLOSE) return 0;
    if (connection && connection->token && opcode == MG_WEBSOCKET_OPCODE_TEXT &&
        self.websocket.received && size <= 4096)
      self.websocket.received(connection->token, std::string(bytes, size));
    return 1;
  }

  static void on_ws_close(const mg_connection* conn, void* data) {
    Impl& self = *static_cast<Impl*>(data);
    std::unique_ptr<Connection> connection(
        static_cast<Connection*>(mg_get_user_connection_data(conn)));
    if (!connection) return;
    if (connection->peer) connection->peer->close();
    if (connection->token && self.websocket.closed) self.websocket.closed(connection->token);
    mg_set_user_connection_data(conn, nullptr);
  }

  static int on_log(const mg_connection*, const char* message) {
    spdlog::debug("serve: civetweb: {}", message);
    return 1;
  }
};

HttpServer::HttpServer(const HttpServerOptions& options, Handler handler,
                       WebSocketHandler websocket)
    : impl_(std::make_unique<Impl>()) {
  static std::once_flag library;
  std::call_once(library, [] { mg_init_library(0); });
  impl_->options = options;
  impl_->handler = std::move(handler);
  impl_->websocket = std::move(websocket);

  const std::string listen = options.address + ":" + std::to_string(options.port);
  const std::string threads = std::to_string(options.threads);
  const std::string header_bytes = std::to_string(options.max_header_bytes);
  const std::string timeout = std::to_string(options.request_timeout_ms);
  const std::string ws_timeout = std::to_string(options.websocket_timeout_ms);
  const char* civet_options[] = {"listening_ports", listen.c_str(),
                                 "num_threads", threads.c_str(),
                                 "max_request_size", header_bytes.c_str(),
                                 "request_timeout_ms", timeout.c_str(),
                                 "websocket_timeout_ms", ws_timeout.c_str(),
                                 "enable_websocket_ping_pong", "yes",
                                 "enable_keep_alive", "yes",
                                 // Connections beyond the workers wait in the kernel's queue
                                 // (a flood of them is served in turn, each idle one for at
                                 // most request_timeout_ms) rather than in SYN retries.
                                 "listen_backlog", "1024",
                                 "decode_url", "yes",
                                 nullptr};
  mg_callbacks callbacks{};
  callbacks.log_message = &Impl::on_log;
  mg_init_data init{};
  init.callbacks = &callbacks;
  init.user_data = impl_.get();
  init.configuration_options = civet_options;
  mg_error_data error{};
  char error_text[256] = "";
  error.text = error_text;
  error.text_buffer_size = sizeof(error_text);
  impl_->context = mg_start2(&init, &error);
  if (!impl_->context)
    throw usage_error("--listen " + listen + ": cannot listen there (" +
                      (error_text[0] ? std::string(error_text) : std::string("in use?")) + ")");
  mg_set_request_handler(impl_->context, "/", &Impl::on_request, impl_.get());
  mg_set_websocket_handler(impl_->context, "/", &Impl::on_ws_connect, &Impl::on_ws_ready,
                           &Impl::on_ws_data, &Impl::on_ws_close, impl_.get());
  mg_server_port ports[4]{};
  const int n = mg_get_server_ports(impl_->context, 4, ports);
  port_ = n > 0 ? ports[0].port : options.port;
}

HttpServer::~HttpServer() {
  if (impl_ && impl_->context) mg_stop(impl_->context);
}

}  // namespace aoscan
