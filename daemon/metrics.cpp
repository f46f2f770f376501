#include "daemon/metrics.hpp"

#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iterator>
#include <map>
#include <sstream>

#include <prometheus/counter.h>
#include <prometheus/family.h>
#include <prometheus/gauge.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>
#include <prometheus/text_serializer.h>

namespace vgr::daemon {

namespace {

constexpr std::size_t kStatusCount = std::size(kAllStatuses);
constexpr TriggerSource kSources[] = {TriggerSource::Modbus, TriggerSource::Robot, TriggerSource::Operator};

// Index of a status in kAllStatuses (a value outside the enum counts as INTERNAL, as statusName
// names it).
std::size_t statusIndex(Status s) {
  std::size_t internal = 0;
  for (std::size_t i = 0; i < kStatusCount; ++i) {
    if (kAllStatuses[i] == s) return i;
    if (kAllStatuses[i] == Status::Internal) internal = i;
  }
  return internal;
}

// Seconds: a cycle is ~10-100 ms when all is well, up to the cycle deadline (<= 60 s) when not.
const prometheus::Histogram::BucketBoundaries kSecondsBuckets = {0.005, 0.01, 0.02, 0.05, 0.1, 0.2,
                                                                 0.5,   1.0,  2.0,  5.0,  10.0, 60.0};

}  // namespace

struct Metrics::Impl {
  prometheus::Registry registry;
  struct JobSeries {
    prometheus::Counter* cycles[kStatusCount] = {};
    prometheus::Histogram* seconds = nullptr;
  };
  std::map<int, JobSeries> jobs;   // built in the constructor, read-only afterwards
  JobSeries otherJob;              // a cycle whose job id is not configured (JOB_NOT_FOUND)
  prometheus::Histogram* grab = nullptr;
  prometheus::Histogram* locate = nullptr;
  prometheus::Counter* parts = nullptr;
  prometheus::Counter* triggers[3] = {};
  prometheus::Counter* overruns[3] = {};
  std::map<std::string, std::array<prometheus::Counter*, kStatusCount>> robotReplies;
  prometheus::Gauge* driftMm = nullptr;  // enableDrift()
  prometheus::Gauge* driftAlarm = nullptr;
  prometheus::Counter* fiducialMissed = nullptr;
  std::vector<MetricSampler> samplers;

