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
#include "daemon/camera_worker.hpp"
#include "daemon/cycle_runner.hpp"
#include "daemon/journal.hpp"
#include "daemon/result_store.hpp"
#include "drivers/camera.hpp"
#include "protocol/modbus_server.hpp"
#include "protocol/robot_server.hpp"

namespace vgr::daemon {

namespace asio = boost::asio;

struct VgrdApp::Impl {
  config::CellConfig cfg;
  asio::io_context io;
  asio::signal_set signals{io, SIGTERM, SIGINT};
  asio::steady_timer readyTimer{io};
  asio::steady_timer watchdogTimer{io};
  asio::steady_timer statsTimer{io};
  Journal journal;
  std::unique_ptr<CameraWorker> camera;
  std::unique_ptr<CycleRunner> cycles;
  std::unique_ptr<ResultStore> results;
  std::unique_ptr<protocol::ModbusServer> modbus;
  std::vector<std::unique_ptr<protocol::RobotServer>> robots;
  bool notifiedReady = false;
  std::uint64_t watchdogUsec = 0;

  explicit Impl(config::CellConfig c) : cfg(std::move(c)) {}

  void publish(const CycleResult& r) {
    // Cycle thread. PLC first (one lock inside), then robots (posted to the I/O thread),
    // then the journal (disk) last.
    if (modbus) {
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
      modbus->publishResult(m);
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
    log::info("main", "camera: {} frames, {} failed ({} timeouts), {} reconnects, {} abandoned; trigger overruns {}",
              c.completed, c.failed, c.timeouts, c.reconnects, c.abandoned, cycles->overruns());
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
  if (impl_->cycles) impl_->cycles->stop();
  if (impl_->camera) impl_->camera->stop();
  for (auto& r : impl_->robots) r->stop();
}

Result<void> VgrdApp::start() {
  Impl& s = *impl_;
  if (auto r = s.journal.open(s.cfg.journalPath); !r) return r;

  auto cam = drivers::makeCamera(s.cfg.camera);
  if (!cam) return std::unexpected(cam.error());
  s.camera = std::make_unique<CameraWorker>(s.cfg.camera, std::move(*cam));

  std::set<int> jobs;
  for (const auto& j : s.cfg.jobs) jobs.insert(j.id);
  s.results = std::make_unique<ResultStore>(s.io, jobs);

  CycleSinks sinks;
  sinks.onStarted = [&s](std::uint32_t id, int job) { asio::post(s.io, [&s, id, job] { s.results->onCycleStarted(id, job); }); };
  sinks.onResult = [&s](const CycleResult& r) { s.publish(r); };
  s.cycles = std::make_unique<CycleRunner>(s.cfg, *s.camera, std::move(sinks));

  for (const auto& rc : s.cfg.robots) {
    protocol::RobotEndpoint ep;
    ep.name = rc.name;
    ep.dialect = rc.dialect == config::Dialect::Ur ? protocol::Dialect::Ur : protocol::Dialect::Abb;
    ep.bind = rc.bind;
    ep.port = rc.port;
    const int deadline = rc.replyDeadlineMs;
    auto server = std::make_unique<protocol::RobotServer>(
        s.io, ep, [&s, deadline](const std::string& robot, const protocol::RobotRequest& req, protocol::ReplyFn reply) {
          s.results->handleGet(robot, req, std::move(reply), deadline);
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
    s.modbus = std::make_unique<protocol::ModbusServer>(
        mo, [&s](int jobId) { return s.cycles->submit(jobId, TriggerSource::Modbus); });
    if (auto r = s.modbus->start(); !r) return r;
    s.modbus->setReady(true);
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
  s.logStats();
  return 0;
}

}  // namespace vgr::daemon
