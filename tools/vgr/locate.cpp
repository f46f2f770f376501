#include "tools/vgr/locate.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "config/cell_config.hpp"
#include "config/depth_dataset.hpp"
#include "config/job.hpp"
#include "config/job3d.hpp"
#include "core/status.hpp"
#include "core/pose.hpp"
#include "daemon/cell_mapping.hpp"
#include "daemon/job_locator.hpp"
#include "tools/vgr/calibrate_common.hpp"
#include "vision/calib/pixel_mapping.hpp"
#include "vision/cloud/locator3d.hpp"
#include "vision/depth_image.hpp"
#include "vision/gray_image.hpp"
#include "vision/locate/locator.hpp"
#include "vision/overlay.hpp"
#include "vision/part_poses.hpp"

namespace vgr::tools {

namespace {

namespace fs = std::filesystem;

nlohmann::ordered_json poseJson(const Pose& p) {
  return {{"x_mm", p.x}, {"y_mm", p.y}, {"z_mm", p.z}, {"qw", p.qw}, {"qx", p.qx}, {"qy", p.qy}, {"qz", p.qz}};
}

// A 3D job (docs/3d.md) on one depth image: poses in the camera frame (T_cam_model and the
// grasp T_cam_grasp), the outcome (found, not_found, retry_new_viewpoint) and its reason.
int runLocate3d(const LocateOptions& o) {
  if (!o.method.empty() || !o.flange.empty() || !o.overlay.empty())
    return badInput("--method, --flange and --overlay are for 2D jobs; " + o.job + " is a 3D job");
  auto job = config::loadJob3d(o.job);
  if (!job) return badInput(job.error().message);
  // The depth camera: --camera, else the data set's camera.yaml (DIR/images/x.png -> DIR).
  const std::string cameraPath =
      !o.camera.empty() ? o.camera : (fs::path(o.image).parent_path().parent_path() / "camera.yaml").string();
  auto camera = config::loadDepthCameraFile(cameraPath);
  if (!camera) return badInput(camera.error().message + (o.camera.empty() ? " (give the depth camera with --camera)" : ""));
  auto depth = vision::readDepthMm(o.image, camera->depthScaleMm, camera->width, camera->height);
  if (!depth) return badInput(depth.error().message);
  auto locator = daemon::makeJobLocator3d(*job);  // as vgrd builds it
  if (!locator) return badInput(locator.error().message);
  const auto t0 = std::chrono::steady_clock::now();
  auto out = (*locator)->locate(*depth, camera->intrinsics());
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (!out) return badInput(o.image + ": " + out.error().message);
  nlohmann::ordered_json j;
  j["outcome"] = std::string(vision::cloud::outcomeName(out->outcome));
  j["reason"] = out->reason;
  j["time_ms"] = ms;
  j["parts"] = nlohmann::json::array();
  for (const auto& part : out->parts)
    j["parts"].push_back({{"pose", poseJson(part.pose)}, {"grasp", poseJson(part.grasp)}, {"fitness", part.fitness},
                          {"contradiction", part.contradiction}, {"rmse_mm", part.rmseMm}, {"refined", part.refined}});
  if (o.json) {
    std::printf("%s\n", j.dump().c_str());
    return 0;
  }
  std::printf("%s: %s, %zu part(s) in %.0f ms%s\n", o.image.c_str(), j["outcome"].get<std::string>().c_str(),
              out->parts.size(), ms, out->reason.empty() ? "" : (" (" + out->reason + ")").c_str());
  for (const auto& part : out->parts) {
    const Pose& p = part.pose;
    std::printf("  model in camera: %.2f %.2f %.2f mm  q %.5f %.5f %.5f %.5f  fitness %.3f  RMSE %.3f mm%s\n", p.x, p.y, p.z,
                p.qw, p.qx, p.qy, p.qz, part.fitness, part.rmseMm, part.refined ? "  (refined)" : "");
    const Pose& g = part.grasp;
    std::printf("  grasp in camera: %.2f %.2f %.2f mm  q %.5f %.5f %.5f %.5f\n", g.x, g.y, g.z, g.qw, g.qx, g.qy, g.qz);
  }
  return 0;
}

}  // namespace

int runLocate(const LocateOptions& o) {
  if (auto kind = config::jobKind(o.job); kind && *kind == "3d") return runLocate3d(o);
  if (!o.camera.empty()) return badInput("--camera is for 3D jobs (a depth camera's camera.yaml); " + o.job + " is a 2D job");
  auto job = config::loadJob(o.job);
  if (!job) return badInput(job.error().message);
  const std::string method = o.method.empty() ? job->method : o.method;
  auto read = vision::readGray8(o.image);
  if (!read) return badInput(read.error().message);
  const cv::Mat img = *read;
  // With a calibration (a cell config), pixels map to the robot frame exactly as vgrd maps
  // them: the mapping that cell selects (daemon/cell_mapping.hpp) and vision::partPoses.
  std::unique_ptr<vision::calib::PixelMapping> mapping;
  vision::PartPoseRules rules;
  if (!job->calibration.empty()) {
    auto cell = config::loadCellConfig(job->calibrationPath());
    if (!cell) return badInput(cell.error().message);
    auto m = daemon::makeCellMapping(*cell);
    if (!m) return badInput(m.error().message);
    mapping = std::move(*m);
    if (const auto size = mapping->imageSize(); size && (size->width != img.cols || size->height != img.rows))
      return badInput(fmt::format("{}: the calibration is for {}x{} px, {} is {}x{} px", job->calibrationPath(), size->width,
                                  size->height, o.image, img.cols, img.rows));
    rules.heightMm = job->partHeightMm;
  }
  // Eye-in-hand: the image maps with the camera where the flange was.
  std::optional<vision::calib::SnapshotMapping> snapshot;
  if (mapping && mapping->eyeInHand()) {
    if (o.flange.empty())
      return badInput(job->calibrationPath() + ": the calibration is eye-in-hand (the camera on the flange): give the image's "
                                               "flange pose with --flange x,y,z,qw,qx,qy,qz");
    std::vector<double> v;
    std::string_view rest(o.flange);
    while (true) {
      const auto comma = rest.find(',');
      const std::string field(rest.substr(0, comma));
      char* end = nullptr;
      const double d = std::strtod(field.c_str(), &end);
      if (field.empty() || end != field.c_str() + field.size() || !std::isfinite(d))
        return badInput("--flange: '" + field + "' is not a number (expected x,y,z,qw,qx,qy,qz)");
      v.push_back(d);
      if (comma == std::string_view::npos) break;
      rest.remove_prefix(comma + 1);
    }
    const double n = v.size() == 7 ? std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]) : 0.0;
    if (v.size() != 7 || std::abs(n - 1.0) > 1e-3)
      return badInput("--flange: expected x,y,z,qw,qx,qy,qz (mm and a unit quaternion), got '" + o.flange + "'");
    snapshot.emplace(*mapping->eyeInHand(), poseFromQuaternion(v[0], v[1], v[2], v[3], v[4], v[5], v[6]));
  } else if (!o.flange.empty()) {
    return badInput("--flange goes with an eye-in-hand calibration; this job's camera is fixed");
  }
  const vision::calib::PixelMapping* mapWith = snapshot ? &*snapshot : mapping.get();
  auto locator = daemon::makeJobLocator(*job, method);
  if (!locator) return badInput(locator.error().message);
  if (!o.overlay.empty()) {
    if (auto w = checkOutputPath(o.overlay, "--overlay"); !w) return badInput(w.error().message);
    if (!cv::haveImageWriter(o.overlay)) return badInput(o.overlay + ": --overlay needs a .png (or another image) file name");
  }
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
    // An image the job cannot search (smaller than the template, the ROI outside it: the
    // locator's input check) is bad input; anything else the method could not do, 1.
    return out.error().code == Status::BadArgument ? 2 : 1;
  }
  const Status status = out->parts.empty() ? Status::NoPartFound : Status::Ok;
  if (!o.overlay.empty()) {
    vision::OverlayFrame f;
    f.job = daemon::overlayJobFor(*job);
    f.parts = vision::overlayParts(out->parts);
    f.caption = fmt::format("{}  {}  {} part{}", method, statusName(status), out->parts.size(), out->parts.size() == 1 ? "" : "s");
    f.ok = status == Status::Ok;
    if (!cv::imwrite(o.overlay, vision::drawOverlay(img, f))) return badInput(o.overlay + ": cannot write the overlay");
  }
  j["status"] = static_cast<int>(status);
  j["method"] = method;
  j["time_ms"] = ms;
  j["parts"] = nlohmann::json::array();
  for (const auto& d : out->parts) {
    nlohmann::ordered_json p;
    p["x_px"] = d.u;
    p["y_px"] = d.v;
    p["angle_deg"] = d.angleDeg;
    p["scale"] = d.scale;
    p["score"] = d.score;
    if (!job->classify.model.empty()) {  // a classifying job (docs/classification.md): 0 = unknown
      p["label"] = d.label;
      p["confidence"] = d.confidence;
    }
    if (mapWith) {
      const auto parts = vision::partPoses({d}, *mapWith, rules);
      if (!parts.empty()) {
        const Pose& pose = parts.front().pose;
        p["x_mm"] = pose.x;
        p["y_mm"] = pose.y;
        p["z_mm"] = pose.z;
        p["rz_deg"] = toEulerZyxDeg(pose).rz;
      }
    }
    j["parts"].push_back(p);
  }
  if (o.json) {
    std::printf("%s\n", j.dump().c_str());
  } else {
    std::printf("%s: %zu part(s) in %.1f ms (%s)\n", o.image.c_str(), out->parts.size(), ms, method.c_str());
    for (const auto& d : out->parts) {
      std::printf("  x %.2f px  y %.2f px  angle %.2f deg  scale %.4f  score %.3f", d.u, d.v, d.angleDeg, d.scale, d.score);
      if (!job->classify.model.empty()) std::printf("  label %d (confidence %.3f)", d.label, d.confidence);
      std::printf("\n");
    }
  }
  return 0;
}

CLI::App* LocateCommand::add(CLI::App& parent) {
  auto& l = options_;
  auto* locateCmd = parent.add_subcommand("locate", "run a job's method on one image (a 3D job on one depth image)");
  locateCmd->add_option("--job", l.job, "job folder")->required();
  locateCmd->add_option("--image", l.image, "image file")->required();
  locateCmd->add_option("--method", l.method, "override the job's method");
  locateCmd->add_flag("--json", l.json, "one JSON object: status, time_ms, parts");
  locateCmd->add_option("--flange", l.flange, "eye-in-hand calibration: the image's flange pose x,y,z,qw,qx,qy,qz (mm)");
  locateCmd->add_option("--overlay", l.overlay, "write the image with the parts, grasp points and search ROI drawn on it (PNG)");
  locateCmd->add_option("--camera", l.camera, "3D job: the depth camera's camera.yaml (default: the image's data set's)");
  return locateCmd;
}

}  // namespace vgr::tools
