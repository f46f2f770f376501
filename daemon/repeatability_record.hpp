// The last live `vgr repeatability` run (tools/vgr/repeatability.hpp), as vgrd keeps it for
// the commissioning page (docs/commissioning.md, "Repeatability"): the figures an integrator
// signs a cell off with, next to the drift monitor, on the page the plant looks at.
//
// The tool measures over Modbus (it plays the PLC); vgrd does not know a run is going on. So
// the tool hands its figures to vgrd at the end of the run:
//
//   POST /api/repeatability?job=1&shots=100&found=100&failed=0
//        &x_mm=MEAN,SIGMA,RANGE&y_mm=...&z_mm=...&rx_deg=...&ry_deg=...&rz_deg=...
//        &bar_mm=B&bar_deg=B&pass=1                          (header X-Vgr-Action: 1)
//
// in the query (vgrd's web server takes no request bodies). Numbers are written in their
// shortest exact form, so the page shows exactly what the tool printed. A measurement, not an
// operator action: accepted with web.actions off, from the IPC itself (loopback) or an
// address in web.allowed_clients. vgrd checks every field (ranges, finite, found + failed =
// shots, the job configured), keeps the run in memory and writes it to
// <journal folder>/repeatability.json (write + rename: never half a file), which it reads
// back at start (a file it cannot read is reported on the page, never shown as figures).
// Thread: plain functions; the caller serialises (vgrd: the I/O thread).
#pragma once

#include <array>
#include <functional>
#include <optional>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "core/result.hpp"

namespace vgr::daemon {

struct AxisSpread {
  double mean = 0;   // mm or deg (angles: the circular mean's representative in (-180, 180])
  double sigma = 0;  // sample standard deviation
  double range = 0;  // max - min
};

struct RepeatabilityRun {
  int job = 0;        // [1, 32767]
  int shots = 0;      // [2, 100000]
  int found = 0;      // shots that delivered a part
  int failed = 0;     // shots without a part (status or timeout); found + failed = shots
  std::array<AxisSpread, 6> axes{};  // x_mm, y_mm, z_mm, rx_deg, ry_deg, rz_deg (robot base frame)
  double barMm = 0;   // the run's --max-sigma-mm (0: none given)
  double barDeg = 0;  // the run's --max-sigma-deg (0: none given)
  bool pass = false;  // the tool's verdict (exit 0)
  // Set by vgrd when it accepts the run.
  double at = 0;      // Unix time, s
  std::string from;   // the client's address
};

inline constexpr const char* kRepeatabilityAxes[6] = {"x_mm", "y_mm", "z_mm", "rx_deg", "ry_deg", "rz_deg"};

double maxSigmaMm(const RepeatabilityRun& r);
double maxSigmaDeg(const RepeatabilityRun& r);

// The query the tool sends (no leading '?').
std::string toQuery(const RepeatabilityRun& r);
// From a request's query parameters (`param(key)`: "" when absent). Every field checked.
Result<RepeatabilityRun> fromQuery(const std::function<std::string(const std::string&)>& param);

// The stored form and the page's section: {at (ISO 8601 UTC), unix_time, from, job, shots,
// found, failed, pass, max_sigma_mm, max_sigma_deg, bar_mm, bar_deg, x_mm: {mean, sigma,
// range}, ...}.
nlohmann::json toJson(const RepeatabilityRun& r);
Result<RepeatabilityRun> fromJson(const nlohmann::json& j);

// The file beside the journal.
std::string repeatabilityRecordPath(const std::string& journalPath);
Result<void> writeRepeatabilityRecord(const std::string& path, const RepeatabilityRun& r);
// nullopt when there is no file; an error when there is one that does not read.
Result<std::optional<RepeatabilityRun>> readRepeatabilityRecord(const std::string& path);

}  // namespace vgr::daemon
