#include "daemon/vgrd_app.hpp"

#include <systemd/sd-daemon.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <cstdlib>
#include <set>
#include <vector>

#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <opencv2/core.hpp>

#include "core/log.hpp"
#include "core/log_limiter.hpp"
#include "daemon/commissioning_status.hpp"
#include "daemon/cycle_runner.hpp"
#include "daemon/drift_monitor.hpp"
#include "daemon/image_archive.hpp"
#include "daemon/journal.hpp"
#include "daemon/metrics.hpp"
#include "daemon/pause_probe.hpp"
#include "daemon/plc_links.hpp"
#include "daemon/result_store.hpp"
#include "daemon/watchdog.hpp"
#include "drivers/camera.hpp"
#include "daemon/plant.hpp"
#include "drivers/camera_worker.hpp"
#include "protocol/modbus_map.hpp"  // modbusResultFrom
#include "protocol/robot_server.hpp"

namespace vgr::daemon {

namespace asio = boost::asio;

struct VgrdApp::Impl {
  config::CellConfig cfg;
  asio::io_context io;
  asio::signal_set signals{io, SIGTERM, SIGINT};
  asio::signal_set operatorSignal{io, SIGUSR1};
  asio::steady_timer readyTimer{io};
  asio::steady_timer watchdogTimer{io};
  asio::steady_timer statsTimer{io};
  Journal journal;
  std::unique_ptr<drivers::CameraWorker> camera;
  std::unique_ptr<CycleRunner> cycles;
  std::unique_ptr<ResultStore> results;
  // The PLC side: the Modbus server and/or client mode, behind one interface.
  std::vector<std::unique_ptr<protocol::PlcLink>> plcs;
  std::vector<std::unique_ptr<protocol::RobotServer>> robots;
  std::unique_ptr<Plant> plant;  // metrics + web server + page (daemon/plant.hpp)
  std::unique_ptr<ImageArchive> archive;  // when the config has an `archive` section
  bool notifiedReady = false;
  std::uint64_t watchdogUsec = 0;  // systemd's WatchdogSec in µs; 0 = not asked for pings
  Watchdog watchdog;               // every long-lived thread's heartbeat (daemon/watchdog.hpp)
  bool stallReported = false;
  PauseProbe pauseProbe;           // why vgrd did not run, when the watchdog tick comes late
  bool watchdogTicked = false;     // watchdogTimer has an expiry to compare with
  // Hand-over lag: how long a published result waited for the I/O thread before robots
  // could get it (see handOver()). I/O thread only.
  static constexpr double kLateHandOverMs = 20;
  log::LogLimiter lateHandOverLog{20, std::chrono::seconds(60)};
  std::uint64_t lateHandOvers = 0;
  double maxHandOverMs = 0;

  explicit Impl(config::CellConfig c) : cfg(std::move(c)) {}

  void publish(CycleResult& r, const CycleImage& shown) {
    // Cycle thread. PLC first (one lock inside each link), then the frame's copies (archive,
    // web page: a memcpy each, no encoding here), then robots (posted to the I/O thread),
    // then the journal (disk) last. A PLC gets the results of the cycles it triggered (a
    // robot's or the operator's cycle would raise RESULT_VALID for a trigger the PLC never
    // sent); robots and the journal get every result.
    plant->cycleDone(r);  // metrics first (atomic adds): a scrape after RESULT_VALID sees this cycle
    if (r.trigger == TriggerSource::Modbus && !plcs.empty()) {
      const protocol::ModbusResult m = protocol::modbusResultFrom(r);
      for (auto& plc : plcs) plc->publishResult(m);
    }
    if (archive && !shown.depth) r.archived = archive->offer(r, shown.image);  // gray frames only (start() says so)
    plant->frameDone(r, shown);
    asio::post(io, [this, r, posted = std::chrono::steady_clock::now()] { handOver(r, posted); });
    journal.append(r);
    plant->resultDelivered(r);  // MQTT (the JSON payload costs the cycle thread ~tens of µs): after the PLC
    if (r.status == Status::Ok)
      log::debug("cycle", "cycle {} ok in {:.1f} ms", r.cycleId, r.totalMs);
    else
      log::info("cycle", "cycle {} ended {} ({})", r.cycleId, statusCode(r.status), statusName(r.status));
  }

