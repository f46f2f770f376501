#include "tools/vgr/check.hpp"

#include <cstdio>

#include <CLI/CLI.hpp>

#include "daemon/check.hpp"

namespace vgr::tools {

int runCheck(const CheckOptions& o) {
  auto checked = daemon::checkCellConfig(o.configPath);
  if (!checked) {
    std::fprintf(stderr, "%s\n", checked.error().message.c_str());
    return checked.error().exitCode;
  }
  std::printf("%s: ok\n", o.configPath.c_str());
  return 0;
}

CLI::App* CheckCommand::add(CLI::App& parent) {
  auto* checkCmd = parent.add_subcommand("check", "validate a cell config and everything vgrd would load from it (job folders, calibration files, journal, "
                                        "bind hosts); exit 2 for the config file (file:line and key), 1 for what it names");
  checkCmd->add_option("--config", options_.configPath, "cell config")->required();
  return checkCmd;
}

}  // namespace vgr::tools
