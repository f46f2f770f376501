#include "daemon/web_server.hpp"

#include <atomic>
#include <chrono>
#include <deque>
#include <optional>
#include <set>
#include <utility>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/core/tcp_stream.hpp>
#include <boost/beast/http/empty_body.hpp>
#include <boost/beast/http/parser.hpp>
#include <boost/beast/http/read.hpp>
#include <boost/beast/http/string_body.hpp>
#include <boost/beast/http/write.hpp>
#include <boost/beast/websocket.hpp>

#include "core/log.hpp"
#include "core/token_bucket.hpp"

namespace vgr::daemon {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using boost::system::error_code;

namespace {
constexpr std::size_t kHeaderLimitBytes = 8 * 1024;
constexpr auto kIoTimeout = std::chrono::seconds(10);
constexpr std::size_t kMaxConnections = 32;
// One peer address may hold at most this many of them: a connection storm or a slowloris
// from one host leaves the rest to everyone else (issue 19).
constexpr std::size_t kMaxConnectionsPerAddress = 8;
// And what one peer can make the I/O thread do is bounded: sessions from one address at
// most 200 a second (more are closed as soon as they are accepted), requests of one
// connection at most 2000 a second (more wait in its socket). The listen backlog itself is
// drained at up to 5000 accepts a second (an accept and a close cost a few microseconds):
// whatever waits there waits for everyone, so a storm's leftovers must not stay in it. At
// 200 accepts a second, the ~3400 connections a one-thread storm left there took 17 s to
// drain, and every new client, from any address, waited behind them (input_attacks_test).
constexpr double kAcceptsPerSecond = 5000, kAcceptBurst = 500;
constexpr double kSessionsPerSecondPerAddress = 200, kSessionBurstPerAddress = 50;
// Session budgets are kept for this many recently seen addresses; a budget unused for
// kPeerBudgetIdle is full again and may be forgotten. Beyond that, addresses share one.
constexpr std::size_t kMaxPeerBudgets = 256;
constexpr auto kPeerBudgetIdle = std::chrono::seconds(1);
constexpr double kRequestsPerSecond = 2000, kRequestBurst = 200;
constexpr std::size_t kMaxWebSockets = 16;
constexpr std::size_t kWsQueue = 64;
constexpr std::size_t kWsReadLimit = 1024;
constexpr auto kAcceptRetryDelay = std::chrono::milliseconds(200);
const char* kTextType = "text/plain; charset=utf-8";

std::string remoteAddress(const tcp::socket& socket) {
  error_code ec;
  const auto ep = socket.remote_endpoint(ec);
  if (ec) return "";
  auto a = ep.address();
  if (a.is_v6() && a.to_v6().is_v4_mapped()) return asio::ip::make_address_v4(asio::ip::v4_mapped, a.to_v6()).to_string();
  return a.to_string();
}
}  // namespace

std::string HttpRequest::header(const std::string& lowerName) const {
  const auto it = headers.find(lowerName);
  return it == headers.end() ? std::string() : it->second;
}

std::string HttpRequest::param(const std::string& key) const {
  std::size_t pos = 0;
  while (pos <= query.size()) {
    const std::size_t amp = query.find('&', pos);
    const std::string item = query.substr(pos, amp == std::string::npos ? std::string::npos : amp - pos);
    const std::size_t eq = item.find('=');
    if (item.substr(0, eq) == key) return eq == std::string::npos ? std::string() : item.substr(eq + 1);
    if (amp == std::string::npos) break;
    pos = amp + 1;
  }
  return "";
}

struct WebServer::Impl : std::enable_shared_from_this<WebServer::Impl> {
  Impl(asio::io_context& ioIn, WebOptions o) : io(ioIn), options(std::move(o)), acceptor(ioIn), retry(ioIn) {}

  class Session;
  class WsSession;
  struct Route {
    HttpHandler sync;
    AsyncHttpHandler async;
  };

