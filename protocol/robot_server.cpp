#include "protocol/robot_server.hpp"

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>

#include <array>
#include <atomic>
#include <chrono>
#include <deque>
#include <exception>
#include <memory>
#include <string_view>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include <fmt/core.h>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/write.hpp>

#include "core/log.hpp"
#include "core/log_limiter.hpp"
#include "core/token_bucket.hpp"

namespace vgr::protocol {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using boost::system::error_code;

namespace robot_detail {

constexpr std::size_t kReadChunkBytes = 4096;  // one async_read_some (a 1 MB line: 256 reads, not 2048)
// Connection events (connect, disconnect, refusals) logged per endpoint at most this many
// per window; the rest are counted (RobotServerStats) and summarised on the next line.
constexpr int kConnLogBurst = 20;
constexpr auto kConnLogWindow = std::chrono::seconds(10);
constexpr std::size_t kMaxQueuedRequests = 8;  // per connection; beyond it we stop reading
constexpr auto kWriteTimeout = std::chrono::seconds(5);
constexpr auto kAcceptRetryDelay = std::chrono::milliseconds(200);
// A reply that carries a part counts as delivered only if the robot has not reset the
// connection on it this long after it was written: a robot (program) that closed its
// socket without reading answers our data with RST within one round trip; one that read it
// and closed sends FIN; a half-closed one still reads.
constexpr auto kResetProbeDelay = std::chrono::milliseconds(50);
// Strict dialect: pause before asking again after a reply that came at once and had
// nothing to push (e.g. NO_PART_FOUND), so a misconfigured job never spins.
constexpr auto kStrictRetryDelay = std::chrono::milliseconds(100);
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
  // doAccept() within the accept budget (kRobotAcceptsPerSecond), else when it allows.
  void acceptNext();
  void onAccept(const error_code& ec, tcp::socket socket);
  void stopAll();
  bool allowed(const asio::ip::address& peer) const;
  bool mayControl(const asio::ip::address& peer) const;
  // A connection event through the endpoint's rate limit (info, or warn).
  template <class... Args>
  void connLog(bool warning, fmt::format_string<Args...> f, Args&&... args) {
    if (!log::limitedLog(connLimiter, "robot", "connection events", warning, f, std::forward<Args>(args)...))
      ++stats.logLinesHeldBack;
  }

  asio::io_context& io;
  const RobotEndpoint endpoint;
  const RequestHandler handler;
  StrictOutcomeFn strictOutcome;
  std::vector<asio::ip::address> allowedAddresses;  // parsed from endpoint.allowedClients
  std::vector<asio::ip::address> controlAddresses;  // parsed from endpoint.controlClients
  std::size_t maxPerAddress = 0;                    // endpoint.maxClientsPerAddress, resolved
  RobotServerStats stats;
  log::LogLimiter connLimiter{kConnLogBurst, kConnLogWindow};
  TokenBucket acceptBudget{kRobotAcceptsPerSecond, kRobotAcceptBurst};
  // Session budgets of recently seen addresses (at most kMaxPeerBudgets; one unused for a
  // second is full again and may be forgotten); addresses beyond those share one.
  struct PeerBudget {
    TokenBucket sessions{kRobotSessionsPerSecond, kRobotSessionBurst};
    TokenBucket::Clock::time_point lastUsed{};
  };
  static constexpr std::size_t kMaxPeerBudgets = 256;
  std::map<asio::ip::address, PeerBudget> peerBudgets;
  PeerBudget sharedBudget;
  bool takeSession(const asio::ip::address& address) {
    const auto now = TokenBucket::Clock::now();
    auto it = peerBudgets.find(address);
    if (it == peerBudgets.end()) {
      if (peerBudgets.size() >= kMaxPeerBudgets)
        std::erase_if(peerBudgets, [now](const auto& kv) { return now - kv.second.lastUsed > std::chrono::seconds(1); });
      if (peerBudgets.size() < kMaxPeerBudgets) it = peerBudgets.emplace(address, PeerBudget{}).first;
    }
    PeerBudget& b = it == peerBudgets.end() ? sharedBudget : it->second;
    b.lastUsed = now;
    return b.sessions.take(now);
  }
  tcp::acceptor acceptor;
  asio::steady_timer retryTimer;
  std::uint16_t boundPort = 0;
  bool started = false;
  bool stopped = false;
  std::uint64_t nextSessionId = 1;
  // Open sessions by id (ids grow: a smaller id is an older connection). Weak: a session
  // is owned by its pending operations (Beast's shape).
  std::map<std::uint64_t, std::weak_ptr<Session>> sessions;
};

// What every connection shares: the socket, the one-write-at-a-time reply path with its
// deadline, the close path, and the hooks a ReplyFn reaches. Subclasses: RequestSession
// (robot asks, vgrd answers: ur, abb, fanuc, binary) and StrictSession (vgrd pushes).
class Session : public std::enable_shared_from_this<Session> {
 public:
  Session(tcp::socket socket, std::shared_ptr<ServerCore> server, std::uint64_t id, std::string peer,
          asio::ip::address address)
      : socket_(std::move(socket)),
        writeTimer_(server->io),
        server_(std::move(server)),
        id_(id),
        peer_(std::move(peer)),
        address_(std::move(address)) {}
  virtual ~Session() = default;
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  virtual void start() = 0;
  // Reply for request number `seq` from the handler; ignored unless it is still awaited
  // (then `written` gets false at once).
  void deliver(std::uint64_t seq, const RobotReply& reply, WrittenFn written) {
    if (closed_ || !awaitingReply_ || seq != seq_) {
      if (written) written(false);
      return;
    }
    written_ = std::move(written);
    deliverAwaited(reply);
  }

