#include "tools/vgr/soak_actors.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <modbus.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <optional>
#include <random>
#include <string_view>

#include "core/status.hpp"
#include "protocol/modbus_map.hpp"
#include "protocol/robot_codec.hpp"
#include "protocol/robot_reply.hpp"

namespace vgr::tools::soak {

namespace mb = protocol::modbus;
using namespace std::chrono_literals;

double wallNow() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

namespace {

constexpr double kPi = 3.14159265358979323846;

// ---- plain blocking sockets with poll() timeouts ---------------------------------------

int connectTcp(int port, const char* from, int timeoutMs) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  if (from != nullptr) {
    sockaddr_in local{};
    local.sin_family = AF_INET;
    ::inet_pton(AF_INET, from, &local.sin_addr);
    if (::bind(fd, reinterpret_cast<sockaddr*>(&local), sizeof local) != 0) {
      ::close(fd);
      return -1;
    }
  }
  const int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(static_cast<std::uint16_t>(port));
  ::inet_pton(AF_INET, "127.0.0.1", &sa.sin_addr);
  const int flags = ::fcntl(fd, F_GETFL, 0);
  ::fcntl(fd, F_SETFL, flags | O_NONBLOCK);
  int rc = ::connect(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa);
  if (rc != 0 && errno == EINPROGRESS) {
    pollfd p{fd, POLLOUT, 0};
    if (::poll(&p, 1, timeoutMs) == 1) {
      int err = 0;
      socklen_t len = sizeof err;
      ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len);
      rc = err == 0 ? 0 : -1;
    }
  }
  ::fcntl(fd, F_SETFL, flags);
  if (rc != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

bool sendAll(int fd, std::string_view data) {
  while (!data.empty()) {
    const auto n = ::send(fd, data.data(), data.size(), MSG_NOSIGNAL);
    if (n <= 0) return false;
    data.remove_prefix(static_cast<std::size_t>(n));
  }
  return true;
}

// Appends what arrives within timeoutMs (one recv); false on close, error or timeout.
bool recvSome(int fd, std::string& into, int timeoutMs, std::size_t max = 4096) {
  pollfd p{fd, POLLIN, 0};
  if (::poll(&p, 1, timeoutMs) != 1) return false;
  std::array<char, 4096> buf{};
  const auto n = ::recv(fd, buf.data(), std::min(max, buf.size()), 0);
  if (n <= 0) return false;
  into.append(buf.data(), static_cast<std::size_t>(n));
  return true;
}

// ---- the PLC's Modbus link ------------------------------------------------------------

class ModbusLink {
 public:
  explicit ModbusLink(int port) : ctx_(modbus_new_tcp("127.0.0.1", port)) {
    if (ctx_) modbus_set_response_timeout(ctx_, 0, 300000);
  }
  ~ModbusLink() {
    if (!ctx_) return;
    if (connected_) modbus_close(ctx_);
    modbus_free(ctx_);
  }
  ModbusLink(const ModbusLink&) = delete;
  ModbusLink& operator=(const ModbusLink&) = delete;

  bool ensure() {
    if (connected_) return true;
    if (!ctx_ || modbus_connect(ctx_) != 0) return false;
    connected_ = true;
    return true;
  }
  void drop() {
    if (connected_) modbus_close(ctx_);
    connected_ = false;
  }
  // Registers 16..45 in one FC04 read (one consistent snapshot: vgrd answers under its lock).
  bool readBlock(std::array<std::uint16_t, 30>& regs) {
    if (!ensure()) return false;
    if (modbus_read_input_registers(ctx_, mb::kStatus, 30, regs.data()) == 30) return true;
    drop();
    return false;
  }
  bool write(std::uint16_t address, std::uint16_t value) {
    if (!ensure()) return false;
    if (modbus_write_register(ctx_, address, value) == 1) return true;
    drop();
    return false;
  }

 private:
  modbus_t* ctx_;
  bool connected_ = false;
};

std::uint16_t reg(const std::array<std::uint16_t, 30>& b, std::uint16_t address) { return b[address - mb::kStatus]; }
double f32(const std::array<std::uint16_t, 30>& b, std::uint16_t address) {
  return mb::unpackFloat(reg(b, address), reg(b, address + 1), protocol::WordOrder::HighWordFirst);
}

}  // namespace

// ---- PLC -------------------------------------------------------------------------------

PlcActor::PlcActor(PlcOptions options, CellState& cell) : options_(options), cell_(cell) {}
PlcActor::~PlcActor() { stop(); }
void PlcActor::start() { thread_ = std::thread([this] { run(); }); }
void PlcActor::stop() {
  if (thread_.joinable()) thread_.join();
}

void PlcActor::run() {
  ModbusLink link(options_.port);
  std::mt19937 rng(12345);
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / options_.rateHz));
  auto nextStart = Clock::now();
  std::array<std::uint16_t, 30> regs{};
  int n = 0;

  // One handshake step: poll the block until `pred` holds. Returns false on timeout or when
  // vgrd was killed meanwhile (rec.interrupted); a requested disconnect is done here.
  auto step = [&](TriggerRecord& rec, const char* name, auto pred) {
    const auto deadline = Clock::now() + std::chrono::milliseconds(options_.stepTimeoutMs);
    for (;;) {
      if (cell_.incarnation.load() != rec.incarnation) {
        rec.interrupted = true;
        rec.stoppedAt = name;
        return false;
      }
      if (disconnect_.exchange(false)) {
        // A PLC that loses its connection mid-handshake (cable, PLC program restart) and
        // comes back: the handshake state lives in vgrd, the PLC carries on.
        link.drop();
        rec.plcDropped = true;
        ++disconnects_;
        std::this_thread::sleep_for(std::chrono::milliseconds(std::uniform_int_distribution<int>(20, 200)(rng)));
      }
      if (link.readBlock(regs) && pred(reg(regs, mb::kStatus))) return true;
      if (Clock::now() >= deadline || cell_.stop) {
        rec.stoppedAt = name;
        return false;
      }
      std::this_thread::sleep_for(2ms);
    }
  };
  auto writeUntil = [&](TriggerRecord& rec, const char* name, std::uint16_t address, std::uint16_t value) {
    const auto deadline = Clock::now() + std::chrono::milliseconds(options_.stepTimeoutMs);
    while (!link.write(address, value)) {
      if (cell_.incarnation.load() != rec.incarnation) {
        rec.interrupted = true;
        rec.stoppedAt = name;
        return false;
      }
      if (Clock::now() >= deadline || cell_.stop) {
        rec.stoppedAt = name;
        return false;
      }
      std::this_thread::sleep_for(5ms);
    }
    return true;
  };

  while (!cell_.stop && !cell_.draining && (options_.maxTriggers == 0 || n < options_.maxTriggers)) {
    std::this_thread::sleep_until(nextStart);
    nextStart = std::max(nextStart + period, Clock::now());
    // Wait for READY, not BUSY, no result pending (vgrd may be restarting): not a trigger yet.
    const auto readyBy = Clock::now() + 500ms;
    bool ready = false;
    while (!cell_.stop && Clock::now() < readyBy) {
      if (cell_.vgrdUp && link.readBlock(regs)) {
        const std::uint16_t s = reg(regs, mb::kStatus);
        if ((s & mb::kStatusReady) && !(s & mb::kStatusBusy) && !(s & mb::kStatusResultValid) &&
            !(s & mb::kStatusTriggerAck))
          ready = true;
        else if (s & mb::kStatusResultValid)  // leftover from an interrupted handshake
          link.write(mb::kControl, mb::kControlResultAck | mb::kControlClearError);
        else if (s & mb::kStatusTriggerAck)
          link.write(mb::kControl, 0);
        if (ready) break;
      }
      std::this_thread::sleep_for(5ms);
    }
    if (!ready) continue;
    TriggerRecord rec;
    rec.incarnation = cell_.incarnation.load();
    if (!link.write(mb::kJobId, static_cast<std::uint16_t>(options_.job)) || !link.write(mb::kControl, 0)) continue;
    rec.n = n + 1;
    rec.t0 = wallNow();
    const auto s0 = Clock::now();
    if (!link.write(mb::kControl, mb::kControlTrigger)) continue;  // never reached vgrd: no trigger
    ++n;
    ++issued_;
    const bool acked = step(rec, "trigger_ack", [](std::uint16_t s) { return (s & mb::kStatusTriggerAck) != 0; });
    if (acked) {
      rec.acked = true;
      rec.acqId = reg(regs, mb::kAcqId);
      const std::uint16_t s = reg(regs, mb::kStatus);
      // Refused by vgrd (queue full): TRIGGER_ACK with RESULT_VALID and -3 at once, no BUSY.
      if ((s & mb::kStatusResultValid) && !(s & mb::kStatusBusy) &&
          static_cast<std::int16_t>(reg(regs, mb::kErrorCode)) == statusCode(Status::BusyOverrun))
        rec.refused = true;
    }
    bool valid = false;
    if (acked && writeUntil(rec, "trigger_clear", mb::kControl, 0)) {
      valid = step(rec, "result_valid", [](std::uint16_t s) { return (s & mb::kStatusResultValid) != 0; });
    }
    if (valid) {
      rec.answered = true;
      rec.latencyMs = std::chrono::duration<double, std::milli>(Clock::now() - s0).count();
      rec.resultId = reg(regs, mb::kResultId);
      rec.status = static_cast<std::int16_t>(reg(regs, mb::kErrorCode));
      rec.x = f32(regs, mb::kX);
      rec.y = f32(regs, mb::kY);
      rec.rz = f32(regs, mb::kR3);
      const bool error = (reg(regs, mb::kStatus) & mb::kStatusError) != 0;
      const auto ack = static_cast<std::uint16_t>(mb::kControlResultAck | (error ? mb::kControlClearError : 0));
      if (writeUntil(rec, "result_ack", mb::kControl, ack) &&
          step(rec, "result_valid_clear", [](std::uint16_t st) { return (st & mb::kStatusResultValid) == 0; }))
        writeUntil(rec, "ack_clear", mb::kControl, 0);
    } else {
      link.write(mb::kControl, 0);  // best effort: a clean CONTROL for the next trigger
    }
    records_.push_back(std::move(rec));
  }
}

