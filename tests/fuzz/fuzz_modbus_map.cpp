// libFuzzer target: the register map and handshake (protocol/modbus_map.hpp) under any
// sequence of PLC holding-register writes, daemon results, refusals, heartbeats, READY
// changes and deadline expiries — what the Modbus thread and the cycle thread do to it.
// Input: 4-byte operations [op, a, b, c]. Checks (abort = finding): the status and result
// registers are mirrored in both tables; BUSY and RESULT_VALID are never set together;
// the daemon is asked for a cycle only while READY, not BUSY and (when required)
// TRIGGER_ENABLE is set; every accepted cycle gets exactly one published result (its own
// or the deadline's -5); the PLC area is never written by the map.
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <set>

#include "protocol/modbus_map.hpp"

namespace {

using namespace vgr::protocol;
using namespace vgr::protocol::modbus;

void check(bool ok) {
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  ModbusMap map(data[0] & 1 ? WordOrder::LowWordFirst : WordOrder::HighWordFirst);
  const bool requireEnable = (data[0] & 2) != 0;
  map.setRequireTriggerEnable(requireEnable);
  map.setResultDeadline(std::chrono::milliseconds(10));
  auto now = ModbusMap::Clock::time_point{} + std::chrono::hours(1);

  bool refuse = false;
  std::uint32_t nextCycle = 1;
  std::set<std::uint32_t> open;      // accepted, no result yet
  std::set<std::uint32_t> answered;  // got a result: published, or ended by the deadline
  std::uint32_t lastExpired = 0;

  const auto onTrigger = [&](int) -> std::uint32_t {
    const std::uint16_t control = map.holding(kControl);
    check(map.ready() && !map.busy());
    if (requireEnable) check((control & kControlTriggerEnable) != 0);
    // Like CycleRunner: one running and a queue of 4; beyond that, refused.
    if (refuse || open.size() >= 5) return 0;
    const std::uint32_t id = nextCycle++;
    open.insert(id);
    return id;
  };

  for (std::size_t i = 1; i + 4 <= size; i += 4) {
    const std::uint8_t op = data[i], a = data[i + 1], b = data[i + 2], c = data[i + 3];
    const auto value = static_cast<std::uint16_t>((b << 8) | c);
    std::uint16_t plcArea[kWritableCount];
    switch (op % 8) {
      case 0:
      case 1:  // a PLC writes one of its registers (FC06), then the handshake runs
        map.holdingRegisters()[a % kWritableCount] = value;
        std::memcpy(plcArea, map.holdingRegisters().data(), sizeof plcArea);
        map.onHoldingWritten(onTrigger, now);
        check(std::memcmp(plcArea, map.holdingRegisters().data(), sizeof plcArea) == 0);
        break;
      case 2: {  // the daemon publishes the oldest open cycle
        if (open.empty()) break;
        const std::uint32_t id = *open.begin();
        ModbusResult r;
        r.cycleId = id;
        r.status = static_cast<vgr::Status>(static_cast<std::int16_t>(static_cast<std::int8_t>(a) % 10));
        r.x = static_cast<double>(static_cast<std::int16_t>(value)) * 0.37;
        r.score = c / 255.0;
        const bool taken = map.publishResult(r);
        open.erase(id);
        // A late result is dropped only for a cycle the deadline already answered.
        check(taken != answered.contains(id));
        answered.insert(id);
        break;
      }
      case 3:
        map.tick();
        break;
      case 4:
        map.setReady((a & 1) != 0);
        break;
      case 5:
        refuse = (a & 1) != 0;
        break;
      case 6:  // time passes; the backstop may answer the cycle in flight
        now += std::chrono::milliseconds(a);
        if (const std::uint32_t id = map.expireOverdue(now); id != 0) {
          check(open.contains(id) && !answered.contains(id));
          check(vgr::protocol::modbus::asInt16(map.input(kErrorCode)) == -5);
          answered.insert(id);
          lastExpired = id;
        }
        break;
      default:  // the late result of the last expired cycle arrives (again): dropped
        if (lastExpired != 0) {
          ModbusResult r;
          r.cycleId = lastExpired;
          r.status = vgr::Status::Ok;
          const auto before = map.status();
          check(!map.publishResult(r));
          check(map.status() == before);
        }
        break;
    }
    for (std::uint16_t addr = kStatus; addr < kRegisterCount; ++addr) check(map.holding(addr) == map.input(addr));
    for (std::uint16_t addr = 0; addr < kStatus; ++addr) check(map.input(addr) == 0);
    const auto s = map.status();
    check(!((s & kStatusBusy) && (s & kStatusResultValid)));
    std::size_t unanswered = 0;
    for (const auto id : open) unanswered += answered.contains(id) ? 0 : 1;
    check(unanswered <= 1);
    check(map.busy() == (unanswered == 1));
  }
  return 0;
}
