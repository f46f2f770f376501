// SimCell for the Modbus tests (modbus_vgrd_test, modbus_soak_test, locate_vgrd_*,
// calib_vgrd_test, modbus_client_mode_test): the whole simulated cell plus the counter-mode
// trigger handshake of docs/protocols.md, driven through a libmodbus context of the test's.
#pragma once

#include <chrono>
#include <cstdint>

#include <modbus.h>

#include <thread>
#include <vector>

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

  // `count` PLC triggers in counter mode (TRIGGER_ID firstId, firstId + 1, ...), each
  // asserted to end in RESULT_VALID with ERROR_CODE 0 within `timeout`, `pause` between
  // them; the RESULT_IDs into `cycles`. Call as ASSERT_NO_FATAL_FAILURE(triggerCycles(...)).
  void triggerCycles(int count, std::uint16_t firstId, std::chrono::milliseconds timeout, std::vector<std::uint32_t>& cycles,
                     std::chrono::milliseconds pause = std::chrono::milliseconds(20)) {
    modbus_t* ctx = modbus_new_tcp("127.0.0.1", kModbusPort);
    ASSERT_NE(ctx, nullptr);
    const bool connected = modbus_connect(ctx) == 0;
    for (int n = 0; connected && n < count; ++n) {
      const auto r = triggerCounter(ctx, static_cast<std::uint16_t>(firstId + n), timeout);
      if (!(r.status & 0x08)) {
        ADD_FAILURE() << "RESULT_VALID";
        break;
      }
      EXPECT_EQ(r.error, 0) << "ERROR_CODE";
      cycles.push_back(r.resultId);
      std::this_thread::sleep_for(pause);
    }
    modbus_close(ctx);
    modbus_free(ctx);
    ASSERT_TRUE(connected) << "Modbus connect to 127.0.0.1:" << kModbusPort;
    ASSERT_EQ(cycles.size(), static_cast<std::size_t>(count));
  }
};

}  // namespace vgr::test
