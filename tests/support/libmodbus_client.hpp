// A libmodbus TCP client to 127.0.0.1:port with a 1 s response timeout, for "another PLC
// keeps working" in the Modbus server tests. Owns the context; `connected` says whether
// modbus_connect() succeeded.
#pragma once

#include <cstdint>

#include <modbus.h>

namespace vgr::test {

struct LibmodbusClient {
  explicit LibmodbusClient(std::uint16_t port) : ctx(modbus_new_tcp("127.0.0.1", port)) {
    if (ctx != nullptr) {
      modbus_set_response_timeout(ctx, 1, 0);
      connected = modbus_connect(ctx) == 0;
    }
  }
  ~LibmodbusClient() {
    if (ctx == nullptr) return;
    modbus_close(ctx);
    modbus_free(ctx);
  }
  LibmodbusClient(const LibmodbusClient&) = delete;
  LibmodbusClient& operator=(const LibmodbusClient&) = delete;
  // STATUS (input register 16, docs/protocols.md) by FC04; libmodbus' return code (1 on success).
  int readStatus(std::uint16_t& status) const { return modbus_read_input_registers(ctx, 16, 1, &status); }

  modbus_t* ctx;
  bool connected = false;
};

}  // namespace vgr::test
