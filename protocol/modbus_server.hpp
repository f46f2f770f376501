// Modbus TCP server for PLCs (PROTOCOLS.md, "PLC side: Modbus TCP"): the register map and
// handshake of protocol/modbus_map.hpp served by libmodbus on one thread of its own.
//
// Threads: start()/stop()/destructor from the owning thread; setReady() and publishResult()
// from any thread; the TriggerHandler runs on the Modbus thread. One mutex guards the map:
// every client request is answered and its handshake logic run under it, so a reader never
// sees half a result.
// Clients: up to maxClients at once and maxClientsPerAddress from one address (more are
// accepted and closed at once), only from allowedClients when that is set; one silent for
// idleTimeout is closed. Reads never block: each connection's bytes are buffered and its
// complete requests answered (framed by the MBAP header), at most kMaxAdusPerRound per
// connection per round of the poll loop, so a client that dribbles bytes, or pipelines
// thousands of requests, holds only itself. Writes never block either: a client whose
// socket cannot take a reply at once (it does not read) is dropped. A client that
// disconnects, sends a malformed frame (protocol id != 0, MBAP length outside [2, 254] or
// inconsistent with its function code) or does not complete a request within 500 ms of
// its first byte is dropped; the others are not disturbed.
// Writes outside HR 0..15 get exception 02 (illegal data address), and so does every
// register write of a client outside controlClients when that is set (it may read);
// function codes other than FC01-06, 15, 16, 22, 23 (FC17 included) get exception 01
// (illegal function) and the connection stays; any unit id is served.
// Connection events are logged at most 20 per 10 s; stats() counts all of them.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/result.hpp"
#include "core/status.hpp"
#include "protocol/modbus_map.hpp"  // WordOrder, ModbusResult, register constants
#include "protocol/plc_link.hpp"

namespace vgr::protocol {

struct ModbusOptions {
  std::string bind = "127.0.0.1";  // IPv4 address to listen on; "0.0.0.0" for all
  std::uint16_t port = 1502;       // 0 = pick a free port (read it back with port())
  WordOrder floatOrder = WordOrder::HighWordFirst;
  int maxClients = 8;  // simultaneous PLC connections, [1, 64]
  int maxClientsPerAddress = 0;  // from one peer address, [0, maxClients]; 0 = maxClients
  // A connection that sends nothing for this long is closed (its slot freed); zero = off.
  std::chrono::milliseconds idleTimeout{60000};
  // Peer IPv4 addresses (numeric) allowed to connect; empty = anyone. Others are closed at
  // once. start() fails on an entry that is not an IPv4 address.
  std::vector<std::string> allowedClients;
  // Peer IPv4 addresses (numeric) whose register writes are served; empty = every allowed
  // client. start() fails on an entry that is not an IPv4 address.
  std::vector<std::string> controlClients;
  bool requireTriggerEnable = false;  // triggers need CONTROL b3 (ModbusMap::setRequireTriggerEnable)
  // Backstop: BUSY longer than this ends the cycle with -5 PROCESSING_TIMEOUT at the PLC
  // (ModbusMap::setResultDeadline); zero = off. vgrd: cell.cycle_deadline_ms + 100 ms.
  std::chrono::milliseconds resultDeadline{0};
};

// Counters since start() (any thread; the 60 s summary).
struct ModbusServerStats {
  std::uint64_t accepted = 0;
  std::uint64_t closed = 0;             // accepted connections that ended, for any reason
  std::uint64_t refusedNotAllowed = 0;  // peer not in allowedClients
  std::uint64_t refusedFull = 0;        // maxClients or maxClientsPerAddress reached
  std::uint64_t writesRefused = 0;      // writes from outside controlClients (exception 02)
  std::uint64_t logLinesHeldBack = 0;   // connection log lines counted instead of written
};

// Complete requests of one connection answered per round of the poll loop (fairness).
inline constexpr int kMaxAdusPerRound = 8;
// What one peer can make the Modbus thread do is bounded (docs/robustness.md): at most
// kModbusAcceptsPerSecond new connections (bursts of kModbusAcceptBurst; more wait in the
// listen backlog), at most kModbusRequestsPerSecond requests of one connection answered
// (bursts of kModbusRequestBurst; more wait in its socket). A PLC polling every 1 ms is
// well within it.
inline constexpr double kModbusAcceptsPerSecond = 200, kModbusAcceptBurst = 50;
inline constexpr double kModbusRequestsPerSecond = 5000, kModbusRequestBurst = 250;

class ModbusServer final : public PlcLink {
 public:
  // Called on the Modbus thread, under the map lock, when a trigger is accepted. Must not
  // block and must not call publishResult() synchronously (post it to another thread; a
  // synchronous call is deferred until the handler returns). Returns the cycle id the
  // daemon assigned (ACQ_ID = its low 16 bits), or 0 to refuse (the map then ends the
  // trigger with RESULT_VALID + ERROR_CODE -3 BUSY_OVERRUN).
  using TriggerHandler = PlcLink::TriggerHandler;

  ModbusServer(ModbusOptions options, TriggerHandler onTrigger);
  ~ModbusServer() override;  // stops and joins
  ModbusServer(const ModbusServer&) = delete;
  ModbusServer& operator=(const ModbusServer&) = delete;

  // Binds and listens (the error names bind address and port), then starts the thread.
  // Fails when already started.
  Result<void> start() override;
  // Closes all connections and joins the thread. Idempotent; the map keeps its state.
  void stop() override;

  void setReady(bool ready) override;                  // any thread
  void publishResult(const ModbusResult& r) override;  // any thread; one lock, results before RESULT_ID before RESULT_VALID
  std::string describe() const override;
  std::string summary() const override;  // from stats()
  const Heartbeat& heartbeat() const override;
  // poll() wakes at least once a second (the HEARTBEAT bit): 3 s.
  std::chrono::milliseconds stallLimit() const override { return std::chrono::milliseconds(3000); }

  // The bound port once start() succeeded (the real one when options.port was 0), else
  // options.port.
  std::uint16_t port() const;

  // Snapshot of one register (holding table, address < 64), for tests and diagnostics.
  // Any thread.
  std::uint16_t holdingRegister(std::uint16_t address) const;

  ModbusServerStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vgr::protocol
