#include "protocol/modbus_server.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <modbus.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <exception>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "core/log.hpp"
#include "core/log_limiter.hpp"
#include "core/token_bucket.hpp"
#include "protocol/modbus_request.hpp"

namespace vgr::protocol {

namespace {

constexpr auto kHeartbeatPeriod = std::chrono::seconds(1);
constexpr auto kByteTimeout = std::chrono::milliseconds(200);  // ModbusRequestHandler::receive() only (unused here)
// A request must be complete this long after its first byte arrived, else the client is
// dropped (a peer dribbling bytes never holds the server: reads never block).
constexpr auto kFrameTimeout = std::chrono::milliseconds(500);
constexpr std::size_t kReadChunk = 4096;  // bytes read per readable client per poll round
// A connection's unanswered bytes at most: reading pauses beyond it (TCP flow control then
// holds a pipelining client back) until kMaxAdusPerRound-sized bites have answered them.
constexpr std::size_t kMaxPendingBytes = 4 * kModbusTcpMaxAdu;
constexpr int kSendBufferBytes = 32 * 1024;     // per client socket (the kernel doubles it)
constexpr int kReceiveBufferBytes = 64 * 1024;  // per client socket (the kernel doubles it)
constexpr int kConnLogBurst = 20;  // connection events logged per kConnLogWindow, the rest counted
constexpr auto kConnLogWindow = std::chrono::seconds(10);

std::string errnoText(int err) { return std::strerror(err); }

std::string peerName(const sockaddr_in& addr) {
  std::array<char, INET_ADDRSTRLEN> ip{};
  inet_ntop(AF_INET, &addr.sin_addr, ip.data(), ip.size());
  return std::string(ip.data()) + ":" + std::to_string(ntohs(addr.sin_port));
}

// Set while a TriggerHandler runs on this thread, so re-entrant calls from the handler do
// not dead-lock on the map mutex.
thread_local const void* tHandlerOwner = nullptr;

}  // namespace

struct ModbusServer::Impl {
  using Clock = std::chrono::steady_clock;
  struct Client {
    int fd = -1;
    std::string peer;
    in_addr address{};
    bool mayWrite = true;  // in controlClients (or no list)
    std::vector<std::uint8_t> pending;  // bytes of the request(s) not yet complete
    Clock::time_point frameStart{};     // when the first byte of `pending` arrived
    Clock::time_point lastActivity{};   // when bytes last arrived (or it connected)
    TokenBucket budget{kModbusRequestsPerSecond, kModbusRequestBurst};
  };

  Impl(ModbusOptions o, TriggerHandler h) : options(std::move(o)), onTrigger(std::move(h)), map(options.floatOrder) {
    map.setRequireTriggerEnable(options.requireTriggerEnable);
    map.setResultDeadline(options.resultDeadline);
  }

  ModbusOptions options;
  TriggerHandler onTrigger;

  mutable std::mutex mutex;  // guards map and deferred
  ModbusMap map;
  std::vector<ModbusResult> deferred;  // publishResult() calls made from inside onTrigger

  // Owned by the Modbus thread between start() and stop().
  std::unique_ptr<ModbusRequestHandler> handler_;
  int listenFd = -1;
  std::array<int, 2> wakePipe{-1, -1};
  std::vector<Client> clients;
  std::vector<in_addr> allowed;  // options.allowedClients, parsed
  std::vector<in_addr> control;  // options.controlClients, parsed
  int perAddress = 0;            // options.maxClientsPerAddress, resolved
  TokenBucket acceptBudget{kModbusAcceptsPerSecond, kModbusAcceptBurst};  // Modbus thread
  log::LogLimiter connLimiter{kConnLogBurst, kConnLogWindow};  // Modbus thread
  struct AtomicStats {
    std::atomic<std::uint64_t> accepted{0}, closed{0}, refusedNotAllowed{0}, refusedFull{0}, writesRefused{0},
        logLinesHeldBack{0};
  } stats;
  // A connection event through the rate limit (Modbus thread).
  template <class... Args>
  void connLog(bool warning, fmt::format_string<Args...> f, Args&&... args) {
    if (!log::limitedLog(connLimiter, "modbus", "connection events", warning, f, std::forward<Args>(args)...))
      ++stats.logLinesHeldBack;
  }
  std::uint16_t boundPort = 0;
  std::thread thread;
  Heartbeat heartbeat;  // beaten by the Modbus thread at every poll() turn

