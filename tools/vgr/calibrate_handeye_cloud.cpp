// `vgr calibrate handeye --cloud`: hand-eye of a depth camera from depth images of a sphere
// target (docs/calibration.md, "Depth cameras: hand-eye by point-cloud registration").
//   FOLDER/camera.yaml   the 3D data-set format's camera file (intrinsics, depth_scale_mm)
//   FOLDER/target.yaml   the sphere target (vision/calib/sphere_target.hpp)
//   FOLDER/poses.txt     robot poses, naming one 16-bit depth PNG each (robot_pose_file.hpp)
#include <cstdio>
#include <filesystem>
#include <optional>
#include <vector>

#include <fmt/core.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/depth_dataset.hpp"
#include "core/pose.hpp"
#include "tools/vgr/calibrate_handeye.hpp"
#include "vision/calib/handeye_cloud.hpp"
#include "vision/calib/mapping.hpp"
#include "vision/calib/robot_pose_file.hpp"
#include "vision/calib/se3.hpp"
#include "vision/calib/sphere_target.hpp"

namespace vgr::tools {
namespace calib = vision::calib;
namespace se3 = vision::se3;
namespace fs = std::filesystem;

int runCalibrateHandEyeCloud(const CalibHandEyeOptions& o) {
  if (auto w = checkOutputPath(o.out); !w) return bad(w.error().message);
  if (!o.intrinsics.empty()) return bad("--intrinsics goes with a 2D camera; a depth camera's intrinsics are in --camera (camera.yaml)");
  const std::string cameraPath = o.camera.empty() ? (fs::path(o.folder) / "camera.yaml").string() : o.camera;
  const std::string targetPath = o.target.empty() ? (fs::path(o.folder) / "target.yaml").string() : o.target;
  auto camera = config::loadDepthCameraFile(cameraPath);
  if (!camera) return bad(camera.error().message);
  auto target = calib::readSphereTarget(targetPath);
  if (!target) return bad(target.error().message);
  const std::string posePath = (fs::path(o.folder) / "poses.txt").string();
  auto poses = calib::loadPoseFile(posePath);
  if (!poses) return bad(poses.error().message);

  std::vector<calib::CloudHandEyeView> views;
  std::vector<std::string> notFound;
  for (std::size_t i = 0; i < poses->size(); ++i) {
    const auto& p = (*poses)[i];
    const std::string file = (fs::path(o.folder) / p.image).string();
    const cv::Mat raw = cv::imread(file, cv::IMREAD_UNCHANGED);
    if (raw.empty()) return bad(fmt::format("{}:{}: depth image '{}' cannot be read", posePath, p.line, p.image));
    if (raw.type() != CV_16UC1)
      return bad(fmt::format("{}: not a 16-bit single-channel depth image ({} channel(s), {}-bit): the 3D data-set format "
                             "stores z as 16-bit PNG",
                             file, raw.channels(), raw.depth() == CV_8U ? 8 : raw.depth() == CV_16U ? 16 : 32));
    if (raw.cols != camera->width || raw.rows != camera->height)
      return bad(fmt::format("{}: {}x{} px, {} is for {}x{} px", file, raw.cols, raw.rows, cameraPath, camera->width,
                             camera->height));
    cv::Mat depth;
    raw.convertTo(depth, CV_32F, camera->depthScaleMm);  // 0 stays 0: no data
    const auto found = calib::findSpheres(depth, camera->intrinsics(), target->radiusMm);
    auto m = calib::matchSphereTarget(found, *target);
    if (!m) {
      progress(i + 1, poses->size(), p.image, "target NOT found: " + m.error().message);
      notFound.push_back(p.image);
      continue;
    }
    progress(i + 1, poses->size(), p.image,
             fmt::format("{} of {} spheres, fit {:.3f} mm", m->ids.size(), target->centres.size(), m->fitRmsMm));
    views.push_back({p.image, p.baseFromGripper, m->ids, m->points});
  }
  if (!notFound.empty()) {
    std::string list;
    for (const auto& u : notFound) list += (list.empty() ? "" : ", ") + u;
    std::fprintf(stderr, "warning: target not found in %zu of %zu depth images, they are left out: %s\n", notFound.size(),
                 poses->size(), list.c_str());
  }
  Result<calib::HandEyeResult> r =
      o.configuration == "auto"          ? calib::calibrateHandEyeCloudAuto(views, *target)
      : o.configuration == "eye-in-hand" ? calib::calibrateHandEyeCloud(views, *target, calib::HandEyeConfig::EyeInHand)
      : o.configuration == "eye-to-hand"
          ? calib::calibrateHandEyeCloud(views, *target, calib::HandEyeConfig::EyeToHand)
          : Result<calib::HandEyeResult>(fail(Status::BadArgument, fmt::format("--configuration '{}': expected eye-in-hand, "
                                                                               "eye-to-hand or auto",
                                                                               o.configuration)));
  if (!r) return bad(r.error().message);
  auto truth = readHandEyeTruth(o.truth);
  if (!truth) return bad(truth.error().message);
  for (const auto& w : r->warnings) std::printf("warning: %s\n", w.c_str());
  std::printf("hand-eye %s (depth camera, sphere target), %zu views\n", calib::handEyeConfigName(r->config), views.size());
  nlohmann::json methods = printHandEyeMethods(*r, *truth, "point_mm");
  std::printf("chosen: %s\n", r->reason.c_str());
  {
    const calib::CellCalibrationLimits limits;
    const auto& b = r->bestResult();
    if (b.pointRmsMm > limits.maxPointRmsMm || b.transResidMm > limits.maxHandEyeMm || b.rotResidDeg > limits.maxHandEyeDeg)
      return implausible("hand-eye result",
                         fmt::format("{} fits the target points at {:.2f} mm RMS (limit {} mm) and the views disagree by "
                                     "{:.2f} mm / {:.3f} deg RMS (limits {} mm / {} deg)",
                                     b.method, b.pointRmsMm, limits.maxPointRmsMm, b.transResidMm, b.rotResidDeg,
                                     limits.maxHandEyeMm, limits.maxHandEyeDeg),
                         "Hint: check target.yaml (the sphere radius and centres, in mm, as built), camera.yaml's "
                         "depth_scale_mm and the poses' units and format");
  }
  return writeHandEyeAndReport(o, *r, "point_mm", views.size(), methods);
}

}  // namespace vgr::tools
