#include "protocol/modbus_map.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

#include "core/cycle.hpp"
#include "core/pose.hpp"

namespace vgr::protocol {

ModbusResult modbusResultFrom(const CycleResult& r) {
  ModbusResult m;
  m.cycleId = r.cycleId;
  m.status = r.status;
  m.jobId = r.jobId;
  m.numFound = static_cast<int>(r.parts.size());
  if (r.status == Status::Ok && !r.parts.empty()) {
    const auto& p = r.parts.front();
    const auto e = toEulerZyxDeg(p.pose);
    m.x = p.pose.x + 0.0;  // + 0.0: -0.0 -> 0.0
    m.y = p.pose.y + 0.0;
    m.z = p.pose.z + 0.0;
    m.r1 = e.rx + 0.0;
    m.r2 = e.ry + 0.0;
    m.r3 = e.rz + 0.0;
    m.score = p.score;
    m.label = p.label;
    m.confidence = p.confidence;
  }
  return m;
}

namespace modbus {

std::array<std::uint16_t, 2> packFloat(float value, WordOrder order) {
  const auto bits = std::bit_cast<std::uint32_t>(value);
  const auto high = static_cast<std::uint16_t>(bits >> 16);
  const auto low = static_cast<std::uint16_t>(bits & 0xFFFFu);
  if (order == WordOrder::HighWordFirst) return {high, low};
  return {low, high};
}

float unpackFloat(std::uint16_t first, std::uint16_t second, WordOrder order) {
  const std::uint16_t high = order == WordOrder::HighWordFirst ? first : second;
  const std::uint16_t low = order == WordOrder::HighWordFirst ? second : first;
  return std::bit_cast<float>((static_cast<std::uint32_t>(high) << 16) | low);
}

std::uint16_t toInt16Register(double value, double scale) {
  const double scaled = value * scale;
  if (std::isnan(scaled)) return 0;
  const double rounded = std::round(scaled);
  std::int16_t v;
  if (rounded >= 32767.0) {
    v = 32767;
  } else if (rounded <= -32768.0) {
    v = -32768;
  } else {
    v = static_cast<std::int16_t>(rounded);
  }
  return static_cast<std::uint16_t>(v);
}

}  // namespace modbus

using namespace modbus;

ModbusMap::ModbusMap(WordOrder floatOrder) : floatOrder_(floatOrder) {}

void ModbusMap::set(std::uint16_t address, std::uint16_t value) {
  holding_.at(address) = value;
  input_.at(address) = value;
}

void ModbusMap::setStatusBits(std::uint16_t bits, bool on) {
  const std::uint16_t s = status();
  set(kStatus, static_cast<std::uint16_t>(on ? (s | bits) : (s & ~bits)));
}

void ModbusMap::writeFloat(std::uint16_t address, double value) {
  const auto words = packFloat(static_cast<float>(value), floatOrder_);
  set(address, words[0]);
  set(static_cast<std::uint16_t>(address + 1), words[1]);
}

void ModbusMap::setReady(bool ready) { setStatusBits(kStatusReady, ready); }

void ModbusMap::tick() { setStatusBits(kStatusHeartbeat, (status() & kStatusHeartbeat) == 0); }

void ModbusMap::handleTriggerRequest(const TriggerFn& onTrigger, bool levelMode, bool enabled,
                                     Clock::time_point now, HandshakeEvents& ev) {
  if (!enabled) {
    ev.ignoredNotEnabled = true;
    return;
  }
  if (busy()) {
    ev.overrun = true;
    setStatusBits(kStatusOverrun, true);
    set(kErrorCode, toInt16Register(statusCode(Status::BusyOverrun)));
    return;
  }
  if (!ready()) {
    ev.ignoredNotReady = true;
    return;
  }
  const int jobId = asInt16(holding_[kJobId]);
  ev.jobId = jobId;
  setStatusBits(kStatusResultValid | kStatusPartFound, false);
  const std::uint32_t cycleId = onTrigger ? onTrigger(jobId) : 0;
  if (cycleId == 0) {
    // Refused: answer at once so the PLC never waits blindly.
    // In level mode TRIGGER_ACK still follows TRIGGER so the PLC's sequence runs through.
    ev.triggerRefused = true;
    if (levelMode) setStatusBits(kStatusTriggerAck, true);
    ModbusResult refused;
    refused.status = Status::BusyOverrun;
    refused.jobId = jobId;
    refused.cycleId = input_[kResultId];  // RESULT_ID unchanged: no cycle was started
    write(refused);
    return;
  }
  ev.triggerAccepted = true;
  ev.cycleId = cycleId;
  set(kAcqId, static_cast<std::uint16_t>(cycleId & 0xFFFFu));
  set(kCurrentJob, toInt16Register(jobId));
  setStatusBits(kStatusBusy | kStatusTriggerAck, true);
  counterModeAck_ = !levelMode;
  inFlight_ = cycleId;
  inFlightSince_ = now;
}

HandshakeEvents ModbusMap::onHoldingWritten(const TriggerFn& onTrigger, Clock::time_point now) {
  HandshakeEvents ev;
  const std::uint16_t control = holding_[kControl];
  const auto rising = static_cast<std::uint16_t>(control & ~lastControl_);
  const auto falling = static_cast<std::uint16_t>(~control & lastControl_);
  lastControl_ = control;
  const std::uint16_t triggerId = holding_[kTriggerId];
  const bool counterTrigger = triggerId != lastTriggerId_ && triggerId != 0;
  lastTriggerId_ = triggerId;

  // CLEAR_ERROR first, so "clear + trigger" in one write starts a clean cycle.
  if ((rising & kControlClearError) != 0) {
    ev.errorCleared = true;
    setStatusBits(kStatusError | kStatusOverrun, false);
    set(kErrorCode, 0);
  }
  if ((rising & kControlResultAck) != 0) {
    ev.resultAcked = true;
    setStatusBits(kStatusResultValid | kStatusPartFound, false);
  }
  if ((falling & kControlTrigger) != 0 && !counterModeAck_) {
    setStatusBits(kStatusTriggerAck, false);
  }
  const bool enabled = !requireTriggerEnable_ || (control & kControlTriggerEnable) != 0;
  if ((rising & kControlTrigger) != 0) {
    handleTriggerRequest(onTrigger, true, enabled, now, ev);
  } else if (counterTrigger) {
    handleTriggerRequest(onTrigger, false, enabled, now, ev);
  }
  return ev;
}

bool ModbusMap::publishResult(const ModbusResult& r) {
  if (r.cycleId != 0 && std::find(expired_.begin(), expired_.end(), r.cycleId) != expired_.end()) return false;
  write(r);
  return true;
}

std::optional<ModbusMap::Clock::time_point> ModbusMap::busyDeadline() const {
  if (resultDeadline_.count() <= 0 || !busy() || inFlight_ == 0) return std::nullopt;
  return inFlightSince_ + resultDeadline_;
}

std::uint32_t ModbusMap::expireOverdue(Clock::time_point now) {
  const auto due = busyDeadline();
  if (!due || now < *due) return 0;
  const std::uint32_t id = inFlight_;
  ModbusResult r;
  r.cycleId = id;
  r.status = Status::ProcessingTimeout;
  r.jobId = asInt16(input_[kCurrentJob]);
  write(r);
  expired_[expiredNext_] = id;
  expiredNext_ = (expiredNext_ + 1) % expired_.size();
  return id;
}

void ModbusMap::write(const ModbusResult& r) {
  const int code = statusCode(r.status);
  set(kNumFound, toInt16Register(r.numFound));
  set(kCurrentJob, toInt16Register(r.jobId));
  set(kLabel, toInt16Register(r.label));
  set(kConfidenceInt, toInt16Register(r.confidence, 1000.0));
  writeFloat(kX, r.x);
  writeFloat(kY, r.y);
  writeFloat(kZ, r.z);
  writeFloat(kR1, r.r1);
  writeFloat(kR2, r.r2);
  writeFloat(kR3, r.r3);
  writeFloat(kScore, r.score);
  writeFloat(kConfidence, r.confidence);
  set(kXInt, toInt16Register(r.x, 10.0));
  set(kYInt, toInt16Register(r.y, 10.0));
  set(kZInt, toInt16Register(r.z, 10.0));
  set(kR1Int, toInt16Register(r.r1, 100.0));
  set(kR2Int, toInt16Register(r.r2, 100.0));
  set(kR3Int, toInt16Register(r.r3, 100.0));
  // ERROR_CODE is the status of the result being published (0 OK, 1 NO_PART_FOUND,
  // negative errors); the ERROR bit latches any error until CLEAR_ERROR.
  set(kErrorCode, toInt16Register(code));
  if (code < 0) setStatusBits(kStatusError, true);
  set(kResultId, static_cast<std::uint16_t>(r.cycleId & 0xFFFFu));
  setStatusBits(kStatusPartFound, r.status == Status::Ok);
  setStatusBits(kStatusResultValid, true);
  setStatusBits(kStatusBusy, false);
  if (counterModeAck_) {
    counterModeAck_ = false;
    setStatusBits(kStatusTriggerAck, false);
  }
  inFlight_ = 0;
}

}  // namespace vgr::protocol