// ---- Robots ----------------------------------------------------------------------------

RobotActor::RobotActor(RobotOptions options, CellState& cell) : options_(std::move(options)), cell_(cell) {}
RobotActor::~RobotActor() { stop(); }
void RobotActor::start() {
  thread_ = std::thread([this] { options_.dialect == protocol::Dialect::Strict ? runStrict() : run(); });
}
void RobotActor::stop() {
  if (thread_.joinable()) thread_.join();
}

namespace {

std::string getRequest(protocol::Dialect d, int job) {
  switch (d) {
    case protocol::Dialect::Ur: return "GET," + std::to_string(job) + "\n";
    case protocol::Dialect::Fanuc: return "GET," + std::to_string(job) + "\r\n";
    case protocol::Dialect::Binary: return protocol::binary::encodeRequest(protocol::binary::kCmdGet, job);
    default: return "GET," + std::to_string(job) + "#";
  }
}

// A malformed request and the status its reply must carry (docs/protocols.md).
std::pair<std::string, int> malformedRequest(protocol::Dialect d, int variant) {
  if (d == protocol::Dialect::Binary) {
    // A frame whose length field lies: -2, then vgrd looks for the next magic.
    std::string f = protocol::binary::encodeRequest(protocol::binary::kCmdGet, 1);
    f[7] = 20;
    return {f, statusCode(Status::BadArgument)};
  }
  const std::string end = d == protocol::Dialect::Ur ? "\n" : d == protocol::Dialect::Fanuc ? "\r\n" : "#";
  if (variant % 2 == 0) return {"GET,abc" + end, statusCode(Status::BadArgument)};
  return {"HELLO,1" + end, statusCode(Status::UnknownCommand)};
}

// Bytes of one complete reply at the front of `rx`, 0 while incomplete (as the robot
// programs read: ur up to ')', fanuc up to CR LF, binary 40 bytes; abb takes one recv).
std::size_t replyLength(protocol::Dialect d, const std::string& rx) {
  if (d == protocol::Dialect::Binary) return rx.size() >= protocol::binary::kReplyBytes ? protocol::binary::kReplyBytes : 0;
  if (d == protocol::Dialect::Abb) return rx.size();
  const std::string_view end = d == protocol::Dialect::Ur ? ")" : "\r\n";
  const std::size_t at = rx.find(end);
  return at == std::string::npos ? 0 : at + end.size();
}

void fill(RobotRequestRecord& r, protocol::Dialect d, const std::string& raw) {
  const auto parsed = protocol::parseRobotReply(d, raw);
  if (!parsed) {
    r.valid = false;
    r.error = "malformed reply (" + parsed.error().message + "): " + raw.substr(0, 100);
    return;
  }
  r.valid = true;
  r.status = parsed->status;
  r.cycle = parsed->cycle;
  r.x = parsed->xMm;
  r.y = parsed->yMm;
  r.rz = parsed->rzDeg;
}

}  // namespace