  Result<void> start();
  void stop();
  void run();
  void acceptClient();
  bool serveClient(Client& c, bool readable);  // false: the client was dropped
  static bool hasCompleteAdu(const Client& c);
  // A complete request waits and the connection's budget allows one now.
  static bool canServe(Client& c, Clock::time_point now) {
    return hasCompleteAdu(c) && c.budget.nextToken(now) <= now;
  }
  bool answer(Client& c, const ModbusFrame& req, int length);  // false: the client was dropped
  void dropStalled(Clock::time_point now);
  void closeClient(Client& c, std::string_view why);
  std::uint32_t callHandler(int jobId);
  void releaseResources();
};

Result<void> ModbusServer::Impl::start() {
  if (thread.joinable()) return fail(Status::Internal, "modbus: server already started");
  const std::string where = options.bind + ":" + std::to_string(options.port);
  if (options.maxClients < 1 || options.maxClients > 64) {
    return fail(Status::BadArgument, "modbus: maxClients " + std::to_string(options.maxClients) + " outside [1, 64]");
  }
  allowed.clear();
  for (const auto& a : options.allowedClients) {
    in_addr ip{};
    if (inet_pton(AF_INET, a.c_str(), &ip) != 1) {
      return fail(Status::BadArgument, "modbus: allowed client '" + a + "' is not a numeric IPv4 address");
    }
    allowed.push_back(ip);
  }
  if (options.maxClientsPerAddress < 0 || options.maxClientsPerAddress > options.maxClients) {
    return fail(Status::BadArgument, "modbus: maxClientsPerAddress " + std::to_string(options.maxClientsPerAddress) +
                                         " outside [0, maxClients]");
  }
  perAddress = options.maxClientsPerAddress == 0 ? options.maxClients : options.maxClientsPerAddress;
  control.clear();
  for (const auto& a : options.controlClients) {
    in_addr ip{};
    if (inet_pton(AF_INET, a.c_str(), &ip) != 1) {
      return fail(Status::BadArgument, "modbus: control client '" + a + "' is not a numeric IPv4 address");
    }
    control.push_back(ip);
  }
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(options.port);
  if (inet_pton(AF_INET, options.bind.c_str(), &addr.sin_addr) != 1) {
    return fail(Status::BadArgument, "modbus: bind address '" + options.bind + "' is not an IPv4 address");
  }
  listenFd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (listenFd < 0) return fail(Status::Internal, "modbus: socket() for " + where + ": " + errnoText(errno));
  const int one = 1;
  setsockopt(listenFd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (::bind(listenFd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0 ||
      ::listen(listenFd, options.maxClients) != 0) {
    const int err = errno;
    releaseResources();
    return fail(Status::Internal, "modbus: cannot listen on " + where + ": " + errnoText(err));
  }
  sockaddr_in bound{};
  socklen_t len = sizeof bound;
  getsockname(listenFd, reinterpret_cast<sockaddr*>(&bound), &len);
  boundPort = ntohs(bound.sin_port);

  handler_ = std::make_unique<ModbusRequestHandler>(kByteTimeout);
  if (!handler_->valid() || pipe2(wakePipe.data(), O_CLOEXEC | O_NONBLOCK) != 0) {
    const int err = errno;
    releaseResources();
    return fail(Status::Internal, "modbus: cannot create server context for " + where + ": " + errnoText(err));
  }

  thread = std::thread([this] {
    nameThisThread("vgr-modbus");
    run();
  });
  log::info("modbus", "listening on {}:{} (max {} clients, {} per address, idle timeout {} ms, {} allowed, floats {})",
            options.bind, boundPort, options.maxClients, perAddress, options.idleTimeout.count(),
            allowed.empty() ? std::string("any client") : std::to_string(allowed.size()) + " addresses",
            options.floatOrder == WordOrder::HighWordFirst ? "high word first" : "low word first");
  if (control.empty()) {
    log::warn("modbus", "any client may trigger, switch jobs and clear errors (control_clients not set; "
              "docs/protocols.md)");
  }
  return {};
}

void ModbusServer::Impl::stop() {
  if (!thread.joinable()) return;
  const char byte = 1;
  [[maybe_unused]] const auto n = ::write(wakePipe[1], &byte, 1);
  thread.join();
  releaseResources();
  log::info("modbus", "server on {}:{} stopped", options.bind, boundPort);
}

void ModbusServer::Impl::releaseResources() {
  for (auto& c : clients) closeClient(c, "server stopping");
  clients.clear();
  handler_.reset();
  for (int& fd : wakePipe) {
    if (fd >= 0) ::close(fd);
    fd = -1;
  }
  if (listenFd >= 0) ::close(listenFd);
  listenFd = -1;
}

void ModbusServer::Impl::closeClient(Client& c, std::string_view why) {
  if (c.fd < 0) return;
  ::close(c.fd);
  c.fd = -1;
  ++stats.closed;
  connLog(false, "client {} disconnected: {}", c.peer, why);
}

void ModbusServer::Impl::acceptClient() {
  sockaddr_in addr{};
  socklen_t len = sizeof addr;
  const int fd = ::accept4(listenFd, reinterpret_cast<sockaddr*>(&addr), &len, SOCK_CLOEXEC);
  if (fd < 0) {
    if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR && errno != ECONNABORTED) {
      log::warn("modbus", "accept on {}:{} failed: {}", options.bind, boundPort, errnoText(errno));
    }
    return;
  }
  const std::string peer = peerName(addr);
  const auto listed = [&](const std::vector<in_addr>& list) {
    return std::any_of(list.begin(), list.end(), [&](const in_addr& a) { return a.s_addr == addr.sin_addr.s_addr; });
  };
  if (!allowed.empty() && !listed(allowed)) {
    ::close(fd);
    ++stats.refusedNotAllowed;
    connLog(true, "client {} refused: not in allowed_clients", peer);
    return;
  }
  const auto fromAddress = std::count_if(clients.begin(), clients.end(), [&](const Client& c) {
    return c.fd >= 0 && c.address.s_addr == addr.sin_addr.s_addr;
  });
  if (std::ssize(clients) >= options.maxClients || fromAddress >= perAddress) {
    ::close(fd);
    ++stats.refusedFull;
    connLog(true, "client {} refused: already {} clients, {} from its address (max_clients {}, {} per address)", peer,
            clients.size(), fromAddress, options.maxClients, perAddress);
    return;
  }
  const int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  // Replies are at most 260 bytes: 32 KiB of them unread is a client that does not read,
  // found within seconds instead of after megabytes of autotuned buffer.
  const int sendBuffer = kSendBufferBytes, receiveBuffer = kReceiveBufferBytes;
  setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &sendBuffer, sizeof sendBuffer);
  // And what a client pipelines waits in its own socket, not in megabytes of ours.
  setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &receiveBuffer, sizeof receiveBuffer);
  // Non-blocking: a reply the socket cannot take at once (the client does not read) fails
  // and drops that client; the Modbus thread never waits on one client.
  const int flags = ::fcntl(fd, F_GETFL, 0);
  if (flags < 0 || ::fcntl(fd, F_SETFL, flags | O_NONBLOCK) != 0) {
    ::close(fd);
    log::warn("modbus", "client {} refused: cannot make its socket non-blocking: {}", peer, errnoText(errno));
    return;
  }
  Client c;
  c.fd = fd;
  c.peer = peer;
  c.address = addr.sin_addr;
  c.mayWrite = control.empty() || listed(control);
  c.lastActivity = Clock::now();
  clients.push_back(std::move(c));
  ++stats.accepted;
  connLog(false, "client {} connected ({} connected{})", peer, clients.size(),
          clients.back().mayWrite ? "" : ", read-only: not in control_clients");
}

