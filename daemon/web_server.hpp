// vgrd's HTTP server: a small read-only router (path -> handler returning body + content
// type) on the cell's `web` address. It serves /metrics (daemon/metrics.hpp) and will
// serve the commissioning page; Boost.Beast stays inside web_server.cpp (one translation
// unit: Beast costs ~29 s CPU and ~550 MB RAM per file, PITFALLS.md).
//
// Threads: everything runs on the io_context's thread (the daemon's I/O thread); route()
// before start(); handlers run there too and must not block. Limits (Beast's server
// shape, STYLE.md rule 9): request head <= 8 KiB, no request body accepted, 10 s to read a
// request and to write a reply, at most 32 connections at once and 8 from one peer address;
// keep-alive honoured.
// Only GET and HEAD: other methods get 405, unknown paths 404.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include "core/result.hpp"

namespace boost::asio {
class io_context;
}

namespace vgr::daemon {

struct HttpReply {
  int status = 200;                        // HTTP status code
  std::string contentType = "text/plain; charset=utf-8";
  std::string body;
};

// The request as a handler sees it: the path without the query, and the query string.
struct HttpRequest {
  std::string path;   // "/metrics"
  std::string query;  // "a=1&b=2" (no '?'), "" when absent
};

using HttpHandler = std::function<HttpReply(const HttpRequest&)>;

struct WebOptions {
  std::string bind = "127.0.0.1";  // numeric IPv4/IPv6 address
  std::uint16_t port = 8080;       // 0 = any free port (port() tells which)
};

class WebServer {
 public:
  WebServer(boost::asio::io_context& io, WebOptions options);
  ~WebServer();  // stops
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  // Exact path match ("/metrics"). Before start().
  void route(const std::string& path, HttpHandler handler);
  // Binds and listens; the error names the address ("web 127.0.0.1:8080: Address in use").
  Result<void> start();
  void stop();  // closes the acceptor and every connection; idempotent
  std::uint16_t port() const;  // the bound port after start()
  std::string describe() const;  // "web 127.0.0.1:8080"

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;
};

}  // namespace vgr::daemon
