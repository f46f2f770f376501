#include "daemon/commissioning_status.hpp"

#include <cmath>

#include <nlohmann/json.hpp>

#include "daemon/drift_monitor.hpp"

namespace vgr::daemon {
namespace {

nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(std::round(v * 1000) / 1000 + 0.0) : nlohmann::json(nullptr); }

}  // namespace

void fillDriftSection(const DriftMonitor& monitor, nlohmann::json& out) {
  const DriftMonitor::Snapshot s = monitor.snapshot();
  const auto& c = monitor.config();
  out["residual_mm"] = number(s.residualMm);
  out["median_mm"] = number(s.medianMm);
  out["alarm"] = s.alarm;
  out["reason"] = s.reason;
  out["threshold_mm"] = c.thresholdMm;
  out["window"] = c.window;
  out["on_alarm"] = c.refuse ? "refuse" : "warn";
  out["frames_seen"] = s.seen;
  out["frames_missed"] = s.missed;
}

}  // namespace vgr::daemon
