#include "daemon/drift_monitor.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/core.h>
#include <opencv2/core.hpp>

#include "core/log.hpp"

namespace vgr::daemon {

DriftMonitor::DriftMonitor(const config::CalibrationFilesConfig::Drift& cfg, const vision::calib::CheckFile::Fiducial& fiducial)
    : cfg_(cfg), fiducial_(fiducial) {
  snap_.residualMm = std::numeric_limits<double>::quiet_NaN();
  snap_.medianMm = std::numeric_limits<double>::quiet_NaN();
  search_.window = fiducial.window;
  search_.bright = fiducial.bright;
  search_.expectedAreaPx = fiducial.areaPx;
  ring_.assign(static_cast<std::size_t>(std::max(1, cfg.window)), 0.0);
  scratch_.reserve(ring_.size());
}

std::string DriftMonitor::describe() const {
  return fmt::format("fiducial at ({:.3f}, {:.3f}, {:.3f}) mm in window {}x{} at ({}, {}) px, alarm above {} mm (median of {} "
                     "frames), on alarm: {}",
                     fiducial_.positionMm.x, fiducial_.positionMm.y, fiducial_.positionMm.z, fiducial_.window.width,
                     fiducial_.window.height, fiducial_.window.x, fiducial_.window.y, cfg_.thresholdMm, cfg_.window,
                     cfg_.refuse ? "refuse (-6)" : "warn");
}

void DriftMonitor::measure(const cv::Mat& gray, const vision::calib::PixelMapping& mapping, CycleResult& r) {
  r.driftMonitored = true;
  r.driftMm = std::numeric_limits<double>::quiet_NaN();
  const auto found = vision::calib::locateFiducial(gray, search_);
  if (found) {
    if (const auto p = mapping.pixelToRobot(found->centre, fiducial_.heightMm)) {
      r.driftMm = std::sqrt((p->x - fiducial_.positionMm.x) * (p->x - fiducial_.positionMm.x) +
                            (p->y - fiducial_.positionMm.y) * (p->y - fiducial_.positionMm.y) +
                            (p->z - fiducial_.positionMm.z) * (p->z - fiducial_.positionMm.z));
    }
  }
  if (std::isfinite(r.driftMm)) {
    ++seen_;
    missesInRow_ = 0;
    ring_[next_] = r.driftMm;
    next_ = (next_ + 1) % ring_.size();
    count_ = std::min(count_ + 1, ring_.size());
  } else {
    ++missed_;
    ++missesInRow_;
  }

  bool up = false;
  std::string why;
  double median = std::numeric_limits<double>::quiet_NaN();
  if (missesInRow_ >= cfg_.window) {
    up = true;
    why = fmt::format("fiducial not seen in {} frames in a row ({})", missesInRow_,
                      found ? "its centre does not map" : found.error().message);
  } else if (count_ >= std::min<std::size_t>(ring_.size(), 3)) {
    scratch_.assign(ring_.begin(), ring_.begin() + static_cast<std::ptrdiff_t>(count_));
    const auto mid = scratch_.begin() + static_cast<std::ptrdiff_t>(count_ / 2);
    std::nth_element(scratch_.begin(), mid, scratch_.end());
    median = *mid;
    if (count_ % 2 == 0) median = (median + *std::max_element(scratch_.begin(), mid)) / 2;
    if (median > cfg_.thresholdMm) {
      up = true;
      why = fmt::format("median residual {:.3f} mm over the last {} frames above {} mm", median, count_, cfg_.thresholdMm);
    }
  }
  if (up && !alarm_) {
    log::warn("cycle", "calibration drift ALARM at cycle {}: {} (check the camera mount; vgr calibrate verify)", r.cycleId, why);
  } else if (!up && alarm_) {
    log::info("cycle", "calibration drift alarm cleared at cycle {} (was: {})", r.cycleId, reason_);
  }
  const bool changed = up != alarm_ || (up && why != reason_);
  alarm_ = up;
  if (up) reason_ = std::move(why);
  else reason_.clear();
  r.driftAlarm = alarm_;
  std::lock_guard lock(snapMutex_);
  snap_.residualMm = r.driftMm;
  snap_.medianMm = median;
  snap_.alarm = alarm_;
  if (changed) snap_.reason = reason_;  // a copy only when it changes
  snap_.seen = seen_;
  snap_.missed = missed_;
}

DriftMonitor::Snapshot DriftMonitor::snapshot() const {
  std::lock_guard lock(snapMutex_);
  return snap_;
}

}  // namespace vgr::daemon
