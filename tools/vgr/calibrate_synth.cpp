#include "tools/vgr/calibrate_synth.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <opencv2/imgcodecs.hpp>

#include "config/cell_config.hpp"
#include "core/pose.hpp"
#include "config/depth_dataset.hpp"
#include "sim/calib_scene.hpp"
#include "sim/depth_calib_scene.hpp"
#include "vision/calib/handeye.hpp"
#include "vision/calib/intrinsics.hpp"
#include "vision/calib/robot_pose_file.hpp"
#include "vision/calib/se3.hpp"

namespace vgr::tools {
namespace calib = vision::calib;
namespace se3 = vision::se3;
namespace fs = std::filesystem;

namespace {

// The views' images, poses.txt and truth.yaml (handeye.yaml layout, for `--truth`) in `dir`.
int writeHandEyeSet(const sim::TrueCamera& cam, const calib::PatternSpec& spec, const sim::HandEyeScenario& s,
                    const CalibSynthOptions& o, const fs::path& dir) {
  sim::PlateRenderOptions ro;
  std::vector<calib::PoseEntry> poses;
  for (std::size_t i = 0; i < s.camFromPlate.size(); ++i) {
    ro.seed = o.seed * 1000 + i;
    const std::string name = fmt::format("pose_{:03d}.png", i);
    cv::imwrite((dir / name).string(), sim::renderPlate(cam, spec, s.camFromPlate[i], ro));
    poses.push_back({name, s.robotReported[i], 0});
    progress(i + 1, s.camFromPlate.size(), name, "rendered");
  }
  if (auto w = calib::writePoseFile((dir / "poses.txt").string(), o.poseFormat, poses); !w) return bad(w.error().message);
  if (auto w = calib::writeHandEyeTruth((dir / "truth.yaml").string(), s.config, s.x, s.y); !w) return bad(w.error().message);
  return 0;
}

// A plate lying face up on the conveyor plane (z = planeZ), centred at (x, y), for
// `vgr calibrate plane --image`, seen by the eye-to-hand camera mounted at `baseFromCam`.
void writeConveyorPlate(const sim::TrueCamera& cam, const calib::PatternSpec& spec, const Pose& baseFromCam, double x,
                        double y, double planeZ, std::uint64_t seed, const fs::path& dir) {
  const Eigen::Vector3d centre((spec.cols - 1) * spec.pitchMm / 2, (spec.rows - 1) * spec.pitchMm / 2, 0);
  const se3::Iso basePlate = Eigen::Translation3d(x, y, planeZ) * Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) * Eigen::Translation3d(-centre);
  sim::PlateRenderOptions ro;
  ro.seed = seed * 1000 + 999;
  fs::create_directories(dir);  // not in the hand-eye folder: it has no robot pose
  cv::imwrite((dir / "conveyor_plate.png").string(),
              sim::renderPlate(cam, spec, se3::toPose(se3::toIso(baseFromCam).inverse() * basePlate), ro));
}

Result<void> writeCameraTruth(const sim::TrueCamera& cam, const fs::path& path) {
  calib::CameraIntrinsics truthCam;
  truthCam.cameraMatrix = cam.cameraMatrix;
  truthCam.dist = cam.dist;
  truthCam.imageSize = cam.imageSize;
  return calib::writeIntrinsics(path.string(), truthCam);
}

// --kind cell: what commissioning a real eye-to-hand cell collects, for the cell's own
// camera (docs/calibration.md, "The simulated cell, calibrated like a real one"):
// intrinsics/ (a plate shown at varied tilts), handeye/ (the plate on the flange, robot
// poses), plane/ (the plate lying on the conveyor).
int synthCell(const CalibSynthOptions& o, const calib::PatternSpec& spec) {
  auto cell = o.cellConfig.empty() ? config::parseCellConfig(config::embeddedSimCellYaml(), "<embedded sim-cell.yaml>")
                                   : config::loadCellConfig(o.cellConfig);
  if (!cell) return bad(cell.error().message);
  const sim::TrueCamera cam = sim::cellCamera(*cell);
  const Pose mount = sim::cellCameraMount(*cell);
  // Plates held 300-460 mm below a camera 500 mm above the belt (randomPlateViews: +-20 %).
  const double distance = std::min(o.distanceMm, 0.76 * (cell->model.camZ - cell->model.planeZ));
  const fs::path out(o.out);
  fs::create_directories(out / "intrinsics");
  fs::create_directories(out / "handeye");
  if (auto w = writeCameraTruth(cam, out / "camera_truth.yaml"); !w) return bad(w.error().message);
  sim::PlateRenderOptions ro;
  if (o.partialShare > 0 && spec.kind != calib::PatternKind::Charuco)
    return bad(fmt::format("--partial {}: partial views need --pattern charuco (a {} must be seen whole)", o.partialShare,
                           o.pattern.pattern));
  // --partial applies to the intrinsics views only: hand-eye and plane need the whole plate.
  const auto views = sim::randomPlateViews(cam, spec, o.views, o.seed, distance, o.maxTiltDeg, 25, o.partialShare);
  for (std::size_t i = 0; i < views.size(); ++i) {
    ro.seed = o.seed * 1000 + 500 + i;
    const std::string name = fmt::format("plate_{:03d}.png", i);
    cv::imwrite((out / "intrinsics" / name).string(), sim::renderPlate(cam, spec, views[i], ro));
    progress(i + 1, views.size(), "intrinsics/" + name, "rendered");
  }
  const auto s = sim::makeHandEyeScenario(calib::HandEyeConfig::EyeToHand, cam, spec, o.views, o.seed + 1, o.robotNoiseMm,
                                          o.robotNoiseDeg, mount, distance);
  if (int rc = writeHandEyeSet(cam, spec, s, o, out / "handeye"); rc != 0) return rc;
  writeConveyorPlate(cam, spec, mount, cell->model.camX, cell->model.camY, cell->model.planeZ, o.seed, out / "plane");
  std::printf("%s: intrinsics/ (%zu views), handeye/ (%zu poses, eye-to-hand, %s), plane/ and camera_truth.yaml for %s\n",
              o.out.c_str(), views.size(), s.camFromPlate.size(), o.poseFormat.c_str(),
              o.cellConfig.empty() ? "the embedded sim cell" : o.cellConfig.c_str());
  return 0;
}

// --kind handeye-cloud: a depth camera and the sphere target (docs/calibration.md, "Depth
// cameras"): camera.yaml (3D data-set format), target.yaml, images/pose_NNN.png (16-bit z),
// poses.txt naming them, truth.yaml.
int synthHandEyeCloud(const CalibSynthOptions& o, calib::HandEyeConfig cfg) {
  sim::DepthCamera cam = sim::defaultDepthCamera();
  if (o.depthFocalPx > 0) cam.intrinsics.fx = cam.intrinsics.fy = o.depthFocalPx;  // e.g. the 3D scenes' camera (800 px)
  const auto target = sim::defaultSphereTarget();
  const auto footprint = sim::sphereTargetFootprint();
  sim::TrueCamera plateCam;  // the depth camera as the view generator wants it (no distortion)
  plateCam.cameraMatrix = cv::Matx33d(cam.intrinsics.fx, 0, cam.intrinsics.cx, 0, cam.intrinsics.fy, cam.intrinsics.cy, 0, 0, 1);
  plateCam.dist = cv::Vec<double, 5>(0, 0, 0, 0, 0);
  plateCam.imageSize = cv::Size(cam.width, cam.height);
  const fs::path dir(o.out);
  fs::create_directories(dir / "images");
  config::DepthCameraFile camFile;
  camFile.width = cam.width;
  camFile.height = cam.height;
  camFile.setIntrinsics(cam.intrinsics);
  camFile.depthScaleMm = cam.depthScaleMm;
  if (auto w = config::writeDepthCameraFile((dir / "camera.yaml").string(), camFile); !w) return bad(w.error().message);
  if (auto w = calib::writeSphereTarget((dir / "target.yaml").string(), target); !w) return bad(w.error().message);
  const auto s = sim::makeHandEyeScenario(cfg, plateCam, footprint, o.views, o.seed, o.robotNoiseMm, o.robotNoiseDeg,
                                          std::nullopt, o.distanceMm);
  std::vector<calib::PoseEntry> poses;
  for (std::size_t i = 0; i < s.camFromPlate.size(); ++i) {
    sim::DepthRenderOptions ro;
    ro.noiseSigmaMm = o.depthNoiseMm;
    ro.seed = o.seed * 1000 + i;
    const std::string name = fmt::format("images/pose_{:03d}.png", i);
    const cv::Mat depth = sim::renderSphereTargetDepth(cam, target, footprint, s.camFromPlate[i], ro);
    if (!cv::imwrite((dir / name).string(), sim::quantiseDepth(depth, cam.depthScaleMm)))
      return bad(fmt::format("{}: cannot write", (dir / name).string()));
    poses.push_back({name, s.robotReported[i], 0});
    progress(i + 1, s.camFromPlate.size(), name, "rendered");
  }
  if (auto w = calib::writePoseFile((dir / "poses.txt").string(), o.poseFormat, poses); !w) return bad(w.error().message);
  if (auto w = calib::writeHandEyeTruth((dir / "truth.yaml").string(), s.config, s.x, s.y); !w) return bad(w.error().message);
  std::printf("%zu depth images (%.2f mm noise), poses.txt (%s), camera.yaml, target.yaml and truth.yaml in %s\n",
              s.camFromPlate.size(), o.depthNoiseMm, o.poseFormat.c_str(), o.out.c_str());
  return 0;
}

}  // namespace

