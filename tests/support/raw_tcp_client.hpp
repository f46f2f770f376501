// A blocking TCP client with deadlines, as a robot program's socket behaves (URScript
// socket_read_ascii_float, RAPID SocketReceive, KAREL READ): connect to an IPv4 address,
// send bytes, read one receive / N bytes / up to a stop character, detect the peer's close.
// Received bytes are buffered: a read never loses what came with an earlier receive.
// Timeouts are wall-clock deadlines per call; a negative timeout means the client's
// default (Options::readTimeout). One thread at a time; owns its socket (closed on
// destruction).
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace vgr::test {

class RawTcpClient {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr std::chrono::milliseconds kDefault{-1};

  struct Options {
    std::string host = "127.0.0.1";  // IPv4 literal
    const char* from = nullptr;      // local address to bind first (all of 127/8 is local on Linux)
    std::chrono::milliseconds connectTimeout{2000};
    std::chrono::milliseconds readTimeout{2000};  // the default of every read below
    bool throwOnFailure = true;  // false: a failed connect leaves connected() false
  };

  // Throws std::runtime_error when it cannot connect (unless !throwOnFailure).
  explicit RawTcpClient(std::uint16_t port) : RawTcpClient(port, Options{}) {}
  RawTcpClient(std::uint16_t port, Options options);
  ~RawTcpClient();
  RawTcpClient(RawTcpClient&& other) noexcept;
  RawTcpClient& operator=(RawTcpClient&& other) noexcept;
  RawTcpClient(const RawTcpClient&) = delete;
  RawTcpClient& operator=(const RawTcpClient&) = delete;

  bool connected() const { return fd_ >= 0; }
  int fd() const { return fd_; }

  // All of `bytes` (false on a send error or a closed socket).
  [[nodiscard]] bool send(std::string_view bytes);

  // Everything up to and including `stop`; when `limit` bytes came without `stop`, those
  // `limit` bytes. nullopt on timeout or close.
  std::optional<std::string> readUntil(char stop, std::chrono::milliseconds timeout = kDefault,
                                       std::size_t limit = std::string::npos);
  // readUntil('\n').
  std::optional<std::string> readLine(std::chrono::milliseconds timeout = kDefault) { return readUntil('\n', timeout); }
  // What one receive returns, at most `max` bytes (RAPID SocketReceive \Str style).
  std::optional<std::string> readOnce(std::size_t max = 80, std::chrono::milliseconds timeout = kDefault);
  // Exactly n bytes, or nullopt.
  std::optional<std::string> readExactly(std::size_t n, std::chrono::milliseconds timeout = kDefault);
  // n bytes, or what came before the deadline / close.
  std::string readBytes(std::size_t n, std::chrono::milliseconds timeout = kDefault);

  // True when nothing (not even a close) arrives for `period`.
  bool quiet(std::chrono::milliseconds period = std::chrono::milliseconds(100));
  // True when the peer closes the connection within `timeout` (data before it is dropped).
  bool waitClosed(std::chrono::milliseconds timeout = kDefault);

  void shutdownWrite();
  // Abortive close (RST), like a robot controller losing power mid-exchange.
  void reset();
  // Orderly close (FIN).
  void close();

 private:
  std::chrono::milliseconds orDefault(std::chrono::milliseconds t) const { return t.count() < 0 ? options_.readTimeout : t; }
  // One receive of at most `max` bytes into pending_; false on deadline or close.
  bool fill(Clock::time_point deadline, std::size_t max = 4096);

  Options options_;
  int fd_ = -1;
  std::string pending_;
};

// RawTcpClient as the protocol-robustness tests use it (robot_delivery, robot_slots,
// modbus_robustness): connecting never throws (connected() says whether it worked), reads
// give "" instead of nullopt.
class TestSocket : public RawTcpClient {
 public:
  explicit TestSocket(std::uint16_t port, const char* from = nullptr);
  // Up to and including `stop`, or "" on timeout / close.
  std::string readUntil(char stop, std::chrono::milliseconds timeout = kDefault) {
    return RawTcpClient::readUntil(stop, timeout).value_or("");
  }
  // One reply of unknown length: what arrives within `timeout`, until 100 ms pass without data.
  std::string recvSome(std::chrono::milliseconds timeout);
  // True when the peer closes within `timeout`.
  bool closedWithin(std::chrono::milliseconds timeout) { return waitClosed(timeout); }
};

// One HTTP/1.1 request to 127.0.0.1:port with "Connection: close" (and `headers`, each line
// "Name: value\r\n"): the whole response (head + body) as the server sent it before closing,
// "" when nothing could be had within `timeout`.
std::string httpRequest(std::uint16_t port, const std::string& method, const std::string& target,
                        std::chrono::milliseconds timeout = std::chrono::milliseconds(5000), const std::string& headers = "");

// True when nothing listens on 127.0.0.1:port.
bool loopbackPortFree(std::uint16_t port);
// A loopback TCP port nobody listens on now (the kernel's pick); 0 when none could be had.
std::uint16_t freeLoopbackPort();

}  // namespace vgr::test