  void makeJob(prometheus::Family<prometheus::Counter>& cycles, prometheus::Family<prometheus::Histogram>& seconds,
               const std::string& job, JobSeries& out) {
    for (std::size_t i = 0; i < kStatusCount; ++i)
      out.cycles[i] = &cycles.Add({{"job", job}, {"status", std::string(statusName(kAllStatuses[i]))}});
    out.seconds = &seconds.Add({{"job", job}}, kSecondsBuckets);
  }
};

Metrics::Metrics(const std::string& cell, const std::vector<int>& jobIds, const std::vector<std::string>& robots,
                 const std::string& version)
    : impl_(std::make_unique<Impl>()) {
  auto& reg = impl_->registry;
  prometheus::BuildGauge()
      .Name("vgr_build_info")
      .Help("vgrd's version (git describe); the value is always 1")
      .Register(reg)
      .Add({{"version", version}, {"cell", cell}})
      .Set(1);
  auto& cycles = prometheus::BuildCounter()
                     .Name("vgr_cycles_total")
                     .Help("Cycles finished (one per accepted trigger), by job and status (the status table's name)")
                     .Register(reg);
  auto& seconds = prometheus::BuildHistogram()
                      .Name("vgr_cycle_seconds")
                      .Help("Trigger to result, seconds, by job")
                      .Register(reg);
  for (int id : jobIds) impl_->makeJob(cycles, seconds, std::to_string(id), impl_->jobs[id]);
  impl_->makeJob(cycles, seconds, "unknown", impl_->otherJob);
  auto& stages = prometheus::BuildHistogram()
                     .Name("vgr_cycle_stage_seconds")
                     .Help("Time of one stage of the cycle, seconds: grab (trigger to frame), locate (localization)")
                     .Register(reg);
  impl_->grab = &stages.Add({{"stage", "grab"}}, kSecondsBuckets);
  impl_->locate = &stages.Add({{"stage", "locate"}}, kSecondsBuckets);
  impl_->parts = &prometheus::BuildCounter()
                      .Name("vgr_parts_found_total")
                      .Help("Parts located, summed over all cycles")
                      .Register(reg)
                      .Add({});
  auto& triggers = prometheus::BuildCounter()
                       .Name("vgr_triggers_total")
                       .Help("Triggers accepted into the cycle queue, by source (modbus, robot, operator)")
                       .Register(reg);
  auto& overruns = prometheus::BuildCounter()
                       .Name("vgr_trigger_overruns_total")
                       .Help("Triggers refused because the cycle queue was full (answered BUSY_OVERRUN), by source")
                       .Register(reg);
  for (std::size_t i = 0; i < 3; ++i) {
    impl_->triggers[i] = &triggers.Add({{"source", triggerSourceName(kSources[i])}});
    impl_->overruns[i] = &overruns.Add({{"source", triggerSourceName(kSources[i])}});
  }
  auto& replies = prometheus::BuildCounter()
                      .Name("vgr_robot_replies_total")
                      .Help("Replies sent to robots, by robot endpoint and status")
                      .Register(reg);
  for (const auto& robot : robots) {
    auto& row = impl_->robotReplies[robot];
    for (std::size_t i = 0; i < kStatusCount; ++i)
      row[i] = &replies.Add({{"robot", robot}, {"status", std::string(statusName(kAllStatuses[i]))}});
  }
}

Metrics::~Metrics() = default;

void Metrics::cycleDone(const CycleResult& r) {
  const auto it = impl_->jobs.find(r.jobId);
  const Impl::JobSeries& job = it != impl_->jobs.end() ? it->second : impl_->otherJob;
  job.cycles[statusIndex(r.status)]->Increment();
  job.seconds->Observe(r.totalMs / 1000.0);
  impl_->grab->Observe(r.grabMs / 1000.0);
  impl_->locate->Observe(r.locateMs / 1000.0);
  if (!r.parts.empty()) impl_->parts->Increment(static_cast<double>(r.parts.size()));
  if (r.driftMonitored && impl_->driftMm) {
    impl_->driftMm->Set(r.driftMm);
    impl_->driftAlarm->Set(r.driftAlarm ? 1 : 0);
    if (!std::isfinite(r.driftMm)) impl_->fiducialMissed->Increment();
  }
}

void Metrics::enableDrift() {
  auto& reg = impl_->registry;
  impl_->driftMm = &prometheus::BuildGauge()
                        .Name("vgr_calibration_drift_mm")
                        .Help("Drift monitor: the fixed fiducial's residual in the last frame (mapped minus stored "
                              "position, mm); NaN when it was not seen")
                        .Register(reg)
                        .Add({});
  impl_->driftMm->Set(std::nan(""));
  impl_->driftAlarm = &prometheus::BuildGauge()
                           .Name("vgr_calibration_drift_alarm")
                           .Help("Drift monitor: 1 while the calibration drift alarm is up")
                           .Register(reg)
                           .Add({});
  impl_->fiducialMissed = &prometheus::BuildCounter()
                               .Name("vgr_calibration_fiducial_missed_total")
                               .Help("Drift monitor: frames in which the fiducial was not seen")
                               .Register(reg)
                               .Add({});
}

void Metrics::watchCalibrationFiles(std::vector<std::pair<std::string, std::string>> files) {
  if (files.empty()) return;
  addSampler([files = std::move(files)](std::vector<SampledMetric>& out) {
    namespace fs = std::filesystem;
    for (const auto& [label, path] : files) {
      std::error_code ec;
      const auto written = fs::last_write_time(path, ec);
      double age = -1;
      if (!ec) age = std::chrono::duration<double>(fs::file_time_type::clock::now() - written).count();
      out.push_back({"vgr_calibration_age_seconds",
                     "Age of each calibration file the cell maps with (now minus its modification time, s; -1 unreadable)",
                     SampledMetric::Type::Gauge, {{"file", label}, {"path", path}}, age});
    }
  });
}

void Metrics::triggered(TriggerSource source, bool accepted) {
  const auto i = static_cast<std::size_t>(source);
  if (i >= 3) return;
  (accepted ? impl_->triggers[i] : impl_->overruns[i])->Increment();
}

void Metrics::robotReplied(const std::string& robot, Status status) {
  const auto it = impl_->robotReplies.find(robot);
  if (it != impl_->robotReplies.end()) it->second[statusIndex(status)]->Increment();
}

void Metrics::addSampler(MetricSampler sampler) { impl_->samplers.push_back(std::move(sampler)); }

std::string Metrics::render() const {
  std::vector<prometheus::MetricFamily> families = impl_->registry.Collect();
  std::vector<SampledMetric> sampled;
  for (const auto& s : impl_->samplers) s(sampled);
  // One family per name, in the order first seen.
  std::map<std::string, std::size_t> byName;
  for (const auto& m : sampled) {
    auto [it, added] = byName.try_emplace(m.name, families.size());
    if (added) {
      prometheus::MetricFamily f;
      f.name = m.name;
      f.help = m.help;
      f.type = m.type == SampledMetric::Type::Counter ? prometheus::MetricType::Counter : prometheus::MetricType::Gauge;
      families.push_back(std::move(f));
    }
    prometheus::ClientMetric c;
    for (const auto& [k, v] : m.labels) c.label.push_back({k, v});
    if (m.type == SampledMetric::Type::Counter) c.counter.value = m.value;
    else c.gauge.value = m.value;
    families[it->second].metric.push_back(std::move(c));
  }
  std::ostringstream out;
  prometheus::TextSerializer().Serialize(out, families);
  return out.str();
}

}  // namespace vgr::daemon