std::uint32_t ModbusServer::Impl::callHandler(int jobId) {
  if (!onTrigger) return 0;
  tHandlerOwner = this;
  std::uint32_t cycleId = 0;
  try {
    cycleId = onTrigger(jobId);
  } catch (const std::exception& e) {
    log::error("modbus", "trigger handler threw for job {}: {}; trigger refused", jobId, e.what());
  } catch (...) {
    log::error("modbus", "trigger handler threw a non-standard exception for job {}; trigger refused", jobId);
  }
  tHandlerOwner = nullptr;
  return cycleId;
}

bool ModbusServer::Impl::hasCompleteAdu(const Client& c) {
  return c.fd >= 0 && scanAdu(std::span<const std::uint8_t>(c.pending)).kind != AduScan::Kind::NeedMore;
}

bool ModbusServer::Impl::serveClient(Client& c, bool readable) {
  // Non-blocking: take what the socket holds now (up to kMaxPendingBytes buffered), answer
  // up to kMaxAdusPerRound complete ADUs, keep the rest for the next round. No read ever
  // waits for a client.
  if (readable && c.pending.size() < kMaxPendingBytes) {
    std::array<std::uint8_t, kReadChunk> buf{};
    const std::size_t room = std::min(buf.size(), kMaxPendingBytes - c.pending.size());
    const auto n = ::recv(c.fd, buf.data(), room, MSG_DONTWAIT);
    if (n == 0) {
      closeClient(c, "closed by peer");
      return false;
    }
    if (n < 0) {
      if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
        closeClient(c, errno == ECONNRESET ? std::string("closed by peer") : "receive failed: " + errnoText(errno));
        return false;
      }
    } else {
      c.lastActivity = Clock::now();
      if (c.pending.empty()) c.frameStart = c.lastActivity;
      c.pending.insert(c.pending.end(), buf.begin(), buf.begin() + n);
    }
  }

  std::size_t used = 0;
  for (int answered = 0; answered < kMaxAdusPerRound; ++answered) {
    const AduScan scan = scanAdu(std::span<const std::uint8_t>(c.pending).subspan(used));
    if (scan.kind == AduScan::Kind::Malformed) {
      closeClient(c, "malformed frame");
      return false;
    }
    if (scan.kind == AduScan::Kind::NeedMore) break;
    if (!c.budget.take()) break;  // over its request rate: the rest waits for tokens
    ModbusFrame req{};
    std::copy_n(c.pending.begin() + static_cast<std::ptrdiff_t>(used), scan.length, req.begin());
    used += scan.length;
    if (!answer(c, req, static_cast<int>(scan.length))) return false;
  }
  if (used > 0) {
    c.pending.erase(c.pending.begin(), c.pending.begin() + static_cast<std::ptrdiff_t>(used));
    c.frameStart = Clock::now();  // the remainder, if any, starts the next request now
  }
  return true;
}

