#include "daemon/web_server.hpp"

#include <chrono>
#include <optional>
#include <set>
#include <utility>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/core/tcp_stream.hpp>
#include <boost/beast/http/empty_body.hpp>
#include <boost/beast/http/parser.hpp>
#include <boost/beast/http/read.hpp>
#include <boost/beast/http/string_body.hpp>
#include <boost/beast/http/write.hpp>

#include "core/log.hpp"
#include "core/token_bucket.hpp"

namespace vgr::daemon {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;
using boost::system::error_code;

namespace {
constexpr std::size_t kHeaderLimitBytes = 8 * 1024;
constexpr auto kIoTimeout = std::chrono::seconds(10);
constexpr std::size_t kMaxConnections = 32;
// One peer address may hold at most this many of them: a connection storm or a slowloris
// from one host leaves the rest to everyone else (issue 19).
constexpr std::size_t kMaxConnectionsPerAddress = 8;
// And what one peer can make the I/O thread do is bounded: new connections at most 200 a
// second (more wait in the listen backlog), requests of one connection at most 2000 a
// second (more wait in its socket).
constexpr double kAcceptsPerSecond = 200, kAcceptBurst = 50;
constexpr double kRequestsPerSecond = 2000, kRequestBurst = 200;
constexpr auto kAcceptRetryDelay = std::chrono::milliseconds(200);
}  // namespace

struct WebServer::Impl : std::enable_shared_from_this<WebServer::Impl> {
  Impl(asio::io_context& ioIn, WebOptions o) : io(ioIn), options(std::move(o)), acceptor(ioIn), retry(ioIn) {}

  class Session;

  asio::io_context& io;
  const WebOptions options;
  std::map<std::string, HttpHandler> routes;
  tcp::acceptor acceptor;
  asio::steady_timer retry;
  std::set<Session*> sessions;  // I/O thread only
  std::map<asio::ip::address, std::size_t> perAddress;  // open sessions by peer address, I/O thread
  TokenBucket acceptBudget{kAcceptsPerSecond, kAcceptBurst};
  bool stopped = false;
  std::uint16_t boundPort = 0;

  void doAccept();
  HttpReply dispatch(const http::request<http::empty_body>& req) const;
};

class WebServer::Impl::Session : public std::enable_shared_from_this<Session> {
 public:
  Session(std::shared_ptr<Impl> server, tcp::socket socket, asio::ip::address peer)
      : server_(std::move(server)), stream_(std::move(socket)), peer_(std::move(peer)), pace_(stream_.get_executor()) {}

  void start() {
    server_->sessions.insert(this);
    ++server_->perAddress[peer_];
    doRead();
  }
  void close() {
    error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_both, ec);
    stream_.close();
  }

 private:
  void doRead() {
    if (!budget_.take()) {  // over the connection's request rate: read on when a token comes
      pace_.expires_at(budget_.nextToken());
      pace_.async_wait([self = shared_from_this()](const error_code& ec) {
        if (!ec) self->doRead();
      });
      return;
    }
    parser_.emplace();
    parser_->header_limit(kHeaderLimitBytes);
    parser_->body_limit(0);
    stream_.expires_after(kIoTimeout);
    http::async_read(stream_, buffer_, *parser_,
                     [self = shared_from_this()](const error_code& ec, std::size_t) { self->onRead(ec); });
  }

  void onRead(const error_code& ec) {
    if (ec) return finish();  // end of stream, timeout, over-long head, a body: drop the connection
    const auto& req = parser_->get();
    HttpReply r;
    if (req.method() != http::verb::get && req.method() != http::verb::head) {
      r = {405, "text/plain; charset=utf-8", "method not allowed: vgrd's web server is read-only\n"};
    } else {
      r = server_->dispatch(req);
    }
    auto res = std::make_shared<http::response<http::string_body>>(static_cast<http::status>(r.status), req.version());
    res->set(http::field::server, "vgrd");
    res->set(http::field::content_type, r.contentType);
    res->set(http::field::cache_control, "no-store");
    if (r.status == 405) res->set(http::field::allow, "GET, HEAD");
    res->keep_alive(req.keep_alive());
    const bool head = req.method() == http::verb::head;
    res->body() = std::move(r.body);
    res->prepare_payload();
    if (head) res->body().clear();  // Content-Length stays that of the GET reply
    stream_.expires_after(kIoTimeout);
    http::async_write(stream_, *res, [self = shared_from_this(), res](const error_code& wec, std::size_t) {
      if (wec || !res->keep_alive()) return self->finish();
      self->doRead();
    });
  }