  // The handler dropped every copy of the ReplyFn for `seq` without calling it.
  void replyDropped(std::uint64_t seq, int job) {
    if (closed_ || !awaitingReply_ || seq != seq_) return;
    log::error("robot", "robot '{}': request handler dropped the reply for job {} ({}); answering INTERNAL",
               server_->endpoint.name, job, peer_);
    RobotReply r;
    r.status = Status::Internal;
    deliver(seq, r, {});
  }

  void close(std::string_view reason);
  bool closed() const { return closed_; }
  // Something is in progress on the connection (see RobotEndpoint::staleAfterMs).
  virtual bool busy() const = 0;
  // Nothing in progress and no byte from the robot for staleAfter.
  bool stale(std::chrono::steady_clock::time_point now, std::chrono::milliseconds staleAfter) const {
    return !closed_ && !busy() && now - lastActivity_ >= staleAfter;
  }
  // When the robot last sent a byte (or the connection opened, or a reply was written).
  std::chrono::steady_clock::time_point lastActivity() const { return lastActivity_; }
  const asio::ip::address& address() const { return address_; }
  asio::io_context::executor_type executor() { return server_->io.get_executor(); }

 protected:
  // Hands `req` to the handler as request number seq_+1; the reply comes to deliver().
  void callHandler(const RobotRequest& req);

  // One write of `bytes` at a time, with kWriteTimeout; onWritten() after success.
  void writeBytes(std::string bytes) {
    outgoing_ = std::move(bytes);
    writing_ = true;
    const std::uint64_t gen = ++writeGen_;
    writeTimer_.expires_after(kWriteTimeout);
    writeTimer_.async_wait([self = shared_from_this(), gen](const error_code& ec) {
      if (!ec && self->writing_ && self->writeGen_ == gen) self->close("reply write timed out");
    });
    asio::async_write(socket_, asio::buffer(outgoing_),
                      [self = shared_from_this()](const error_code& ec, std::size_t) { self->onWrite(ec); });
  }
  virtual void onWritten() = 0;
  virtual void onClosing() {}
  // The awaited reply, accepted: send it (written_ holds its WrittenFn).
  virtual void deliverAwaited(const RobotReply& reply) = 0;
  // Tells the handler whether the reply in flight reached the robot (once).
  void settleWritten(bool written) {
    if (!written_) return;
    WrittenFn fn = std::move(written_);
    written_ = nullptr;
    fn(written);
  }

  void onWrite(const error_code& ec) {
    writing_ = false;
    writeTimer_.cancel();
    if (closed_) return;
    if (ec) {
      if (ec == asio::error::connection_reset || ec == asio::error::broken_pipe) resetSeen_ = true;
      close(ec.message());
      return;
    }
    ++replies_;
    onWritten();
  }

