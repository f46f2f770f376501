// vgrd's HTTP server: a small router (exact path -> handler returning status, type, body)
// on the cell's `web` address, with one WebSocket path for live pushes. It serves /metrics
// (daemon/metrics.hpp) and the commissioning page (daemon/web_page.hpp). Boost.Beast stays
// inside web_server.cpp (one translation unit: Beast costs ~29 s CPU and ~550 MB RAM per
// file, PITFALLS.md).
//
// Threads: everything runs on the io_context's thread (the daemon's I/O thread); route*()
// and websocket() before start(); handlers run there too and must not block: slow work
// (image encoding) goes to routeAsync(), whose handler hands a `respond` callback to
// another thread. broadcast() on the I/O thread; websocketClients() from any thread.
// Limits (Beast's server shape, STYLE.md rule 9): request head <= 8 KiB, no request body
// accepted, 10 s to read a request and to write a reply, at most 32 HTTP connections (8 from one
// peer address; new sessions 200/s per address, over it closed at once; requests 2000/s per connection) and 16 WebSocket clients
// at once; keep-alive honoured. GET and HEAD on route()/routeAsync()
// paths, POST only on routePost() paths: another method gets 405 (with Allow), an unknown
// path 404. A WebSocket client only listens: messages it sends are read and dropped (1 KiB
// each at most); each client has a queue of 64 messages, beyond which its oldest waiting
// message is dropped and counted.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/result.hpp"

namespace boost::asio {
class io_context;
}

namespace vgr::daemon {

struct HttpReply {
  int status = 200;                        // HTTP status code
  std::string contentType = "text/plain; charset=utf-8";
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;  // extra response headers
};

// The request as a handler sees it.
struct HttpRequest {
  std::string method;  // "GET", "HEAD", "POST"
  std::string path;    // "/metrics"
  std::string query;   // "a=1&b=2" (no '?'), "" when absent
  std::string remote;  // the client's address, canonical text; an IPv4-mapped IPv6 address as IPv4
  std::map<std::string, std::string> headers;  // lower-case names
  std::string header(const std::string& lowerName) const;  // "" when absent
  // The value of `key` in the query (percent-decoding not applied: our keys and values are
  // plain), "" when absent.
  std::string param(const std::string& key) const;
};

using HttpHandler = std::function<HttpReply(const HttpRequest&)>;
// Call once, from any thread; the reply is written on the I/O thread. Dropped without a
// call, the request is answered 500 (a client never waits forever).
using HttpRespond = std::function<void(HttpReply)>;
using AsyncHttpHandler = std::function<void(const HttpRequest&, HttpRespond)>;

struct WebOptions {
  std::string bind = "127.0.0.1";  // numeric IPv4/IPv6 address
  std::uint16_t port = 8080;       // 0 = any free port (port() tells which)
};

struct WebSocketCounters {
  std::uint64_t clients = 0;   // connected now
  std::uint64_t accepted = 0;  // since start
  std::uint64_t dropped = 0;   // messages dropped from a full client queue
};

class WebServer {
 public:
  WebServer(boost::asio::io_context& io, WebOptions options);
  ~WebServer();  // stops
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  // Exact path match ("/metrics"). Before start().
  void route(const std::string& path, HttpHandler handler);            // GET, HEAD
  void routeAsync(const std::string& path, AsyncHttpHandler handler);  // GET, HEAD
  void routePost(const std::string& path, HttpHandler handler);        // POST
  // WebSocket upgrades are accepted on `path` (GET with Upgrade: websocket). `onOpen` runs on
  // the I/O thread for each new client and returns the first message it gets ("" = none).
  void websocket(const std::string& path, std::function<std::string()> onOpen = nullptr);
  // I/O thread: one text message to every WebSocket client.
  void broadcast(std::string text);
  // I/O thread: one binary message to every WebSocket client. A binary message still
  // waiting in a client's queue is replaced by the newer one (a picture only matters newest).
  void broadcastBinary(std::string bytes);
  WebSocketCounters websocketCounters() const;  // any thread

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
