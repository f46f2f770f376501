// vgr-sim-plc: a PLC that drives vgrd's Modbus TCP level-mode handshake (PROTOCOLS.md,
// "PLC side: Modbus TCP") with libmodbus as the CLIENT, and prints one line per cycle.
//
// Per cycle: wait READY and not BUSY -> write CONTROL = TRIGGER (latency clock starts) ->
// wait TRIGGER_ACK -> write CONTROL = 0 -> wait RESULT_VALID (clock stops) -> read 16..45
// in one FC04 read -> write CONTROL = RESULT_ACK (| CLEAR_ERROR when ERROR is set, as a
// PLC acknowledges a fault, so every cycle reports its own status) -> wait RESULT_VALID
// cleared -> write CONTROL = 0. Status polled every 1 ms. A step that exceeds --timeout-ms
// prints a timeout line, clears CONTROL and the next cycle starts.
// The reported status: ERROR_CODE, the status of the result being read (0 OK,
// 1 NO_PART_FOUND, negative errors).
// Exit: 0 when all cycles ran (whatever their status), 1 on bad options, 2 when the server
// cannot be reached (at start, or again within --timeout-ms after the connection dropped).
#include <modbus.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <array>
#include <functional>
#include <iostream>
#include <optional>
#include <string>
#include <thread>

#include "core/log.hpp"
#include "core/status.hpp"
#include "protocol/modbus_map.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using namespace vgr::protocol::modbus;
using vgr::protocol::WordOrder;

constexpr auto kPollPeriod = std::chrono::milliseconds(1);
constexpr auto kReconnectPeriod = std::chrono::milliseconds(100);

struct Options {
  std::string host = "127.0.0.1";
  int port = 1502;
  int cycles = 1;
  int job = 0;
  int intervalMs = 0;    // pause between cycles, ms
  int timeoutMs = 5000;  // per handshake step, ms
  bool json = false;
};

// libmodbus client that reconnects on its own: any failed request closes the connection
// (a timed-out reply could otherwise arrive late and desynchronise transaction ids), and
// the next request reconnects, at most every kReconnectPeriod.
class PlcLink {
 public:
  PlcLink(const std::string& host, int port, std::chrono::milliseconds responseTimeout)
      : ctx_(modbus_new_tcp(host.c_str(), port)), host_(host), port_(port) {
    if (ctx_ != nullptr) {
      const auto us = std::min<long long>(responseTimeout.count() * 1000, 1'000'000);
      modbus_set_response_timeout(ctx_, 0, static_cast<std::uint32_t>(us));
    }
  }
  ~PlcLink() {
    if (ctx_ == nullptr) return;
    if (connected_) modbus_close(ctx_);
    modbus_free(ctx_);
  }
  PlcLink(const PlcLink&) = delete;
  PlcLink& operator=(const PlcLink&) = delete;

  bool valid() const { return ctx_ != nullptr; }

  bool ensureConnected() {
    if (connected_) return true;
    if (ctx_ == nullptr) return false;
    const auto now = Clock::now();
    if (now < nextAttempt_) return false;
    nextAttempt_ = now + kReconnectPeriod;
    if (modbus_connect(ctx_) != 0) {
      lastError_ = modbus_strerror(errno);
      return false;
    }
    connected_ = true;
    if (everConnected_) vgr::log::info("sim", "reconnected to {}:{}", host_, port_);
    everConnected_ = true;
    return true;
  }

  // Keeps trying until the deadline; false when still not connected.
  bool connectUntil(Clock::time_point deadline) {
    while (!ensureConnected()) {
      if (Clock::now() >= deadline) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return true;
  }

  bool readInput(std::uint16_t address, int count, std::uint16_t* out) {
    if (!ensureConnected()) return false;
    if (modbus_read_input_registers(ctx_, address, count, out) == count) return true;
    dropConnection();
    return false;
  }

  bool writeRegister(std::uint16_t address, std::uint16_t value) {
    if (!ensureConnected()) return false;
    if (modbus_write_register(ctx_, address, value) == 1) return true;
    dropConnection();
    return false;
  }

  const std::string& lastError() const { return lastError_; }

 private:
  void dropConnection() {
    lastError_ = modbus_strerror(errno);
    vgr::log::warn("sim", "connection to {}:{} lost: {}", host_, port_, lastError_);
    modbus_close(ctx_);
    connected_ = false;
  }

  modbus_t* ctx_;
  std::string host_;
  int port_;
  bool connected_ = false;
  bool everConnected_ = false;
  Clock::time_point nextAttempt_{};
  std::string lastError_;
};

class Plc {
 public:
  Plc(PlcLink& link, const Options& o) : link_(link), opt_(o) {}

