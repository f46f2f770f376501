// One Modbus TCP request as ModbusServer handles it, socket given by the caller: framing
// by the MBAP header (pure, scanAdu(): the server buffers each connection's bytes and
// never waits inside a read), the checks the server adds (length per function code, the
// supported function codes, the PLC's writable area), libmodbus' reply logic and the
// handshake of protocol/modbus_map.hpp. Split out of the server so the fuzzer
// (tests/fuzz/fuzz_modbus_adu.cpp) drives exactly this code path.
//
// Not thread-safe; one handler per server thread. handle() touches the map: the caller
// serialises it with every other map access (ModbusServer holds its mutex).
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "protocol/modbus_map.hpp"

namespace vgr::protocol {

// MODBUS_TCP_MAX_ADU_LENGTH: MBAP header (7) + the largest PDU (253).
inline constexpr std::size_t kModbusTcpMaxAdu = 260;
using ModbusFrame = std::array<std::uint8_t, kModbusTcpMaxAdu>;

// Where the next ADU in a connection's buffered bytes ends, from its MBAP header (pure).
struct AduScan {
  enum class Kind {
    NeedMore,   // header or body incomplete: wait for more bytes
    Complete,   // the first `length` bytes are one ADU
    Malformed,  // protocol id != 0, or MBAP length outside [2, 254]: drop the connection
  };
  Kind kind = Kind::NeedMore;
  std::size_t length = 0;
};
AduScan scanAdu(std::span<const std::uint8_t> buffered);

// What the server does with one complete ADU, from the frame alone (pure).
enum class FrameVerdict {
  Serve,           // a valid request: libmodbus answers it (exceptions included)
  RejectAddress,   // a write outside HR 0..15: exception 02, nothing written
  Unsupported,     // a function code outside FC01-06, 15, 16, 22, 23 (FC17 included):
                   // exception 01 (illegal function), the connection is kept
  Drop,            // protocol id != 0, MBAP length inconsistent with the frame or with
                   // its function code's fields, no function code
};
struct FrameCheck {
  FrameVerdict verdict = FrameVerdict::Drop;
  bool writes = false;  // the function writes holding registers (FC06, FC16, FC22, FC23)
};
FrameCheck checkFrame(std::span<const std::uint8_t> frame);

class ModbusRequestHandler {
 public:
  // byteTimeout: longest gap between two bytes of one frame before the client is dropped.
  explicit ModbusRequestHandler(std::chrono::microseconds byteTimeout = std::chrono::milliseconds(200));
  ~ModbusRequestHandler();
  ModbusRequestHandler(const ModbusRequestHandler&) = delete;
  ModbusRequestHandler& operator=(const ModbusRequestHandler&) = delete;

  bool valid() const;  // false when libmodbus could not allocate its context

  // Reads one request frame from `fd`, framed by scanAdu() (blocks up to the byte timeout
  // between bytes; ModbusServer does not use it, it buffers per connection without
  // blocking). Returns its length (> 0), or -1 (connection closed, stalled or unparsable;
  // the reason in lastError()).
  int receive(int fd, ModbusFrame& frame);

  struct Outcome {
    bool keep = true;        // false: close the connection (reason in dropReason)
    std::string dropReason;
    FrameCheck check;
    HandshakeEvents events;  // when check.writes and the request was served
    bool writeRefused = false;  // a write from a client that may not write: exception 02
  };
  // Answers the first `length` bytes of `frame` (one complete ADU; libmodbus reads the
  // whole buffer, never past it) on `fd` and runs the handshake after writes. A write of
  // a client that may not write (mayWrite false: not in the server's control clients) is
  // answered with exception 02 and changes nothing. The caller holds the map's lock.
  Outcome handle(int fd, const ModbusFrame& frame, int length, ModbusMap& map, const ModbusMap::TriggerFn& onTrigger,
                 bool mayWrite = true);

  const std::string& lastError() const { return lastError_; }

 private:
  struct Ctx;
  std::unique_ptr<Ctx> ctx_;
  std::chrono::microseconds byteTimeout_;
  std::string lastError_;
};

}  // namespace vgr::protocol
