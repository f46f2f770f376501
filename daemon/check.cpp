#include "daemon/check.hpp"

#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <filesystem>

#include <fmt/format.h>

#include "daemon/cell_mapping.hpp"
#include "daemon/job_locator.hpp"
#include "vision/calib/check_file.hpp"

namespace vgr::daemon {
namespace {

// What Journal::open does (create the folders, open for append), checked without creating
// anything: the file writable if it exists, else the nearest existing folder above it.
std::string journalProblem(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path p(path);
  if (fs::exists(p, ec)) {
    if (fs::is_directory(p, ec)) return "is a folder";
    return ::access(path.c_str(), W_OK) == 0 ? "" : "is not writable";
  }
  fs::path dir = p.parent_path();
  if (dir.empty()) dir = ".";
  while (!fs::exists(dir, ec) && dir.has_parent_path() && dir != dir.parent_path()) dir = dir.parent_path();
  if (!fs::is_directory(dir, ec)) return fmt::format("cannot be created: {} is not a folder", dir.string());
  if (::access(dir.c_str(), W_OK | X_OK) != 0) return fmt::format("cannot be created: {} is not writable", dir.string());
  return "";
}

// The robot server binds a name as it resolves (passive); "" when it does.
std::string resolveProblem(const std::string& host) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE;
  addrinfo* res = nullptr;
  const int rc = ::getaddrinfo(host.c_str(), nullptr, &hints, &res);
  if (res) ::freeaddrinfo(res);
  return rc == 0 ? "" : ::gai_strerror(rc);
}

}  // namespace

CheckResult checkCellConfig(const std::string& path) {
  auto cfg = config::loadCellConfig(path);
  if (!cfg) return std::unexpected(CheckFailure{2, cfg.error().message});
  auto problem = [&](const std::string& what) { return std::unexpected(CheckFailure{1, path + ": " + what}); };

  // Each job's method, built as vgrd's start builds it (its errors name the job.yaml line).
  for (const auto& job : cfg->jobs)
    if (auto loc = makeJobLocator(job); !loc) return problem(loc.error().message);
  // The calibration vgrd maps with: files present, consistent and within their residual limits.
  if (auto m = makeCellMapping(*cfg); !m) return problem("calibration: " + m.error().message);
  // The check targets (vgr calibrate verify, the drift monitor): the file loads, names a job
  // of the cell, and has the fiducial the drift monitor watches.
  if (!cfg->calibration.check.empty()) {
    auto check = vision::calib::readCheckFile(cfg->calibration.check);
    if (!check) return problem("key 'calibration.check': " + check.error().message);
    if (cfg->calibration.drift.enabled && !check->fiducial.present)
      return problem(fmt::format("key 'calibration.drift': {} has no 'fiducial' for the drift monitor to watch",
                                 cfg->calibration.check));
    if (check->part.present && !cfg->findJob(check->part.job))
      return problem(fmt::format("key 'calibration.check': {}: part.job {} is not a job of this cell", cfg->calibration.check,
                                 check->part.job));
  }
  if (const std::string why = journalProblem(cfg->journalPath); !why.empty())
    return problem(fmt::format("key 'cell.journal': journal {} {}", cfg->journalPath, why));
  for (std::size_t i = 0; i < cfg->robots.size(); ++i)
    if (const std::string why = resolveProblem(cfg->robots[i].bind); !why.empty())
      return problem(fmt::format("key 'robots[{}].bind': '{}' does not resolve: {}", i, cfg->robots[i].bind, why));

  std::string summary = fmt::format("{} job(s), {} robot endpoint(s), Modbus {}", cfg->jobs.size(), cfg->robots.size(),
                                    cfg->modbus.enabled ? "on" : "off");
  return CheckedConfig{std::move(*cfg), std::move(summary)};
}

}  // namespace vgr::daemon
