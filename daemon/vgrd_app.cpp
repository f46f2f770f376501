#include "daemon/vgrd_app.hpp"

#include <systemd/sd-daemon.h>

#include <cmath>
#include <cstdlib>
#include <set>
#include <vector>

#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>

#include "core/log.hpp"
#include "daemon/cycle_runner.hpp"
#include "daemon/journal.hpp"
#include "daemon/result_store.hpp"
#include "drivers/camera.hpp"
#include "drivers/camera_worker.hpp"
#include "protocol/modbus_client_trigger.hpp"
#include "protocol/modbus_server.hpp"
#include "protocol/robot_server.hpp"

namespace vgr::daemon {

namespace asio = boost::asio;

// Modbus result deadline = cell.cycle_deadline_ms + this (ms): the daemon's own deadline
// answers first; this only catches a hung cycle thread.
constexpr int kModbusDeadlineSlackMs = 100;

struct VgrdApp::Impl {
  config::CellConfig cfg;
  asio::io_context io;
  asio::signal_set signals{io, SIGTERM, SIGINT};
  asio::steady_timer readyTimer{io};
  asio::steady_timer watchdogTimer{io};
  asio::steady_timer statsTimer{io};
  Journal journal;
  std::unique_ptr<drivers::CameraWorker> camera;
  std::unique_ptr<CycleRunner> cycles;
  std::unique_ptr<ResultStore> results;
  std::unique_ptr<protocol::ModbusServer> modbus;
  std::unique_ptr<protocol::ModbusClientTrigger> modbusClient;  // modbus.client.enabled
  std::vector<std::unique_ptr<protocol::RobotServer>> robots;
  bool notifiedReady = false;
  std::uint64_t watchdogUsec = 0;

  explicit Impl(config::CellConfig c) : cfg(std::move(c)) {}

  void publish(const CycleResult& r) {
    // Cycle thread. PLC first (one lock inside), then robots (posted to the I/O thread),
    // then the journal (disk) last.
    if (modbus || modbusClient) {
      protocol::ModbusResult m;
      m.cycleId = r.cycleId;
      m.status = r.status;
      m.jobId = r.jobId;
      m.numFound = static_cast<int>(r.parts.size());
      if (r.status == Status::Ok && !r.parts.empty()) {
        const auto& p = r.parts.front();
        const auto e = toEulerZyxDeg(p.pose);
        // + 0.0: a PLC shows -0.0 as "-0"; nobody wants that on an HMI.
        m.x = p.pose.x + 0.0;
        m.y = p.pose.y + 0.0;
        m.z = p.pose.z + 0.0;
        m.r1 = e.rx + 0.0;
        m.r2 = e.ry + 0.0;
        m.r3 = e.rz + 0.0;
        m.score = p.score;
      }
      if (modbus) modbus->publishResult(m);
      if (modbusClient) modbusClient->publishResult(m);
    }
    asio::post(io, [this, r] { results->onResult(r); });
    journal.append(r, "modbus");
    if (r.status == Status::Ok)
      log::debug("cycle", "cycle {} ok in {:.1f} ms", r.cycleId, r.totalMs);
    else
      log::info("cycle", "cycle {} ended {} ({})", r.cycleId, statusCode(r.status), statusName(r.status));
  }

  void checkReady() {
    if (!notifiedReady && camera->streaming()) {
      notifiedReady = true;
      // READY goes up with the first frame the camera can give: a PLC that triggers the
      // moment it sees READY gets a part, not -4. Later camera loss keeps READY (triggers
      // end in -4 CAMERA_ERROR within the deadline, so the PLC sees the fault).
      if (modbus) modbus->setReady(true);
      if (modbusClient) modbusClient->setReady(true);
      sd_notify(0, "READY=1\nSTATUS=camera streaming, servers listening");
      log::info("main", "ready: camera streaming, Modbus on {}:{}, {} robot endpoint(s)", cfg.modbus.bind,
                modbus ? modbus->port() : 0, robots.size());
      return;
    }
    if (notifiedReady) return;
    readyTimer.expires_after(std::chrono::milliseconds(50));
    readyTimer.async_wait([this](const boost::system::error_code& ec) {
      if (!ec) checkReady();
    });
  }

