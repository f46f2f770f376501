// `vgrd --check` and `vgr check`: loads and validates everything vgrd's start would load,
// without opening the camera or binding a port: the cell config (every key and range, every
// job folder: config/cell_config.hpp), each job's method built from its folder as vgrd
// builds it (daemon/job_locator.hpp), the calibration files with their residual limits
// (daemon/cell_mapping.hpp), the journal path (writable), the robots' bind hosts
// (resolvable). Any thread; reads files only (creates no file, no folder).
//
// Exit codes (README "Checking a cell config"):
//   0  everything loads
//   2  the config file itself: cannot open, YAML syntax, unknown key, value out of range,
//      duplicate key, a job folder's job.yaml (the loader's "FILE:LINE: key 'k': what")
//   1  the config parses but names something vgrd cannot use: a job whose method cannot be
//      built from its folder (the parameter's FILE:LINE), a calibration file missing or
//      outside its limits, an unwritable journal, a bind host that does not resolve
#pragma once

#include <expected>
#include <string>

#include "config/cell_config.hpp"

namespace vgr::daemon {

struct CheckedConfig {
  config::CellConfig config;
  std::string summary;  // "N job(s), M robot endpoint(s), Modbus on|off"
};

struct CheckFailure {
  int exitCode = 2;     // 2: the config file; 1: what it names (see above)
  std::string message;  // one line, naming the file (and line)
};

using CheckResult = std::expected<CheckedConfig, CheckFailure>;

CheckResult checkCellConfig(const std::string& path);

}  // namespace vgr::daemon