int runCalibrateSynth(const CalibSynthOptions& o) {
  auto spec = patternSpec(o.pattern);
  if (!spec) return bad(spec.error().message);
  if (o.out.empty()) return bad("--out: a folder is needed");
  if (o.poseFormat != "abb" && o.poseFormat != "fanuc" && o.poseFormat != "ur")
    return bad(fmt::format("--pose-format '{}': expected abb, fanuc or ur", o.poseFormat));
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (ec) return bad(fmt::format("{}: {}", o.out, ec.message()));
  if (o.kind == "cell") return synthCell(o, *spec);
  if (o.kind == "handeye-cloud") {
    if (o.configuration == "eye-in-hand") return synthHandEyeCloud(o, calib::HandEyeConfig::EyeInHand);
    if (o.configuration == "eye-to-hand") return synthHandEyeCloud(o, calib::HandEyeConfig::EyeToHand);
    return bad(fmt::format("--configuration '{}': expected eye-in-hand or eye-to-hand", o.configuration));
  }
  const sim::TrueCamera cam = sim::defaultCalibCamera();
  // The true camera, in the intrinsics file format (for comparison).
  if (auto w = writeCameraTruth(cam, fs::path(o.out) / "camera_truth.yaml"); !w) return bad(w.error().message);
  if (o.kind == "intrinsics") {
    sim::PlateRenderOptions ro;
    if (o.partialShare > 0 && spec->kind != calib::PatternKind::Charuco)
      return bad(fmt::format("--partial {}: partial views need --pattern charuco (a {} must be seen whole)",
                             o.partialShare, o.pattern.pattern));
    const auto poses = sim::randomPlateViews(cam, *spec, o.views, o.seed, o.distanceMm, o.maxTiltDeg, 25, o.partialShare);
    for (std::size_t i = 0; i < poses.size(); ++i) {
      ro.seed = o.seed * 1000 + i;
      const std::string name = fmt::format("plate_{:03d}.png", i);
      cv::imwrite((fs::path(o.out) / name).string(), sim::renderPlate(cam, *spec, poses[i], ro));
      progress(i + 1, poses.size(), name, "rendered");
    }
    std::printf("%zu plate images and camera_truth.yaml in %s\n", poses.size(), o.out.c_str());
    return 0;
  }
  if (o.kind != "handeye") return bad(fmt::format("--kind '{}': expected intrinsics, handeye, handeye-cloud or cell", o.kind));
  calib::HandEyeConfig cfg;
  if (o.configuration == "eye-in-hand") cfg = calib::HandEyeConfig::EyeInHand;
  else if (o.configuration == "eye-to-hand") cfg = calib::HandEyeConfig::EyeToHand;
  else return bad(fmt::format("--configuration '{}': expected eye-in-hand or eye-to-hand", o.configuration));
  const auto s = sim::makeHandEyeScenario(cfg, cam, *spec, o.views, o.seed, o.robotNoiseMm, o.robotNoiseDeg);
  if (int rc = writeHandEyeSet(cam, *spec, s, o, fs::path(o.out)); rc != 0) return rc;
  if (cfg == calib::HandEyeConfig::EyeToHand) writeConveyorPlate(cam, *spec, s.x, 330, -60, 0, o.seed, fs::path(o.out) / "plane");
  std::printf("%zu images, poses.txt (%s), truth.yaml and camera_truth.yaml in %s\n", s.camFromPlate.size(),
              o.poseFormat.c_str(), o.out.c_str());
  return 0;
}