  // The robot reset the connection (RST): our data did not reach a reader.
  bool socketReset() {
    if (!socket_.is_open()) return false;
    tcp_info info{};
    socklen_t len = sizeof info;
    if (::getsockopt(socket_.native_handle(), IPPROTO_TCP, TCP_INFO, &info, &len) != 0) return true;
    int err = 0;
    len = sizeof err;
    ::getsockopt(socket_.native_handle(), SOL_SOCKET, SO_ERROR, &err, &len);
    return info.tcpi_state == TCP_CLOSE || err != 0;
  }

  tcp::socket socket_;
  asio::steady_timer writeTimer_;
  std::shared_ptr<ServerCore> server_;
  const std::uint64_t id_;
  const std::string peer_;
  const asio::ip::address address_;
  std::array<char, kReadChunkBytes> readBuf_{};
  std::string outgoing_;  // the bytes being written
  WrittenFn written_;     // of the handler's reply being written, if it asked
  std::chrono::steady_clock::time_point lastActivity_ = std::chrono::steady_clock::now();
  std::uint64_t seq_ = 0;  // number of the request handed to the handler
  std::uint64_t writeGen_ = 0;
  std::uint64_t replies_ = 0;
  bool reading_ = false;
  bool writing_ = false;
  bool awaitingReply_ = false;
  bool closed_ = false;
  bool resetSeen_ = false;  // an RST from the robot was seen (read/write error or at close)
};

// One robot connection of a request/reply dialect. Requests are served strictly one at a
// time: the next queued request goes to the handler only after the previous reply was
// written. Reading goes on while a request is pending (to queue pipelined requests and to
// notice a vanished peer) until kMaxQueuedRequests are queued; then TCP flow control
// holds the robot back.
class RequestSession final : public Session {
 public:
  RequestSession(tcp::socket socket, std::shared_ptr<ServerCore> server, std::uint64_t id, std::string peer,
                 asio::ip::address address)
      : Session(std::move(socket), server, id, std::move(peer), std::move(address)), decoder_(server->endpoint.dialect) {}

  void start() override {
    armIdleTimer();
    advance();
  }

  void deliverAwaited(const RobotReply& reply) override {
    awaitingReply_ = false;
    writeBytes(formatReply(server_->endpoint.dialect, reply, server_->endpoint.replyLabel, server_->endpoint.abbRotation));
    advance();
  }

  bool busy() const override {
    return awaitingReply_ || writing_ || probes_ > 0 || !inbox_.empty() || partialSince_.has_value();
  }

 private:
  // Moves the state machine on after any event: queue complete requests, serve the next
  // one, keep reading if there is room, finish after the peer's EOF.
  void advance() {
    if (closed_) return;
    drainDecoder();
    pump();
    if (closed_) return;
    drainDecoder();
    if (!reading_ && !peerEof_ && inbox_.size() < kMaxQueuedRequests) doRead();
    if (peerEof_ && !awaitingReply_ && !writing_ && probes_ == 0 && inbox_.empty()) close("peer closed the connection");
  }

  void drainDecoder() {
    while (inbox_.size() < kMaxQueuedRequests) {
      std::optional<Result<RobotRequest>> item = decoder_.next();
      if (!item) {
        trackPartial();
        return;
      }
      inbox_.push_back(std::move(*item));
    }
    partialSince_.reset();  // the decoder may hold complete requests the inbox has no room for
  }

  // The decoder holds the start of a request: it must be complete within
  // endpoint.requestTimeoutMs of its first byte (slowloris, a line that never ends).
  void trackPartial() {
    if (decoder_.partial() == 0) {
      partialSince_.reset();
      return;
    }
    if (partialSince_) return;
    partialSince_ = std::chrono::steady_clock::now();
    const int ms = server_->endpoint.requestTimeoutMs;
    partialTimer_.expires_after(std::chrono::milliseconds(ms));
    partialTimer_.async_wait([self = shared_from_this(), this, ms, since = *partialSince_](const error_code& ec) {
      if (ec || closed_ || partialSince_ != since) return;
      close(fmt::format("request incomplete {} ms after its first byte", ms));
    });
  }