bool ModbusServer::Impl::answer(Client& c, const ModbusFrame& req, int length) {
  std::lock_guard lock(mutex);
  const auto out =
      handler_->handle(c.fd, req, length, map, [this](int jobId) { return callHandler(jobId); }, c.mayWrite);
  if (out.writeRefused) {
    ++stats.writesRefused;
    connLog(true, "client {} may not write (not in control_clients): exception 02", c.peer);
  }
  for (const auto& r : deferred) map.publishResult(r);
  deferred.clear();
  const HandshakeEvents& ev = out.events;
  if (ev.triggerAccepted) log::debug("modbus", "trigger accepted: job {} cycle {}", ev.jobId, ev.cycleId);
  if (ev.triggerRefused) log::debug("modbus", "trigger refused by the daemon: job {}", ev.jobId);
  if (ev.overrun) log::debug("modbus", "trigger while busy from {}: OVERRUN", c.peer);
  if (ev.ignoredNotReady) log::debug("modbus", "trigger while not ready from {} ignored", c.peer);
  if (ev.ignoredNotEnabled) log::debug("modbus", "trigger without TRIGGER_ENABLE from {} ignored", c.peer);
  if (out.check.verdict == FrameVerdict::Unsupported) {
    log::debug("modbus", "function code {} from {}: exception 01 (illegal function)", static_cast<int>(req[7]), c.peer);
  }
  if (!out.keep) {
    closeClient(c, out.dropReason);
    return false;
  }
  return true;
}