  // Polls STATUS every 1 ms until pred holds; the status word, or nullopt on timeout.
  std::optional<std::uint16_t> waitStatus(const std::function<bool(std::uint16_t)>& pred) {
    const auto deadline = Clock::now() + std::chrono::milliseconds(opt_.timeoutMs);
    for (;;) {
      std::uint16_t s = 0;
      if (link_.readInput(kStatus, 1, &s) && pred(s)) return s;
      if (Clock::now() >= deadline) return std::nullopt;
      std::this_thread::sleep_for(kPollPeriod);
    }
  }

  // Writes CONTROL, retrying (through reconnects) until the step deadline.
  bool writeControl(std::uint16_t value) { return writeRegister(kControl, value); }

  bool writeRegister(std::uint16_t address, std::uint16_t value) {
    const auto deadline = Clock::now() + std::chrono::milliseconds(opt_.timeoutMs);
    for (;;) {
      if (link_.writeRegister(address, value)) return true;
      if (Clock::now() >= deadline) return false;
      std::this_thread::sleep_for(kPollPeriod);
    }
  }

  void runCycle(int n) {
    std::string step;
    auto timeout = [&](const char* name) {
      step = name;
      printTimeout(n, step);
      link_.writeRegister(kControl, 0);  // best effort: the next cycle starts from a clean CONTROL
    };
    if (!waitStatus([](std::uint16_t s) { return (s & kStatusReady) != 0 && (s & kStatusBusy) == 0; })) {
      return timeout("ready");
    }
    // JOB_ID before every trigger: the server may have restarted with a zeroed map.
    if (!writeRegister(kJobId, static_cast<std::uint16_t>(static_cast<std::int16_t>(opt_.job)))) return timeout("job");
    const auto t0 = Clock::now();
    if (!writeControl(kControlTrigger)) return timeout("trigger");
    if (!waitStatus([](std::uint16_t s) { return (s & kStatusTriggerAck) != 0; })) return timeout("trigger_ack");
    if (!writeControl(0)) return timeout("trigger_clear");
    const auto valid = waitStatus([](std::uint16_t s) { return (s & kStatusResultValid) != 0; });
    if (!valid) return timeout("result_valid");
    const auto t1 = Clock::now();

    std::array<std::uint16_t, kR3Int - kStatus + 1> regs{};
    const auto readDeadline = Clock::now() + std::chrono::milliseconds(opt_.timeoutMs);
    while (!link_.readInput(kStatus, static_cast<int>(regs.size()), regs.data())) {
      if (Clock::now() >= readDeadline) return timeout("read_result");
      std::this_thread::sleep_for(kPollPeriod);
    }
    auto reg = [&](std::uint16_t address) { return regs[address - kStatus]; };
    auto f32 = [&](std::uint16_t address) { return unpackFloat(reg(address), reg(address + 1), WordOrder::HighWordFirst); };
    const std::uint16_t status = reg(kStatus);
    const int code = asInt16(reg(kErrorCode));  // this result's status

    const auto ack = static_cast<std::uint16_t>(kControlResultAck | ((status & kStatusError) != 0 ? kControlClearError : 0));
    if (!writeControl(ack)) return timeout("result_ack");
    if (!waitStatus([](std::uint16_t s) { return (s & kStatusResultValid) == 0; })) return timeout("result_valid_clear");
    if (!writeControl(0)) return timeout("ack_clear");

    const double latencyMs = std::round(std::chrono::duration<double, std::milli>(t1 - t0).count() * 1000.0) / 1000.0;
    // Shortest decimal that round-trips the float32, so 512.3f prints as 512.3.
    auto num = [&](std::uint16_t address) { return std::stod(fmt::format("{}", f32(address))); };
    if (opt_.json) {
      nlohmann::ordered_json j;
      j["n"] = n;
      j["result_id"] = reg(kResultId);
      j["status"] = code;
      j["num_found"] = asInt16(reg(kNumFound));
      j["x"] = num(kX);
      j["y"] = num(kY);
      j["z"] = num(kZ);
      j["r1"] = num(kR1);
      j["r2"] = num(kR2);
      j["r3"] = num(kR3);
      j["score"] = num(kScore);
      j["latency_ms"] = latencyMs;
      std::cout << j.dump() << std::endl;
    } else {
      std::cout << fmt::format(
                       "cycle {}: {} ({}) result_id={} found={} x={:.3f} y={:.3f} z={:.3f} r1={:.3f} r2={:.3f} "
                       "r3={:.3f} score={:.3f} latency={:.3f} ms",
                       n, code, vgr::statusName(static_cast<vgr::Status>(code)), reg(kResultId),
                       asInt16(reg(kNumFound)), f32(kX), f32(kY), f32(kZ), f32(kR1), f32(kR2), f32(kR3), f32(kScore),
                       latencyMs)
                << std::endl;
    }
  }