  void kickWatchdog() {
    sd_notify(0, "WATCHDOG=1");
    watchdogTimer.expires_after(std::chrono::microseconds(watchdogUsec / 2));
    watchdogTimer.async_wait([this](const boost::system::error_code& ec) {
      if (!ec) kickWatchdog();
    });
  }

  void logStats() {
    // Periodic summary instead of per-frame logging (STYLE.md rule 12).
    const auto c = camera->counters();
    log::info("main",
              "camera: {} frames, {} failed ({} timeouts, {} incomplete), {} re-triggers ({} recovered), {} reconnects, "
              "{} abandoned; packets missing {}, resent {}; underruns {}; trigger overruns {}",
              c.completed, c.failed, c.timeouts, c.incomplete, c.retries, c.recovered, c.reconnects, c.abandoned,
              c.missingPackets, c.resentPackets, c.underruns, cycles->overruns());
    statsTimer.expires_after(std::chrono::seconds(60));
    statsTimer.async_wait([this](const boost::system::error_code& ec) {
      if (!ec) logStats();
    });
  }
};

VgrdApp::VgrdApp(config::CellConfig config) : impl_(std::make_unique<Impl>(std::move(config))) {}

VgrdApp::~VgrdApp() {
  // Order: stop producers of work before what they feed.
  if (impl_->modbus) impl_->modbus->stop();
  if (impl_->modbusClient) impl_->modbusClient->stop();
  if (impl_->cycles) impl_->cycles->stop();
  if (impl_->camera) impl_->camera->stop();
  for (auto& r : impl_->robots) r->stop();
}

Result<void> VgrdApp::start() {
  Impl& s = *impl_;
  if (auto r = s.journal.open(s.cfg.journalPath); !r) return r;

  auto cam = drivers::makeCamera(s.cfg.camera);
  if (!cam) return std::unexpected(cam.error());
  s.camera = std::make_unique<drivers::CameraWorker>(s.cfg.camera, std::move(*cam));

  std::set<int> jobs;
  for (const auto& j : s.cfg.jobs) jobs.insert(j.id);
  s.results = std::make_unique<ResultStore>(s.io, jobs);

  CycleSinks sinks;
  sinks.onStarted = [&s](std::uint32_t id, int job) { asio::post(s.io, [&s, id, job] { s.results->onCycleStarted(id, job); }); };
  sinks.onResult = [&s](const CycleResult& r) { s.publish(r); };
  s.cycles = std::make_unique<CycleRunner>(s.cfg, *s.camera, std::move(sinks));
  if (auto r = s.cycles->prepareJobs(); !r) return r;

  for (const auto& rc : s.cfg.robots) {
    protocol::RobotEndpoint ep;
    ep.name = rc.name;
    const auto dialect = protocol::parseDialect(config::dialectName(rc.dialect));
    if (!dialect) return fail(Status::Internal, "robot '" + rc.name + "': unknown dialect");
    ep.dialect = *dialect;
    ep.bind = rc.bind;
    ep.port = rc.port;
    ep.maxClients = static_cast<std::size_t>(rc.maxClients);
    ep.allowedClients = rc.allowedClients;
    ep.strict.command = rc.strict.command;
    ep.strict.ready = rc.strict.ready;
    ep.strict.done = rc.strict.done;
    ep.strict.lineEnd = rc.strict.lineEnd;
    ep.stepTimeoutMs = rc.strict.stepTimeoutMs;

    RobotPolicy policy;
    policy.job = rc.job != 0 ? rc.job : (s.cfg.jobs.empty() ? 0 : s.cfg.jobs.front().id);  // like Modbus JOB_ID 0
    policy.replyDeadlineMs = rc.replyDeadlineMs;
    policy.order = rc.partOrder;
    policy.label = rc.label;
    s.results->addRobot(rc.name, policy);

    auto server = std::make_unique<protocol::RobotServer>(
        s.io, ep, [&s](const std::string& robot, const protocol::RobotRequest& req, protocol::ReplyFn reply) {
          s.results->handle(robot, req, std::move(reply));
        });
    if (auto r = server->start(); !r) return r;
    s.robots.push_back(std::move(server));
  }

  if (s.cfg.modbus.enabled) {
    protocol::ModbusOptions mo;
    mo.bind = s.cfg.modbus.bind;
    mo.port = s.cfg.modbus.port;
    mo.floatOrder = s.cfg.modbus.floatWordOrder == config::WordOrder::HighWordFirst ? protocol::WordOrder::HighWordFirst
                                                                                     : protocol::WordOrder::LowWordFirst;
    mo.maxClients = s.cfg.modbus.maxClients;
    mo.requireTriggerEnable = s.cfg.modbus.requireTriggerEnable;
    // Backstop behind the cycle deadline: the PLC is answered even if the cycle thread hangs.
    mo.resultDeadline = std::chrono::milliseconds(s.cfg.cycleDeadlineMs + kModbusDeadlineSlackMs);
    s.modbus = std::make_unique<protocol::ModbusServer>(
        mo, [&s](int jobId) { return s.cycles->submit(jobId, TriggerSource::Modbus); });
    if (auto r = s.modbus->start(); !r) return r;
  }
  if (s.cfg.modbus.client.enabled) {
    const auto& c = s.cfg.modbus.client;
    protocol::ModbusClientOptions co;
    co.host = c.host;
    co.port = c.port;
    co.unitId = c.unitId;
    co.input = c.trigger == config::TriggerInputKind::Coil ? protocol::ModbusClientOptions::Input::Coil
                                                            : protocol::ModbusClientOptions::Input::DiscreteInput;
    co.inputAddress = static_cast<std::uint16_t>(c.triggerAddress);
    co.statusAddress = static_cast<std::uint16_t>(c.statusAddress);
    co.poll = std::chrono::milliseconds(c.pollMs);
    co.debounce = std::chrono::milliseconds(c.debounceMs);
    co.reconnect = std::chrono::milliseconds(c.reconnectMs);
    co.floatOrder = s.cfg.modbus.floatWordOrder == config::WordOrder::HighWordFirst ? protocol::WordOrder::HighWordFirst
                                                                                     : protocol::WordOrder::LowWordFirst;
    co.jobId = c.job;
    co.resultDeadline = std::chrono::milliseconds(s.cfg.cycleDeadlineMs + kModbusDeadlineSlackMs);
    s.modbusClient = std::make_unique<protocol::ModbusClientTrigger>(
        co, [&s](int jobId) { return s.cycles->submit(jobId, TriggerSource::Modbus); });
    if (auto r = s.modbusClient->start(); !r) return r;
  }

  s.camera->start();
  s.cycles->start();
  return {};
}

int VgrdApp::run() {
  Impl& s = *impl_;
  s.signals.async_wait([&s](const boost::system::error_code& ec, int sig) {
    if (ec) return;
    log::info("main", "signal {}: stopping", sig);
    sd_notify(0, "STOPPING=1");
    s.io.stop();
  });
  if (sd_watchdog_enabled(0, &s.watchdogUsec) > 0 && s.watchdogUsec > 0) s.kickWatchdog();
  s.checkReady();
  s.statsTimer.expires_after(std::chrono::seconds(60));
  s.statsTimer.async_wait([&s](const boost::system::error_code& ec) {
    if (!ec) s.logStats();
  });
  s.io.run();
  if (s.modbus) s.modbus->setReady(false);
  if (s.modbusClient) s.modbusClient->setReady(false);
  s.logStats();
  return 0;
}

}  // namespace vgr::daemon