void ModbusServer::Impl::dropStalled(Clock::time_point now) {
  for (auto& c : clients) {
    if (c.fd >= 0 && !c.pending.empty() && !hasCompleteAdu(c) && now - c.frameStart >= kFrameTimeout) {
      closeClient(c, "stalled mid-frame (request incomplete after " + std::to_string(kFrameTimeout.count()) + " ms)");
    } else if (c.fd >= 0 && options.idleTimeout.count() > 0 && now - c.lastActivity >= options.idleTimeout) {
      closeClient(c, "idle for " + std::to_string(options.idleTimeout.count()) + " ms");
    }
  }
}

void ModbusServer::Impl::run() {
  auto nextBeat = Clock::now() + kHeartbeatPeriod;
  std::vector<pollfd> fds;
  for (;;) {
    heartbeat.beat();
    fds.clear();
    fds.push_back({wakePipe[0], POLLIN, 0});
    fds.push_back({listenFd, POLLIN, 0});
    bool backlog = false;  // a client has complete requests it may have answered now
    auto wakeAt = nextBeat;
    const auto roundStart = Clock::now();
    for (auto& c : clients) {
      const bool room = c.pending.size() < kMaxPendingBytes;
      fds.push_back({c.fd, static_cast<short>(room ? POLLIN : 0), 0});
      if (hasCompleteAdu(c)) {
        const auto next = c.budget.nextToken(roundStart);
        if (next <= roundStart) backlog = true;
        wakeAt = std::min(wakeAt, next);
      }
    }
    // Accepting within the accept budget: the listening socket is polled only when a new
    // connection may be taken, else the loop wakes when it may.
    const auto acceptAt = acceptBudget.nextToken(roundStart);
    const bool mayAccept = acceptAt <= roundStart;
    fds[1].events = mayAccept ? POLLIN : 0;
    if (!mayAccept) wakeAt = std::min(wakeAt, acceptAt);
    if (backlog) wakeAt = roundStart;
    for (const auto& c : clients) {
      if (!c.pending.empty()) wakeAt = std::min(wakeAt, c.frameStart + kFrameTimeout);
      if (options.idleTimeout.count() > 0) wakeAt = std::min(wakeAt, c.lastActivity + options.idleTimeout);
    }
    {
      std::lock_guard lock(mutex);
      if (const auto due = map.busyDeadline(); due && *due < wakeAt) wakeAt = *due;
    }
    const auto wait = std::chrono::ceil<std::chrono::milliseconds>(wakeAt - Clock::now());
    const int rc = ::poll(fds.data(), fds.size(), static_cast<int>(std::max<std::int64_t>(0, wait.count())));
    if (rc < 0 && errno != EINTR) {
      log::error("modbus", "poll failed: {}; server thread exits", errnoText(errno));
      return;
    }
    const auto now = Clock::now();
    if (now >= nextBeat) {
      std::lock_guard lock(mutex);
      map.tick();
      nextBeat += kHeartbeatPeriod;
      if (nextBeat < now) nextBeat = now + kHeartbeatPeriod;  // after a long stall
    }
    {
      std::lock_guard lock(mutex);
      if (const std::uint32_t expired = map.expireOverdue(now); expired != 0) {
        log::warn("modbus", "cycle {} not published within {} ms: PLC answered with PROCESSING_TIMEOUT", expired,
                  options.resultDeadline.count());
      }
    }
    if (rc > 0 && (fds[0].revents & POLLIN) != 0) return;  // stop()
    if (rc <= 0 && !backlog && std::none_of(clients.begin(), clients.end(), [&](Client& c) { return canServe(c, now); })) {
      dropStalled(now);
      std::erase_if(clients, [](const Client& c) { return c.fd < 0; });
      continue;
    }
    // Serve the clients polled in this round (fds[2 + i] belongs to clients[i]) and those
    // with complete requests still buffered.
    const auto serveAt = Clock::now();
    for (std::size_t i = 0; i + 2 < fds.size(); ++i) {
      const bool readable = rc > 0 && (fds[i + 2].revents & (POLLIN | POLLHUP | POLLERR)) != 0;
      if (readable || canServe(clients[i], serveAt)) serveClient(clients[i], readable);
    }
    dropStalled(Clock::now());
    std::erase_if(clients, [](const Client& c) { return c.fd < 0; });
    if (rc > 0 && (fds[1].revents & POLLIN) != 0 && acceptBudget.take()) acceptClient();
  }
}