  void schedulePump() {
    if (pumpScheduled_) return;
    pumpScheduled_ = true;
    pumpTimer_.expires_at(budget_.nextToken());
    pumpTimer_.async_wait([self = shared_from_this(), this](const error_code& ec) {
      pumpScheduled_ = false;
      if (!ec) advance();
    });
  }

  void pump() {
    if (closed_ || awaitingReply_ || writing_ || pumpScheduled_ || inbox_.empty()) return;
    Result<RobotRequest> item = std::move(inbox_.front());
    inbox_.pop_front();
    if (!item && !budget_.take()) {
      inbox_.push_front(std::move(item));
      schedulePump();
      return;
    }
    if (!item) {  // malformed: answer at once, in order, and keep the connection
      log::debug("robot", "robot '{}': {} sent a bad request: {}", server_->endpoint.name, peer_,
                 item.error().message);
      RobotReply r;
      r.status = item.error().code;
      writeBytes(formatReply(server_->endpoint.dialect, r, server_->endpoint.replyLabel, server_->endpoint.abbRotation));
      return;
    }
    if (!budget_.take()) {  // over the connection's request rate: served when a token comes
      inbox_.push_front(std::move(item));
      schedulePump();
      return;
    }
    if (item->command != Command::Get && !server_->mayControl(address_)) {
      // JOB and TRIG change what the robot gets or start cycles: only from control_clients.
      ++server_->stats.controlRefused;
      server_->connLog(true, "robot '{}': {} may not send {} (not in control_clients): -10 NOT_PERMITTED",
                       server_->endpoint.name, peer_, item->command == Command::Job ? "JOB" : "TRIG");
      RobotReply r;
      r.status = Status::NotPermitted;
      writeBytes(formatReply(server_->endpoint.dialect, r));
      return;
    }
    callHandler(*item);
  }

  void doRead() {
    reading_ = true;
    socket_.async_read_some(asio::buffer(readBuf_), [self = shared_from_this(), this](const error_code& ec, std::size_t n) {
      onRead(ec, n);
    });
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
      if (ec == asio::error::connection_reset) resetSeen_ = true;
      close(ec.message());
      return;
    }
    lastActivity_ = std::chrono::steady_clock::now();
    decoder_.append(std::string_view(readBuf_.data(), n));
    advance();
  }

  // endpoint.idleTimeoutMs: close a connection silent that long with nothing in progress.
  void armIdleTimer() {
    const int ms = server_->endpoint.idleTimeoutMs;
    if (ms <= 0) return;
    const auto now = std::chrono::steady_clock::now();
    const bool busy = awaitingReply_ || writing_ || !inbox_.empty();
    const auto due = lastActivity_ + std::chrono::milliseconds(ms);
    idleTimer_.expires_at(busy || due <= now ? now + std::chrono::milliseconds(ms) : due);
    idleTimer_.async_wait([self = shared_from_this(), this, ms](const error_code& ec) {
      if (ec || closed_) return;
      const bool idle = !awaitingReply_ && !writing_ && inbox_.empty() &&
                        std::chrono::steady_clock::now() - lastActivity_ >= std::chrono::milliseconds(ms);
      if (idle) {
        close("idle for " + std::to_string(ms) + " ms (idle_timeout_ms)");
        return;
      }
      armIdleTimer();
    });
  }

  void onWritten() override {
    lastActivity_ = std::chrono::steady_clock::now();
    if (!written_) {
      advance();
      return;
    }
    // A reply with a part: delivered unless the robot resets the connection on it within a
    // round trip (it closed its socket without reading: a program aborted mid-request). Not
    // only after an EOF was seen: the robot's close may reach us after our write completed.
    // The next request is served meanwhile; an EOF closes only after the probes.
    WrittenFn fn = std::move(written_);
    written_ = nullptr;
    ++probes_;
    auto timer = std::make_shared<asio::steady_timer>(server_->io, kResetProbeDelay);
    timer->async_wait([self = shared_from_this(), this, timer, fn = std::move(fn)](const error_code&) {
      --probes_;
      const bool reset = resetSeen_ || (!closed_ && socketReset());
      fn(!reset);
      advance();
    });
    advance();
  }

  void onClosing() override {
    if (probes_ > 0 && !resetSeen_) resetSeen_ = socketReset();
    idleTimer_.cancel();
    partialTimer_.cancel();
    pumpTimer_.cancel();
  }

