#include "protocol/robot_server.hpp"

#include <netinet/in.h>
#include <netinet/tcp.h>

#include <array>
#include <atomic>
#include <chrono>
#include <deque>
#include <exception>
#include <memory>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include <fmt/core.h>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/write.hpp>

#include "core/log.hpp"

namespace vgr::protocol {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using boost::system::error_code;

namespace robot_detail {

constexpr std::size_t kReadChunkBytes = 512;   // one async_read_some
constexpr std::size_t kMaxQueuedRequests = 8;  // per connection; beyond it we stop reading
constexpr auto kWriteTimeout = std::chrono::seconds(5);
constexpr auto kAcceptRetryDelay = std::chrono::milliseconds(200);
// Dead peers (robot powered off, cable pulled): keepalive probes after 10 s of silence,
// every 5 s, 3 unanswered -> the read fails after ~25 s and the session is cleaned up.
// Idle but alive robots answer the probes and keep their connection for hours.
constexpr int kKeepIdleS = 10;
constexpr int kKeepIntervalS = 5;
constexpr int kKeepCount = 3;
constexpr int kUserTimeoutMs = 20000;  // unacknowledged reply data -> give up after 20 s

using KeepIdle = asio::detail::socket_option::integer<IPPROTO_TCP, TCP_KEEPIDLE>;
using KeepInterval = asio::detail::socket_option::integer<IPPROTO_TCP, TCP_KEEPINTVL>;
using KeepCount = asio::detail::socket_option::integer<IPPROTO_TCP, TCP_KEEPCNT>;
using UserTimeout = asio::detail::socket_option::integer<IPPROTO_TCP, TCP_USER_TIMEOUT>;

std::string peerName(const tcp::socket& s) {
  error_code ec;
  const tcp::endpoint ep = s.remote_endpoint(ec);
  if (ec) return "?";
  return fmt::format("{}:{}", ep.address().to_string(), ep.port());
}

class Session;

// Shared by the RobotServer and its sessions' pending operations, so a session that is
// still unwinding after stop() never touches freed memory. I/O thread only.
struct ServerCore : std::enable_shared_from_this<ServerCore> {
  ServerCore(asio::io_context& ioIn, RobotEndpoint endpointIn, RequestHandler handlerIn)
      : io(ioIn), endpoint(std::move(endpointIn)), handler(std::move(handlerIn)), acceptor(ioIn), retryTimer(ioIn) {}

  void doAccept();
  void onAccept(const error_code& ec, tcp::socket socket);
  void stopAll();

  asio::io_context& io;
  const RobotEndpoint endpoint;
  const RequestHandler handler;
  tcp::acceptor acceptor;
  asio::steady_timer retryTimer;
  std::uint16_t boundPort = 0;
  bool started = false;
  bool stopped = false;
  std::uint64_t nextSessionId = 1;
  // Open sessions. Weak: a session is owned by its pending operations (Beast's shape).
  std::unordered_map<std::uint64_t, std::weak_ptr<Session>> sessions;
};

// One robot connection. Requests are served strictly one at a time: the next queued
// request goes to the handler only after the previous reply was written. Reading goes on
// while a request is pending (to queue pipelined requests and to notice a vanished peer)
// until kMaxQueuedRequests are queued; then TCP flow control holds the robot back.
class Session : public std::enable_shared_from_this<Session> {
 public:
  Session(tcp::socket socket, std::shared_ptr<ServerCore> server, std::uint64_t id, std::string peer)
      : socket_(std::move(socket)),
        writeTimer_(server->io),
        server_(std::move(server)),
        id_(id),
        peer_(std::move(peer)) {}

  void start() { advance(); }

  void close(std::string_view reason);

  // Reply for request number `seq`; ignored unless it is the pending one on an open session.
  void deliver(std::uint64_t seq, const RobotReply& reply) {
    if (closed_ || !awaitingReply_ || seq != seq_) return;
    awaitingReply_ = false;
    writeReply(reply);
    advance();
  }

