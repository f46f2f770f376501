// `vgrd --check` and `vgr check`: the cell config loaded and validated exactly as vgrd's
// start loads it (every key and range, every job folder: config/cell_config.hpp), with a
// one-line summary of what was found. Any thread; reads files only.
#pragma once

#include <string>

#include "config/cell_config.hpp"
#include "core/result.hpp"

namespace vgr::daemon {

struct CheckedConfig {
  config::CellConfig config;
  std::string summary;  // "N job(s), M robot endpoint(s), Modbus on|off"
};

// Errors are the loader's one line, "FILE:LINE: key 'camera.timeout_ms': ..." or
// "FILE: cannot open the config file" (Status::BadArgument).
Result<CheckedConfig> checkCellConfig(const std::string& path);

}  // namespace vgr::daemon