  RequestDecoder decoder_;
  asio::steady_timer idleTimer_{server_->io};
  asio::steady_timer partialTimer_{server_->io};
  asio::steady_timer pumpTimer_{server_->io};
  TokenBucket budget_{kRobotRequestsPerSecond, kRobotRequestBurst};
  bool pumpScheduled_ = false;
  std::optional<std::chrono::steady_clock::time_point> partialSince_;  // first byte of an incomplete request
  std::deque<Result<RobotRequest>> inbox_;  // parsed requests and error replies, in order
  bool peerEof_ = false;
  int probes_ = 0;  // replies whose delivery is being checked (kResetProbeDelay)
};

// One robot connection of the strict dialect (paper 002): vgrd asks its handler for the
// robot's next part (GET of the current job) whenever idle and pushes every Ok result
// through the four-step exchange of StrictExchange, each step within stepTimeoutMs. A
// wrong token, silence or a lost connection aborts the exchange with an error log and a
// StrictOutcome, and the connection is closed so that the robot program starts afresh;
// the server keeps accepting.
class StrictSession final : public Session {
 public:
  StrictSession(tcp::socket socket, std::shared_ptr<ServerCore> server, std::uint64_t id, std::string peer,
                asio::ip::address address)
      : Session(std::move(socket), server, id, std::move(peer), std::move(address)),
        exchange_(server->endpoint.strict),
        stepTimer_(server->io) {}

  void start() override {
    doRead();
    ask();
  }

  // vgrd's own GET (waiting for the next part) is not the robot's doing: only a running
  // exchange or a write makes the connection busy.
  bool busy() const override { return writing_ || exchange_.step() != StrictExchange::Step::Idle; }

  void deliverAwaited(const RobotReply& reply) override {
    awaitingReply_ = false;
    if (reply.status == Status::Ok) {
      Result<std::string> frame = formatStrictPoseFrame(reply.pose);
      if (frame) {
        cycleId_ = reply.cycleId;
        writeBytes(exchange_.begin(std::move(*frame)));
        armStepTimer();
        return;
      }
      log::error("robot", "robot '{}': cycle {}: {}; not sent", server_->endpoint.name, reply.cycleId,
                 frame.error().message);
    }
    if (exchange_.snapshotMode()) {
      // The robot waits for an answer to its snapshot: tell it there is nothing to move.
      const Status st = reply.status == Status::Ok ? Status::Internal : reply.status;
      log::debug("robot", "robot '{}': snapshot cycle {} ended {}", server_->endpoint.name, reply.cycleId, statusCode(st));
      writeBytes(exchange_.noResult(st));  // onWritten() settles the reply as delivered
      return;
    }
    // Statuses are not pushed in this dialect: consumed as they are.
    settleWritten(true);
    // Nothing to move. Statuses 2 and 3 came after the reply deadline: ask again at once;
    // anything else may have come at once: pause so a misconfiguration cannot spin.
    const bool waited = reply.status == Status::ResultNotReady || reply.status == Status::NoNewTrigger;
    if (waited) {
      ask();
    } else {
      log::debug("robot", "robot '{}': cycle {} ended {}: nothing to push", server_->endpoint.name, reply.cycleId,
                 statusCode(reply.status));
      pauseThenAsk();
    }
  }

 private:
  void ask() {
    // Snapshot mode: the robot drives (onSnapshot); push mode: GET whenever idle.
    if (exchange_.snapshotMode()) return;
    if (closed_ || awaitingReply_ || exchange_.step() != StrictExchange::Step::Idle) return;
    RobotRequest req;  // GET of the robot's current job
    callHandler(req);
  }

  void onSnapshot(const Pose& flange) {
    if (closed_ || awaitingReply_) return;
    RobotRequest req;  // TRIG of the robot's current job, with the flange pose of the image
    req.command = Command::Trigger;
    req.flange = flange;
    callHandler(req);
  }

  void pauseThenAsk() {
    stepTimer_.expires_after(kStrictRetryDelay);
    stepTimer_.async_wait([self = shared_from_this(), this](const error_code& ec) {
      if (!ec && !closed_) ask();
    });
  }