  void finish() {
    close();
    if (server_->sessions.erase(this) == 0) return;
    if (auto it = server_->perAddress.find(peer_); it != server_->perAddress.end() && --it->second == 0)
      server_->perAddress.erase(it);
  }

  std::shared_ptr<Impl> server_;
  beast::tcp_stream stream_;
  asio::ip::address peer_;
  asio::steady_timer pace_;
  TokenBucket budget_{kRequestsPerSecond, kRequestBurst};
  beast::flat_buffer buffer_{kHeaderLimitBytes};
  std::optional<http::request_parser<http::empty_body>> parser_;
};

HttpReply WebServer::Impl::dispatch(const http::request<http::empty_body>& req) const {
  const std::string target(req.target());
  HttpRequest hr;
  const auto q = target.find('?');
  hr.path = target.substr(0, q);
  if (q != std::string::npos) hr.query = target.substr(q + 1);
  const auto it = routes.find(hr.path);
  if (it == routes.end()) return {404, "text/plain; charset=utf-8", "not found: " + hr.path + "\n"};
  return it->second(hr);
}

void WebServer::Impl::doAccept() {
  if (stopped) return;
  acceptor.async_accept(asio::make_strand(io), [self = shared_from_this()](const error_code& ec, tcp::socket socket) {
    if (self->stopped) return;
    if (ec) {
      // EMFILE and friends: pause instead of spinning.
      log::warn("web", "accept on {}:{} failed: {}", self->options.bind, self->boundPort, ec.message());
      self->retry.expires_after(kAcceptRetryDelay);
      self->retry.async_wait([self](const error_code& rec) {
        if (!rec) self->doAccept();
      });
      return;
    }
    error_code peerEc;
    const asio::ip::address peer = socket.remote_endpoint(peerEc).address();
    const auto fromPeer = self->perAddress.find(peer);
    if (peerEc || self->sessions.size() >= kMaxConnections ||
        (fromPeer != self->perAddress.end() && fromPeer->second >= kMaxConnectionsPerAddress)) {
      error_code ignored;
      socket.close(ignored);  // gone already, or over a limit: refuse this one, keep serving the others
    } else {
      std::make_shared<Session>(self, std::move(socket), peer)->start();
    }
    if (self->acceptBudget.take()) {
      self->doAccept();
      return;
    }
    self->retry.expires_at(self->acceptBudget.nextToken());
    self->retry.async_wait([self](const error_code& rec) {
      if (!rec) self->doAccept();
    });
  });
}

WebServer::WebServer(asio::io_context& io, WebOptions options) : impl_(std::make_shared<Impl>(io, std::move(options))) {}

WebServer::~WebServer() { stop(); }

void WebServer::route(const std::string& path, HttpHandler handler) { impl_->routes[path] = std::move(handler); }

Result<void> WebServer::start() {
  Impl& s = *impl_;
  error_code ec;
  const auto address = asio::ip::make_address(s.options.bind, ec);
  if (ec) return fail(Status::BadArgument, describe() + ": not a numeric address");
  const tcp::endpoint ep(address, s.options.port);
  s.acceptor.open(ep.protocol(), ec);
  if (!ec) s.acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) s.acceptor.bind(ep, ec);
  if (!ec) s.acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) return fail(Status::BadArgument, describe() + ": " + ec.message());
  s.boundPort = s.acceptor.local_endpoint().port();
  s.doAccept();
  return {};
}

void WebServer::stop() {
  Impl& s = *impl_;
  if (s.stopped) return;
  s.stopped = true;
  error_code ec;
  s.acceptor.close(ec);
  s.retry.cancel();
  for (auto* session : std::set<Impl::Session*>(s.sessions)) session->close();
}

std::uint16_t WebServer::port() const { return impl_->boundPort; }

std::string WebServer::describe() const {
  return "web " + impl_->options.bind + ":" + std::to_string(impl_->boundPort ? impl_->boundPort : impl_->options.port);
}

}  // namespace vgr::daemon
