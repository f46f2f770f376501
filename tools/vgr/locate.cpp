#include "tools/vgr/locate.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/cell_config.hpp"
#include "config/job.hpp"
#include "core/status.hpp"
#include "vision/calib/plane_model.hpp"
#include "vision/locate/locator.hpp"

namespace vgr::tools {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

// Pixels -> robot base frame with the job's calibration (a cell config's `model`), at the
// part's grasp height; the angle is the direction of a 20 px step along the part's axis,
// mapped the same way (as daemon/cycle_runner.cpp does).
struct RobotMapping {
  vision::PinholePlaneModel model;
  double heightMm;
};

}  // namespace

int runLocate(const LocateOptions& o) {
  auto job = config::loadJob(o.job);
  if (!job) return badInput(job.error().message);
  const std::string method = o.method.empty() ? job->method : o.method;
  const cv::Mat templ = cv::imread(job->templatePath(), cv::IMREAD_GRAYSCALE);
  if (templ.empty()) return badInput(job->templatePath() + ": cannot read the template image");
  const cv::Mat img = cv::imread(o.image, cv::IMREAD_GRAYSCALE);
  if (img.empty()) return badInput(o.image + ": cannot read the image");
  std::optional<RobotMapping> robot;
  if (!job->calibration.empty()) {
    auto cell = config::loadCellConfig(job->calibrationPath());
    if (!cell) return badInput(cell.error().message);
    const auto& m = cell->model;
    robot = RobotMapping{vision::PinholePlaneModel(m.fx, m.fy, m.cx, m.cy,
                                                   vision::PinholePlaneModel::downLookingCamera(m.camX, m.camY, m.camZ, m.camRzDeg),
                                                   m.planeZ),
                         job->partHeightMm};
  }
  auto locator = vision::makeLocator(method, templ, job->taught);
  if (!locator) return badInput(locator.error().message);
  const auto t0 = std::chrono::steady_clock::now();
  auto out = (*locator)->locate(img);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  nlohmann::ordered_json j;
  if (!out) {
    j["status"] = static_cast<int>(out.error().code);
    j["error"] = out.error().message;
    j["time_ms"] = ms;
    j["parts"] = nlohmann::json::array();
    std::printf("%s\n", j.dump().c_str());
    return 1;
  }
  j["status"] = out->parts.empty() ? static_cast<int>(Status::NoPartFound) : static_cast<int>(Status::Ok);
  j["method"] = method;
  j["time_ms"] = ms;
  j["parts"] = nlohmann::json::array();
  for (const auto& d : out->parts) {
    nlohmann::ordered_json p;
    p["x_px"] = d.u;
    p["y_px"] = d.v;
    p["angle_deg"] = d.angleDeg;
    p["score"] = d.score;
    if (robot) {
      const double a = d.angleDeg * kDegToRad;
      const auto q0 = robot->model.pixelToPlane({d.u, d.v}, robot->heightMm);
      const auto q1 = robot->model.pixelToPlane({d.u + 20 * std::cos(a), d.v - 20 * std::sin(a)}, robot->heightMm);
      if (q0 && q1) {
        p["x_mm"] = q0->x;
        p["y_mm"] = q0->y;
        p["z_mm"] = q0->z;
        p["rz_deg"] = std::remainder(std::atan2(q1->y - q0->y, q1->x - q0->x) / kDegToRad, 360.0);
      }
    }
    j["parts"].push_back(p);
  }
  if (o.json) {
    std::printf("%s\n", j.dump().c_str());
  } else {
    std::printf("%s: %zu part(s) in %.1f ms (%s)\n", o.image.c_str(), out->parts.size(), ms, method.c_str());
    for (const auto& d : out->parts)
      std::printf("  x %.2f px  y %.2f px  angle %.2f deg  score %.3f\n", d.u, d.v, d.angleDeg, d.score);
  }
  return 0;
}

CLI::App* LocateCommand::add(CLI::App& parent) {
  auto& l = options_;
  auto* locateCmd = parent.add_subcommand("locate", "run a job's method on one image");
  locateCmd->add_option("--job", l.job, "job folder")->required();
  locateCmd->add_option("--image", l.image, "image file")->required();
  locateCmd->add_option("--method", l.method, "override the job's method");
  locateCmd->add_flag("--json", l.json, "one JSON object: status, time_ms, parts");
  return locateCmd;
}

}  // namespace vgr::tools