ModbusServer::ModbusServer(ModbusOptions options, TriggerHandler onTrigger)
    : impl_(std::make_unique<Impl>(std::move(options), std::move(onTrigger))) {}

ModbusServer::~ModbusServer() { stop(); }

Result<void> ModbusServer::start() { return impl_->start(); }

void ModbusServer::stop() { impl_->stop(); }

void ModbusServer::setReady(bool ready) {
  if (tHandlerOwner == impl_.get()) {  // from inside the trigger handler: lock already held
    impl_->map.setReady(ready);
    return;
  }
  std::lock_guard lock(impl_->mutex);
  impl_->map.setReady(ready);
}

void ModbusServer::publishResult(const ModbusResult& r) {
  if (tHandlerOwner == impl_.get()) {  // applied right after the trigger is accepted
    impl_->deferred.push_back(r);
    return;
  }
  std::lock_guard lock(impl_->mutex);
  if (!impl_->map.publishResult(r)) {
    log::warn("modbus", "late result of cycle {} dropped: the PLC already got PROCESSING_TIMEOUT", r.cycleId);
  }
}

std::uint16_t ModbusServer::port() const { return impl_->boundPort != 0 ? impl_->boundPort : impl_->options.port; }

std::string ModbusServer::describe() const {
  return "Modbus server " + impl_->options.bind + ":" + std::to_string(port());
}

std::string ModbusServer::summary() const {
  const ModbusServerStats st = stats();
  return fmt::format("{}: connections {} accepted, {} closed; refused {} not allowed, {} full; {} writes refused; {} "
                     "log lines held back",
                     describe(), st.accepted, st.closed, st.refusedNotAllowed, st.refusedFull, st.writesRefused,
                     st.logLinesHeldBack);
}

ModbusServerStats ModbusServer::stats() const {
  const auto& a = impl_->stats;
  return {a.accepted.load(), a.closed.load(), a.refusedNotAllowed.load(), a.refusedFull.load(), a.writesRefused.load(),
          a.logLinesHeldBack.load()};
}

const Heartbeat& ModbusServer::heartbeat() const { return impl_->heartbeat; }

std::uint16_t ModbusServer::holdingRegister(std::uint16_t address) const {
  std::lock_guard lock(impl_->mutex);
  return impl_->map.holding(address);
}

}  // namespace vgr::protocol
