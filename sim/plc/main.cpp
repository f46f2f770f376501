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
// With --serve it is instead the Modbus SERVER that vgrd's client mode polls (see runServer).
// Exit: 0 when all cycles ran (whatever their status), 1 on bad options, 2 when the server
// cannot be reached (at start, or again within --timeout-ms after the connection dropped).
#include <modbus.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <CLI/CLI.hpp>

#include "core/cli.hpp"
#include <nlohmann/json.hpp>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <algorithm>
#include <array>
#include <functional>
#include <iostream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

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
  // --serve (PLC as Modbus server for vgrd's client mode)
  bool serve = false;
  int sensorAddress = 0;   // discrete input / coil of the laser sensor
  int statusAddress = 100; // first of the 30 holding registers vgrd writes
  int pulseMs = 100;       // sensor high time per cycle, ms (longer than vgrd's debounce)
};

// The 30 words of registers 16..45 (STATUS .. R3 x100), as vgrd serves them or writes
// them to a PLC in client mode: one line per cycle.
using ResultBlock = std::array<std::uint16_t, kR3Int - kStatus + 1>;

void printCycle(int n, const ResultBlock& regs, double latencyMs, bool json) {
  auto reg = [&](std::uint16_t address) { return regs[address - kStatus]; };
  auto f32 = [&](std::uint16_t address) { return unpackFloat(reg(address), reg(address + 1), WordOrder::HighWordFirst); };
  const int code = asInt16(reg(kErrorCode));  // this result's status
  latencyMs = std::round(latencyMs * 1000.0) / 1000.0;
  // Shortest decimal that round-trips the float32, so 512.3f prints as 512.3.
  auto num = [&](std::uint16_t address) { return std::stod(fmt::format("{}", f32(address))); };
  if (json) {
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
    j["label"] = asInt16(reg(kLabel));
    j["confidence"] = num(kConfidence);
    j["confidence_int"] = asInt16(reg(kConfidenceInt));
    j["latency_ms"] = latencyMs;
    std::cout << j.dump() << std::endl;
  } else {
    std::cout << fmt::format(
                     "cycle {}: {} ({}) result_id={} found={} x={:.3f} y={:.3f} z={:.3f} r1={:.3f} r2={:.3f} "
                     "r3={:.3f} score={:.3f} latency={:.3f} ms",
                     n, code, vgr::statusName(static_cast<vgr::Status>(code)), reg(kResultId), asInt16(reg(kNumFound)),
                     f32(kX), f32(kY), f32(kZ), f32(kR1), f32(kR2), f32(kR3), f32(kScore), latencyMs)
              << std::endl;
  }
}

void printTimeout(int n, const std::string& step, bool json) {
  if (json) {
    nlohmann::ordered_json j;
    j["n"] = n;
    j["status"] = "timeout";
    j["step"] = step;
    std::cout << j.dump() << std::endl;
  } else {
    std::cout << fmt::format("cycle {}: timeout in step {}", n, step) << std::endl;
  }
}

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
      printTimeout(n, step, opt_.json);
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

    ResultBlock regs{};
    const auto readDeadline = Clock::now() + std::chrono::milliseconds(opt_.timeoutMs);
    while (!link_.readInput(kStatus, static_cast<int>(regs.size()), regs.data())) {
      if (Clock::now() >= readDeadline) return timeout("read_result");
      std::this_thread::sleep_for(kPollPeriod);
    }
    const std::uint16_t status = regs[0];

    const auto ack = static_cast<std::uint16_t>(kControlResultAck | ((status & kStatusError) != 0 ? kControlClearError : 0));
    if (!writeControl(ack)) return timeout("result_ack");
    if (!waitStatus([](std::uint16_t s) { return (s & kStatusResultValid) == 0; })) return timeout("result_valid_clear");
    if (!writeControl(0)) return timeout("ack_clear");

    const double latencyMs = std::chrono::duration<double, std::milli>(t1 - t0).count();
    printCycle(n, regs, latencyMs, opt_.json);
  }

 private:
  PlcLink& link_;
  const Options& opt_;
};

// --serve: the PLC as a Modbus TCP SERVER for vgrd's client mode (modbus.client). The
// simulated laser sensor is bit --sensor-address of both the discrete inputs and the coils
// (so either `trigger:` setting reads it); vgrd writes the 30-word result block to the
// holding registers from --status-address. Per cycle: wait until the block says READY and
// not BUSY -> raise the sensor for --pulse-ms (latency clock starts at the rising edge) ->
// wait for RESULT_VALID with a RESULT_ID other than the previous one (client mode has no
// RESULT_ACK: RESULT_VALID stays until the next trigger) -> print the block.
class PlcServer {
 public:
  explicit PlcServer(const Options& o) : opt_(o), ctx_(modbus_new_tcp(o.host.c_str(), o.port)) {
    const int bits = std::max(o.sensorAddress + 1, 8);
    map_ = modbus_mapping_new(bits, bits, o.statusAddress + static_cast<int>(ResultBlock{}.size()), 0);
  }
  ~PlcServer() {
    for (const int fd : clients_) ::close(fd);
    if (listenFd_ >= 0) ::close(listenFd_);
    if (map_ != nullptr) modbus_mapping_free(map_);
    if (ctx_ != nullptr) modbus_free(ctx_);
  }
  PlcServer(const PlcServer&) = delete;
  PlcServer& operator=(const PlcServer&) = delete;

  bool listen() {
    if (ctx_ == nullptr || map_ == nullptr) return false;
    listenFd_ = modbus_tcp_listen(ctx_, 4);
    return listenFd_ >= 0;
  }

