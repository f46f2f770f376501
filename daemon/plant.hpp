// vgrd's plant interfaces in one place, so the daemon's wiring (vgrd_app.cpp) only calls
// in: the Prometheus metrics (daemon/metrics.hpp) served by the web server
// (daemon/web_server.hpp) on the cell's `web` address together with the commissioning
// page (daemon/web_page.hpp, docs/commissioning.md), and the MQTT sink
// (daemon/mqtt_sink.hpp) when the cell has an `mqtt` section. docs/plant.md has the names.
//
// Threads: construct, addStatusSection(), start() and stop() on the I/O thread (or before
// it runs); cycleDone() and frameDone() on the cycle thread; triggered() on any thread;
// countReplies() wraps a robot's reply callback on the I/O thread. None of them blocks or
// touches the network.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "config/cell_config.hpp"
#include "core/cycle.hpp"
#include "core/result.hpp"
#include "daemon/web_page.hpp"  // StatusSection
#include "protocol/robot_server.hpp"

#include <boost/asio/steady_timer.hpp>

namespace vgr::drivers {
class CameraWorker;
}

namespace vgr::daemon {

class CycleRunner;
class ImageArchive;
class Metrics;
class MqttSink;
class WebPage;
class WebServer;

// What the metrics sample at scrape time (I/O thread). Borrowed: they outlive the Plant's
// start()..stop().
struct PlantSources {
  const drivers::CameraWorker* camera = nullptr;
  const CycleRunner* cycles = nullptr;
  std::vector<const protocol::RobotServer*> robots;
  std::function<bool()> ready;  // READY as the PLC sees it
  const ImageArchive* archive = nullptr;  // null: no archive
  // The page's operator actions (daemon/web_page.hpp).
  std::function<std::uint32_t(int jobId)> trigger;
  std::function<Result<void>(int jobId)> setDefaultJob;
  std::function<int()> defaultJob;
};

class Plant {
 public:
  Plant(boost::asio::io_context& io, const config::CellConfig& cell);
  ~Plant();
  Plant(const Plant&) = delete;
  Plant& operator=(const Plant&) = delete;

  // Starts the web server and the MQTT sink the config asks for; the error names which.
  Result<void> start(PlantSources sources);
  void stop();

  // Cycle thread, in vgrd's publish order: cycleDone() first (metrics, cheap), then the PLC,
  // robots and journal, then resultDelivered() (the MQTT message, built from the journal line).
  void cycleDone(const CycleResult& r);
  void resultDelivered(const CycleResult& r);
  // Cycle thread, after the PLC: the frame the locator saw (gray, or a 3D cycle's depth
  // frame; empty: no frame), for the page.
  void frameDone(const CycleResult& r, const CycleImage& image);
  // The page's extension point (daemon/web_page.hpp): a section of /api/status and of the
  // page, e.g. addStatusSection("drift", ...). Before start(); ignored when the page is off.
  void addStatusSection(const std::string& name, StatusSection fill);
  // Counts a submitted trigger; returns `cycleId` (0 = refused) so a call site can wrap
  // CycleRunner::submit: `return plant.triggered(src, cycles.submit(job, src));`.
  std::uint32_t triggered(TriggerSource source, std::uint32_t cycleId);
  // The same reply callback, counting what it sends by robot and status.
  protocol::ReplyFn countReplies(const std::string& robot, protocol::ReplyFn reply);

  Metrics& metrics() { return *metrics_; }
  // The web server's bound port (0 when off).
  std::uint16_t webPort() const;

 private:
  boost::asio::io_context& io_;
  const config::CellConfig& cell_;
  std::unique_ptr<Metrics> metrics_;
  std::unique_ptr<WebServer> web_;
  std::unique_ptr<WebPage> page_;
  std::vector<std::pair<std::string, StatusSection>> sections_;
  std::unique_ptr<MqttSink> mqtt_;
  std::unique_ptr<boost::asio::steady_timer> statusTimer_;  // MQTT status, every second
  std::atomic<int> lastJob_{0};
  PlantSources sources_;
  void pollStatus();
};

}  // namespace vgr::daemon
