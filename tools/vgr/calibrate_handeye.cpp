#include "tools/vgr/calibrate_handeye.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "core/pose.hpp"
#include "vision/calib/handeye.hpp"
#include "vision/calib/intrinsics.hpp"
#include "vision/calib/mapping.hpp"
#include "vision/calib/robot_pose_file.hpp"
#include "vision/calib/se3.hpp"
#include "vision/gray_image.hpp"

namespace vgr::tools {
namespace calib = vision::calib;
namespace se3 = vision::se3;
namespace fs = std::filesystem;

int runCalibrateHandEye(const CalibHandEyeOptions& o) {
  if (o.cloud) return runCalibrateHandEyeCloud(o);
  if (auto w = checkOutputPath(o.out); !w) return bad(w.error().message);
  if (o.intrinsics.empty()) return bad("--intrinsics: the camera's intrinsics.yaml is needed (or --cloud for a depth camera)");
  auto spec = patternSpec(o.pattern);
  if (!spec) return bad(spec.error().message);
  auto cam = calib::readIntrinsics(o.intrinsics);
  if (!cam) return bad(cam.error().message);
  const std::string posePath = (fs::path(o.folder) / "poses.txt").string();
  auto poses = calib::loadPoseFile(posePath);
  if (!poses) return bad(poses.error().message);
  // Images in the folder that poses.txt does not mention: a count mismatch worth an error.
  std::vector<std::string> unlisted;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(o.folder, ec)) {
    const std::string ext = e.path().extension().string();
    if (ext != ".png" && ext != ".bmp" && ext != ".tif" && ext != ".tiff" && ext != ".jpg") continue;
    const std::string n = e.path().filename().string();
    if (std::none_of(poses->begin(), poses->end(), [&](const auto& p) { return p.image == n; })) unlisted.push_back(n);
  }
  if (!unlisted.empty()) {
    std::sort(unlisted.begin(), unlisted.end());
    std::string list;
    for (const auto& u : unlisted) list += (list.empty() ? "" : ", ") + u;
    return bad(fmt::format("{}: {} poses but {} more images in {} without a pose: {}", posePath, poses->size(),
                           unlisted.size(), o.folder, list));
  }
  std::vector<calib::HandEyeView> views;
  std::vector<std::string> notFound;
  for (std::size_t i = 0; i < poses->size(); ++i) {
    const auto& p = (*poses)[i];
    const std::string file = (fs::path(o.folder) / p.image).string();
    auto read = vision::readGray8(file);
    if (!read) return bad(fmt::format("{}:{}: image '{}' cannot be read ({})", posePath, p.line, p.image, read.error().message));
    const cv::Mat img = *read;
    if (img.size() != cam->imageSize)
      return bad(fmt::format("{}: {}x{} px, the intrinsics are for {}x{} px", file, img.cols, img.rows,
                             cam->imageSize.width, cam->imageSize.height));
    auto d = calib::detectPattern(img, *spec, p.image);
    if (d.found && !d.ids.empty() && d.ids.size() != static_cast<std::size_t>(spec->cols * spec->rows)) {
      d.found = false;  // hand-eye uses the whole plate in every view
      d.note = fmt::format("partial charuco view, {} of {} corners: hand-eye needs the whole plate", d.corners.size(),
                           spec->cols * spec->rows);
    }
    progress(i + 1, poses->size(), p.image, d.found ? "found" : "pattern NOT found" + (d.note.empty() ? "" : ": " + d.note));
    if (!d.found) {
      notFound.push_back(p.image);
      continue;
    }
    views.push_back({p.image, p.baseFromGripper, d.corners});
  }
  if (!notFound.empty()) {
    std::string list;
    for (const auto& u : notFound) list += (list.empty() ? "" : ", ") + u;
    std::fprintf(stderr, "warning: pattern not found in %zu of %zu images, they are left out: %s\n", notFound.size(),
                 poses->size(), list.c_str());
  }
  Result<calib::HandEyeResult> r = o.configuration == "auto" ? calib::calibrateHandEyeAuto(views, *cam, *spec)
                                   : o.configuration == "eye-in-hand"
                                       ? calib::calibrateHandEye(views, *cam, *spec, calib::HandEyeConfig::EyeInHand)
                                   : o.configuration == "eye-to-hand"
                                       ? calib::calibrateHandEye(views, *cam, *spec, calib::HandEyeConfig::EyeToHand)
                                       : Result<calib::HandEyeResult>(fail(Status::BadArgument,
                                             fmt::format("--configuration '{}': expected eye-in-hand, eye-to-hand or auto",
                                                         o.configuration)));
  if (!r) return bad(r.error().message);
  auto truth = readHandEyeTruth(o.truth);
  if (!truth) return bad(truth.error().message);
  for (const auto& w : r->warnings) std::printf("warning: %s\n", w.c_str());
  std::printf("hand-eye %s, %zu views\n", calib::handEyeConfigName(r->config), views.size());
  nlohmann::json methods = printHandEyeMethods(*r, *truth, "reproj_px");
  std::printf("chosen: %s\n", r->reason.c_str());
  {
    // The limits vgrd loads a hand-eye file with: a result beyond them would only make every
    // cycle answer NOT_CALIBRATED.
    const calib::CellCalibrationLimits limits;
    const auto& b = r->bestResult();
    if (b.reprojRmsPx > limits.maxReprojPx || b.transResidMm > limits.maxHandEyeMm || b.rotResidDeg > limits.maxHandEyeDeg)
      return implausible("hand-eye result",
                         fmt::format("{} reprojects the plate at {:.2f} px RMS (limit {} px) and the views disagree by "
                                     "{:.2f} mm / {:.3f} deg RMS (limits {} mm / {} deg)",
                                     b.method, b.reprojRmsPx, limits.maxReprojPx, b.transResidMm, b.rotResidDeg,
                                     limits.maxHandEyeMm, limits.maxHandEyeDeg),
                         "Hint: check --square (the printed square's size in mm, measured on the plate), --cols/--rows (inner corners), --intrinsics (the same camera at the same resolution) and the poses' units and --pose-format");
  }
  return writeHandEyeAndReport(o, *r, "reproj_px", views.size(), methods);
}

