#include "protocol/modbus_server.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <unistd.h>

#include <modbus.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <exception>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

#include "core/log.hpp"

namespace vgr::protocol {

namespace {

constexpr auto kHeartbeatPeriod = std::chrono::seconds(1);
constexpr std::uint32_t kByteTimeoutUs = 200'000;  // max gap inside one request frame
constexpr int kSendTimeoutMs = 200;                // a client that does not read is dropped

std::string errnoText(int err) { return std::strerror(err); }

std::string peerName(const sockaddr_in& addr) {
  std::array<char, INET_ADDRSTRLEN> ip{};
  inet_ntop(AF_INET, &addr.sin_addr, ip.data(), ip.size());
  return std::string(ip.data()) + ":" + std::to_string(ntohs(addr.sin_port));
}

std::uint16_t be16(const std::uint8_t* p) { return static_cast<std::uint16_t>((p[0] << 8) | p[1]); }

// Set while a TriggerHandler runs on this thread, so re-entrant calls from the handler do
// not dead-lock on the map mutex.
thread_local const void* tHandlerOwner = nullptr;

}  // namespace

struct ModbusServer::Impl {
  struct Client {
    int fd = -1;
    std::string peer;
  };

  Impl(ModbusOptions o, TriggerHandler h) : options(std::move(o)), onTrigger(std::move(h)), map(options.floatOrder) {}

  ModbusOptions options;
  TriggerHandler onTrigger;

  mutable std::mutex mutex;  // guards map and deferred
  ModbusMap map;
  std::vector<ModbusResult> deferred;  // publishResult() calls made from inside onTrigger

  // Owned by the Modbus thread between start() and stop().
  modbus_t* ctx = nullptr;
  int listenFd = -1;
  std::array<int, 2> wakePipe{-1, -1};
  std::vector<Client> clients;
  std::uint16_t boundPort = 0;
  std::thread thread;

  Result<void> start();
  void stop();
  void run();
  void acceptClient();
  bool serveClient(Client& c);  // false: drop the client
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

  // The context only parses and answers requests on sockets we accepted ourselves.
  ctx = modbus_new_tcp("127.0.0.1", boundPort);
  if (ctx == nullptr || pipe2(wakePipe.data(), O_CLOEXEC | O_NONBLOCK) != 0) {
    const int err = errno;
    releaseResources();
    return fail(Status::Internal, "modbus: cannot create server context for " + where + ": " + errnoText(err));
  }
  modbus_set_byte_timeout(ctx, 0, kByteTimeoutUs);
  modbus_set_indication_timeout(ctx, 0, kByteTimeoutUs);  // poll() said readable; never wait forever
  modbus_set_error_recovery(ctx, MODBUS_ERROR_RECOVERY_NONE);

