#include "protocol/modbus_client_trigger.hpp"

#include <arpa/inet.h>
#include <modbus.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/log.hpp"

namespace vgr::protocol {

using namespace modbus;

std::optional<bool> Debouncer::sample(bool raw, Clock::time_point now) {
  if (raw == level_) {
    candidate_ = level_;
    return std::nullopt;
  }
  if (raw != candidate_) {  // a new level starts (or the input bounced back)
    candidate_ = raw;
    candidateSince_ = now;
  }
  if (now - candidateSince_ < hold_) return std::nullopt;
  level_ = raw;
  return level_;
}

namespace {
constexpr auto kHeartbeatPeriod = std::chrono::seconds(1);
thread_local const void* tHandlerOwner = nullptr;
}  // namespace

struct ModbusClientTrigger::Impl {
  using Clock = std::chrono::steady_clock;

  Impl(ModbusClientOptions o, TriggerHandler h)
      : options(std::move(o)), onTrigger(std::move(h)), map(options.floatOrder), debouncer(options.debounce) {
    map.setResultDeadline(options.resultDeadline);
  }

  ModbusClientOptions options;
  TriggerHandler onTrigger;

  mutable std::mutex mutex;  // guards map, deferred, counters, wake, quit
  std::condition_variable cv;
  ModbusMap map;
  std::vector<ModbusResult> deferred;
  Counters counters;
  bool wake = false;
  bool quit = false;
  std::atomic<bool> isConnected{false};

  // Client thread only.
  Debouncer debouncer;
  modbus_t* ctx = nullptr;
  std::optional<std::array<std::uint16_t, kClientBlockWords>> written;  // last block the PLC has
  std::thread thread;
  Heartbeat heartbeat;  // beaten by the client thread at every turn of its loop