  // Serves requests until `until` holds (true) or the deadline passes (false), polling
  // the sockets every 1 ms.
  template <class Pred>
  bool serveUntil(Clock::time_point deadline, Pred until) {
    for (;;) {
      if (until()) return true;
      if (Clock::now() >= deadline) return false;
      serveOnce(std::chrono::milliseconds(1));
    }
  }

  void setSensor(bool on) {
    map_->tab_input_bits[opt_.sensorAddress] = on ? 1 : 0;
    map_->tab_bits[opt_.sensorAddress] = on ? 1 : 0;
  }

  ResultBlock block() const {
    ResultBlock b{};
    std::copy_n(map_->tab_registers + opt_.statusAddress, b.size(), b.begin());
    return b;
  }

 private:
  void serveOnce(std::chrono::milliseconds wait) {
    std::vector<pollfd> fds;
    fds.push_back({listenFd_, POLLIN, 0});
    for (const int fd : clients_) fds.push_back({fd, POLLIN, 0});
    if (::poll(fds.data(), fds.size(), static_cast<int>(wait.count())) <= 0) return;
    if ((fds[0].revents & POLLIN) != 0) {
      const int fd = ::accept(listenFd_, nullptr, nullptr);
      if (fd >= 0) {
        clients_.push_back(fd);
        vgr::log::info("sim", "client connected ({} connected)", clients_.size());
      }
    }
    for (std::size_t i = 1; i < fds.size(); ++i) {
      if (fds[i].revents == 0) continue;
      std::array<std::uint8_t, MODBUS_TCP_MAX_ADU_LENGTH> query{};
      modbus_set_socket(ctx_, fds[i].fd);
      const int rc = modbus_receive(ctx_, query.data());
      if (rc > 0) {
        modbus_reply(ctx_, query.data(), rc, map_);
      } else if (rc < 0) {
        ::close(fds[i].fd);
        std::erase(clients_, fds[i].fd);
        vgr::log::info("sim", "client disconnected ({} connected)", clients_.size());
      }
    }
  }

  const Options& opt_;
  modbus_t* ctx_;
  modbus_mapping_t* map_ = nullptr;
  int listenFd_ = -1;
  std::vector<int> clients_;
};

int runServer(const Options& o) {
  PlcServer plc(o);
  if (!plc.listen()) {
    std::cerr << "vgr-sim-plc: cannot listen on " << o.host << ":" << o.port << ": " << modbus_strerror(errno) << "\n";
    return 2;
  }
  std::cout << nlohmann::json{{"listening", o.port}}.dump() << std::endl;
  const auto step = std::chrono::milliseconds(o.timeoutMs);
  auto blockReady = [&] {
    const auto b = plc.block();
    return (b[0] & kStatusReady) != 0 && (b[0] & kStatusBusy) == 0;
  };
  std::optional<std::uint16_t> lastResultId;
  for (int n = 1; n <= o.cycles; ++n) {
    if (!plc.serveUntil(Clock::now() + step, blockReady)) {
      printTimeout(n, "ready", o.json);
      continue;
    }
    if (!lastResultId) lastResultId = plc.block()[kResultId - kStatus];
    const auto t0 = Clock::now();
    plc.setSensor(true);
    plc.serveUntil(t0 + std::chrono::milliseconds(o.pulseMs), [] { return false; });
    plc.setSensor(false);
    auto fresh = [&] {
      const auto b = plc.block();
      return (b[0] & kStatusResultValid) != 0 && b[kResultId - kStatus] != *lastResultId;
    };
    if (!plc.serveUntil(t0 + step, fresh)) {
      printTimeout(n, "result_valid", o.json);
      continue;
    }
    const auto t1 = Clock::now();
    const auto b = plc.block();
    lastResultId = b[kResultId - kStatus];
    // Latency: the sensor's rising edge -> the new block seen here (includes vgrd's poll
    // period and debounce, as a real PLC would measure it).
    printCycle(n, b, std::chrono::duration<double, std::milli>(t1 - t0).count(), o.json);
    if (n < o.cycles && o.intervalMs > 0) plc.serveUntil(Clock::now() + std::chrono::milliseconds(o.intervalMs), [] { return false; });
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"vgr-sim-plc: a PLC driving vgrd's Modbus TCP trigger/result handshake"};
  vgr::cli::showDefaults(app);
  app.add_option("--host", o.host, "Modbus server address");
  app.add_option("--port", o.port, "Modbus server port")->check(CLI::Range(1, 65535));
  app.add_option("--cycles", o.cycles, "number of trigger cycles")->check(CLI::NonNegativeNumber);
  app.add_option("--job", o.job, "job id written to HR1")->check(CLI::Range(-32768, 32767));
  app.add_option("--interval-ms", o.intervalMs, "pause between cycles, ms")->check(CLI::NonNegativeNumber);
  app.add_option("--timeout-ms", o.timeoutMs, "timeout of each handshake step, ms")->check(CLI::PositiveNumber);
  app.add_flag("--json", o.json, "one JSON object per cycle");
  app.add_flag("--serve", o.serve, "be the Modbus server of vgrd's client mode: pulse a sensor bit, read the block vgrd writes");
  app.add_option("--sensor-address", o.sensorAddress, "--serve: discrete input and coil of the sensor (0-based)")
      ->check(CLI::Range(0, 65535));
  app.add_option("--status-address", o.statusAddress, "--serve: first of the 30 holding registers vgrd writes")
      ->check(CLI::Range(0, 65506));
  app.add_option("--pulse-ms", o.pulseMs, "--serve: sensor high time per cycle, ms")->check(CLI::Range(1, 60000));
  if (const auto rc = vgr::cli::parse(app, argc, argv)) return *rc;
  if (o.serve) return runServer(o);

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