  thread = std::thread([this] { run(); });
  log::info("modbus", "listening on {}:{} (max {} clients, floats {})", options.bind, boundPort, options.maxClients,
            options.floatOrder == WordOrder::HighWordFirst ? "high word first" : "low word first");
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
  if (ctx != nullptr) {
    modbus_set_socket(ctx, -1);
    modbus_free(ctx);
    ctx = nullptr;
  }
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
  log::info("modbus", "client {} disconnected: {}", c.peer, why);
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
  if (std::ssize(clients) >= options.maxClients) {
    ::close(fd);
    log::warn("modbus", "client {} refused: already {} clients", peer, clients.size());
    return;
  }
  if (fd >= FD_SETSIZE) {  // libmodbus waits with select() inside modbus_receive()
    ::close(fd);
    log::warn("modbus", "client {} refused: descriptor {} above FD_SETSIZE", peer, fd);
    return;
  }
  const int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  timeval sendTimeout{0, kSendTimeoutMs * 1000};
  setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &sendTimeout, sizeof sendTimeout);
  clients.push_back(Client{fd, peer});
  log::info("modbus", "client {} connected ({} connected)", peer, clients.size());
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

bool ModbusServer::Impl::serveClient(Client& c) {
  std::array<std::uint8_t, MODBUS_TCP_MAX_ADU_LENGTH> req{};
  modbus_set_socket(ctx, c.fd);
  const int rc = modbus_receive(ctx, req.data());
  if (rc < 0) {
    const int err = errno;
    closeClient(c, err == ECONNRESET ? std::string("closed by peer") : "receive failed: " + std::string(modbus_strerror(err)));
    return false;
  }
  if (rc == 0) return true;  // request for another unit, ignored by libmodbus

  // MBAP: transaction id (2), protocol id (2, must be 0), length (2, bytes that follow),
  // unit id (1), then the PDU. libmodbus checks none of this on the server side.
  const int header = modbus_get_header_length(ctx);
  if (rc < header + 1 || be16(&req[2]) != 0 || be16(&req[4]) != rc - 6) {
    closeClient(c, "malformed frame");
    return false;
  }
  const std::uint8_t function = req[static_cast<std::size_t>(header)];
  const std::uint8_t* pdu = &req[static_cast<std::size_t>(header)];
  bool writes = false;
  std::uint32_t address = 0, count = 0;
  switch (function) {
    case MODBUS_FC_WRITE_SINGLE_REGISTER:
    case MODBUS_FC_MASK_WRITE_REGISTER:
      writes = true;
      address = be16(pdu + 1);
      count = 1;
      break;
    case MODBUS_FC_WRITE_MULTIPLE_REGISTERS:
      writes = true;
      address = be16(pdu + 1);
      count = be16(pdu + 3);
      break;
    case MODBUS_FC_WRITE_AND_READ_REGISTERS:
      writes = true;
      address = be16(pdu + 5);
      count = be16(pdu + 7);
      break;
    default:
      break;
  }
  if (writes && !modbus::isWritable(address, count)) {
    if (modbus_reply_exception(ctx, req.data(), MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS) < 0) {
      closeClient(c, "send failed: " + std::string(modbus_strerror(errno)));
      return false;
    }
    return true;
  }

  std::lock_guard lock(mutex);
  auto holding = map.holdingRegisters();
  auto input = map.inputRegisters();
  modbus_mapping_t mapping{};
  mapping.nb_registers = static_cast<int>(holding.size());
  mapping.tab_registers = holding.data();
  mapping.nb_input_registers = static_cast<int>(input.size());
  mapping.tab_input_registers = input.data();
  const int sent = modbus_reply(ctx, req.data(), rc, &mapping);
  const int sendErr = errno;
  if (writes) {
    const HandshakeEvents ev = map.onHoldingWritten([this](int jobId) { return callHandler(jobId); });
    for (const auto& r : deferred) map.publishResult(r);
    deferred.clear();
    if (ev.triggerAccepted) log::debug("modbus", "trigger accepted: job {} cycle {}", ev.jobId, ev.cycleId);
    if (ev.triggerRefused) log::debug("modbus", "trigger refused by the daemon: job {}", ev.jobId);
    if (ev.overrun) log::debug("modbus", "trigger while busy from {}: OVERRUN", c.peer);
    if (ev.ignoredNotReady) log::debug("modbus", "trigger while not ready from {} ignored", c.peer);
  }
  if (sent < 0) {
    closeClient(c, "send failed: " + std::string(modbus_strerror(sendErr)));
    return false;
  }
  return true;
}

void ModbusServer::Impl::run() {
  using Clock = std::chrono::steady_clock;
  auto nextBeat = Clock::now() + kHeartbeatPeriod;
  std::vector<pollfd> fds;
  for (;;) {
    fds.clear();
    fds.push_back({wakePipe[0], POLLIN, 0});
    fds.push_back({listenFd, POLLIN, 0});
    for (const auto& c : clients) fds.push_back({c.fd, POLLIN, 0});
    const auto wait = std::chrono::ceil<std::chrono::milliseconds>(nextBeat - Clock::now());
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
    if (rc <= 0) continue;
    if ((fds[0].revents & POLLIN) != 0) return;  // stop()
    // Serve the clients polled in this round (fds[2 + i] belongs to clients[i]).
    for (std::size_t i = 0; i + 2 < fds.size(); ++i) {
      if ((fds[i + 2].revents & (POLLIN | POLLHUP | POLLERR)) != 0) serveClient(clients[i]);
    }
    std::erase_if(clients, [](const Client& c) { return c.fd < 0; });
    if ((fds[1].revents & POLLIN) != 0) acceptClient();
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
  impl_->map.publishResult(r);
}

std::uint16_t ModbusServer::port() const { return impl_->boundPort != 0 ? impl_->boundPort : impl_->options.port; }

std::uint16_t ModbusServer::holdingRegister(std::uint16_t address) const {
  std::lock_guard lock(impl_->mutex);
  return impl_->map.holding(address);
}

}  // namespace vgr::protocol
