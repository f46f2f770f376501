#include "daemon/check.hpp"

#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <filesystem>

#include <fmt/format.h>

#include "daemon/cell_mapping.hpp"
#include "daemon/image_archive.hpp"
#include "daemon/job_locator.hpp"
#include "daemon/mqtt_sink.hpp"
#include "drivers/camera.hpp"
#include "vision/calib/check_file.hpp"

namespace vgr::daemon {
namespace {

// What vgrd's start does with a path it writes (Journal::open: create the folders, open the
// file for append; ImageArchive::start: create the folder), checked without creating
// anything: the path writable if it exists (a file, or a folder for `folder`), else the
// nearest existing folder above it.
std::string writableProblem(const std::string& path, bool folder) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path p(path);
  if (fs::exists(p, ec)) {
    if (fs::is_directory(p, ec) != folder) return folder ? "is not a folder" : "is a folder";
    return ::access(path.c_str(), folder ? W_OK | X_OK : W_OK) == 0 ? "" : "is not writable";
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
  // A 3D job's locator is built as vgrd builds it (its model's features: seconds).
  for (const auto& job : cfg->jobs) {
    if (!job.depth) {
      if (auto loc = makeJobLocator(job); !loc) return problem(loc.error().message);
    } else if (auto loc = makeJobLocator3d(job); !loc) {
      return problem(loc.error().message);
    }
  }
  // A depth camera's cell: its hand-eye file alone (the camera gives the intrinsics).
  if (cfg->camera.depth()) {
    if (auto frame = makeDepthCellFrame(*cfg); !frame) return problem("calibration: " + frame.error().message);
  }
  // The calibration vgrd maps with: files present, consistent and within their residual limits.
  auto mapping = cfg->camera.depth() ? Result<std::unique_ptr<vision::calib::PixelMapping>>(nullptr) : makeCellMapping(*cfg);
  if (!mapping) return problem("calibration: " + mapping.error().message);
  // A camera ROI fixes the frame size: a calibration for another size answers every cycle
  // -6 (CycleRunner's size check). Without both ROI sizes the size is the sensor's: unknown here.
  if (const auto size = *mapping ? (*mapping)->imageSize() : std::nullopt; size && cfg->camera.roiWidth > 0 && cfg->camera.roiHeight > 0 &&
                                                 (size->width != cfg->camera.roiWidth || size->height != cfg->camera.roiHeight))
    return problem(fmt::format("key 'camera.roi': the camera delivers {}x{} px, the calibration is for {}x{} px",
                               cfg->camera.roiWidth, cfg->camera.roiHeight, size->width, size->height));
  // A replay camera's folder, read as the camera worker's open() reads it (an Aravis camera
  // is not opened: the check opens no camera on the network).
  if (cfg->camera.driver == "replay") {
    auto cam = drivers::makeCamera(cfg->camera);
    if (!cam) return problem(cam.error().message);
    auto opened = (*cam)->open();
    (*cam)->close();
    if (!opened) return problem(opened.error().message);
  }
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
  if (const std::string why = writableProblem(cfg->journalPath, false); !why.empty())
    return problem(fmt::format("key 'cell.journal': journal {} {}", cfg->journalPath, why));
  if (cfg->archive.enabled) {
    const std::string dir = archiveDir(*cfg);
    if (const std::string why = writableProblem(dir, true); !why.empty())
      return problem(fmt::format("key 'archive.dir': archive folder {} {}", dir, why));
  }
  // The MQTT sink's setup as its start() does it (libmosquitto opens the TLS files).
  if (cfg->mqtt.enabled)
    if (auto r = MqttSink(cfg->mqtt, cfg->name, "").checkSetup(); !r) return problem("key 'mqtt.tls': " + r.error().message);
  for (std::size_t i = 0; i < cfg->robots.size(); ++i)
    if (const std::string why = resolveProblem(cfg->robots[i].bind); !why.empty())
      return problem(fmt::format("key 'robots[{}].bind': '{}' does not resolve: {}", i, cfg->robots[i].bind, why));

  std::string summary = fmt::format("{} job(s), {} robot endpoint(s), Modbus {}", cfg->jobs.size(), cfg->robots.size(),
                                    cfg->modbus.enabled ? "on" : "off");
  return CheckedConfig{std::move(*cfg), std::move(summary)};
}

}  // namespace vgr::daemon
