// Modbus register map and level-mode handshake of PROTOCOLS.md ("PLC side: Modbus TCP").
// Pure logic: no sockets, no threads, no libmodbus. ModbusServer owns one ModbusMap behind
// a mutex and points libmodbus at its two register tables.
//
// Addresses are 0-based PDU addresses. Holding registers 0..15 are the PLC's (CONTROL,
// JOB_ID, TRIGGER_ID); everything from 16 up is written by vgrd only and mirrored in the
// holding AND input tables, so FC03 and FC04 read the same status and results.
//
// Handshake (level mode), all transitions in onHoldingWritten() / publishResult():
//   READY=1 -> PLC raises TRIGGER -> on the rising edge, while READY and not BUSY, the map
//   clears RESULT_VALID and PART_FOUND, sets BUSY and TRIGGER_ACK, asks the caller for a
//   cycle id (job id from JOB_ID) and writes its low 16 bits to ACQ_ID -> PLC drops TRIGGER
//   -> map drops TRIGGER_ACK -> publishResult() writes the result registers, then
//   RESULT_ID, then RESULT_VALID, and clears BUSY -> PLC raises RESULT_ACK -> map clears
//   RESULT_VALID and PART_FOUND. Dropping RESULT_ACK does nothing.
// Other rules:
//   - TRIGGER_ENABLE (CONTROL b3): with setRequireTriggerEnable(true) (config key
//     modbus.require_trigger_enable) a trigger edge, level or counter, is accepted only
//     while b3 is set in the same or an earlier write; without it the edge is ignored like
//     a trigger while not READY (no ACK, no cycle, HandshakeEvents::ignoredNotEnabled).
//     Raising b3 while TRIGGER is already high does not trigger: an edge is needed.
//     Off (the default), b3 is ignored.
//   - Result deadline (setResultDeadline(), cell.cycle_deadline_ms + slack in vgrd): a
//     backstop behind the daemon's own cycle deadline. When BUSY has lasted longer than
//     it, expireOverdue() publishes the cycle in flight as -5 PROCESSING_TIMEOUT (RESULT_ID
//     = its id) so the PLC never waits blindly, even on a hung cycle thread; the late real
//     result of that cycle is then dropped by publishResult() (it returns false).
//   - A rising TRIGGER while BUSY is not accepted: it sets OVERRUN and ERROR_CODE = -3
//     (BUSY_OVERRUN); the cycle in flight continues.
//   - A rising TRIGGER while not READY is ignored (no ACK): the PLC must wait for READY.
//   - When the caller refuses a trigger (returns cycle id 0) the map answers at once:
//     TRIGGER_ACK (level mode), zeroed results, RESULT_VALID, ERROR and ERROR_CODE = -3;
//     BUSY stays 0, ACQ_ID and RESULT_ID keep their values.
//   - ERROR_CODE is the status of the current result (0 OK, 1 NO_PART_FOUND, negative
//     errors from the status table), written with the result; an overrun writes -3 at
//     once and the next result overwrites it. ERROR and OVERRUN latch (ERROR: some result
//     was an error or a trigger was refused, since the last clear) until a rising
//     CLEAR_ERROR clears them and ERROR_CODE. PART_FOUND and NUM_FOUND describe the
//     current result. So a PLC reads the cycle's outcome from ERROR_CODE alone.
//   - Counter mode: a change of TRIGGER_ID (HR 2) to a non-zero value is a trigger request
//     under the same rules; its TRIGGER_ACK is cleared when the result is published.
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>

#include "core/status.hpp"
#include "protocol/wire_types.hpp"  // WordOrder

namespace vgr {
struct CycleResult;
}