  void armStepTimer() {
    const std::uint64_t gen = ++stepGen_;
    stepTimer_.expires_after(std::chrono::milliseconds(server_->endpoint.stepTimeoutMs));
    stepTimer_.async_wait([self = shared_from_this(), this, gen](const error_code& ec) {
      if (ec || closed_ || gen != stepGen_) return;
      finish(exchange_.onTimeout());
    });
  }

  void doRead() {
    reading_ = true;
    socket_.async_read_some(asio::buffer(readBuf_), [self = shared_from_this(), this](const error_code& ec, std::size_t n) {
      onRead(ec, n);
    });
  }

  void onRead(const error_code& ec, std::size_t n) {
    reading_ = false;
    if (closed_) return;
    if (ec) {
      close(ec == asio::error::eof ? std::string("peer closed the connection") : ec.message());
      return;
    }
    lastActivity_ = std::chrono::steady_clock::now();
    exchange_.feed(std::string_view(readBuf_.data(), n));
    for (;;) {
      StrictExchange::Event e = exchange_.poll();
      if (e.kind == StrictExchange::EventKind::None) break;
      if (e.kind == StrictExchange::EventKind::SendPose) {
        writeBytes(std::move(e.bytes));
        armStepTimer();
        continue;
      }
      if (e.kind == StrictExchange::EventKind::Unexpected) {
        log::warn("robot", "robot '{}': {} sent '{}' while no exchange was running; ignored", server_->endpoint.name,
                  peer_, e.detail);
        continue;
      }
      if (e.kind == StrictExchange::EventKind::Snapshot) {
        onSnapshot(e.pose);
        continue;
      }
      if (e.kind == StrictExchange::EventKind::BadSnapshot) {
        log::warn("robot", "robot '{}': {}: {}; answered {}", server_->endpoint.name, peer_, e.detail, statusCode(e.status));
        if (!writing_) writeBytes(exchange_.noResult(e.status));
        continue;
      }
      finish(std::move(e));
      if (closed_) return;
    }
    doRead();
  }

  // Completed or Failed.
  void finish(StrictExchange::Event e) {
    ++stepGen_;
    stepTimer_.cancel();
    StrictOutcome outcome;
    outcome.cycleId = cycleId_;
    if (e.kind == StrictExchange::EventKind::Completed) {
      ++exchanges_;
      log::debug("robot", "robot '{}': cycle {} pushed and done", server_->endpoint.name, cycleId_);
      report(outcome);
      ask();
      return;
    }
    if (e.kind != StrictExchange::EventKind::Failed) return;
    outcome.status = e.status;
    outcome.detail = e.detail;
    log::error("robot", "robot '{}': {}: exchange for cycle {} aborted with status {} ({}): {}", server_->endpoint.name,
               peer_, cycleId_, statusCode(e.status), statusName(e.status), e.detail);
    report(outcome);
    close("strict exchange aborted");
  }

  void report(const StrictOutcome& outcome) {
    if (server_->strictOutcome) server_->strictOutcome(server_->endpoint.name, outcome);
  }

  // The pose frame (or a later step) reached the robot: the part counts as delivered.
  void onWritten() override { settleWritten(true); }

  void onClosing() override {
    ++stepGen_;
    stepTimer_.cancel();
    StrictExchange::Event e = exchange_.onClosed();
    if (e.kind != StrictExchange::EventKind::Failed) return;
    StrictOutcome outcome;
    outcome.cycleId = cycleId_;
    outcome.status = e.status;
    outcome.detail = e.detail;
    log::error("robot", "robot '{}': {}: exchange for cycle {} aborted with status {} ({}): {}", server_->endpoint.name,
               peer_, cycleId_, statusCode(e.status), statusName(e.status), e.detail);
    report(outcome);
  }

  StrictExchange exchange_;
  asio::steady_timer stepTimer_;
  std::uint64_t stepGen_ = 0;
  std::uint32_t cycleId_ = 0;
  std::uint64_t exchanges_ = 0;
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

  void complete(const RobotReply& reply, WrittenFn written) {
    if (done_.exchange(true)) {  // exactly once
      if (written) written(false);
      return;
    }
    asio::dispatch(session_->executor(),
                   [s = session_, seq = seq_, reply, w = std::move(written)]() mutable { s->deliver(seq, reply, std::move(w)); });
  }