void RobotActor::run() {
  const protocol::Dialect d = options_.dialect;
  const std::string request = getRequest(d, options_.job);
  int fd = -1;
  std::string rx;
  int malformedVariant = 0;
  auto closeFd = [&] {
    if (fd >= 0) ::close(fd);
    fd = -1;
    rx.clear();
  };
  // Reads one reply into `rec`; false when none came (the connection is then closed).
  auto readReply = [&](RobotRequestRecord& rec, int timeoutMs) {
    const auto deadline = Clock::now() + std::chrono::milliseconds(timeoutMs);
    for (;;) {
      if (const std::size_t len = replyLength(d, rx); len > 0) {
        rec.replied = wallNow();
        rec.answered = true;
        fill(rec, d, rx.substr(0, len));
        rx.erase(0, len);
        return true;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0 || !recvSome(fd, rx, static_cast<int>(left), d == protocol::Dialect::Abb ? 80 : 4096)) {
        rec.error = left <= 0 ? "no reply within " + std::to_string(timeoutMs) + " ms" : "connection closed";
        closeFd();
        return false;
      }
    }
  };

  while (!cell_.stop) {
    if (fd < 0) {
      if (!cell_.vgrdUp) {
        std::this_thread::sleep_for(20ms);
        continue;
      }
      fd = connectTcp(options_.port, nullptr, 1000);
      if (fd < 0) {
        std::this_thread::sleep_for(50ms);
        continue;
      }
      ++reconnects_;
    }
    RobotRequestRecord rec;
    if (malformed_.exchange(false)) {
      const auto [bytes, expected] = malformedRequest(d, malformedVariant++);
      rec.kind = RequestKind::Malformed;
      rec.expectedStatus = expected;
      rec.sent = wallNow();
      if (!sendAll(fd, bytes)) {
        rec.error = "send failed";
        closeFd();
      } else if (readReply(rec, options_.replyTimeoutMs) && rec.valid && rec.status != expected) {
        rec.error = "malformed request answered " + std::to_string(rec.status) + ", expected " + std::to_string(expected);
      }
      records_.push_back(std::move(rec));
      continue;
    }
    if (drop_.exchange(false)) {
      // The robot program is aborted right after asking: whatever reply is already in our
      // buffer is thrown away (vgrd rightly counts it delivered); anything later must come
      // back to the robot's next request.
      rec.kind = RequestKind::Dropped;
      rec.sent = wallNow();
      sendAll(fd, request);
      for (;;) {
        std::string got;
        if (!recvSome(fd, got, 0)) break;
        rx += got;
      }
      while (const std::size_t len = replyLength(d, rx)) {
        RobotRequestRecord seen;
        fill(seen, d, rx.substr(0, len));
        rx.erase(0, len);
        if (seen.valid) rec.discarded.push_back(seen.cycle);
        if (d == protocol::Dialect::Abb) break;
      }
      rec.replied = wallNow();  // the moment of the close
      closeFd();
      records_.push_back(std::move(rec));
      continue;
    }
    const bool stall = stall_.exchange(false);
    rec.kind = stall ? RequestKind::Stalled : RequestKind::Normal;
    const bool sent = sendAll(fd, request);
    rec.sent = wallNow();  // after send(): never earlier than vgrd could have it
    if (!sent) {
      rec.error = "send failed";
      closeFd();
      records_.push_back(std::move(rec));
      continue;
    }
    if (stall) std::this_thread::sleep_for(std::chrono::milliseconds(options_.stallMs));
    readReply(rec, options_.replyTimeoutMs);
    records_.push_back(std::move(rec));
  }
  closeFd();
}

