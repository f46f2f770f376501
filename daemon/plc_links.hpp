// vgrd's PLC links from the cell config's `modbus` section: the Modbus TCP server
// (modbus.enabled) and client mode (modbus.client.enabled), each a protocol::PlcLink, in
// that order. Not started: the caller starts each and reports the first error. Both get the
// result deadline backstop cycle_deadline_ms + 100 ms (the cycle's own deadline answers
// first; the backstop only catches a hung cycle thread).
#pragma once

#include <memory>
#include <vector>

#include "config/cell_config.hpp"
#include "protocol/plc_link.hpp"

namespace vgr::daemon {

std::vector<std::unique_ptr<protocol::PlcLink>> makePlcLinks(const config::CellConfig& cell,
                                                             protocol::PlcLink::TriggerHandler onTrigger);

}  // namespace vgr::daemon
