// vgrd: the vision-guided robotics daemon (run by systemd, Type=notify).
//   vgrd --config /etc/vgr/cell.yaml            run the cell
//   vgrd --config FILE --check                  validate the config and exit (non-zero on error)
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>

#include "config/cell_config.hpp"
#include "core/log.hpp"
#include "core/version.hpp"
#include "daemon/check.hpp"
#include "daemon/vgrd_app.hpp"

int main(int argc, char** argv) {
  CLI::App app{"vgrd: vision-guided robotics daemon"};
  app.set_version_flag("--version", std::string("vgrd ") + vgr::buildVersion());
  std::string configPath = "/etc/vgr/cell.yaml";
  std::string journalPath;
  std::string logLevel;
  bool check = false;
  app.add_option("--config", configPath, "cell config (YAML)");
  app.add_flag("--check", check, "validate the config and exit: 0 when valid, 2 with one line naming file:line and key when not");
  app.add_option("--journal", journalPath, "override cell.journal (the per-cycle JSON-lines journal)");
  app.add_option("--log-level", logLevel, "override cell.log_level");
  CLI11_PARSE(app, argc, argv);

  auto checked = vgr::daemon::checkCellConfig(configPath);
  if (!checked) {
    std::fprintf(stderr, "vgrd: %s\n", checked.error().message.c_str());
    return 2;
  }
  if (check) {
    std::printf("%s: ok (%s)\n", configPath.c_str(), checked->summary.c_str());
    return 0;
  }
  vgr::config::CellConfig& cfg = checked->config;
  if (!journalPath.empty()) cfg.journalPath = journalPath;
  vgr::log::Level level = vgr::log::Level::Info;
  if (!vgr::log::parseLevel(logLevel.empty() ? cfg.logLevel : logLevel, level)) {
    std::fprintf(stderr, "vgrd: unknown log level '%s'\n", logLevel.c_str());
    return 2;
  }
  vgr::log::setDefaultLevel(level);

  vgr::daemon::VgrdApp daemon(std::move(cfg));
  if (auto r = daemon.start(); !r) {
    std::fprintf(stderr, "vgrd: %s\n", r.error().message.c_str());
    return 1;
  }
  return daemon.run();
}