namespace vgr::protocol {

// One vision result as the PLC sees it. Units: x, y, z in mm; r1, r2, r3 in degrees
// (r1 = rx, r2 = ry, r3 = rz); score in [0, 1].
struct ModbusResult {
  std::uint32_t cycleId = 0;  // daemon cycle id; RESULT_ID = its low 16 bits
  Status status = Status::Internal;
  int numFound = 0;
  double x = 0, y = 0, z = 0, r1 = 0, r2 = 0, r3 = 0, score = 0;
  int jobId = 0;
  int label = 0;  // the best part's label (paper 002's classes), 0 = unclassified
  double confidence = 0;  // [0, 1]: the classifier's confidence in that label; 0 without a classifier
};

// The registers' view of a cycle result (owned here, so every PLC link shows the same):
// status, cycle, job and part count, and for an Ok result its best part (parts.front())
// in mm and Z-Y-X Euler degrees (r1 = rx, r2 = ry, r3 = rz) with its score, label and the
// label's confidence. -0.0 is
// written as 0.0 (a PLC's HMI shows "-0" otherwise).
ModbusResult modbusResultFrom(const CycleResult& result);

namespace modbus {

inline constexpr std::size_t kRegisterCount = 64;   // size of each table
inline constexpr std::uint16_t kWritableCount = 16;  // PLC may write HR 0..15 only

// Register addresses (0-based).
inline constexpr std::uint16_t kControl = 0;
inline constexpr std::uint16_t kJobId = 1;
inline constexpr std::uint16_t kTriggerId = 2;
inline constexpr std::uint16_t kStatus = 16;
inline constexpr std::uint16_t kErrorCode = 17;   // int16, core/status.hpp codes
inline constexpr std::uint16_t kAcqId = 18;       // low 16 bits of the cycle being served
inline constexpr std::uint16_t kResultId = 19;    // low 16 bits of the cycle of the result
inline constexpr std::uint16_t kNumFound = 20;    // int16
inline constexpr std::uint16_t kCurrentJob = 21;  // int16
inline constexpr std::uint16_t kLabel = 22;       // int16: the best part's label (0 = unclassified)
inline constexpr std::uint16_t kConfidenceInt = 23;  // int16: the label's confidence x 1000 (0..1000)
inline constexpr std::uint16_t kX = 24;           // float32, mm (24-25)
inline constexpr std::uint16_t kY = 26;           // float32, mm
inline constexpr std::uint16_t kZ = 28;           // float32, mm
inline constexpr std::uint16_t kR1 = 30;          // float32, degrees (rx)
inline constexpr std::uint16_t kR2 = 32;          // float32, degrees (ry)
inline constexpr std::uint16_t kR3 = 34;          // float32, degrees (rz)
inline constexpr std::uint16_t kScore = 36;       // float32, 0..1
inline constexpr std::uint16_t kConfidence = 38;  // float32, 0..1: the label's confidence (38-39)
inline constexpr std::uint16_t kXInt = 40;        // int16, 0.1 mm
inline constexpr std::uint16_t kYInt = 41;        // int16, 0.1 mm
inline constexpr std::uint16_t kZInt = 42;        // int16, 0.1 mm
inline constexpr std::uint16_t kR1Int = 43;       // int16, 0.01 degree
inline constexpr std::uint16_t kR2Int = 44;       // int16, 0.01 degree
inline constexpr std::uint16_t kR3Int = 45;       // int16, 0.01 degree

// STATUS bits (register 16).
inline constexpr std::uint16_t kStatusReady = 1u << 0;
inline constexpr std::uint16_t kStatusTriggerAck = 1u << 1;
inline constexpr std::uint16_t kStatusBusy = 1u << 2;
inline constexpr std::uint16_t kStatusResultValid = 1u << 3;
inline constexpr std::uint16_t kStatusPartFound = 1u << 4;
inline constexpr std::uint16_t kStatusError = 1u << 5;
inline constexpr std::uint16_t kStatusHeartbeat = 1u << 6;
inline constexpr std::uint16_t kStatusOverrun = 1u << 7;

// CONTROL bits (holding register 0).
inline constexpr std::uint16_t kControlTrigger = 1u << 0;
inline constexpr std::uint16_t kControlResultAck = 1u << 1;
inline constexpr std::uint16_t kControlClearError = 1u << 2;
inline constexpr std::uint16_t kControlTriggerEnable = 1u << 3;  // required with setRequireTriggerEnable(true)

// Float32 as two registers in the given word order (bytes packed by hand: libmodbus
// 3.1.6's modbus_set_float_abcd swaps bytes). 123.456f, HighWordFirst -> {0x42F6, 0xE979}.
std::array<std::uint16_t, 2> packFloat(float value, WordOrder order);
float unpackFloat(std::uint16_t first, std::uint16_t second, WordOrder order);

// value * scale rounded to nearest, saturated to [-32768, 32767], as the two's-complement
// register word. NaN -> 0.
std::uint16_t toInt16Register(double value, double scale = 1.0);
// A register word read back as int16.
constexpr std::int16_t asInt16(std::uint16_t word) { return static_cast<std::int16_t>(word); }

// True when a client write of `count` holding registers from `address` stays inside the
// PLC's writable area (HR 0..15).
constexpr bool isWritable(std::uint32_t address, std::uint32_t count) {
  return count > 0 && address + count <= kWritableCount;
}

}  // namespace modbus

// What one onHoldingWritten() call did; for counters and debug logs.
struct HandshakeEvents {
  bool triggerAccepted = false;    // handler returned a cycle id; BUSY set
  bool triggerRefused = false;     // handler returned 0; error result published
  bool overrun = false;            // rising trigger while BUSY
  bool ignoredNotReady = false;    // rising trigger while not READY
  bool resultAcked = false;        // rising RESULT_ACK
  bool errorCleared = false;       // rising CLEAR_ERROR
  bool ignoredNotEnabled = false;  // trigger edge without TRIGGER_ENABLE (when required)
  int jobId = 0;                   // job of the accepted/refused trigger
  std::uint32_t cycleId = 0;       // cycle id of the accepted trigger
};

// Not thread-safe: the owner serialises every call (ModbusServer holds one mutex).
class ModbusMap {
 public:
  // Returns the daemon's cycle id for a trigger on `jobId`, or 0 to refuse. Must not call
  // back into this map.
  using TriggerFn = std::function<std::uint32_t(int jobId)>;

