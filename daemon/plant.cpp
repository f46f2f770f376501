#include "daemon/plant.hpp"

#include "core/log.hpp"
#include "core/version.hpp"
#include "drivers/camera_worker.hpp"
#include "daemon/cycle_runner.hpp"
#include "daemon/image_archive.hpp"
#include "daemon/metrics.hpp"
#include "daemon/mqtt_sink.hpp"
#include "daemon/web_page.hpp"
#include "daemon/web_server.hpp"

namespace vgr::daemon {

namespace {

std::vector<int> jobIds(const config::CellConfig& cell) {
  std::vector<int> ids;
  for (const auto& j : cell.jobs) ids.push_back(j.id);
  return ids;
}

std::vector<std::string> robotNames(const config::CellConfig& cell) {
  std::vector<std::string> names;
  for (const auto& r : cell.robots) names.push_back(r.name);
  return names;
}

}  // namespace

Plant::Plant(boost::asio::io_context& io, const config::CellConfig& cell)
    : io_(io), cell_(cell), metrics_(std::make_unique<Metrics>(cell.name, jobIds(cell), robotNames(cell), buildVersion())) {}

Plant::~Plant() { stop(); }

Result<void> Plant::start(PlantSources src) {
  using T = SampledMetric::Type;
  sources_ = src;
  if (src.camera != nullptr) {
    const drivers::CameraWorker* camera = src.camera;
    const std::string cameraName = cell_.camera.name;
    metrics_->addSampler([camera, cameraName](std::vector<SampledMetric>& out) {
      const drivers::CameraCounters c = camera->counters();
      const std::vector<std::pair<std::string, std::string>> l = {{"camera", cameraName}};
      auto add = [&](const char* name, const char* help, double v, T type = T::Counter) {
        out.push_back({name, help, type, l, v});
      };
      add("vgr_camera_frames_total", "Grabs that got their frame", static_cast<double>(c.completed));
      add("vgr_camera_grab_failures_total", "Grabs that got no frame (after every re-trigger)", static_cast<double>(c.failed));
      add("vgr_camera_timeouts_total", "Failed grabs that timed out", static_cast<double>(c.timeouts));
      add("vgr_camera_incomplete_total", "Failed grabs whose last frame missed packets", static_cast<double>(c.incomplete));
      add("vgr_camera_retriggers_total", "Re-triggers after a lost frame", static_cast<double>(c.retries));
      add("vgr_camera_recovered_total", "Grabs that got their frame on a re-trigger", static_cast<double>(c.recovered));
      add("vgr_camera_abandoned_total", "Grabs the cycle stopped waiting for (deadline)", static_cast<double>(c.abandoned));
      add("vgr_camera_reconnects_total", "Reconnects after the camera dropped out", static_cast<double>(c.reconnects));
      add("vgr_camera_packets_missing_total", "GVSP packets missing (driver statistics)", static_cast<double>(c.missingPackets));
      add("vgr_camera_packets_resent_total", "GVSP packets resent on request (driver statistics)", static_cast<double>(c.resentPackets));
      add("vgr_camera_underruns_total", "Frames dropped for want of a free buffer", static_cast<double>(c.underruns));
      add("vgr_camera_streaming", "1 while the camera is open and streaming", camera->streaming() ? 1.0 : 0.0, T::Gauge);
    });
  }
  if (src.cycles != nullptr) {
    const CycleRunner* cycles = src.cycles;
    metrics_->addSampler([cycles](std::vector<SampledMetric>& out) {
      out.push_back({"vgr_cycle_queue_overruns_total", "Triggers refused by the full cycle queue, all sources",
                     T::Counter, {}, static_cast<double>(cycles->overruns())});
    });
  }
  if (!src.robots.empty()) {
    auto robots = src.robots;
    metrics_->addSampler([robots](std::vector<SampledMetric>& out) {
      for (const auto* r : robots)
        out.push_back({"vgr_robot_connections", "Robot connections open, by endpoint", T::Gauge,
                       {{"robot", r->endpoint().name}}, static_cast<double>(r->clientCount())});
    });
  }
  if (src.ready) {
    auto ready = src.ready;
    metrics_->addSampler([ready](std::vector<SampledMetric>& out) {
      out.push_back({"vgr_ready", "1 while vgrd reports READY (camera streaming, servers listening)", T::Gauge, {},
                     ready() ? 1.0 : 0.0});
    });
  }

  if (src.archive != nullptr) {
    const ImageArchive* archive = src.archive;
    metrics_->addSampler([archive](std::vector<SampledMetric>& out) {
      const ArchiveCounters a = archive->counters();
      auto add = [&](const char* name, const char* help, std::uint64_t v, T type) {
        out.push_back({name, help, type, {}, static_cast<double>(v)});
      };
      add("vgr_archive_bytes", "Bytes of frames in the image archive (PNG + journal line)", a.bytes, T::Gauge);
      add("vgr_archive_quota_bytes", "The image archive's quota", a.quotaBytes, T::Gauge);
      add("vgr_archive_files", "Frames in the image archive", a.files, T::Gauge);
      add("vgr_archive_queued", "Frames waiting for the disk", a.queued, T::Gauge);
      add("vgr_archive_written_total", "Frames written to the image archive", a.written, T::Counter);
      add("vgr_archive_dropped_total", "Frames to keep that were dropped: the archive's queue was full", a.dropped, T::Counter);
      add("vgr_archive_deleted_total", "Frames deleted for the quota, oldest first", a.deleted, T::Counter);
      add("vgr_archive_write_errors_total", "Frames that could not be written", a.writeErrors, T::Counter);
    });
  }

  if (cell_.web.enabled) {
    web_ = std::make_unique<WebServer>(io_, WebOptions{cell_.web.bind, cell_.web.port});
    Metrics* metrics = metrics_.get();
    web_->route("/metrics", [metrics](const HttpRequest&) { return HttpReply{200, Metrics::kContentType, metrics->render(), {}}; });
    if (cell_.web.page) {
      WebPageSources ps;
      ps.cell = &cell_;
      ps.version = buildVersion();
      ps.camera = src.camera;
      ps.archive = src.archive;
      ps.ready = src.ready;
      ps.trigger = src.trigger;
      ps.setDefaultJob = src.setDefaultJob;
      ps.defaultJob = src.defaultJob;
      page_ = std::make_unique<WebPage>(io_, *web_, cell_.web, std::move(ps));
      for (auto& [name, fill] : sections_) page_->addStatusSection(name, std::move(fill));
      page_->start();
    } else {
      web_->route("/", [](const HttpRequest&) {
        return HttpReply{200, "text/plain; charset=utf-8", "vgrd " + std::string(buildVersion()) + "\n/metrics\n", {}};
      });
    }
    if (auto r = web_->start(); !r) return r;
    log::info("main", "{} serving /metrics{}{}", web_->describe(), cell_.web.page ? " and the commissioning page" : "",
              cell_.web.actions ? " (operator actions on)" : "");
  }

  if (cell_.mqtt.enabled) {
    mqtt_ = std::make_unique<MqttSink>(cell_.mqtt, cell_.name, buildVersion());
    mqtt_->setRobots(journalRobots(cell_));
    lastJob_ = cell_.jobs.empty() ? 0 : cell_.jobs.front().id;
    pollStatus();  // the status is known before the first connect
    if (auto r = mqtt_->start(); !r) return r;
    MqttSink* mqtt = mqtt_.get();
    metrics_->addSampler([mqtt](std::vector<SampledMetric>& out) {
      const MqttCounters c = mqtt->counters();
      out.push_back({"vgr_mqtt_published_total", "Results the MQTT broker acknowledged", T::Counter, {},
                     static_cast<double>(c.published)});
      out.push_back({"vgr_mqtt_dropped_total", "Results dropped from the full MQTT queue", T::Counter, {},
                     static_cast<double>(c.dropped)});
      out.push_back({"vgr_mqtt_connects_total", "Connections made to the MQTT broker", T::Counter, {},
                     static_cast<double>(c.connects)});
      out.push_back({"vgr_mqtt_queued", "Results waiting for the MQTT broker", T::Gauge, {}, static_cast<double>(c.queued)});
      out.push_back({"vgr_mqtt_connected", "1 while connected to the MQTT broker", T::Gauge, {}, c.connected ? 1.0 : 0.0});
    });
    statusTimer_ = std::make_unique<boost::asio::steady_timer>(io_);
    statusTimer_->expires_after(std::chrono::seconds(1));
    statusTimer_->async_wait([this](const boost::system::error_code& ec) {
      if (!ec) pollStatus();
    });
  }
  return {};
}

void Plant::pollStatus() {
  // I/O thread: the retained status follows READY, the camera and the job (published on change).
  MqttStatus st;
  st.ready = sources_.ready ? sources_.ready() : false;
  st.camera = sources_.camera != nullptr && sources_.camera->streaming();
  st.job = lastJob_.load();
  mqtt_->setStatus(st);
  if (!statusTimer_) return;
  statusTimer_->expires_after(std::chrono::seconds(1));
  statusTimer_->async_wait([this](const boost::system::error_code& ec) {
    if (!ec) pollStatus();
  });
}

void Plant::stop() {
  if (page_) page_->stop();
  if (web_) web_->stop();
  if (statusTimer_) statusTimer_->cancel();
  if (mqtt_) mqtt_->stop();
}

void Plant::cycleDone(const CycleResult& r) { metrics_->cycleDone(r); }

void Plant::frameDone(const CycleResult& r, const CycleImage& image) {
  if (page_) page_->frameDone(r, image);
}

void Plant::addStatusSection(const std::string& name, StatusSection fill) { sections_.emplace_back(name, std::move(fill)); }

void Plant::resultDelivered(const CycleResult& r) {
  if (mqtt_) {
    lastJob_ = r.jobId;
    mqtt_->publishResult(r);
  }
}

std::uint32_t Plant::triggered(TriggerSource source, std::uint32_t cycleId) {
  metrics_->triggered(source, cycleId != 0);
  return cycleId;
}

protocol::ReplyFn Plant::countReplies(const std::string& robot, protocol::ReplyFn reply) {
  Metrics* metrics = metrics_.get();
  // withCompletion: the session's "was it written" callback must reach the ResultStore
  // (a part counts as delivered only once written), so it is passed through, not consumed.
  return protocol::ReplyFn::withCompletion(
      [metrics, robot, reply = std::move(reply)](const protocol::RobotReply& r, protocol::WrittenFn written) {
        metrics->robotReplied(robot, r.status);
        reply(r, std::move(written));
      });
}

std::uint16_t Plant::webPort() const { return web_ ? web_->port() : 0; }

}  // namespace vgr::daemon
