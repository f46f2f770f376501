// SimCell for the Modbus tests (modbus_vgrd_test, modbus_soak_test, locate_vgrd_*,
// calib_vgrd_test, modbus_client_mode_test): the whole simulated cell plus the counter-mode
// trigger handshake of docs/protocols.md, driven through a libmodbus context of the test's.
#pragma once

#include <chrono>
#include <cstdint>

#include <modbus.h>

#include "tests/support/sim_cell.hpp"

namespace vgr::test {

class ModbusCell : public SimCell {
 protected:
  // Counter mode: writes `triggerId` to TRIGGER_ID (HR 2; each new value triggers) and waits
  // up to `timeout` for RESULT_VALID without BUSY. Returns {STATUS, ERROR_CODE, RESULT_ID}
  // (IR 16..18); STATUS without RESULT_VALID (bit 3) when it timed out.
  struct CounterResult {
    std::uint16_t status = 0, error = 0, resultId = 0;
  };
  static CounterResult triggerCounter(modbus_t* ctx, std::uint16_t triggerId, std::chrono::milliseconds timeout) {
    CounterResult r;
    if (modbus_write_register(ctx, 2, triggerId) != 1) return r;
    std::uint16_t head[4] = {};
    const auto t = Clock::now();
    do {
      if (modbus_read_input_registers(ctx, 16, 4, head) != 4) return r;
    } while (!((head[0] & 0x08) && !(head[0] & 0x04)) && Clock::now() - t < timeout);
    return {head[0], head[1], head[2]};
  }
};

}  // namespace vgr::test
