// `vgrd --check` and `vgr check`: loads and validates everything vgrd's start would load,
// without opening the camera or binding a port: the cell config (every key and range, every
// job folder: config/cell_config.hpp), each job's method built from its folder as vgrd
// builds it (daemon/job_locator.hpp), the calibration files with their residual limits
// (daemon/cell_mapping.hpp) and a camera ROI against their image size, the calibration check
// file, the journal path and the image archive's folder (writable or creatable), the robots'
// bind hosts (resolvable), the MQTT sink's setup with its TLS files (MqttSink::checkSetup),
// a replay camera's folder (the driver's open()). Not: an Aravis camera, free ports, the
// PLC or broker being reachable. Any thread; reads files only (creates no file, no folder).
//
// Exit codes (README "Running vgrd"), as vgrd's start would exit:
//   0  everything loads
//   2  the config file itself: cannot open, YAML syntax, unknown key, value out of range,
//      duplicate key, a port used twice, a job folder's job.yaml (the loader's
//      "FILE:LINE: key 'k': what")
//   1  the config parses but names something vgrd cannot use: a job whose method cannot be
//      built from its folder (the parameter's FILE:LINE), a calibration file missing or
//      outside its limits, an unwritable journal or archive, a bind host that does not
//      resolve, MQTT TLS files, a replay folder without images
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