  using Clock = std::chrono::steady_clock;

  explicit ModbusMap(WordOrder floatOrder = WordOrder::HighWordFirst);

  // Triggers need CONTROL b3 TRIGGER_ENABLE (see the header comment). Default false.
  void setRequireTriggerEnable(bool on) { requireTriggerEnable_ = on; }
  bool requireTriggerEnable() const { return requireTriggerEnable_; }
  // Longest BUSY before expireOverdue() ends the cycle with -5; zero = never (default).
  void setResultDeadline(std::chrono::milliseconds d) { resultDeadline_ = d; }
  std::chrono::milliseconds resultDeadline() const { return resultDeadline_; }

  // The register tables, kRegisterCount words each; the server hands them to libmodbus.
  // Clients write holding registers through these, then the owner calls onHoldingWritten().
  std::span<std::uint16_t, modbus::kRegisterCount> holdingRegisters() { return holding_; }
  std::span<std::uint16_t, modbus::kRegisterCount> inputRegisters() { return input_; }
  std::uint16_t holding(std::uint16_t address) const { return holding_.at(address); }
  std::uint16_t input(std::uint16_t address) const { return input_.at(address); }
  std::uint16_t status() const { return input_[modbus::kStatus]; }

  // Runs the handshake after a client wrote holding registers: edge detection on CONTROL
  // and TRIGGER_ID against the values seen by the previous call. `now` stamps an accepted
  // trigger for the result deadline.
  HandshakeEvents onHoldingWritten(const TriggerFn& onTrigger, Clock::time_point now = Clock::now());

  void setReady(bool ready);
  bool ready() const { return (status() & modbus::kStatusReady) != 0; }
  bool busy() const { return (status() & modbus::kStatusBusy) != 0; }

  // Writes the result registers, then RESULT_ID, then RESULT_VALID; clears BUSY; ERROR and
  // ERROR_CODE when r.status < 0; PART_FOUND when r.status == Ok. Returns false (and
  // changes nothing) for the late result of a cycle expireOverdue() already ended.
  bool publishResult(const ModbusResult& r);

  // When BUSY for longer than the result deadline at `now`: publishes the cycle in flight
  // as PROCESSING_TIMEOUT and returns its id; else 0. The server calls it from its loop.
  std::uint32_t expireOverdue(Clock::time_point now);
  // When the cycle in flight must be ended by expireOverdue(); nullopt when not BUSY or
  // no deadline is set.
  std::optional<Clock::time_point> busyDeadline() const;

  // Toggles HEARTBEAT; the server calls it once a second.
  void tick();

  WordOrder floatOrder() const { return floatOrder_; }

 private:
  void set(std::uint16_t address, std::uint16_t value);  // both tables
  void setStatusBits(std::uint16_t bits, bool on);
  void writeFloat(std::uint16_t address, double value);
  void handleTriggerRequest(const TriggerFn& onTrigger, bool levelMode, bool enabled, Clock::time_point now,
                            HandshakeEvents& ev);
  void write(const ModbusResult& r);  // publishResult() without the expired check

  WordOrder floatOrder_;
  std::array<std::uint16_t, modbus::kRegisterCount> holding_{};
  std::array<std::uint16_t, modbus::kRegisterCount> input_{};
  std::uint16_t lastControl_ = 0;    // CONTROL as of the previous onHoldingWritten()
  std::uint16_t lastTriggerId_ = 0;  // TRIGGER_ID as of the previous onHoldingWritten()
  bool counterModeAck_ = false;      // TRIGGER_ACK came from a counter-mode trigger
  bool requireTriggerEnable_ = false;
  std::chrono::milliseconds resultDeadline_{0};
  std::uint32_t inFlight_ = 0;        // cycle id accepted and not yet published; 0 = none
  Clock::time_point inFlightSince_{};
  std::array<std::uint32_t, 8> expired_{};  // cycles ended by expireOverdue(), ring
  std::size_t expiredNext_ = 0;
};

}  // namespace vgr::protocol