  asio::io_context& io;
  const WebOptions options;
  std::map<std::string, Route> getRoutes;
  std::map<std::string, HttpHandler> postRoutes;
  std::string wsPath;
  std::function<std::string()> wsOnOpen;
  tcp::acceptor acceptor;
  asio::steady_timer retry;
  std::set<Session*> sessions;  // I/O thread only
  std::map<asio::ip::address, std::size_t> perAddress;  // open sessions by peer address, I/O thread
  TokenBucket acceptBudget{kAcceptsPerSecond, kAcceptBurst};
  struct PeerBudget {
    TokenBucket sessions{kSessionsPerSecondPerAddress, kSessionBurstPerAddress};
    TokenBucket::Clock::time_point lastUsed{};
  };
  std::map<asio::ip::address, PeerBudget> peerBudgets;  // I/O thread, at most kMaxPeerBudgets
  PeerBudget sharedBudget;                              // addresses beyond those
  std::set<std::shared_ptr<WsSession>> wsSessions;  // I/O thread only
  std::atomic<std::uint64_t> wsClients{0}, wsAccepted{0}, wsDropped{0};
  bool stopped = false;
  std::uint16_t boundPort = 0;

  void doAccept();
  // One more session from `peer` within its budget (kSessionsPerSecondPerAddress).
  bool takeSession(const asio::ip::address& peer);
};

class WebServer::Impl::WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(std::shared_ptr<Impl> server, beast::tcp_stream stream) : server_(std::move(server)), ws_(std::move(stream)) {}

  void start(http::request<http::empty_body> req) {
    beast::get_lowest_layer(ws_).expires_never();  // the websocket's own timeouts from here on
    // 10 s for the handshake; a client silent for 60 s is pinged (at half of it) and closed
    // when it does not answer: a browser answers pings by itself.
    websocket::stream_base::timeout t{};
    t.handshake_timeout = std::chrono::seconds(10);
    t.idle_timeout = std::chrono::seconds(60);
    t.keep_alive_pings = true;
    ws_.set_option(t);
    ws_.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& res) { res.set(http::field::server, "vgrd"); }));
    ws_.read_message_max(kWsReadLimit);
    ws_.async_accept(req, [self = shared_from_this()](const error_code& ec) {
      if (ec || self->server_->stopped) return self->close();
      self->server_->wsSessions.insert(self);
      self->server_->wsClients = self->server_->wsSessions.size();
      self->server_->wsAccepted++;
      if (self->server_->wsOnOpen) {
        std::string first = self->server_->wsOnOpen();
        if (!first.empty()) self->send(std::make_shared<const std::string>(std::move(first)));
      }
      self->doRead();
    });
  }

  struct Message {
    std::shared_ptr<const std::string> data;
    bool binary = false;
  };

  void send(std::shared_ptr<const std::string> msg, bool binary = false) {
    if (closed_) return;
    if (binary)  // a newer picture replaces one still waiting (not the one being written)
      for (auto it = queue_.begin() + (writing_ && !queue_.empty() ? 1 : 0); it != queue_.end();)
        it = it->binary ? queue_.erase(it) : it + 1;
    if (queue_.size() >= kWsQueue) {
      // The client reads too slowly: drop its oldest waiting message (not the one being written).
      queue_.erase(queue_.begin() + (writing_ ? 1 : 0));
      server_->wsDropped++;
    }
    queue_.push_back({std::move(msg), binary});
    if (!writing_) doWrite();
  }

  void close() {
    if (closed_) return;
    closed_ = true;
    error_code ec;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ec);
    beast::get_lowest_layer(ws_).close();
    server_->wsSessions.erase(shared_from_this());
    server_->wsClients = server_->wsSessions.size();
  }

  asio::any_io_executor executor() { return ws_.get_executor(); }

 private:
  void doRead() {
    ws_.async_read(buffer_, [self = shared_from_this()](const error_code& ec, std::size_t) {
      if (ec) return self->close();  // closed by the client, timeout, over-long message
      self->buffer_.consume(self->buffer_.size());  // a listener: what it says is dropped
      self->doRead();
    });
  }

  void doWrite() {
    writing_ = true;
    ws_.binary(queue_.front().binary);
    ws_.async_write(asio::buffer(*queue_.front().data), [self = shared_from_this()](const error_code& ec, std::size_t) {
      if (!self->queue_.empty()) self->queue_.pop_front();
      if (ec) return self->close();
      if (self->queue_.empty()) {
        self->writing_ = false;
        return;
      }
      self->doWrite();
    });
  }

  std::shared_ptr<Impl> server_;
  websocket::stream<beast::tcp_stream> ws_;
  beast::flat_buffer buffer_;
  std::deque<Message> queue_;
  bool writing_ = false;
  bool closed_ = false;
};

