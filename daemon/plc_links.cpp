#include "daemon/plc_links.hpp"

#include <chrono>

#include "protocol/modbus_client_trigger.hpp"
#include "protocol/modbus_server.hpp"

namespace vgr::daemon {

namespace {
constexpr int kModbusDeadlineSlackMs = 100;  // ms after cell.cycle_deadline_ms
}  // namespace

std::vector<std::unique_ptr<protocol::PlcLink>> makePlcLinks(const config::CellConfig& cell,
                                                             protocol::PlcLink::TriggerHandler onTrigger) {
  std::vector<std::unique_ptr<protocol::PlcLink>> links;
  const auto& m = cell.modbus;
  const auto backstop = std::chrono::milliseconds(cell.cycleDeadlineMs + kModbusDeadlineSlackMs);
  if (m.enabled) {
    protocol::ModbusOptions o;
    o.bind = m.bind;
    o.port = m.port;
    o.floatOrder = m.floatWordOrder;
    o.maxClients = m.maxClients;
    o.maxClientsPerAddress = m.maxClientsPerAddress;
    o.idleTimeout = std::chrono::milliseconds(m.idleTimeoutMs);
    o.allowedClients = m.allowedClients;
    o.controlClients = m.controlClients;
    o.requireTriggerEnable = m.requireTriggerEnable;
    o.resultDeadline = backstop;
    links.push_back(std::make_unique<protocol::ModbusServer>(o, onTrigger));
  }
  if (m.client.enabled) {
    const auto& c = m.client;
    protocol::ModbusClientOptions o;
    o.host = c.host;
    o.port = c.port;
    o.unitId = c.unitId;
    o.input = c.trigger == config::TriggerInputKind::Coil ? protocol::ModbusClientOptions::Input::Coil
                                                           : protocol::ModbusClientOptions::Input::DiscreteInput;
    o.inputAddress = static_cast<std::uint16_t>(c.triggerAddress);
    o.statusAddress = static_cast<std::uint16_t>(c.statusAddress);
    o.poll = std::chrono::milliseconds(c.pollMs);
    o.debounce = std::chrono::milliseconds(c.debounceMs);
    o.reconnect = std::chrono::milliseconds(c.reconnectMs);
    o.floatOrder = m.floatWordOrder;
    o.jobId = c.job;
    o.resultDeadline = backstop;
    links.push_back(std::make_unique<protocol::ModbusClientTrigger>(o, onTrigger));
  }
  return links;
}

}  // namespace vgr::daemon