 private:
  void printTimeout(int n, const std::string& step) const {
    if (opt_.json) {
      nlohmann::ordered_json j;
      j["n"] = n;
      j["status"] = "timeout";
      j["step"] = step;
      std::cout << j.dump() << std::endl;
    } else {
      std::cout << fmt::format("cycle {}: timeout in step {}", n, step) << std::endl;
    }
  }

  PlcLink& link_;
  const Options& opt_;
};

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"vgr-sim-plc: a PLC driving vgrd's Modbus TCP trigger/result handshake"};
  app.add_option("--host", o.host, "Modbus server address")->capture_default_str();
  app.add_option("--port", o.port, "Modbus server port")->capture_default_str()->check(CLI::Range(1, 65535));
  app.add_option("--cycles", o.cycles, "number of trigger cycles")->capture_default_str()->check(CLI::NonNegativeNumber);
  app.add_option("--job", o.job, "job id written to HR1")->capture_default_str()->check(CLI::Range(-32768, 32767));
  app.add_option("--interval-ms", o.intervalMs, "pause between cycles, ms")->capture_default_str()->check(CLI::NonNegativeNumber);
  app.add_option("--timeout-ms", o.timeoutMs, "timeout of each handshake step, ms")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_flag("--json", o.json, "one JSON object per cycle");
  CLI11_PARSE(app, argc, argv);

  PlcLink link(o.host, o.port, std::chrono::milliseconds(o.timeoutMs));
  if (!link.valid()) {
    std::cerr << "vgr-sim-plc: cannot create a Modbus context for " << o.host << ":" << o.port << "\n";
    return 2;
  }
  const auto connectTimeout = std::chrono::milliseconds(o.timeoutMs);
  if (!link.ensureConnected()) {
    std::cerr << "vgr-sim-plc: cannot connect to " << o.host << ":" << o.port << ": " << link.lastError() << "\n";
    return 2;
  }
  Plc plc(link, o);
  // Like a PLC after power-up: fault reset, then a clean CONTROL.
  if (!link.writeRegister(kControl, kControlClearError) || !link.writeRegister(kControl, 0)) {
    std::cerr << "vgr-sim-plc: cannot write CONTROL on " << o.host << ":" << o.port << ": " << link.lastError() << "\n";
    return 2;
  }
  for (int n = 1; n <= o.cycles; ++n) {
    if (!link.connectUntil(Clock::now() + connectTimeout)) {
      std::cerr << "vgr-sim-plc: connection to " << o.host << ":" << o.port << " lost: " << link.lastError() << "\n";
      return 2;
    }
    plc.runCycle(n);
    if (n < o.cycles && o.intervalMs > 0) std::this_thread::sleep_for(std::chrono::milliseconds(o.intervalMs));
  }
  return 0;
}