// Strict dialect (paper 002): vgrd pushes. Wait for the command token, answer "ready",
// read the pose frame "(x,y,z,rx,ry,rz)" (m, rad), answer "done". Each pushed pose is one
// record (no cycle id on this wire: the checker matches the pose to the journal).
void RobotActor::runStrict() {
  const std::string command = "MoveJ_pose", ready = "MoveJ_pose_wait_pos", done = "MoveJ_pose_done";
  int fd = -1;
  std::string rx;
  auto closeFd = [&] {
    if (fd >= 0) ::close(fd);
    fd = -1;
    rx.clear();
  };
  while (!cell_.stop) {
    if (fd < 0) {
      if (!cell_.vgrdUp) {
        std::this_thread::sleep_for(20ms);
        continue;
      }
      fd = connectTcp(options_.port, nullptr, 1000);
      if (fd < 0) {
        std::this_thread::sleep_for(50ms);
        continue;
      }
      ++reconnects_;
    }
    // Wait (up to 200 ms a round, so stop is seen) for the command token.
    if (rx.find(command) == std::string::npos) {
      if (!recvSome(fd, rx, 200)) {
        pollfd p{fd, POLLIN, 0};
        if (::poll(&p, 1, 0) == 1) closeFd();  // readable but nothing read: closed
        continue;
      }
      continue;
    }
    rx.erase(0, rx.find(command) + command.size());
    RobotRequestRecord rec;
    rec.sent = wallNow();
    if (!sendAll(fd, ready)) {
      closeFd();
      continue;
    }
    const auto deadline = Clock::now() + std::chrono::milliseconds(options_.replyTimeoutMs);
    while (rx.find(')') == std::string::npos && Clock::now() < deadline) {
      if (!recvSome(fd, rx, 100) && Clock::now() >= deadline) break;
    }
    const std::size_t close = rx.find(')');
    if (close == std::string::npos || rx.front() != '(') {
      rec.error = "no pose frame";
      records_.push_back(std::move(rec));
      closeFd();
      continue;
    }
    const std::string frame = rx.substr(1, close - 1);
    rx.erase(0, close + 1);
    std::array<double, 6> v{};
    std::size_t field = 0, pos = 0;
    bool ok = true;
    while (field < 6 && ok) {
      const std::size_t comma = frame.find(',', pos);
      const std::string_view t(frame.data() + pos, (comma == std::string::npos ? frame.size() : comma) - pos);
      ok = std::from_chars(t.data(), t.data() + t.size(), v[field]).ec == std::errc{};
      ++field;
      if (comma == std::string::npos) break;
      pos = comma + 1;
    }
    rec.answered = true;
    rec.replied = wallNow();
    rec.valid = ok && field == 6;
    if (!rec.valid) rec.error = "malformed pose frame: " + frame;
    rec.x = std::round(v[0] * 1e6) / 1e3;
    rec.y = std::round(v[1] * 1e6) / 1e3;
    rec.rz = std::round(v[5] * 180.0 / kPi * 1e3) / 1e3;
    records_.push_back(std::move(rec));
    if (!sendAll(fd, done)) closeFd();
  }
  closeFd();
}

