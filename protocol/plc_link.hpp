// The PLC side of vgrd behind one small interface (STYLE.md rule 2): the Modbus TCP server
// (the PLC reads and writes our registers) and client mode (we poll the PLC's sensor input
// and write our block into its registers) both implement it, so vgrd holds a list of links
// and hands every one the same result (ModbusResult, protocol/modbus_map.hpp).
//
// Lifecycle: start() once (errors name the address), stop() idempotent (also from the
// destructor). Threads: start()/stop() from the owning thread; setReady() and
// publishResult() from any thread. The trigger handler runs on the link's own thread and
// must not block (contract of ModbusServer::TriggerHandler).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

#include "core/heartbeat.hpp"
#include "core/result.hpp"

namespace vgr::protocol {

struct ModbusResult;

class PlcLink {
 public:
  // Returns the cycle id the daemon assigned, or 0 to refuse (the link answers the PLC
  // with -3 BUSY_OVERRUN).
  using TriggerHandler = std::function<std::uint32_t(int jobId)>;

  virtual ~PlcLink() = default;
  virtual Result<void> start() = 0;
  virtual void stop() = 0;
  virtual void setReady(bool ready) = 0;
  virtual void publishResult(const ModbusResult& result) = 0;
  // "Modbus server 127.0.0.1:1502", "Modbus client of 10.0.0.5:502": for logs.
  virtual std::string describe() const = 0;
  // What the link counted since start (connections, refusals), one line for the daemon's
  // 60 s summary; empty when it counts nothing. Any thread.
  virtual std::string summary() const { return {}; }
  // The link's thread beats this at every turn of its loop; stallLimit() is the longest
  // legitimate gap between two beats. vgrd's systemd watchdog stops pinging when a link's
  // thread stays silent longer (daemon/watchdog.hpp). Any thread.
  virtual const Heartbeat& heartbeat() const = 0;
  virtual std::chrono::milliseconds stallLimit() const = 0;
};

}  // namespace vgr::protocol
