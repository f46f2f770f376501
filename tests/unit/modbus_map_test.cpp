// Register map and level-mode handshake of PROTOCOLS.md, "PLC side: Modbus TCP".
#include "protocol/modbus_map.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

namespace vgr::protocol {
namespace {

using namespace modbus;

// A fake daemon: records trigger calls and hands out cycle ids (0 = refuse).
struct FakeDaemon {
  std::vector<int> jobs;
  std::uint32_t nextCycle = 70000;  // > 16 bits on purpose
  bool refuse = false;
  ModbusMap::TriggerFn fn() {
    return [this](int job) -> std::uint32_t {
      jobs.push_back(job);
      return refuse ? 0 : nextCycle++;
    };
  }
};

class ModbusMapFixture : public ::testing::Test {
 protected:
  // What libmodbus does for an FC06 write, followed by the server's handshake call.
  HandshakeEvents writeHr(std::uint16_t address, std::uint16_t value) {
    map.holdingRegisters()[address] = value;
    return map.onHoldingWritten(daemon.fn());
  }
  bool bit(std::uint16_t mask) const { return (map.status() & mask) != 0; }
  // Status must be the same in both tables.
  void expectMirrored() const {
    for (std::uint16_t a = kStatus; a < kRegisterCount; ++a) {
      ASSERT_EQ(map.holding(a), map.input(a)) << "register " << a;
    }
  }
  ModbusResult okResult(std::uint32_t cycle) const {
    ModbusResult r;
    r.cycleId = cycle;
    r.status = Status::Ok;
    r.numFound = 2;
    r.x = 512.3;
    r.y = -120.25;
    r.z = 35.0;
    r.r1 = 1.5;
    r.r2 = -2.25;
    r.r3 = -12.5;
    r.score = 0.875;
    r.jobId = 4;
    return r;
  }