class WebServer::Impl::Session : public std::enable_shared_from_this<Session> {
 public:
  Session(std::shared_ptr<Impl> server, tcp::socket socket, asio::ip::address peer)
      : server_(std::move(server)), stream_(std::move(socket)), peer_(std::move(peer)), pace_(stream_.get_executor()) {}

  void start() {
    server_->sessions.insert(this);
    ++server_->perAddress[peer_];
    remote_ = remoteAddress(stream_.socket());
    doRead();
  }
  void close() {
    error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_both, ec);
    stream_.close();
  }

  // From any thread (an async handler's respond): the reply is written on the I/O thread.
  struct Pending {
    std::shared_ptr<Session> session;
    unsigned version;
    bool keepAlive, head;
    std::atomic<bool> done{false};
    void deliver(HttpReply r) {
      if (done.exchange(true)) return;
      asio::post(session->stream_.get_executor(), [s = session, r = std::move(r), v = version, k = keepAlive, h = head]() mutable {
        s->write(std::move(r), v, k, h);
      });
    }
    ~Pending() { deliver({500, kTextType, "internal error: the request was dropped without a reply\n", {}}); }
  };

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
    const std::string target(req.target());
    HttpRequest hr;
    hr.method = std::string(req.method_string());
    const auto q = target.find('?');
    hr.path = target.substr(0, q);
    if (q != std::string::npos) hr.query = target.substr(q + 1);
    hr.remote = remote_;
    for (const auto& f : req) {
      std::string name(f.name_string());
      for (auto& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      hr.headers[name] = std::string(f.value());
    }
    const unsigned version = req.version();
    const bool keepAlive = req.keep_alive();
    const bool head = req.method() == http::verb::head;
    const bool get = req.method() == http::verb::get || head;

    if (!server_->wsPath.empty() && hr.path == server_->wsPath && websocket::is_upgrade(req)) {
      if (server_->wsSessions.size() >= kMaxWebSockets)
        return write({503, kTextType, "too many WebSocket clients\n", {}}, version, false, false);
      // The connection becomes a WebSocket: this HTTP session ends here.
      releaseSlot();
      auto ws = std::make_shared<WsSession>(server_, std::move(stream_));
      ws->start(parser_->release());
      return;
    }

    const auto g = server_->getRoutes.find(hr.path);
    const auto p = server_->postRoutes.find(hr.path);
    if (g != server_->getRoutes.end()) {
      if (!get) return write({405, kTextType, "method not allowed: " + hr.path + " is read-only\n", {{"Allow", "GET, HEAD"}}}, version, keepAlive, head);
      if (g->second.sync) return write(g->second.sync(hr), version, keepAlive, head);
      auto pending = std::make_shared<Pending>();
      pending->session = shared_from_this();
      pending->version = version;
      pending->keepAlive = keepAlive;
      pending->head = head;
      g->second.async(hr, [pending](HttpReply r) { pending->deliver(std::move(r)); });
      return;
    }
    if (p != server_->postRoutes.end()) {
      if (req.method() != http::verb::post)
        return write({405, kTextType, "method not allowed: " + hr.path + " takes POST\n", {{"Allow", "POST"}}}, version, keepAlive, head);
      return write(p->second(hr), version, keepAlive, head);
    }
    if (!get && req.method() != http::verb::post)
      return write({405, kTextType, "method not allowed\n", {{"Allow", "GET, HEAD, POST"}}}, version, keepAlive, head);
    write({404, kTextType, "not found: " + hr.path + "\n", {}}, version, keepAlive, head);
  }

  void write(HttpReply r, unsigned version, bool keepAlive, bool head) {
    auto res = std::make_shared<http::response<http::string_body>>(static_cast<http::status>(r.status), version);
    res->set(http::field::server, "vgrd");
    res->set(http::field::content_type, r.contentType);
    res->set(http::field::cache_control, "no-store");
    for (const auto& [name, value] : r.headers) res->set(name, value);
    res->keep_alive(keepAlive);
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
    releaseSlot();
  }

  // Leaves the HTTP session table and the peer's per-address count (once).
  void releaseSlot() {
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
  std::string remote_;
};

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
        (fromPeer != self->perAddress.end() && fromPeer->second >= kMaxConnectionsPerAddress) ||
        !self->takeSession(peer)) {
      error_code ignored;
      socket.close(ignored);  // gone already, or over a limit or its rate: refuse this one, serve the others
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

bool WebServer::Impl::takeSession(const asio::ip::address& peer) {
  const auto now = TokenBucket::Clock::now();
  auto it = peerBudgets.find(peer);
  if (it == peerBudgets.end()) {
    if (peerBudgets.size() >= kMaxPeerBudgets)
      std::erase_if(peerBudgets, [now](const auto& kv) { return now - kv.second.lastUsed > kPeerBudgetIdle; });
    if (peerBudgets.size() < kMaxPeerBudgets) it = peerBudgets.emplace(peer, PeerBudget{}).first;
  }
  PeerBudget& b = it == peerBudgets.end() ? sharedBudget : it->second;
  b.lastUsed = now;
  return b.sessions.take(now);
}

WebServer::WebServer(asio::io_context& io, WebOptions options) : impl_(std::make_shared<Impl>(io, std::move(options))) {}

WebServer::~WebServer() { stop(); }

void WebServer::route(const std::string& path, HttpHandler handler) { impl_->getRoutes[path] = {std::move(handler), {}}; }

void WebServer::routeAsync(const std::string& path, AsyncHttpHandler handler) {
  impl_->getRoutes[path] = {{}, std::move(handler)};
}

void WebServer::routePost(const std::string& path, HttpHandler handler) { impl_->postRoutes[path] = std::move(handler); }

void WebServer::websocket(const std::string& path, std::function<std::string()> onOpen) {
  impl_->wsPath = path;
  impl_->wsOnOpen = std::move(onOpen);
}

void WebServer::broadcast(std::string text) {
  if (impl_->wsSessions.empty()) return;
  auto msg = std::make_shared<const std::string>(std::move(text));
  for (const auto& ws : impl_->wsSessions) asio::post(ws->executor(), [ws, msg] { ws->send(msg); });
}

void WebServer::broadcastBinary(std::string bytes) {
  if (impl_->wsSessions.empty()) return;
  auto msg = std::make_shared<const std::string>(std::move(bytes));
  for (const auto& ws : impl_->wsSessions) asio::post(ws->executor(), [ws, msg] { ws->send(msg, true); });
}

WebSocketCounters WebServer::websocketCounters() const {
  return {impl_->wsClients.load(), impl_->wsAccepted.load(), impl_->wsDropped.load()};
}

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
  for (const auto& ws : std::set<std::shared_ptr<Impl::WsSession>>(s.wsSessions)) ws->close();
}

std::uint16_t WebServer::port() const { return impl_->boundPort; }

std::string WebServer::describe() const {
  return "web " + impl_->options.bind + ":" + std::to_string(impl_->boundPort ? impl_->boundPort : impl_->options.port);
}

}  // namespace vgr::daemon
