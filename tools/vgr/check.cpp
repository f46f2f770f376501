#include "tools/vgr/check.hpp"

#include <cstdio>

#include <CLI/CLI.hpp>

#include "daemon/check.hpp"

namespace vgr::tools {

int runCheck(const CheckOptions& o) {
  auto checked = daemon::checkCellConfig(o.configPath);
  if (!checked) return badInput(checked.error().message);
  std::printf("%s: ok\n", o.configPath.c_str());
  return 0;
}

CLI::App* CheckCommand::add(CLI::App& parent) {
  auto* checkCmd = parent.add_subcommand("check", "validate a cell config; prints file:line and key on error");
  checkCmd->add_option("--config", options_.configPath, "cell config")->required();
  return checkCmd;
}

}  // namespace vgr::tools
