// libFuzzer target: raw Modbus TCP bytes from a PLC connection through exactly the code
// path ModbusServer uses (protocol/modbus_request.hpp): MBAP framing (scanAdu),
// our frame checks, libmodbus' reply on the map's register tables, and the handshake of
// protocol/modbus_map.hpp — with a fake daemon that accepts triggers and publishes results.
// The input is written to one end of a socketpair, which is then shut down, and the server
// side reads requests until the stream ends or a frame is dropped, like a connection.
// Checks: ASan/UBSan; the map's invariants after every request (status mirrored in both
// tables, the PLC area never written by vgrd, BUSY and RESULT_VALID never together, no
// write above HR 15 ever lands; a read-only client's write never lands nor triggers).
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "protocol/modbus_map.hpp"
#include "protocol/modbus_request.hpp"

namespace {

using namespace vgr::protocol;
using namespace vgr::protocol::modbus;

void check(bool ok) {
  if (!ok) std::abort();
}

void checkInvariants(const ModbusMap& map, const std::array<std::uint16_t, kRegisterCount>& holdingBefore) {
  for (std::uint16_t a = kStatus; a < kRegisterCount; ++a) check(map.holding(a) == map.input(a));
  // Registers 16..63 change only through the map (mirrored), never via a client write:
  // the mirror check above catches a client write landing in the holding table alone.
  for (std::uint16_t a = 0; a < kStatus; ++a) check(map.input(a) == 0);
  const auto s = map.status();
  check(!((s & kStatusBusy) && (s & kStatusResultValid)));
  (void)holdingBefore;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static ModbusRequestHandler handler(std::chrono::microseconds(1000));
  check(handler.valid());
  if (size > 64 * 1024) return 0;  // more than a socket buffer holds at once

  int sv[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0) return 0;
  const int big = 1 << 20;
  ::setsockopt(sv[0], SOL_SOCKET, SO_SNDBUF, &big, sizeof big);
  ::setsockopt(sv[1], SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
  std::size_t off = 0;
  while (off < size) {
    const auto n = ::send(sv[0], data + off, size - off, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n <= 0) break;
    off += static_cast<std::size_t>(n);
  }
  ::shutdown(sv[0], SHUT_WR);

  ModbusMap map;
  map.setReady(true);
  map.setResultDeadline(std::chrono::milliseconds(data[0] % 4));  // sometimes expire at once
  std::uint32_t nextCycle = 1;
  std::uint32_t pending = 0;
  const auto onTrigger = [&](int job) -> std::uint32_t {
    if (job == 13) return 0;  // the daemon refuses (queue full)
    pending = nextCycle++;
    return pending;
  };

  for (int requests = 0; requests < 4096; ++requests) {
    ModbusFrame frame{};
    const int rc = handler.receive(sv[1], frame);
    if (rc < 0) break;
    if (rc == 0) continue;
    std::array<std::uint16_t, kRegisterCount> before{};
    std::memcpy(before.data(), map.holdingRegisters().data(), sizeof before);
    // A client outside control_clients (odd transaction ids here) may read, never write.
    const bool mayWrite = (frame[1] & 1) == 0;
    const std::uint32_t cyclesBefore = nextCycle;
    const auto out = handler.handle(sv[1], frame, rc, map, onTrigger, mayWrite);
    checkInvariants(map, before);
    // Writes outside HR 0..15, and every write of a read-only client, are rejected before
    // anything is written, and trigger nothing.
    if (out.check.verdict == FrameVerdict::RejectAddress) {
      check(std::memcmp(before.data(), map.holdingRegisters().data(), sizeof before) == 0);
      check(nextCycle == cyclesBefore);
    }
    if (!mayWrite && out.check.writes) check(out.check.verdict == FrameVerdict::RejectAddress);
    // Drain replies so a long input never blocks on a full socket.
    std::array<char, 4096> sink{};
    while (::recv(sv[0], sink.data(), sink.size(), MSG_DONTWAIT) > 0) {
    }
    // The fake daemon finishes every other cycle at once; the rest may expire.
    if (pending != 0 && (frame[0] & 1) == 0) {
      ModbusResult r;
      r.cycleId = pending;
      r.status = (frame[1] & 1) ? vgr::Status::Ok : vgr::Status::CameraError;
      r.x = static_cast<double>(frame[6]) * 1e3;
      r.numFound = r.status == vgr::Status::Ok ? 1 : 0;
      map.publishResult(r);
      pending = 0;
    } else if (pending != 0 && map.expireOverdue(ModbusMap::Clock::now()) != 0) {
      pending = 0;
    }
    checkInvariants(map, before);
    if (!out.keep) break;
  }
  ::close(sv[0]);
  ::close(sv[1]);
  return 0;
}
