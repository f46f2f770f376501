// vgrd's Prometheus metrics (docs/plant.md lists every name). The registry is
// prometheus-cpp's core; render() produces the text exposition format (TextSerializer)
// that the web server serves on /metrics.
//
// Threads: cycleDone() on the cycle thread, triggered() on whichever thread submits a
// trigger (Modbus link, I/O thread, signal), robotReplied() on the I/O thread. They touch
// only series created in the constructor (no lookups that lock, no allocation): a
// counter increment is one atomic add, a histogram observation one uncontended lock.
// render() and the samplers run on the I/O thread, at scrape time.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/cycle.hpp"
#include "core/status.hpp"

namespace vgr::daemon {

// A value read at scrape time from a part that keeps its own counters (the camera
// worker, the MQTT sink, the robot servers).
struct SampledMetric {
  enum class Type { Counter, Gauge };
  std::string name;  // full name, e.g. "vgr_camera_frames_total"
  std::string help;
  Type type = Type::Counter;
  std::vector<std::pair<std::string, std::string>> labels;
  double value = 0;
};
using MetricSampler = std::function<void(std::vector<SampledMetric>& out)>;

class Metrics {
 public:
  // Series exist from the start for every job x status and robot x status (a dashboard
  // sees zeros, not missing series). `version` goes into vgr_build_info.
  Metrics(const std::string& cell, const std::vector<int>& jobIds, const std::vector<std::string>& robots,
          const std::string& version);
  ~Metrics();
  Metrics(const Metrics&) = delete;
  Metrics& operator=(const Metrics&) = delete;

  void cycleDone(const CycleResult& r);
  // A trigger was submitted to the cycle queue: accepted, or refused (queue full: overrun).
  void triggered(TriggerSource source, bool accepted);
  void robotReplied(const std::string& robot, Status status);
  // Before the first render().
  void addSampler(MetricSampler sampler);
  // Before the cycle thread starts, for a cell with a drift monitor: the series
  // vgr_calibration_drift_mm (the fiducial's last residual, NaN when not seen),
  // vgr_calibration_drift_alarm (0/1) and vgr_calibration_fiducial_missed_total, which
  // cycleDone() then keeps up to date.
  void enableDrift();
  // Before the first render(): vgr_calibration_age_seconds{file} (now minus each file's
  // modification time, sampled at scrape; -1 when it cannot be read), `files` as
  // (label, path): ("intrinsics", ".../intrinsics.yaml"), ...
  void watchCalibrationFiles(std::vector<std::pair<std::string, std::string>> files);

  std::string render() const;
  static constexpr const char* kContentType = "text/plain; version=0.0.4; charset=utf-8";

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vgr::daemon