 private:
  std::shared_ptr<Session> session_;
  std::uint64_t seq_;
  int job_;
  std::atomic<bool> done_{false};
};

void Session::callHandler(const RobotRequest& req) {
  awaitingReply_ = true;
  const std::uint64_t seq = ++seq_;
  auto pending = std::make_shared<PendingReply>(shared_from_this(), seq, req.job);
  ReplyFn reply = ReplyFn::withCompletion([pending](const RobotReply& r, WrittenFn w) { pending->complete(r, std::move(w)); });
  try {
    server_->handler(server_->endpoint.name, req, std::move(reply));
  } catch (const std::exception& e) {
    log::error("robot", "robot '{}': request handler threw for job {}: {}; answering INTERNAL", server_->endpoint.name,
               req.job, e.what());
    RobotReply r;
    r.status = Status::Internal;
    pending->complete(r, {});
  }
}

void Session::close(std::string_view reason) {
  if (closed_) return;
  closed_ = true;
  awaitingReply_ = false;
  onClosing();
  settleWritten(false);
  error_code ignored;
  socket_.shutdown(tcp::socket::shutdown_both, ignored);  // ENOTCONN after a reset is expected
  socket_.close(ignored);
  writeTimer_.cancel();
  server_->sessions.erase(id_);
  ++server_->stats.closed;
  server_->connLog(false, "robot '{}': {} disconnected ({}); {} replies sent, {} clients left", server_->endpoint.name,
                   peer_, reason, replies_, server_->sessions.size());
}

namespace {
bool listed(const std::vector<asio::ip::address>& list, const asio::ip::address& peer) {
  for (const auto& a : list) {
    if (a == peer) return true;
    // An IPv4 client on a dual-stack socket shows up as ::ffff:a.b.c.d.
    if (peer.is_v6() && peer.to_v6().is_v4_mapped() && a.is_v4() &&
        asio::ip::make_address_v4(asio::ip::v4_mapped, peer.to_v6()) == a.to_v4())
      return true;
  }
  return false;
}
}  // namespace

bool ServerCore::allowed(const asio::ip::address& peer) const {
  return allowedAddresses.empty() || listed(allowedAddresses, peer);
}

bool ServerCore::mayControl(const asio::ip::address& peer) const {
  return controlAddresses.empty() || listed(controlAddresses, peer);
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

  error_code addrEc;
  const asio::ip::address address = socket.remote_endpoint(addrEc).address();
  const auto refuse = [&] {
    error_code ignored;
    socket.close(ignored);
    acceptNext();
  };
  if (addrEc) {
    // Reset by the peer between the kernel's accept and ours (a reset storm): nothing to
    // serve and nobody to name.
    ++stats.goneBeforeAccept;
    log::debug("robot", "robot '{}': a connection was reset before it was accepted: {}", endpoint.name,
               addrEc.message());
    return refuse();
  }
  const std::string peer = peerName(socket);
  if (!allowed(address)) {
    ++stats.refusedNotAllowed;
    connLog(true, "robot '{}': refusing {}: not in allowed_clients", endpoint.name, peer);
    return refuse();
  }
  if (!takeSession(address)) {
    ++stats.refusedRate;
    connLog(true, "robot '{}': refusing {}: more than {} new connections a second from its address", endpoint.name,
            peer, kRobotSessionsPerSecond);
    return refuse();
  }
  std::size_t fromAddress = 0;
  for (auto& [sid, weak] : sessions) {
    auto s = weak.lock();
    if (s && s->address() == address) ++fromAddress;
  }
  if (sessions.size() >= endpoint.maxClients || fromAddress >= maxPerAddress) {
    // Full: a new connection from an address takes the slot of that address's stalest
    // connection only if it is really stale (nothing in progress, silent for
    // staleAfterMs: a rebooted controller's old socket). A live one, or one whose robot
    // waits for its reply, is never closed for a newcomer: the newcomer is refused.
    const auto now = std::chrono::steady_clock::now();
    const std::chrono::milliseconds staleAfter(endpoint.staleAfterMs);
    std::shared_ptr<Session> stale;
    for (auto& [sid, weak] : sessions) {
      auto s = weak.lock();
      if (s && s->address() == address && s->stale(now, staleAfter) &&
          (!stale || s->lastActivity() < stale->lastActivity()))
        stale = std::move(s);
    }
    if (!stale) {
      ++stats.refusedFull;
      connLog(true, "robot '{}': refusing {}: {} (max_clients {}, {} per address) and none of its connections is stale",
              endpoint.name, peer,
              sessions.size() >= endpoint.maxClients ? fmt::format("already {} clients", sessions.size())
                                                     : fmt::format("already {} clients from its address", fromAddress),
              endpoint.maxClients, maxPerAddress);
      return refuse();
    }
    ++stats.replacedStale;
    stale->close(fmt::format("stale (nothing in progress, silent for {} ms or more): replaced by a new connection "
                             "from the same address",
                             endpoint.staleAfterMs));
  }
  {
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
    std::shared_ptr<Session> session;
    if (endpoint.dialect == Dialect::Strict)
      session = std::make_shared<StrictSession>(std::move(socket), shared_from_this(), id, peer, address);
    else
      session = std::make_shared<RequestSession>(std::move(socket), shared_from_this(), id, peer, address);
    sessions.emplace(id, session);
    ++stats.accepted;
    connLog(false, "robot '{}': {} connected ({}/{} clients)", endpoint.name, peer, sessions.size(), endpoint.maxClients);
    session->start();
  }
  acceptNext();
}