CLI::App* CalibrateSynthCommand::add(CLI::App& parent) {
  auto& calSyn = options_;
  auto* calSynCmd = parent.add_subcommand("synth", "render a synthetic calibration set with ground truth");
  calSynCmd->add_option("--kind", calSyn.kind,
                        "intrinsics, handeye, handeye-cloud (a depth camera and a sphere target) or cell (all three sets for a "
                        "cell's camera)");
  calSynCmd->add_option("--depth-noise-mm", calSyn.depthNoiseMm, "handeye-cloud: Gaussian depth noise per pixel, mm")
      ->check(CLI::Range(0.0, 10.0));
  calSynCmd->add_option("--depth-focal", calSyn.depthFocalPx, "handeye-cloud: the depth camera's focal length, px (default 570)")
      ->check(CLI::Range(100.0, 5000.0));
  calSynCmd->add_option("--cell", calSyn.cellConfig, "cell config for --kind cell (default: the embedded sim cell)");
  calSynCmd->add_option("--out", calSyn.out, "folder to write")->required();
  calSynCmd->add_option("--configuration", calSyn.configuration, "eye-in-hand or eye-to-hand (handeye)");
  calSynCmd->add_option("--pose-format", calSyn.poseFormat, "abb, fanuc or ur (handeye)");
  addPatternOptions(*calSynCmd, calSyn.pattern);
  calSynCmd->add_option("--views", calSyn.views, "number of views")->check(CLI::Range(1, 1000));
  calSynCmd->add_option("--seed", calSyn.seed, "random seed");
  calSynCmd->add_option("--robot-noise-mm", calSyn.robotNoiseMm, "robot position noise, mm per axis");
  calSynCmd->add_option("--robot-noise-deg", calSyn.robotNoiseDeg, "robot rotation noise, deg per axis");
  calSynCmd->add_option("--max-tilt", calSyn.maxTiltDeg, "largest plate tilt, deg");
  calSynCmd->add_option("--distance", calSyn.distanceMm, "camera-plate distance, mm");
  calSynCmd->add_option("--partial", calSyn.partialShare, "share of views with the plate partly outside the image (charuco)")
      ->check(CLI::Range(0.0, 1.0));
  return calSynCmd;
}

}  // namespace vgr::tools
