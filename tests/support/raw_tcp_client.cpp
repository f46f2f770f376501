#include "tests/support/raw_tcp_client.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <stdexcept>
#include <utility>

namespace vgr::test {
namespace {

int msLeft(RawTcpClient::Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - RawTcpClient::Clock::now());
  return left.count() <= 0 ? 0 : static_cast<int>(left.count());
}

// A connected socket, or -1 with `why` set.
int connectTo(const RawTcpClient::Options& o, std::uint16_t port, std::string& why) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    why = "socket() failed";
    return -1;
  }
  if (o.from != nullptr) {
    sockaddr_in src{};
    src.sin_family = AF_INET;
    ::inet_pton(AF_INET, o.from, &src.sin_addr);
    if (::bind(fd, reinterpret_cast<const sockaddr*>(&src), sizeof src) != 0) {
      ::close(fd);
      why = "bind() failed";
      return -1;
    }
  }
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  if (::inet_pton(AF_INET, o.host.c_str(), &addr.sin_addr) != 1) {
    ::close(fd);
    why = "not an IPv4 address: " + o.host;
    return -1;
  }
  // Non-blocking connect, so that the timeout holds; blocking again afterwards.
  const int flags = ::fcntl(fd, F_GETFL);
  ::fcntl(fd, F_SETFL, flags | O_NONBLOCK);
  int rc = ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);
  if (rc != 0 && errno == EINPROGRESS) {
    pollfd p{fd, POLLOUT, 0};
    if (::poll(&p, 1, static_cast<int>(o.connectTimeout.count())) == 1) {
      int err = 0;
      socklen_t len = sizeof err;
      ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len);
      rc = err == 0 ? 0 : -1;
    }
  }
  if (rc != 0) {
    ::close(fd);
    why = "connect() failed";
    return -1;
  }
  ::fcntl(fd, F_SETFL, flags);
  return fd;
}

}  // namespace

RawTcpClient::RawTcpClient(std::uint16_t port, Options options) : options_(std::move(options)) {
  std::string why;
  fd_ = connectTo(options_, port, why);
  if (fd_ < 0 && options_.throwOnFailure) throw std::runtime_error(why);
}

RawTcpClient::~RawTcpClient() {
  if (fd_ >= 0) ::close(fd_);
}

RawTcpClient::RawTcpClient(RawTcpClient&& other) noexcept
    : options_(std::move(other.options_)), fd_(std::exchange(other.fd_, -1)), pending_(std::move(other.pending_)) {}

RawTcpClient& RawTcpClient::operator=(RawTcpClient&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    options_ = std::move(other.options_);
    fd_ = std::exchange(other.fd_, -1);
    pending_ = std::move(other.pending_);
  }
  return *this;
}

bool RawTcpClient::send(std::string_view bytes) {
  while (!bytes.empty()) {
    const ssize_t n = ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
    if (n <= 0) return false;
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
  return true;
}

bool RawTcpClient::fill(Clock::time_point deadline, std::size_t max) {
  const int left = msLeft(deadline);
  if (left <= 0 || fd_ < 0) return false;
  pollfd p{fd_, POLLIN, 0};
  if (::poll(&p, 1, left) <= 0) return false;
  std::string buf(max, '\0');
  const ssize_t n = ::recv(fd_, buf.data(), buf.size(), 0);
  if (n <= 0) return false;
  pending_.append(buf.data(), static_cast<std::size_t>(n));
  return true;
}

std::optional<std::string> RawTcpClient::readUntil(char stop, std::chrono::milliseconds timeout, std::size_t limit) {
  const auto deadline = Clock::now() + orDefault(timeout);
  for (;;) {
    const std::size_t pos = pending_.find(stop);
    if (pos != std::string::npos && pos < limit) {
      std::string out = pending_.substr(0, pos + 1);
      pending_.erase(0, pos + 1);
      return out;
    }
    if (pending_.size() >= limit) {
      std::string out = pending_.substr(0, limit);
      pending_.erase(0, limit);
      return out;
    }
    if (!fill(deadline)) return std::nullopt;
  }
}

std::optional<std::string> RawTcpClient::readOnce(std::size_t max, std::chrono::milliseconds timeout) {
  if (pending_.empty() && !fill(Clock::now() + orDefault(timeout), max)) return std::nullopt;
  std::string out = pending_.substr(0, max);
  pending_.erase(0, out.size());
  return out;
}

std::optional<std::string> RawTcpClient::readExactly(std::size_t n, std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + orDefault(timeout);
  while (pending_.size() < n) {
    if (!fill(deadline)) return std::nullopt;
  }
  std::string out = pending_.substr(0, n);
  pending_.erase(0, n);
  return out;
}

std::string RawTcpClient::readBytes(std::size_t n, std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + orDefault(timeout);
  while (pending_.size() < n && fill(deadline)) {
  }
  std::string out = pending_.substr(0, n);
  pending_.erase(0, out.size());
  return out;
}

bool RawTcpClient::quiet(std::chrono::milliseconds period) {
  if (!pending_.empty()) return false;
  pollfd p{fd_, POLLIN, 0};
  return ::poll(&p, 1, static_cast<int>(period.count())) == 0;
}

bool RawTcpClient::waitClosed(std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + orDefault(timeout);
  for (;;) {
    const int left = msLeft(deadline);
    if (left <= 0) return false;
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, left) <= 0) continue;
    char buf[256];
    if (::recv(fd_, buf, sizeof buf, 0) <= 0) return true;
  }
}

void RawTcpClient::shutdownWrite() { ::shutdown(fd_, SHUT_WR); }

void RawTcpClient::reset() {
  linger l{1, 0};
  ::setsockopt(fd_, SOL_SOCKET, SO_LINGER, &l, sizeof l);
  close();
}

void RawTcpClient::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

bool loopbackPortFree(std::uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const bool taken = ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  ::close(fd);
  return !taken;
}

std::uint16_t freeLoopbackPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  const bool ok = ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
                  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0;
  ::close(fd);
  return ok ? ntohs(a.sin_port) : 0;
}

TestSocket::TestSocket(std::uint16_t port, const char* from)
    : RawTcpClient(port, [from] {
        Options o;
        o.from = from;
        o.throwOnFailure = false;
        o.readTimeout = std::chrono::milliseconds(3000);
        return o;
      }()) {}

std::string TestSocket::recvSome(std::chrono::milliseconds timeout) {
  std::string out = readOnce(4096, timeout).value_or("");
  if (out.empty()) return out;
  while (auto more = readOnce(4096, std::chrono::milliseconds(100))) out += *more;
  return out;
}

std::string httpRequest(std::uint16_t port, const std::string& method, const std::string& target,
                        std::chrono::milliseconds timeout, const std::string& headers) {
  RawTcpClient::Options o;
  o.throwOnFailure = false;
  RawTcpClient c(port, o);
  if (!c.connected() ||
      !c.send(method + " " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n" + headers + "\r\n"))
    return "";
  return c.readBytes(std::string::npos, timeout);  // up to the server's close
}

}  // namespace vgr::test
