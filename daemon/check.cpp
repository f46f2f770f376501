#include "daemon/check.hpp"

#include <fmt/format.h>

namespace vgr::daemon {

Result<CheckedConfig> checkCellConfig(const std::string& path) {
  auto cfg = config::loadCellConfig(path);
  if (!cfg) return std::unexpected(cfg.error());
  std::string summary = fmt::format("{} job(s), {} robot endpoint(s), Modbus {}", cfg->jobs.size(), cfg->robots.size(),
                                    cfg->modbus.enabled ? "on" : "off");
  return CheckedConfig{std::move(*cfg), std::move(summary)};
}

}  // namespace vgr::daemon