  // I/O thread: the result reaches the robots' side (waiting requests are answered here).
  // Normally within a millisecond of publish(); when the I/O thread was busy or not
  // scheduled (an overloaded PC), requests that arrived meanwhile are read only after this
  // result and the next may both be in, and a robot asking for "the newest" then gets the
  // next one (result_store.hpp's GET semantics). The line names the cycle so such a skip can
  // be told from a fault (`vgr soak` reads it: docs/robustness.md); rate-limited, with the
  // count and the worst lag in the 60 s summary.
  void handOver(const CycleResult& r, std::chrono::steady_clock::time_point posted) {
    const double lagMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - posted).count();
    if (lagMs >= kLateHandOverMs) {
      ++lateHandOvers;
      maxHandOverMs = std::max(maxHandOverMs, lagMs);
      log::limitedLog(lateHandOverLog, "cycle", "late hand-overs", true,
                      "cycle {}: robots got the result {:.1f} ms after it was published (the I/O thread was busy or "
                      "not scheduled; robot replies and the web page were as late)",
                      r.cycleId, lagMs);
    }
    results->onResult(r);
  }

  void setPlcReady(bool ready) {
    for (auto& plc : plcs) plc->setReady(ready);
  }

  void waitOperatorTrigger() {
    // SIGUSR1 (`systemctl kill -s USR1 vgrd`): the operator triggers the first job once.
    operatorSignal.async_wait([this](const boost::system::error_code& ec, int) {
      if (ec) return;
      const std::uint32_t id = plant->triggered(TriggerSource::Operator, cycles->submit(0, TriggerSource::Operator));
      if (id == 0) log::warn("cycle", "operator trigger refused: queue full");
      else log::info("cycle", "operator trigger: cycle {}", id);
      waitOperatorTrigger();
    });
  }

  void checkReady() {
    if (!notifiedReady && camera->streaming()) {
      notifiedReady = true;
      // READY goes up with the first frame the camera can give: a PLC that triggers the
      // moment it sees READY gets a part, not -4. Later camera loss keeps READY (triggers
      // end in -4 CAMERA_ERROR within the deadline, so the PLC sees the fault).
      setPlcReady(true);
      sd_notify(0, "READY=1\nSTATUS=camera streaming, servers listening");
      std::string links;
      for (const auto& plc : plcs) links += (links.empty() ? "" : ", ") + plc->describe();
      log::info("main", "ready: camera streaming, PLC: {}, {} robot endpoint(s)", links.empty() ? "none" : links,
                robots.size());
      return;
    }
    if (notifiedReady) return;
    readyTimer.expires_after(std::chrono::milliseconds(50));
    readyTimer.async_wait([this](const boost::system::error_code& ec) {
      if (!ec) checkReady();
    });
  }