  // The handler dropped every copy of the ReplyFn for `seq` without calling it.
  void replyDropped(std::uint64_t seq, int job) {
    if (closed_ || !awaitingReply_ || seq != seq_) return;
    log::error("robot", "robot '{}': request handler dropped the reply for job {} ({}); answering INTERNAL",
               server_->endpoint.name, job, peer_);
    RobotReply r;
    r.status = Status::Internal;
    deliver(seq, r);
  }

  asio::io_context::executor_type executor() { return server_->io.get_executor(); }

 private:
  // Moves the state machine on after any event: queue complete requests, serve the next
  // one, keep reading if there is room, finish after the peer's EOF.
  void advance() {
    if (closed_) return;
    drainSplitter();
    pump();
    if (closed_) return;
    drainSplitter();
    if (!reading_ && !peerEof_ && inbox_.size() < kMaxQueuedRequests) doRead();
    if (peerEof_ && !awaitingReply_ && !writing_ && inbox_.empty()) close("peer closed the connection");
  }

  void drainSplitter() {
    while (inbox_.size() < kMaxQueuedRequests) {
      std::optional<Result<std::string>> line = splitter_.next();
      if (!line) return;
      if (*line) {
        inbox_.push_back(parseRequest(**line));
      } else {
        inbox_.push_back(std::unexpected(std::move(line->error())));
      }
    }
  }

  void pump();

  void doRead() {
    reading_ = true;
    socket_.async_read_some(asio::buffer(readBuf_),
                            [self = shared_from_this()](const error_code& ec, std::size_t n) { self->onRead(ec, n); });
  }

  void onRead(const error_code& ec, std::size_t n) {
    reading_ = false;
    if (closed_) return;
    if (ec == asio::error::eof) {
      // Half-close: answer what was already received, then close.
      peerEof_ = true;
      advance();
      return;
    }
    if (ec) {
      close(ec.message());
      return;
    }
    splitter_.append(std::string_view(readBuf_.data(), n));
    advance();
  }

  // One reply = one async_write of the whole formatted string.
  void writeReply(const RobotReply& reply) {
    outgoing_ = formatReply(server_->endpoint.dialect, reply);
    writing_ = true;
    const std::uint64_t gen = ++writeGen_;
    writeTimer_.expires_after(kWriteTimeout);
    writeTimer_.async_wait([self = shared_from_this(), gen](const error_code& ec) {
      if (!ec && self->writing_ && self->writeGen_ == gen) self->close("reply write timed out");
    });
    asio::async_write(socket_, asio::buffer(outgoing_),
                      [self = shared_from_this()](const error_code& ec, std::size_t) { self->onWrite(ec); });
  }

  void onWrite(const error_code& ec) {
    writing_ = false;
    writeTimer_.cancel();
    if (closed_) return;
    if (ec) {
      close(ec.message());
      return;
    }
    ++replies_;
    advance();
  }

  tcp::socket socket_;
  asio::steady_timer writeTimer_;
  std::shared_ptr<ServerCore> server_;
  const std::uint64_t id_;
  const std::string peer_;
  RequestSplitter splitter_;
  std::array<char, kReadChunkBytes> readBuf_{};
  std::deque<Result<RobotRequest>> inbox_;  // parsed requests and error replies, in order
  std::string outgoing_;                    // the reply being written
  std::uint64_t seq_ = 0;                   // number of the request handed to the handler
  std::uint64_t writeGen_ = 0;
  std::uint64_t replies_ = 0;
  bool reading_ = false;
  bool writing_ = false;
  bool awaitingReply_ = false;
  bool peerEof_ = false;
  bool closed_ = false;
};

// State behind one ReplyFn: keeps the session alive until the reply is given (or every
// copy of the ReplyFn is gone), and makes second calls no-ops.
class PendingReply {
 public:
  PendingReply(std::shared_ptr<Session> session, std::uint64_t seq, int job)
      : session_(std::move(session)), seq_(seq), job_(job) {}
  PendingReply(const PendingReply&) = delete;
  PendingReply& operator=(const PendingReply&) = delete;

