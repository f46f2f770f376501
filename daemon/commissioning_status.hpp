// The commissioning figures vgrd puts on the page (docs/commissioning.md) beside the page's
// own, through its extension point (WebPage::addStatusSection, /api/status -> sections):
//   "drift"  the drift monitor's state after the last frame (daemon/drift_monitor.hpp).
// ("repeatability", the last live `vgr repeatability` run, is the page's own: the tool posts
// it, daemon/repeatability_record.hpp.)
// Thread: the fill function runs on the I/O thread (the page's status) and takes the
// monitor's short snapshot lock.
#pragma once

#include <nlohmann/json_fwd.hpp>

namespace vgr::daemon {

class DriftMonitor;

// residual_mm (null when not seen), median_mm, alarm, reason, threshold_mm, window,
// on_alarm, frames_seen, frames_missed.
void fillDriftSection(const DriftMonitor& monitor, nlohmann::json& out);

}  // namespace vgr::daemon