CLI::App* CalibrateHandEyeCommand::add(CLI::App& parent) {
  auto& calHe = options_;
  auto* calHeCmd = parent.add_subcommand("handeye", "hand-eye from a folder of plate images (or depth images, --cloud) + poses.txt");
  calHeCmd->add_option("--folder", calHe.folder, "folder with poses.txt and the images it names")->required();
  calHeCmd->add_option("--intrinsics", calHe.intrinsics, "intrinsics.yaml from 'vgr calibrate intrinsics' (2D camera)");
  calHeCmd->add_flag("--cloud", calHe.cloud, "a depth camera: depth images of a sphere target (paper 003's point-cloud registration)");
  calHeCmd->add_option("--target", calHe.target, "--cloud: the sphere target, target.yaml (default FOLDER/target.yaml)");
  calHeCmd->add_option("--camera", calHe.camera, "--cloud: camera.yaml of the depth images (default FOLDER/camera.yaml)");
  calHeCmd->add_option("--configuration", calHe.configuration, "eye-in-hand, eye-to-hand or auto");
  addPatternOptions(*calHeCmd, calHe.pattern);
  calHeCmd->add_option("--out", calHe.out, "handeye.yaml to write");
  calHeCmd->add_option("--truth", calHe.truth, "truth.yaml of a synthetic set: print each method's error");
  calHeCmd->add_flag("--json", calHe.json, "end with one JSON line");
  return calHeCmd;
}

Result<std::optional<calib::HandEyeFile>> readHandEyeTruth(const std::string& path) {
  if (path.empty()) return std::optional<calib::HandEyeFile>{};
  auto t = calib::readHandEye(path);
  if (!t) return std::unexpected(t.error());
  return std::optional<calib::HandEyeFile>{*t};
}

nlohmann::json printHandEyeMethods(const calib::HandEyeResult& r, const std::optional<calib::HandEyeFile>& truth,
                                   const char* fitName) {
  const bool point = std::string_view(fitName) == "point_mm";
  std::printf("  %-15s %-5s %11s %11s %10s%s\n", "method", "ok", "resid_mm", "resid_deg", fitName,
              truth ? "   err_X_mm  err_X_deg" : "");
  nlohmann::json methods = nlohmann::json::array();
  for (const auto& m : r.methods) {
    std::string tr;
    double emm = -1, edeg = -1;
    if (truth && m.x.qw * m.x.qw + m.x.qx * m.x.qx + m.x.qy * m.x.qy + m.x.qz * m.x.qz > 0.5) {
      const se3::Iso d = se3::toIso(truth->x).inverse() * se3::toIso(m.x);
      emm = d.translation().norm();
      edeg = se3::rotationAngleDeg(d.linear());
      tr = fmt::format(" {:10.3f} {:10.4f}", emm, edeg);
    }
    const double fit = point ? m.pointRmsMm : m.reprojRmsPx;
    std::printf("  %-15s %-5s %11.3f %11.4f %10.3f%s%s\n", m.method.c_str(), m.valid ? "yes" : "NO", m.transResidMm,
                m.rotResidDeg, fit, tr.c_str(), m.valid ? "" : ("  " + m.note).c_str());
    methods.push_back({{"method", m.method}, {"valid", m.valid}, {"resid_mm", m.transResidMm},
                       {"resid_deg", m.rotResidDeg}, {fitName, fit}, {"note", m.note}});
    if (truth) methods.back()["err_x_mm"] = emm, methods.back()["err_x_deg"] = edeg;
  }
  return methods;
}

int writeHandEyeAndReport(const CalibHandEyeOptions& o, const calib::HandEyeResult& r, const char* fitName,
                          std::size_t viewsUsed, const nlohmann::json& methods) {
  if (auto w = calib::writeHandEye(o.out, r); !w) return bad(w.error().message);
  std::printf("written: %s\n", o.out.c_str());
  if (o.json) {
    const auto& b = r.bestResult();
    const Vec3 rv = toRotationVector(b.x);
    const double fit = std::string_view(fitName) == "point_mm" ? b.pointRmsMm : b.reprojRmsPx;
    nlohmann::json j{{"configuration", calib::handEyeConfigName(r.config)},
                     {"method", b.method},
                     {"x_mm", {b.x.x, b.x.y, b.x.z}},
                     {"x_rotvec_rad", {rv.x, rv.y, rv.z}},
                     {"resid_mm", b.transResidMm},
                     {"resid_deg", b.rotResidDeg},
                     {fitName, fit},
                     {"views_used", viewsUsed},
                     {"methods", methods},
                     {"out", o.out}};
    std::printf("%s\n", j.dump().c_str());
  }
  return 0;
}

}  // namespace vgr::tools