  // Contract: destroyed on the I/O thread (the handler keeps the ReplyFn on it).
  ~PendingReply() {
    if (!done_.load()) session_->replyDropped(seq_, job_);
  }

  void complete(const RobotReply& reply) {
    if (done_.exchange(true)) return;  // exactly once
    asio::dispatch(session_->executor(), [s = session_, seq = seq_, reply] { s->deliver(seq, reply); });
  }

 private:
  std::shared_ptr<Session> session_;
  std::uint64_t seq_;
  int job_;
  std::atomic<bool> done_{false};
};

void Session::pump() {
  if (closed_ || awaitingReply_ || writing_ || inbox_.empty()) return;
  Result<RobotRequest> item = std::move(inbox_.front());
  inbox_.pop_front();

  if (!item) {  // malformed: answer at once, in order, and keep the connection
    log::debug("robot", "robot '{}': {} sent a bad request: {}", server_->endpoint.name, peer_, item.error().message);
    RobotReply r;
    r.status = item.error().code;
    writeReply(r);
    return;
  }

  awaitingReply_ = true;
  const std::uint64_t seq = ++seq_;
  auto pending = std::make_shared<PendingReply>(shared_from_this(), seq, item->job);
  ReplyFn reply = [pending](const RobotReply& r) { pending->complete(r); };
  try {
    server_->handler(server_->endpoint.name, *item, std::move(reply));
  } catch (const std::exception& e) {
    log::error("robot", "robot '{}': request handler threw for job {}: {}; answering INTERNAL", server_->endpoint.name,
               item->job, e.what());
    RobotReply r;
    r.status = Status::Internal;
    pending->complete(r);
  }
}

void Session::close(std::string_view reason) {
  if (closed_) return;
  closed_ = true;
  awaitingReply_ = false;
  inbox_.clear();
  error_code ignored;
  socket_.shutdown(tcp::socket::shutdown_both, ignored);  // ENOTCONN after a reset is expected
  socket_.close(ignored);
  writeTimer_.cancel();
  server_->sessions.erase(id_);
  log::info("robot", "robot '{}': {} disconnected ({}); {} replies sent, {} clients left", server_->endpoint.name,
            peer_, reason, replies_, server_->sessions.size());
}

void ServerCore::doAccept() {
  acceptor.async_accept(io, [self = shared_from_this()](const error_code& ec, tcp::socket socket) {
    self->onAccept(ec, std::move(socket));
  });
}

void ServerCore::onAccept(const error_code& ec, tcp::socket socket) {
  if (stopped || !acceptor.is_open()) return;
  if (ec) {
    // EMFILE and friends: retry later instead of spinning.
    log::warn("robot", "robot '{}': accept failed: {}; retrying", endpoint.name, ec.message());
    retryTimer.expires_after(kAcceptRetryDelay);
    retryTimer.async_wait([self = shared_from_this()](const error_code& wec) {
      if (!wec && !self->stopped) self->doAccept();
    });
    return;
  }

  const std::string peer = peerName(socket);
  if (sessions.size() >= endpoint.maxClients) {
    log::warn("robot", "robot '{}': refusing {}: already {} clients (maxClients)", endpoint.name, peer,
              sessions.size());
    error_code ignored;
    socket.close(ignored);
  } else {
    // Option failures only cost latency or dead-peer detection; the session still works.
    error_code optEc;
    socket.set_option(tcp::no_delay(true), optEc);  // the reply leaves in one segment, now
    socket.set_option(asio::socket_base::keep_alive(true), optEc);
    socket.set_option(KeepIdle(kKeepIdleS), optEc);
    socket.set_option(KeepInterval(kKeepIntervalS), optEc);
    socket.set_option(KeepCount(kKeepCount), optEc);
    socket.set_option(UserTimeout(kUserTimeoutMs), optEc);
    if (optEc) log::debug("robot", "robot '{}': socket option for {}: {}", endpoint.name, peer, optEc.message());

    const std::uint64_t id = nextSessionId++;
    auto session = std::make_shared<Session>(std::move(socket), shared_from_this(), id, peer);
    sessions.emplace(id, session);
    log::info("robot", "robot '{}': {} connected ({}/{} clients)", endpoint.name, peer, sessions.size(),
              endpoint.maxClients);
    session->start();
  }
  doAccept();
}

void ServerCore::stopAll() {
  if (stopped) return;
  stopped = true;
  error_code ignored;
  acceptor.close(ignored);
  retryTimer.cancel();
  // close() erases from the map: iterate over a snapshot.
  std::vector<std::shared_ptr<Session>> open;
  open.reserve(sessions.size());
  for (auto& [id, weak] : sessions) {
    if (auto s = weak.lock()) open.push_back(std::move(s));
  }
  for (auto& s : open) s->close("server stopped");
  sessions.clear();
  if (started) log::info("robot", "robot '{}': stopped listening on port {}", endpoint.name, boundPort);
}

}  // namespace robot_detail

struct RobotServer::Listener : robot_detail::ServerCore {
  using robot_detail::ServerCore::ServerCore;
};

RobotServer::RobotServer(asio::io_context& io, RobotEndpoint endpoint, RequestHandler handler)
    : listener_(std::make_shared<Listener>(io, std::move(endpoint), std::move(handler))) {}

RobotServer::~RobotServer() { stop(); }

Result<void> RobotServer::start() {
  Listener& l = *listener_;
  const RobotEndpoint& ep = l.endpoint;
  const std::string where =
      fmt::format("robot '{}' ({} dialect) on {}:{}", ep.name, dialectName(ep.dialect), ep.bind, ep.port);
  if (l.started || l.stopped) return fail(Status::Internal, where + ": server already started");
  if (ep.maxClients == 0) return fail(Status::Internal, where + ": maxClients is 0");

  error_code ec;
  tcp::endpoint bindTo;
  const asio::ip::address address = asio::ip::make_address(ep.bind, ec);
  if (!ec) {
    bindTo = tcp::endpoint(address, ep.port);
  } else {
    tcp::resolver resolver(l.io);
    const auto results =
        resolver.resolve(ep.bind, std::to_string(ep.port), tcp::resolver::passive | tcp::resolver::numeric_service, ec);
    if (ec || results.empty()) {
      return fail(Status::Internal, fmt::format("{}: cannot resolve bind address: {}", where,
                                                ec ? ec.message() : std::string("no address")));
    }
    bindTo = results.begin()->endpoint();
  }

  const auto failWith = [&](std::string_view step) {
    error_code ignored;
    l.acceptor.close(ignored);
    return fail(Status::Internal, fmt::format("{}: {} failed: {}", where, step, ec.message()));
  };
  l.acceptor.open(bindTo.protocol(), ec);
  if (ec) return failWith("open");
  l.acceptor.set_option(tcp::acceptor::reuse_address(true), ec);
  if (ec) return failWith("SO_REUSEADDR");
  l.acceptor.bind(bindTo, ec);
  if (ec) return failWith("bind");
  l.acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) return failWith("listen");
  l.boundPort = l.acceptor.local_endpoint(ec).port();
  if (ec) return failWith("getsockname");

  l.started = true;
  log::info("robot", "robot '{}': {} dialect listening on {}:{} (max {} clients)", ep.name, dialectName(ep.dialect),
            bindTo.address().to_string(), l.boundPort, ep.maxClients);
  l.doAccept();
  return {};
}

void RobotServer::stop() {
  if (listener_) listener_->stopAll();
}

std::uint16_t RobotServer::port() const { return listener_->boundPort; }

const RobotEndpoint& RobotServer::endpoint() const { return listener_->endpoint; }

std::size_t RobotServer::clientCount() const { return listener_->sessions.size(); }

}  // namespace vgr::protocol