  // I/O thread, every checkPeriod(): WATCHDOG=1 only while every watched thread beats
  // within its stall limit (the I/O thread proves itself by running this). A stall is
  // logged once when it starts (naming the thread) and once when it ends; systemd, which
  // gets no pings meanwhile, kills vgrd WatchdogSec after the last one.
  void checkWatchdog() {
    const auto now = Watchdog::Clock::now();
    if (const auto pause = pauseProbe.tick(watchdogTicked ? watchdogTimer.expiry() : now, now, watchdog.silences(now)))
      log::warn("main", "{}", *pause);
    watchdogTicked = true;
    const auto stalls = watchdog.stalled(now);
    if (stalls.empty()) {
      if (stallReported) {
        log::info("main", "watchdog: every thread makes progress again; pings resumed");
        sd_notify(0, "STATUS=running");
      }
      stallReported = false;
      if (watchdogUsec > 0) sd_notify(0, "WATCHDOG=1");
    } else if (!stallReported) {
      stallReported = true;
      const Watchdog::Stall& s = stalls.front();
      log::error("main", "watchdog: the {} thread has made no progress for {} ms (limit {} ms){}", s.thread,
                 s.silentFor.count(), s.limit.count(),
                 watchdogUsec > 0 ? "; WATCHDOG=1 withheld, systemd will restart vgrd" : "");
      sd_notifyf(0, "STATUS=%s thread stalled", s.thread.c_str());
    }
    watchdogTimer.expires_after(checkPeriod());
    watchdogTimer.async_wait([this](const boost::system::error_code& ec) {
      if (!ec) checkWatchdog();
    });
  }
  // A quarter of WatchdogSec (systemd's advice is half; a quarter leaves room for a late
  // timer), at most 1 s, so a stall is noticed within a second of its limit.
  std::chrono::microseconds checkPeriod() const {
    const std::uint64_t us = watchdogUsec > 0 ? std::min<std::uint64_t>(watchdogUsec / 4, 1'000'000) : 1'000'000;
    return std::chrono::microseconds(std::max<std::uint64_t>(us, 10'000));
  }

  void logStats() {
    // Periodic summary instead of per-frame logging (STYLE.md rule 12).
    const auto c = camera->counters();
    log::info("main",
              "camera: {} frames, {} failed ({} timeouts, {} incomplete), {} re-triggers ({} recovered), {} reconnects, "
              "{} abandoned; packets missing {}, resent {}; underruns {}; trigger overruns {}; journal write errors {}",
              c.completed, c.failed, c.timeouts, c.incomplete, c.retries, c.recovered, c.reconnects, c.abandoned,
              c.missingPackets, c.resentPackets, c.underruns, cycles->overruns(), journal.writeErrors());
    const JournalStats j = journal.stats();
    log::info("main", "journal: {} records ({:.1f} µs per write), {} syncs ({:.1f} µs each), {} rotations", j.records,
              j.records ? static_cast<double>(j.writeMicros) / static_cast<double>(j.records) : 0.0, j.syncs,
              j.syncs ? static_cast<double>(j.syncMicros) / static_cast<double>(j.syncs) : 0.0, j.rotations);
    if (pauseProbe.pauses() > 0)
      log::info("main", "pauses: {} times vgrd did not run for >= {} ms (worst {} ms; the 'pause:' lines say why)",
                pauseProbe.pauses(), PauseProbe::kReportLate.count(), pauseProbe.worst().count());
    if (lateHandOvers > 0)
      log::info("main", "hand-over: {} results reached the robots' side >= {:.0f} ms after publish (worst {:.1f} ms), "
                "{} of those lines held back", lateHandOvers, kLateHandOverMs, maxHandOverMs,
                lateHandOverLog.heldBackTotal());
    // Connection counters (the connection log lines themselves are rate-limited).
    for (const auto& robot : robots) {
      const protocol::RobotServerStats st = robot->stats();
      log::info("main",
                "robot '{}': connections {} accepted, {} closed, {} open; refused {} not allowed, {} full, {} over the "
                "rate; {} stale replaced, {} reset before accept; {} control requests refused; {} log lines held back",
                robot->endpoint().name, st.accepted, st.closed, robot->clientCount(), st.refusedNotAllowed,
                st.refusedFull, st.refusedRate, st.replacedStale, st.goneBeforeAccept, st.controlRefused, st.logLinesHeldBack);
    }
    for (const auto& plc : plcs) {
      if (const std::string line = plc->summary(); !line.empty()) log::info("main", "{}", line);
    }
    if (archive) {
      const ArchiveCounters a = archive->counters();
      log::info("main", "archive: {} frames ({:.1f} of {:.1f} MB), {} written, {} dropped (queue full), {} deleted (quota), "
                "{} write errors", a.files, a.bytes / 1e6, a.quotaBytes / 1e6, a.written, a.dropped, a.deleted, a.writeErrors);
    }
    statsTimer.expires_after(std::chrono::seconds(60));
    statsTimer.async_wait([this](const boost::system::error_code& ec) {
      if (!ec) logStats();
    });
  }
};

VgrdApp::VgrdApp(config::CellConfig config) : impl_(std::make_unique<Impl>(std::move(config))) {}

VgrdApp::~VgrdApp() {
  // Order: stop producers of work before what they feed.
  for (auto& plc : impl_->plcs) plc->stop();
  if (impl_->cycles) impl_->cycles->stop();
  if (impl_->archive) impl_->archive->stop();  // writes what is queued
  if (impl_->camera) impl_->camera->stop();
  for (auto& r : impl_->robots) r->stop();
  if (impl_->plant) impl_->plant->stop();
}

Result<void> VgrdApp::start() {
  Impl& s = *impl_;
  JournalOptions journalOptions;
  journalOptions.maxBytes = static_cast<std::uint64_t>(s.cfg.journalMaxBytes);
  journalOptions.keepFiles = s.cfg.journalFiles;
  journalOptions.syncMs = s.cfg.journalSyncMs;
  if (auto r = s.journal.open(s.cfg.journalPath, journalOptions); !r) return r;
  s.journal.setRobots(journalRobots(s.cfg));

  auto cam = drivers::makeCamera(s.cfg.camera);
  if (!cam) return std::unexpected(cam.error());
  s.camera = std::make_unique<drivers::CameraWorker>(s.cfg.camera, std::move(*cam));

  std::set<int> jobs;
  for (const auto& j : s.cfg.jobs) jobs.insert(j.id);
  s.results = std::make_unique<ResultStore>(s.io, jobs);
  s.plant = std::make_unique<Plant>(s.io, s.cfg);
  {
    // Calibration age and drift in /metrics (docs/plant.md).
    const auto& c = s.cfg.calibration;
    std::vector<std::pair<std::string, std::string>> files;
    for (const auto& [label, path] : {std::pair{"intrinsics", c.intrinsics}, std::pair{"handeye", c.handeye},
                                      std::pair{"plane", c.plane}, std::pair{"multiheight", c.multiHeight},
                                      std::pair{"check", c.check}})
      if (!path.empty()) files.emplace_back(label, path);
    s.plant->metrics().watchCalibrationFiles(std::move(files));
    if (c.drift.enabled) s.plant->metrics().enableDrift();
  }
  s.results->setTrigger([&s](int jobId, const std::optional<Pose>& flange) {
    return s.plant->triggered(TriggerSource::Robot, s.cycles->submit(jobId, TriggerSource::Robot, flange));
  });

  CycleSinks sinks;
  sinks.onStarted = [&s](std::uint32_t id, int job) { asio::post(s.io, [&s, id, job] { s.results->onCycleStarted(id, job); }); };
  sinks.onResult = [&s](CycleResult& r, const CycleImage& shown) { s.publish(r, shown); };
  s.cycles = std::make_unique<CycleRunner>(s.cfg, *s.camera, std::move(sinks));
  // Cycle ids continue after the journal's last one (unique in the journal, no RESULT_ID
  // repeated to the PLC after a restart).
  s.cycles->setFirstCycleId(firstCycleIdAfter(s.journal.lastCycleId()));
  log::info("main", "journal {}: last cycle {}; cycle ids continue at {}", s.cfg.journalPath, s.journal.lastCycleId(),
            firstCycleIdAfter(s.journal.lastCycleId()));
  if (auto r = s.cycles->prepareJobs(); !r) return r;

  for (const auto& rc : s.cfg.robots) {
    protocol::RobotEndpoint ep;
    ep.name = rc.name;
    ep.dialect = rc.dialect;
    ep.replyLabel = rc.replyLabel;
    ep.bind = rc.bind;
    ep.port = rc.port;
    ep.maxClients = static_cast<std::size_t>(rc.maxClients);
    ep.maxClientsPerAddress = static_cast<std::size_t>(rc.maxClientsPerAddress);
    ep.staleAfterMs = rc.staleAfterMs;
    ep.allowedClients = rc.allowedClients;
    ep.controlClients = rc.controlClients;
    ep.idleTimeoutMs = rc.idleTimeoutMs;
    ep.abbRotation = rc.abbRotation;
    ep.strict.command = rc.strict.command;
    ep.strict.ready = rc.strict.ready;
    ep.strict.done = rc.strict.done;
    ep.strict.lineEnd = rc.strict.lineEnd;
    ep.strict.snapshot = rc.strict.snapshot;
    ep.strict.none = rc.strict.none;
    ep.stepTimeoutMs = rc.strict.stepTimeoutMs;

    RobotPolicy policy;
    policy.job = rc.job != 0 ? rc.job : (s.cfg.jobs.empty() ? 0 : s.cfg.jobs.front().id);  // like Modbus JOB_ID 0
    policy.replyDeadlineMs = rc.replyDeadlineMs;
    policy.order = rc.partOrder;
    policy.label = rc.label;
    s.results->addRobot(rc.name, policy, RobotDelivery{rc.dialect, {rc.delivery, rc.baseFromUser}});
    if (rc.delivery == config::Delivery::Offset || rc.frameName != "base")
      log::info("main", "robot {}: {} dialect, {} in frame '{}'", rc.name, config::dialectName(rc.dialect),
                rc.delivery == config::Delivery::Offset ? "offsets from the job's reference" : "poses", rc.frameName);

    auto server = std::make_unique<protocol::RobotServer>(
        s.io, ep, [&s](const std::string& robot, const protocol::RobotRequest& req, protocol::ReplyFn reply) {
          s.results->handle(robot, req, s.plant->countReplies(robot, std::move(reply)));
        });
    if (auto r = server->start(); !r) return r;
    s.robots.push_back(std::move(server));
  }

  for (auto& plc : makePlcLinks(s.cfg, [&s](int jobId) {
         return s.plant->triggered(TriggerSource::Modbus, s.cycles->submit(jobId, TriggerSource::Modbus));
       })) {
    if (auto r = plc->start(); !r) return r;
    s.plcs.push_back(std::move(plc));
  }

  if (s.cfg.archive.enabled) {
    if (s.cfg.camera.depth())
      log::warn("main", "archive: this cell's camera is a depth camera ({}); its frames are not archived (the archive "
                "keeps 8-bit gray frames; docs/3d.md 'Not done yet'), only the journal records its cycles",
                s.cfg.camera.pixelFormat);
    s.archive = std::make_unique<ImageArchive>(s.cfg.archive, archiveDir(s.cfg));
    if (auto r = s.archive->start(); !r) return r;
  }

  PlantSources sources;
  sources.camera = s.camera.get();
  sources.cycles = s.cycles.get();
  sources.ready = [&s] { return s.notifiedReady; };
  sources.archive = s.archive.get();
  sources.trigger = [&s](int jobId) {
    return s.plant->triggered(TriggerSource::Operator, s.cycles->submit(jobId, TriggerSource::Operator));
  };
  sources.setDefaultJob = [&s](int jobId) { return s.cycles->setDefaultJob(jobId); };
  sources.defaultJob = [&s] { return s.cycles->defaultJob(); };
  for (const auto& r : s.robots) sources.robots.push_back(r.get());
  // The commissioning figures on the page (daemon/commissioning_status.hpp).
  if (const DriftMonitor* drift = s.cycles->driftMonitor())
    s.plant->addStatusSection("drift", [drift](nlohmann::json& out) { fillDriftSection(*drift, out); });
  if (auto r = s.plant->start(std::move(sources)); !r) return r;

  s.camera->start();
  s.cycles->start();
  s.watchdog.watch("cycle", s.cycles->heartbeat(), s.cycles->stallLimit());
  s.watchdog.watch("camera", s.camera->heartbeat(), drivers::CameraWorker::kStallLimit);
  for (const auto& plc : s.plcs)
    s.watchdog.watch(plc->describe(), plc->heartbeat(), plc->stallLimit());
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
  if (sd_watchdog_enabled(0, &s.watchdogUsec) <= 0) s.watchdogUsec = 0;
  if (s.watchdogUsec > 0)
    log::info("main", "systemd watchdog: {} ms; WATCHDOG=1 only while the {} watched threads make progress",
              s.watchdogUsec / 1000, s.watchdog.size());
  s.checkWatchdog();
  s.waitOperatorTrigger();
  s.checkReady();
  s.statsTimer.expires_after(std::chrono::seconds(60));
  s.statsTimer.async_wait([&s](const boost::system::error_code& ec) {
    if (!ec) s.logStats();
  });
  s.io.run();
  s.setPlcReady(false);
  s.logStats();
  return 0;
}

}  // namespace vgr::daemon
