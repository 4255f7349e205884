/// @file http_client.h
/// @brief One HTTP request to a local `aoscan serve` over civetweb's client, for the service's
/// tests and its load benchmark.
#pragma once

#include <string>

#include <civetweb.h>

namespace aoscan::testing {

struct HttpReply {
  int status = -1;   ///< -1: no answer (`body` then holds civetweb's reason)
  std::string body;
};

/// `method path` to 127.0.0.1:`port` over a new connection, with `body` and `extra_headers`
/// (each "Name: value\r\n"); waits up to 30 s for the answer.
inline HttpReply http_request(int port, const std::string& method, const std::string& path,
                              const std::string& body = "", const std::string& extra_headers = "") {
  char error[256] = "";
  mg_connection* conn = mg_connect_client("127.0.0.1", port, 0, error, sizeof(error));
  if (!conn) return {-1, error};
  mg_printf(conn,
            "%s %s HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n%sContent-Length: %zu\r\n\r\n",
            method.c_str(), path.c_str(), extra_headers.c_str(), body.size());
  if (!body.empty()) mg_write(conn, body.data(), body.size());
  HttpReply reply;
  if (mg_get_response(conn, error, sizeof(error), 30000) >= 0) {
    reply.status = mg_get_response_info(conn)->status_code;
    char buffer[8192];
    int n;
    while ((n = mg_read(conn, buffer, sizeof(buffer))) > 0) reply.body.append(buffer, n);
  } else {
    reply.body = error;
  }
  mg_close_connection(conn);
  return reply;
}

}  // namespace aoscan::testing