  ModbusMap map;
  FakeDaemon daemon;
};

// Suite names start with "modbus" so `ctest -R modbus` selects every Modbus test.
using modbus_map = ModbusMapFixture;

TEST(modbus_float, GoldenWordsHighWordFirst) {
  const auto w = packFloat(123.456f, WordOrder::HighWordFirst);
  EXPECT_EQ(w[0], 0x42F6);
  EXPECT_EQ(w[1], 0xE979);
  const auto one = packFloat(1.0f, WordOrder::HighWordFirst);
  EXPECT_EQ(one[0], 0x3F80);
  EXPECT_EQ(one[1], 0x0000);
  const auto neg = packFloat(-2.5f, WordOrder::HighWordFirst);
  EXPECT_EQ(neg[0], 0xC020);
  EXPECT_EQ(neg[1], 0x0000);
}

TEST(modbus_float, GoldenWordsLowWordFirst) {
  const auto w = packFloat(123.456f, WordOrder::LowWordFirst);
  EXPECT_EQ(w[0], 0xE979);
  EXPECT_EQ(w[1], 0x42F6);
}

TEST(modbus_float, RoundTripsBothOrders) {
  for (const float v : {0.0f, -0.0f, 1e-20f, 3.14159f, -987654.3f, std::numeric_limits<float>::max()}) {
    for (const auto order : {WordOrder::HighWordFirst, WordOrder::LowWordFirst}) {
      const auto w = packFloat(v, order);
      const float back = unpackFloat(w[0], w[1], order);
      EXPECT_EQ(std::memcmp(&back, &v, sizeof v), 0) << v;
    }
  }
  const auto w = packFloat(std::numeric_limits<float>::quiet_NaN(), WordOrder::HighWordFirst);
  EXPECT_TRUE(std::isnan(unpackFloat(w[0], w[1], WordOrder::HighWordFirst)));
}

TEST(modbus_int16, ScalesRoundsAndSaturates) {
  EXPECT_EQ(asInt16(toInt16Register(512.34, 10.0)), 5123);
  EXPECT_EQ(asInt16(toInt16Register(-120.25, 10.0)), -1203);  // round half away from zero
  EXPECT_EQ(asInt16(toInt16Register(-12.5, 100.0)), -1250);
  EXPECT_EQ(toInt16Register(-1250, 1.0), 0xFB1E);  // two's complement on the wire
  EXPECT_EQ(asInt16(toInt16Register(5000.0, 10.0)), 32767);
  EXPECT_EQ(asInt16(toInt16Register(-5000.0, 10.0)), -32768);
  EXPECT_EQ(asInt16(toInt16Register(3276.7, 10.0)), 32767);
  EXPECT_EQ(asInt16(toInt16Register(-3276.8, 10.0)), -32768);
  EXPECT_EQ(asInt16(toInt16Register(std::numeric_limits<double>::infinity(), 10.0)), 32767);
  EXPECT_EQ(toInt16Register(std::numeric_limits<double>::quiet_NaN(), 10.0), 0);
}

TEST(modbus_writable, OnlyControlArea) {
  EXPECT_TRUE(isWritable(0, 1));
  EXPECT_TRUE(isWritable(0, 16));
  EXPECT_TRUE(isWritable(15, 1));
  EXPECT_FALSE(isWritable(15, 2));
  EXPECT_FALSE(isWritable(16, 1));
  EXPECT_FALSE(isWritable(0, 0));
}

TEST_F(modbus_map, StartsIdleAndNotReady) {
  EXPECT_EQ(map.status(), 0);
  EXPECT_FALSE(writeHr(kControl, kControlTrigger).triggerAccepted);
  EXPECT_TRUE(daemon.jobs.empty());
}

TEST_F(modbus_map, FullLevelModeHandshake) {
  map.setReady(true);
  EXPECT_TRUE(bit(kStatusReady));
  writeHr(kJobId, 4);
  EXPECT_TRUE(daemon.jobs.empty());

  // TRIGGER rising: accepted, BUSY + TRIGGER_ACK, ACQ_ID = low 16 bits of the cycle id.
  const auto ev = writeHr(kControl, kControlTrigger);
  EXPECT_TRUE(ev.triggerAccepted);
  EXPECT_EQ(ev.jobId, 4);
  EXPECT_EQ(ev.cycleId, 70000u);
  ASSERT_EQ(daemon.jobs, std::vector<int>{4});
  EXPECT_TRUE(bit(kStatusBusy));
  EXPECT_TRUE(bit(kStatusTriggerAck));
  EXPECT_FALSE(bit(kStatusResultValid));
  EXPECT_EQ(map.input(kAcqId), 70000u & 0xFFFFu);
  EXPECT_EQ(map.input(kCurrentJob), 4);

  // Holding TRIGGER high (another write) does not trigger again.
  writeHr(kJobId, 4);
  EXPECT_EQ(daemon.jobs.size(), 1u);

  // PLC drops TRIGGER: TRIGGER_ACK drops, still BUSY.
  writeHr(kControl, 0);
  EXPECT_FALSE(bit(kStatusTriggerAck));
  EXPECT_TRUE(bit(kStatusBusy));

  map.publishResult(okResult(70000));
  EXPECT_FALSE(bit(kStatusBusy));
  EXPECT_TRUE(bit(kStatusResultValid));
  EXPECT_TRUE(bit(kStatusPartFound));
  EXPECT_FALSE(bit(kStatusError));
  EXPECT_EQ(map.input(kResultId), 70000u & 0xFFFFu);
  EXPECT_EQ(map.input(kNumFound), 2);
  EXPECT_EQ(map.input(kErrorCode), 0);
  EXPECT_FLOAT_EQ(unpackFloat(map.input(kX), map.input(kX + 1), WordOrder::HighWordFirst), 512.3f);
  EXPECT_FLOAT_EQ(unpackFloat(map.input(kY), map.input(kY + 1), WordOrder::HighWordFirst), -120.25f);
  EXPECT_FLOAT_EQ(unpackFloat(map.input(kZ), map.input(kZ + 1), WordOrder::HighWordFirst), 35.0f);
  EXPECT_FLOAT_EQ(unpackFloat(map.input(kR1), map.input(kR1 + 1), WordOrder::HighWordFirst), 1.5f);
  EXPECT_FLOAT_EQ(unpackFloat(map.input(kR2), map.input(kR2 + 1), WordOrder::HighWordFirst), -2.25f);
  EXPECT_FLOAT_EQ(unpackFloat(map.input(kR3), map.input(kR3 + 1), WordOrder::HighWordFirst), -12.5f);
  EXPECT_FLOAT_EQ(unpackFloat(map.input(kScore), map.input(kScore + 1), WordOrder::HighWordFirst), 0.875f);
  EXPECT_EQ(asInt16(map.input(kXInt)), 5123);
  EXPECT_EQ(asInt16(map.input(kYInt)), -1203);
  EXPECT_EQ(asInt16(map.input(kZInt)), 350);
  EXPECT_EQ(asInt16(map.input(kR1Int)), 150);
  EXPECT_EQ(asInt16(map.input(kR2Int)), -225);
  EXPECT_EQ(asInt16(map.input(kR3Int)), -1250);
  expectMirrored();

  // RESULT_ACK rising clears RESULT_VALID and PART_FOUND; results stay readable.
  EXPECT_TRUE(writeHr(kControl, kControlResultAck).resultAcked);
  EXPECT_FALSE(bit(kStatusResultValid));
  EXPECT_FALSE(bit(kStatusPartFound));
  EXPECT_EQ(map.input(kNumFound), 2);
  const auto before = map.status();
  writeHr(kControl, 0);  // dropping RESULT_ACK does nothing
  EXPECT_EQ(map.status(), before);
  EXPECT_TRUE(bit(kStatusReady));

  // Second cycle works and sees the new job.
  writeHr(kJobId, 7);
  EXPECT_TRUE(writeHr(kControl, kControlTrigger).triggerAccepted);
  EXPECT_EQ(daemon.jobs, (std::vector<int>{4, 7}));
  EXPECT_EQ(map.input(kAcqId), 70001u & 0xFFFFu);
  expectMirrored();
}

TEST_F(modbus_map, NewTriggerClearsAnUnackedResult) {
  map.setReady(true);
  writeHr(kControl, kControlTrigger);
  writeHr(kControl, 0);
  map.publishResult(okResult(70000));
  ASSERT_TRUE(bit(kStatusResultValid));
  writeHr(kControl, kControlTrigger);
  EXPECT_FALSE(bit(kStatusResultValid));
  EXPECT_FALSE(bit(kStatusPartFound));
  EXPECT_TRUE(bit(kStatusBusy));
}

TEST_F(modbus_map, TriggerEnableIsNotRequired) {
  map.setReady(true);
  EXPECT_TRUE(writeHr(kControl, kControlTrigger).triggerAccepted);
  writeHr(kControl, 0);
  map.publishResult(okResult(70000));
  EXPECT_TRUE(writeHr(kControl, kControlTrigger | kControlTriggerEnable).triggerAccepted);
}

TEST_F(modbus_map, RequiredTriggerEnableGatesLevelAndCounterTriggers) {
  map.setRequireTriggerEnable(true);
  map.setReady(true);
  // Without b3: ignored, no ACK, no cycle.
  auto ev = writeHr(kControl, kControlTrigger);
  EXPECT_TRUE(ev.ignoredNotEnabled);
  EXPECT_FALSE(ev.triggerAccepted);
  EXPECT_FALSE(bit(kStatusTriggerAck));
  EXPECT_TRUE(daemon.jobs.empty());
  // Raising b3 while TRIGGER is held is not an edge.
  EXPECT_FALSE(writeHr(kControl, kControlTrigger | kControlTriggerEnable).triggerAccepted);
  EXPECT_TRUE(daemon.jobs.empty());
  // Enable + a fresh edge (in the same write as the enable works too).
  writeHr(kControl, 0);
  EXPECT_TRUE(writeHr(kControl, kControlTrigger | kControlTriggerEnable).triggerAccepted);
  writeHr(kControl, kControlTriggerEnable);
  map.publishResult(okResult(70000));
  // Counter mode obeys it as well; the consumed counter value does not fire later.
  writeHr(kControl, 0);
  EXPECT_TRUE(writeHr(kTriggerId, 1).ignoredNotEnabled);
  EXPECT_FALSE(writeHr(kControl, kControlTriggerEnable).triggerAccepted);
  EXPECT_TRUE(writeHr(kTriggerId, 2).triggerAccepted);
  EXPECT_EQ(daemon.jobs.size(), 2u);
  // A trigger without enable while BUSY is ignored, not an overrun.
  writeHr(kControl, 0);
  EXPECT_FALSE(writeHr(kTriggerId, 3).overrun);
  EXPECT_FALSE(bit(kStatusOverrun));
}

TEST_F(modbus_map, ResultDeadlineAnswersAHungCycleAndDropsItsLateResult) {
  using namespace std::chrono_literals;
  map.setResultDeadline(1600ms);
  map.setReady(true);
  const auto t0 = ModbusMap::Clock::now();
  writeHr(kJobId, 4);
  map.holdingRegisters()[kControl] = kControlTrigger;
  ASSERT_TRUE(map.onHoldingWritten(daemon.fn(), t0).triggerAccepted);
  ASSERT_TRUE(map.busyDeadline().has_value());
  EXPECT_EQ(*map.busyDeadline(), t0 + 1600ms);
  EXPECT_EQ(map.expireOverdue(t0 + 1599ms), 0u);
  EXPECT_TRUE(bit(kStatusBusy));
  EXPECT_EQ(map.expireOverdue(t0 + 1600ms), 70000u);
  EXPECT_FALSE(bit(kStatusBusy));
  EXPECT_TRUE(bit(kStatusResultValid));
  EXPECT_TRUE(bit(kStatusError));
  EXPECT_EQ(asInt16(map.input(kErrorCode)), -5);
  EXPECT_EQ(map.input(kResultId), 70000u & 0xFFFFu);
  EXPECT_EQ(map.input(kCurrentJob), 4);
  EXPECT_FALSE(map.busyDeadline().has_value());
  EXPECT_EQ(map.expireOverdue(t0 + 5000ms), 0u);  // once
  expectMirrored();

  // The next cycle starts; the hung cycle's late result must not end it.
  writeHr(kControl, 0);
  writeHr(kControl, kControlResultAck | kControlClearError);
  writeHr(kControl, 0);
  EXPECT_TRUE(writeHr(kControl, kControlTrigger).triggerAccepted);
  EXPECT_FALSE(map.publishResult(okResult(70000)));
  EXPECT_TRUE(bit(kStatusBusy));
  EXPECT_FALSE(bit(kStatusResultValid));
  EXPECT_TRUE(map.publishResult(okResult(70001)));
  EXPECT_EQ(map.input(kResultId), 70001u & 0xFFFFu);
  EXPECT_EQ(map.input(kErrorCode), 0);
}

TEST_F(modbus_map, NoResultDeadlineByDefault) {
  map.setReady(true);
  writeHr(kControl, kControlTrigger);
  EXPECT_FALSE(map.busyDeadline().has_value());
  EXPECT_EQ(map.expireOverdue(ModbusMap::Clock::now() + std::chrono::hours(1)), 0u);
  EXPECT_TRUE(bit(kStatusBusy));
}

TEST_F(modbus_map, TriggerWhileNotReadyIsIgnored) {
  map.setReady(false);
  const auto ev = writeHr(kControl, kControlTrigger);
  EXPECT_TRUE(ev.ignoredNotReady);
  EXPECT_FALSE(ev.triggerAccepted);
  EXPECT_TRUE(daemon.jobs.empty());
  EXPECT_EQ(map.status(), 0);
  // Becoming ready while TRIGGER is held does not fire: an edge is needed.
  map.setReady(true);
  writeHr(kJobId, 1);
  EXPECT_TRUE(daemon.jobs.empty());
  writeHr(kControl, 0);
  EXPECT_TRUE(writeHr(kControl, kControlTrigger).triggerAccepted);
}

TEST_F(modbus_map, OverrunWhileBusyAndClearError) {
  map.setReady(true);
  writeHr(kControl, kControlTrigger);
  writeHr(kControl, 0);
  const auto ev = writeHr(kControl, kControlTrigger);
  EXPECT_TRUE(ev.overrun);
  EXPECT_FALSE(ev.triggerAccepted);
  EXPECT_EQ(daemon.jobs.size(), 1u);  // not accepted
  EXPECT_TRUE(bit(kStatusOverrun));
  EXPECT_FALSE(bit(kStatusTriggerAck));
  EXPECT_EQ(asInt16(map.input(kErrorCode)), -3);
  EXPECT_EQ(map.input(kErrorCode), 0xFFFD);
  EXPECT_EQ(map.input(kAcqId), 70000u & 0xFFFFu);
  expectMirrored();

  // The cycle in flight still completes; OVERRUN latches.
  writeHr(kControl, 0);
  map.publishResult(okResult(70000));
  EXPECT_TRUE(bit(kStatusResultValid));
  EXPECT_TRUE(bit(kStatusOverrun));
  EXPECT_EQ(map.input(kErrorCode), 0);  // the published result's own status

  EXPECT_TRUE(writeHr(kControl, kControlClearError).errorCleared);
  EXPECT_FALSE(bit(kStatusOverrun));
  EXPECT_FALSE(bit(kStatusError));
  EXPECT_EQ(map.input(kErrorCode), 0);
  EXPECT_TRUE(bit(kStatusResultValid));  // CLEAR_ERROR is not RESULT_ACK
  // Holding CLEAR_ERROR does not clear a later error.
  writeHr(kControl, kControlClearError | kControlTrigger);
  writeHr(kControl, kControlClearError);
  writeHr(kControl, kControlClearError | kControlTrigger);
  EXPECT_TRUE(bit(kStatusOverrun));
}

TEST_F(modbus_map, ErrorResultSetsErrorAndNegativeCode) {
  map.setReady(true);
  writeHr(kControl, kControlTrigger);
  writeHr(kControl, 0);
  ModbusResult r;
  r.cycleId = 70000;
  r.status = Status::CameraError;
  map.publishResult(r);
  EXPECT_TRUE(bit(kStatusResultValid));
  EXPECT_TRUE(bit(kStatusError));
  EXPECT_FALSE(bit(kStatusPartFound));
  EXPECT_FALSE(bit(kStatusBusy));
  EXPECT_EQ(asInt16(map.input(kErrorCode)), -4);
  EXPECT_EQ(map.holding(kErrorCode), 0xFFFC);

  // ERROR latches over a following good result until CLEAR_ERROR.
  writeHr(kControl, kControlResultAck);
  writeHr(kControl, kControlTrigger);
  writeHr(kControl, 0);
  map.publishResult(okResult(70001));
  EXPECT_TRUE(bit(kStatusPartFound));
  EXPECT_TRUE(bit(kStatusError));
  EXPECT_EQ(map.input(kErrorCode), 0);  // this cycle's status: OK
  writeHr(kControl, kControlClearError | kControlResultAck);
  EXPECT_FALSE(bit(kStatusError));
  EXPECT_FALSE(bit(kStatusResultValid));
  EXPECT_EQ(map.input(kErrorCode), 0);
}

TEST_F(modbus_map, NoPartFoundIsNotAnError) {
  map.setReady(true);
  writeHr(kControl, kControlTrigger);
  ModbusResult r;
  r.cycleId = 70000;
  r.status = Status::NoPartFound;
  map.publishResult(r);
  EXPECT_TRUE(bit(kStatusResultValid));
  EXPECT_FALSE(bit(kStatusPartFound));
  EXPECT_FALSE(bit(kStatusError));
  EXPECT_EQ(map.input(kErrorCode), 1);  // NO_PART_FOUND
  EXPECT_EQ(map.input(kNumFound), 0);
  // Result published while TRIGGER is still high: TRIGGER_ACK stays until TRIGGER drops.
  EXPECT_TRUE(bit(kStatusTriggerAck));
  writeHr(kControl, 0);
  EXPECT_FALSE(bit(kStatusTriggerAck));
}

// A 3D job's RETRY_NEW_VIEWPOINT (docs/3d.md "Outcomes"): a valid result without a part,
// ERROR_CODE 4, and not an error (nothing is broken: move the camera and trigger again).
TEST_F(modbus_map, RetryNewViewpointIsAResultWithoutAPartAndNotAnError) {
  map.setReady(true);
  writeHr(kControl, kControlTrigger);
  ModbusResult r;
  r.cycleId = 70001;
  r.status = Status::RetryNewViewpoint;
  map.publishResult(r);
  EXPECT_TRUE(bit(kStatusResultValid));
  EXPECT_FALSE(bit(kStatusPartFound));
  EXPECT_FALSE(bit(kStatusError));
  EXPECT_EQ(map.input(kErrorCode), 4);
  EXPECT_EQ(map.input(kNumFound), 0);
}

TEST_F(modbus_map, RefusedTriggerEndsWithErrorResult) {
  map.setReady(true);
  writeHr(kControl, kControlTrigger);
  writeHr(kControl, 0);
  map.publishResult(okResult(70000));
  writeHr(kControl, kControlResultAck);
  writeHr(kControl, 0);

  daemon.refuse = true;
  const auto ev = writeHr(kControl, kControlTrigger);
  EXPECT_TRUE(ev.triggerRefused);
  EXPECT_FALSE(ev.triggerAccepted);
  EXPECT_TRUE(bit(kStatusTriggerAck));
  EXPECT_TRUE(bit(kStatusResultValid));
  EXPECT_TRUE(bit(kStatusError));
  EXPECT_FALSE(bit(kStatusBusy));
  EXPECT_FALSE(bit(kStatusPartFound));
  EXPECT_EQ(asInt16(map.input(kErrorCode)), -3);
  EXPECT_EQ(map.input(kNumFound), 0);
  EXPECT_EQ(map.input(kX), 0);  // no stale pose next to RESULT_VALID
  EXPECT_EQ(map.input(kResultId), 70000u & 0xFFFFu);
  writeHr(kControl, 0);
  EXPECT_FALSE(bit(kStatusTriggerAck));
  // Not busy: the next trigger goes to the daemon again.
  daemon.refuse = false;
  EXPECT_TRUE(writeHr(kControl, kControlTrigger).triggerAccepted);
}

TEST_F(modbus_map, CounterModeTrigger) {
  map.setReady(true);
  writeHr(kJobId, 3);
  const auto ev = writeHr(kTriggerId, 1);
  EXPECT_TRUE(ev.triggerAccepted);
  EXPECT_EQ(daemon.jobs, std::vector<int>{3});
  EXPECT_TRUE(bit(kStatusTriggerAck));
  writeHr(kJobId, 3);  // same counter: nothing
  EXPECT_EQ(daemon.jobs.size(), 1u);
  EXPECT_TRUE(writeHr(kTriggerId, 2).overrun);
  map.publishResult(okResult(70000));
  EXPECT_FALSE(bit(kStatusTriggerAck));  // no level to drop: cleared with the result
  EXPECT_TRUE(bit(kStatusResultValid));
  EXPECT_FALSE(writeHr(kTriggerId, 0).triggerAccepted);  // back to bit mode
  EXPECT_TRUE(writeHr(kTriggerId, 5).triggerAccepted);
}

TEST_F(modbus_map, HeartbeatTogglesOnTick) {
  EXPECT_FALSE(bit(kStatusHeartbeat));
  map.tick();
  EXPECT_TRUE(bit(kStatusHeartbeat));
  map.tick();
  EXPECT_FALSE(bit(kStatusHeartbeat));
  expectMirrored();
}

TEST_F(modbus_map, LowWordFirstMap) {
  ModbusMap low(WordOrder::LowWordFirst);
  ModbusResult r;
  r.x = 123.456;
  r.status = Status::Ok;
  low.publishResult(r);
  EXPECT_EQ(low.input(kX), 0xE979);
  EXPECT_EQ(low.input(kX + 1), 0x42F6);
}

TEST_F(modbus_map, PublishWritesNothingBelowStatus) {
  map.setReady(true);
  writeHr(kJobId, 9);
  map.publishResult(okResult(1));
  EXPECT_EQ(map.holding(kJobId), 9);
  EXPECT_EQ(map.holding(kControl), 0);
  EXPECT_EQ(map.input(kJobId), 0);  // the PLC's area is not mirrored
}

}  // namespace
}  // namespace vgr::protocol