  void run();
  bool connect();
  void disconnect(const char* what);
  std::uint32_t callHandler(int jobId);
  // Waits until `until`, a publishResult() or stop(); false when stopping.
  bool waitUntil(Clock::time_point until) {
    std::unique_lock lock(mutex);
    cv.wait_until(lock, until, [&] { return quit || wake; });
    wake = false;
    return !quit;
  }
};

std::uint32_t ModbusClientTrigger::Impl::callHandler(int jobId) {
  if (!onTrigger) return 0;
  tHandlerOwner = this;
  std::uint32_t id = 0;
  try {
    id = onTrigger(jobId);
  } catch (const std::exception& e) {
    log::error("modbus", "client mode: trigger handler threw for job {}: {}; trigger refused", jobId, e.what());
  } catch (...) {
    log::error("modbus", "client mode: trigger handler threw for job {}; trigger refused", jobId);
  }
  tHandlerOwner = nullptr;
  return id;
}

bool ModbusClientTrigger::Impl::connect() {
  ctx = modbus_new_tcp(options.host.c_str(), options.port);
  if (ctx == nullptr) return false;
  modbus_set_slave(ctx, options.unitId);
  modbus_set_response_timeout(ctx, 0, 500'000);
  if (modbus_connect(ctx) != 0) {
    const int err = errno;
    modbus_free(ctx);
    ctx = nullptr;
    log::debug("modbus", "client mode: connect to {}:{} failed: {}", options.host, options.port, modbus_strerror(err));
    return false;
  }
  written.reset();  // the PLC may have restarted: write the block again
  isConnected = true;
  {
    std::lock_guard lock(mutex);
    counters.connects++;
  }
  log::info("modbus", "client mode: connected to PLC {}:{} (unit {})", options.host, options.port, options.unitId);
  return true;
}

void ModbusClientTrigger::Impl::disconnect(const char* what) {
  if (ctx == nullptr) return;
  log::warn("modbus", "client mode: {} on PLC {}:{} failed: {}; reconnecting", what, options.host, options.port,
            modbus_strerror(errno));
  modbus_close(ctx);
  modbus_free(ctx);
  ctx = nullptr;
  isConnected = false;
  std::lock_guard lock(mutex);
  counters.ioErrors++;
}

void ModbusClientTrigger::Impl::run() {
  auto nextBeat = Clock::now() + kHeartbeatPeriod;
  while (true) {
    heartbeat.beat();
    if (ctx == nullptr && !connect()) {
      if (!waitUntil(Clock::now() + options.reconnect)) break;
      continue;
    }
    const auto tick = Clock::now();
    std::uint8_t bit = 0;
    const int rc = options.input == ModbusClientOptions::Input::Coil
                       ? modbus_read_bits(ctx, options.inputAddress, 1, &bit)
                       : modbus_read_input_bits(ctx, options.inputAddress, 1, &bit);
    if (rc != 1) {
      disconnect(options.input == ModbusClientOptions::Input::Coil ? "reading the trigger coil" : "reading the trigger input");
      continue;
    }
    const auto now = Clock::now();
    std::array<std::uint16_t, kClientBlockWords> block{};
    {
      std::lock_guard lock(mutex);
      if (const auto edge = debouncer.sample(bit != 0, now)) {
        map.holdingRegisters()[kControl] = *edge ? kControlTrigger : 0;
        const HandshakeEvents ev = map.onHoldingWritten([this](int job) { return callHandler(job); }, now);
        for (const auto& r : deferred) map.publishResult(r);
        deferred.clear();
        if (*edge) counters.triggers++;
        if (ev.triggerAccepted) counters.accepted++;
        if (ev.overrun) counters.overruns++;
        if (ev.ignoredNotReady) log::debug("modbus", "client mode: trigger while not ready ignored");
      }
      if (now >= nextBeat) {
        map.tick();
        nextBeat += kHeartbeatPeriod;
        if (nextBeat < now) nextBeat = now + kHeartbeatPeriod;
      }
      if (const auto id = map.expireOverdue(now); id != 0) {
        log::warn("modbus", "client mode: cycle {} not published within {} ms: PROCESSING_TIMEOUT", id,
                  options.resultDeadline.count());
      }
      const auto input = map.inputRegisters();
      std::copy_n(input.begin() + kStatus, kClientBlockWords, block.begin());
    }
    if (!written || *written != block) {
      if (modbus_write_registers(ctx, options.statusAddress, kClientBlockWords, block.data()) != kClientBlockWords) {
        disconnect("writing the status block");
        continue;
      }
      written = block;
      std::lock_guard lock(mutex);
      counters.blockWrites++;
    }
    if (!waitUntil(tick + options.poll)) break;
  }
  if (ctx != nullptr) {
    modbus_close(ctx);
    modbus_free(ctx);
    ctx = nullptr;
  }
  isConnected = false;
}

ModbusClientTrigger::ModbusClientTrigger(ModbusClientOptions options, TriggerHandler onTrigger)
    : impl_(std::make_unique<Impl>(std::move(options), std::move(onTrigger))) {}

ModbusClientTrigger::~ModbusClientTrigger() { stop(); }

Result<void> ModbusClientTrigger::start() {
  Impl& s = *impl_;
  if (s.thread.joinable()) return fail(Status::Internal, "modbus client: already started");
  in_addr addr{};
  if (inet_pton(AF_INET, s.options.host.c_str(), &addr) != 1) {
    return fail(Status::BadArgument, "modbus client: PLC address '" + s.options.host + "' is not an IPv4 address");
  }
  if (s.options.statusAddress + kClientBlockWords > 65536) {
    return fail(Status::BadArgument, "modbus client: status block at " + std::to_string(s.options.statusAddress) +
                                         " does not fit below register 65536");
  }
  {
    std::lock_guard lock(s.mutex);
    s.quit = false;
  }
  s.thread = std::thread([&s] {
    nameThisThread("vgr-modbus-cli");
    s.run();
  });
  log::info("modbus", "client mode: polling {} {} on {}:{} every {} ms (debounce {} ms), status block at HR {}",
            s.options.input == ModbusClientOptions::Input::Coil ? "coil" : "discrete input", s.options.inputAddress,
            s.options.host, s.options.port, s.options.poll.count(), s.options.debounce.count(), s.options.statusAddress);
  return {};
}

void ModbusClientTrigger::stop() {
  Impl& s = *impl_;
  if (!s.thread.joinable()) return;
  {
    std::lock_guard lock(s.mutex);
    s.quit = true;
  }
  s.cv.notify_all();
  s.thread.join();
}

void ModbusClientTrigger::setReady(bool ready) {
  if (tHandlerOwner == impl_.get()) {
    impl_->map.setReady(ready);
    return;
  }
  std::lock_guard lock(impl_->mutex);
  impl_->map.setReady(ready);
  impl_->wake = true;
  impl_->cv.notify_all();
}

void ModbusClientTrigger::publishResult(const ModbusResult& r) {
  if (tHandlerOwner == impl_.get()) {
    impl_->deferred.push_back(r);
    return;
  }
  std::lock_guard lock(impl_->mutex);
  if (!impl_->map.publishResult(r)) log::warn("modbus", "client mode: late result of cycle {} dropped", r.cycleId);
  impl_->wake = true;  // write it to the PLC now, not at the next poll
  impl_->cv.notify_all();
}

ModbusClientTrigger::Counters ModbusClientTrigger::counters() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->counters;
}

bool ModbusClientTrigger::connected() const { return impl_->isConnected.load(); }

const Heartbeat& ModbusClientTrigger::heartbeat() const { return impl_->heartbeat; }

std::chrono::milliseconds ModbusClientTrigger::stallLimit() const {
  return impl_->options.reconnect + std::chrono::milliseconds(3000);
}

std::string ModbusClientTrigger::describe() const {
  return "Modbus client of " + impl_->options.host + ":" + std::to_string(impl_->options.port);
}

}  // namespace vgr::protocol