// ---- Attacker --------------------------------------------------------------------------

AttackOutcome modbusGarbageBurst(int port) {
  AttackOutcome out;
  // Each frame on a fresh connection from 127.0.0.2, so one drop does not hide the next.
  struct Frame {
    std::vector<std::uint8_t> bytes;
    bool expectDrop;
  };
  const std::vector<Frame> frames = {
      {{0, 1, 0, 0, 0, 20, 1, 3, 0, 16, 0, 1}, true},          // MBAP length 20, 6 bytes follow: stalls, dropped
      {{0, 2, 0, 1, 0, 6, 1, 3, 0, 16, 0, 1}, true},           // protocol id 1
      {{0, 3, 0, 0, 0, 1, 1}, true},                            // MBAP length 1
      {{0, 4, 0, 0, 0, 2, 1, 0x2B}, false},                     // unknown function: exception 01
      {{0, 5, 0, 0, 0, 2, 1, 17}, false},                       // FC17 report server id: exception 01
      {{0, 6, 0, 0, 0, 6, 1, 6, 0, 40, 0, 1}, false},           // write HR 40: exception 02
      {{0, 7, 0, 0, 0, 6, 1, 3, 0, 60, 0, 10}, false},          // read HR 60..69 (table has 64): exception 02
      {{0, 8, 0, 0, 0, 6, 1, 6, 0, 0, 0, 1}, false},            // TRIGGER from a read-only client: exception 02
      {{0, 9, 0, 0, 0, 6, 0xF7, 4, 0, 16, 0, 1}, false},        // unit id 247: served (Modbus TCP ignores it)
      {{0, 10, 0, 0, 0, 6, 1, 3, 0, 0, 0, 0}, false},           // count 0: exception 03
  };
  for (const Frame& f : frames) {
    const int fd = connectTcp(port, "127.0.0.2", 1000);
    if (fd < 0) {
      ++out.unanswered;
      continue;
    }
    ++out.frames;
    sendAll(fd, std::string_view(reinterpret_cast<const char*>(f.bytes.data()), f.bytes.size()));
    std::string rx;
    const bool got = recvSome(fd, rx, 1000);
    if (!got) {
      // A drop shows as end of stream (recv 0) within the frame timeout; silence is a defect.
      pollfd p{fd, POLLIN, 0};
      const bool closed = ::poll(&p, 1, 0) == 1;
      if (closed && f.expectDrop)
        ++out.dropped;
      else
        ++out.unanswered;
    } else if (rx.size() >= 9 && (static_cast<std::uint8_t>(rx[7]) & 0x80) != 0 && !f.expectDrop) {
      ++out.exceptions;
    } else if (f.bytes[6] == 0xF7 && rx.size() >= 9 && rx[7] == 4) {
      ++out.served;  // any unit id is served
    } else {
      ++out.unanswered;
    }
    ::close(fd);
  }
  return out;
}

}  // namespace vgr::tools::soak