void ServerCore::acceptNext() {
  if (stopped) return;
  const auto now = TokenBucket::Clock::now();
  if (acceptBudget.take(now)) {
    doAccept();
    return;
  }
  retryTimer.expires_at(acceptBudget.nextToken(now));
  retryTimer.async_wait([self = shared_from_this()](const error_code& ec) {
    if (!ec && !self->stopped) self->acceptNext();
  });
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
  if (ep.maxClientsPerAddress > ep.maxClients)
    return fail(Status::Internal, where + ": maxClientsPerAddress is above maxClients");
  if (ep.staleAfterMs <= 0) return fail(Status::Internal, where + ": staleAfterMs must be > 0");
  if (ep.requestTimeoutMs <= 0) return fail(Status::Internal, where + ": requestTimeoutMs must be > 0");
  l.maxPerAddress = ep.maxClientsPerAddress == 0 ? ep.maxClients : ep.maxClientsPerAddress;
  if (ep.dialect == Dialect::Strict && ep.stepTimeoutMs <= 0)
    return fail(Status::Internal, where + ": stepTimeoutMs must be > 0");
  l.allowedAddresses.clear();
  for (const std::string& a : ep.allowedClients) {
    error_code aec;
    const asio::ip::address parsed = asio::ip::make_address(a, aec);
    if (aec) return fail(Status::Internal, fmt::format("{}: allowed client '{}' is not an IP address", where, a));
    l.allowedAddresses.push_back(parsed);
  }
  l.controlAddresses.clear();
  for (const std::string& a : ep.controlClients) {
    error_code aec;
    const asio::ip::address parsed = asio::ip::make_address(a, aec);
    if (aec) return fail(Status::Internal, fmt::format("{}: control client '{}' is not an IP address", where, a));
    l.controlAddresses.push_back(parsed);
  }

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
  log::info("robot", "robot '{}': {} dialect listening on {}:{} (max {} clients, {} per address)", ep.name,
            dialectName(ep.dialect), bindTo.address().to_string(), l.boundPort, ep.maxClients, l.maxPerAddress);
  if (ep.controlClients.empty() && ep.dialect != Dialect::Strict)
    log::warn("robot", "robot '{}': any client may send JOB and TRIG (control_clients not set; docs/protocols.md)",
              ep.name);
  l.doAccept();
  return {};
}

void RobotServer::onStrictOutcome(StrictOutcomeFn fn) { listener_->strictOutcome = std::move(fn); }

void RobotServer::stop() {
  if (listener_) listener_->stopAll();
}

std::uint16_t RobotServer::port() const { return listener_->boundPort; }

const RobotEndpoint& RobotServer::endpoint() const { return listener_->endpoint; }

std::size_t RobotServer::clientCount() const { return listener_->sessions.size(); }

RobotServerStats RobotServer::stats() const { return listener_->stats; }

}  // namespace vgr::protocol
