// vgrd: the vision-guided robotics daemon (run by systemd, Type=notify).
//   vgrd --config /etc/vgr/cell.yaml            run the cell
//   vgrd --config FILE --check                  validate the config and all it names, exit
//                                               (0 valid, 2 config file error, 1 a job, calibration
//                                               file, journal or bind host vgrd cannot use: daemon/check.hpp)
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>

#include "core/cli.hpp"

#include "config/cell_config.hpp"
#include "core/log.hpp"
#include "core/version.hpp"
#include "daemon/check.hpp"
#include "daemon/vgrd_app.hpp"

int main(int argc, char** argv) {
  CLI::App app{"vgrd: vision-guided robotics daemon"};
  vgr::cli::showDefaults(app);
  app.set_version_flag("--version", std::string("vgrd ") + vgr::buildVersion());
  std::string configPath = "/etc/vgr/cell.yaml";
  std::string journalPath;
  std::string logLevel;
  bool check = false;
  app.add_option("--config", configPath, "cell config (YAML)");
  app.add_flag("--check", check,
               "validate the config and everything it names (job folders and their methods, calibration files, journal, "
               "bind hosts) and exit: 0 when valid; 2 for the config file itself (one line naming file:line and key); 1 "
               "when it names something vgrd cannot use");
  app.add_option("--journal", journalPath, "override cell.journal (the per-cycle JSON-lines journal)");
  app.add_option("--log-level", logLevel, "override cell.log_level");
  if (const auto rc = vgr::cli::parse(app, argc, argv)) return *rc;

  if (check) {
    auto checked = vgr::daemon::checkCellConfig(configPath);
    if (!checked) {
      std::fprintf(stderr, "vgrd: %s\n", checked.error().message.c_str());
      return checked.error().exitCode;
    }
    std::printf("%s: ok (%s)\n", configPath.c_str(), checked->summary.c_str());
    return 0;
  }
  // The start loads the config alone: what it names (job folders' methods, calibration
  // files, journal, bind addresses) fails where the start uses it (exit 1), and a missing
  // calibration leaves vgrd running and answering -6 NOT_CALIBRATED.
  auto loaded = vgr::config::loadCellConfig(configPath);
  if (!loaded) {
    std::fprintf(stderr, "vgrd: %s\n", loaded.error().message.c_str());
    return 2;
  }
  vgr::config::CellConfig& cfg = *loaded;
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
