// Modbus client mode (PROTOCOLS.md, "Offer also a client mode that polls a PLC input"):
// for sites where the PLC cannot write to vgrd. vgrd is the Modbus TCP CLIENT of the PLC:
// it polls one discrete input (FC02) or coil (FC01) — the laser sensor — every pollMs,
// debounces it, triggers a cycle on the debounced rising edge and writes the status and
// result block (the server's registers 16..45: STATUS .. R3 x100, same layout, 30 words)
// to the PLC's holding registers from statusAddress with ONE FC16 request, so the PLC never
// reads half a result.
//
// The handshake is the server's ModbusMap driven by the sensor: the debounced level is
// TRIGGER (b0 of CONTROL), so TRIGGER_ACK follows the sensor, a rising edge while BUSY sets
// OVERRUN and ERROR_CODE -3, and every accepted trigger ends in RESULT_VALID (the result
// deadline backstop included). There is no RESULT_ACK or CLEAR_ERROR (the PLC cannot
// write): RESULT_VALID stays until the next trigger; ERROR and OVERRUN latch until vgrd
// restarts. The block is written when it changes (the HEARTBEAT bit changes it every
// second) and after every reconnect.
//
// Threads: start()/stop()/destructor from the owning thread; setReady()/publishResult()/
// counters() from any thread; the TriggerHandler runs on the client thread (must not
// block; publishResult() from inside it is deferred until it returns).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "core/result.hpp"
#include "protocol/modbus_map.hpp"
#include "protocol/plc_link.hpp"

namespace vgr::protocol {

// Debounce of one sampled binary input: a new level counts once it has been read
// unchanged for at least `hold` (0: at once). Pure; one instance per input.
class Debouncer {
 public:
  using Clock = std::chrono::steady_clock;
  explicit Debouncer(std::chrono::milliseconds hold) : hold_(hold) {}
  // Feeds one sample taken at `now`; returns the new debounced level when it changed.
  std::optional<bool> sample(bool raw, Clock::time_point now);
  bool level() const { return level_; }

 private:
  std::chrono::milliseconds hold_;
  bool level_ = false;
  bool candidate_ = false;
  Clock::time_point candidateSince_{};
};

struct ModbusClientOptions {
  std::string host = "127.0.0.1";  // the PLC, IPv4
  std::uint16_t port = 502;
  int unitId = 1;
  enum class Input { DiscreteInput, Coil } input = Input::DiscreteInput;
  std::uint16_t inputAddress = 0;   // 0-based bit address of the sensor
  std::uint16_t statusAddress = 100;  // first of the 30 holding registers written on the PLC
  std::chrono::milliseconds poll{5};
  std::chrono::milliseconds debounce{20};
  std::chrono::milliseconds reconnect{500};
  WordOrder floatOrder = WordOrder::HighWordFirst;
  int jobId = 0;  // passed to the TriggerHandler
  std::chrono::milliseconds resultDeadline{0};  // as ModbusOptions::resultDeadline
};

// Words written to the PLC: registers 16..45 of the map.
inline constexpr int kClientBlockWords = modbus::kR3Int - modbus::kStatus + 1;

class ModbusClientTrigger final : public PlcLink {
 public:
  // Same contract as ModbusServer::TriggerHandler: returns the cycle id or 0 to refuse.
  using TriggerHandler = PlcLink::TriggerHandler;

  struct Counters {
    std::uint64_t triggers = 0;   // debounced rising edges
    std::uint64_t accepted = 0;
    std::uint64_t overruns = 0;
    std::uint64_t blockWrites = 0;
    std::uint64_t connects = 0;
    std::uint64_t ioErrors = 0;   // failed reads/writes (each drops the connection)
  };

  ModbusClientTrigger(ModbusClientOptions options, TriggerHandler onTrigger);
  ~ModbusClientTrigger() override;  // stops and joins
  ModbusClientTrigger(const ModbusClientTrigger&) = delete;
  ModbusClientTrigger& operator=(const ModbusClientTrigger&) = delete;

  // Starts the client thread; it connects (and reconnects) on its own. Fails on bad
  // options or when already started.
  Result<void> start() override;
  void stop() override;  // idempotent

  void setReady(bool ready) override;
  void publishResult(const ModbusResult& r) override;
  std::string describe() const override;
  const Heartbeat& heartbeat() const override;
  // One loop turn: a connect or a few requests, each bounded by the 500 ms response
  // timeout, then the poll or reconnect wait: reconnect + 3 s.
  std::chrono::milliseconds stallLimit() const override;
  Counters counters() const;
  bool connected() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vgr::protocol
