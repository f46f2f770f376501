#include "tools/vgr/grasp.hpp"

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "tools/vgr/grasp_dataset.hpp"
#include "vision/calib/handeye.hpp"
#include "vision/calib/mapping.hpp"
#include "vision/calib/pixel_mapping.hpp"
#include "vision/grasp/grasp_input.hpp"
#include "vision/grasp/grasp_pose.hpp"

namespace vgr::tools {
namespace {

namespace fs = std::filesystem;
namespace vg = vision::grasp;

// Where grasps go in the robot frame: the 3D calibration, the plane calibration, or none.
struct RobotFrame {
  std::optional<Pose> baseFromCamera;                 // 3D
  std::unique_ptr<vision::calib::PixelMapping> plane;  // plane
  std::string describe;
};

Result<RobotFrame> loadRobotFrame(const GraspDetectOptions& o, const vg::DepthIntrinsics& camera) {
  RobotFrame f;
  const bool anyPlane = !o.intrinsics.empty() || !o.handEye.empty() || !o.plane.empty();
  if (!o.cameraPose.empty()) {
    auto he = vision::calib::readHandEye(o.cameraPose);
    if (!he) return fail(Status::BadArgument, fmt::format("{}: {}", o.cameraPose, he.error().message));
    if (he->config != vision::calib::HandEyeConfig::EyeToHand)
      return fail(Status::BadArgument, o.cameraPose + ": a fixed depth camera needs an eye-to-hand calibration (X = T_base_cam)");
    f.baseFromCamera = he->x;
    f.describe = "3D calibration " + o.cameraPose;
    return f;
  }
  if (anyPlane) {
    if (o.intrinsics.empty() || o.handEye.empty() || o.plane.empty())
      return fail(Status::BadArgument, "the plane calibration needs --intrinsics, --handeye and --plane together");
    auto m = vision::calib::loadCellCalibration(o.intrinsics, o.handEye, o.plane);
    if (!m) return std::unexpected(m.error());
    f.plane = vision::calib::cameraPlaneMapping(*m);
    const auto size = f.plane->imageSize();
    if (size && (size->width != camera.width || size->height != camera.height))
      return fail(Status::NotCalibrated, fmt::format("{}: calibrated for {}x{} px images, the depth images are {}x{} (camera.yaml)",
                                                     o.intrinsics, size->width, size->height, camera.width, camera.height));
    f.describe = "plane calibration " + o.plane;
  }
  return f;
}

// A minimal .npy (format 1.0) writer: header, then the rows as they come.
class NpyWriter {
 public:
  Result<void> open(const std::string& path, const char* descr, const std::vector<int>& shape) {
    path_ = path;
    out_.open(path, std::ios::binary);
    if (!out_) return fail(Status::BadArgument, path + ": cannot create");
    std::string dims;
    for (int d : shape) dims += std::to_string(d) + ", ";
    if (shape.size() > 1) dims.resize(dims.size() - 1);
    std::string header = fmt::format("{{'descr': '{}', 'fortran_order': False, 'shape': ({}), }}", descr, dims);
    const std::size_t total = 10 + header.size() + 1;
    header += std::string((64 - total % 64) % 64, ' ') + "\n";
    const std::uint16_t len = static_cast<std::uint16_t>(header.size());
    out_.write("\x93NUMPY\x01\x00", 8);
    out_.put(static_cast<char>(len & 0xff));
    out_.put(static_cast<char>(len >> 8));
    out_ << header;
    return {};
  }
  void write(const cv::Mat& m) {  // continuous
    out_.write(reinterpret_cast<const char*>(m.data), static_cast<std::streamsize>(m.total() * m.elemSize()));
  }
  Result<void> close() {
    out_.close();
    if (!out_) return fail(Status::Internal, path_ + ": cannot write");
    return {};
  }

 private:
  std::string path_;
  std::ofstream out_;
};

}  // namespace

int runGraspDetect(const GraspDetectOptions& o) {
  auto set = loadGraspDataset(o.dataset);
  if (!set) return badInput(set.error().message);
  auto frameMap = loadRobotFrame(o, set->camera);
  if (!frameMap) return badInput(frameMap.error().message);
  auto det = vg::makeGraspDetector(o.detector);
  if (!det) return badInput(det.error().message);
  std::vector<const GraspImage*> images;
  for (const auto& img : set->images)
    if (o.image.empty() || img.image == o.image) images.push_back(&img);
  if (images.empty()) return badInput(fmt::format("{}: no image '{}' in grasps.csv", o.dataset, o.image));
  if (o.limit > 0 && images.size() > static_cast<std::size_t>(o.limit)) images.resize(static_cast<std::size_t>(o.limit));

  int withGrasp = 0;
  for (const auto* img : images) {
    auto frame = loadGraspFrame(*set, *img);
    if (!frame) return badInput(frame.error().message);
    auto grasps = (*det)->detect(*frame);
    if (!grasps) return badInput(grasps.error().message);
    nlohmann::ordered_json j;
    j["image"] = img->image;
    j["detector"] = std::string((*det)->name());
    j["grasps"] = nlohmann::json::array();
    for (const auto& g : *grasps) {
      const auto pc = vg::backProject(set->camera, g.u, g.v, g.depthMm);
      nlohmann::ordered_json gj = {{"u_px", g.u},         {"v_px", g.v},          {"angle_deg", g.angleDeg}, {"width_px", g.widthPx},
                                   {"quality", g.quality}, {"depth_mm", g.depthMm}, {"height_mm", g.heightMm}, {"width_mm", g.widthMm},
                                   {"camera", {{"x_mm", pc.x}, {"y_mm", pc.y}, {"z_mm", pc.z}}}};
      Result<vg::RobotGrasp> rg = fail(Status::NotCalibrated, "");
      if (frameMap->baseFromCamera) rg = vg::graspToRobot3d(g, set->camera, *frameMap->baseFromCamera);
      else if (frameMap->plane) rg = vg::graspToRobotPlane(g, *frameMap->plane);
      if (frameMap->baseFromCamera || frameMap->plane) {
        if (rg)
          gj["robot"] = {{"x_mm", rg->centre.x}, {"y_mm", rg->centre.y}, {"z_mm", rg->centre.z},
                         {"rz_deg", rg->angleDeg}, {"width_mm", rg->widthMm}, {"via", frameMap->describe}};
        else
          gj["robot"] = {{"error", rg.error().message}};
      }
      j["grasps"].push_back(gj);
    }
    withGrasp += !grasps->empty();
    std::printf("%s\n", j.dump().c_str());
    std::fflush(stdout);  // line by line, before any error on stderr
  }
  return withGrasp > 0 ? 0 : 1;
}

int runGraspTensors(const GraspTensorsOptions& o) {
  auto set = loadGraspDataset(o.dataset);
  if (!set) return badInput(set.error().message);
  std::error_code ec;
  if (fs::exists(o.out, ec) && !(fs::is_directory(o.out, ec) && fs::is_empty(o.out, ec)))
    return badInput(o.out + ": exists and is not an empty folder");
  fs::create_directories(o.out, ec);
  if (ec) return badInput(fmt::format("{}: cannot create: {}", o.out, ec.message()));
  std::size_t n = set->images.size();
  if (o.limit > 0) n = std::min(n, static_cast<std::size_t>(o.limit));
  if (n == 0) return badInput(o.dataset + ": no images in grasps.csv");

  NpyWriter input, target;
  std::ofstream names(fs::path(o.out) / "images.txt");
  int rows = 0, cols = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto& img = set->images[i];
    auto frame = loadGraspFrame(*set, img);
    if (!frame) return badInput(frame.error().message);
    auto floor = vg::fitFloorPlane(frame->zMm, frame->camera, frame->name);
    if (!floor) return badInput(floor.error().message);
    const auto scale = vg::netScale(frame->camera, *floor, frame->name);
    if (!scale) return badInput(scale.error().message);
    const vg::NetInput in = vg::makeNetInput(vg::heightAboveFloor(frame->zMm, frame->camera, *floor), *scale);
    if (i == 0) {
      rows = in.tensor.rows, cols = in.tensor.cols;
      const int N = static_cast<int>(n);
      if (auto r = input.open((fs::path(o.out) / "input.npy").string(), "<f2", {N, 1, rows, cols}); !r) return badInput(r.error().message);
      if (auto r = target.open((fs::path(o.out) / "target.npy").string(), "<f2", {N, 4, rows, cols}); !r) return badInput(r.error().message);
    } else if (in.tensor.rows != rows || in.tensor.cols != cols) {
      return badInput(fmt::format("{}: its network input is {}x{}, the first image's {}x{}: one camera per data set", frame->name,
                                  in.tensor.cols, in.tensor.rows, cols, rows));
    }
    std::vector<vg::TargetGrasp> tg;
    for (const auto& g : img.grasps) tg.push_back({g.u, g.v, g.angleDeg, g.widthPx, set->camera.fx / g.zMm, 2.0});
    const auto maps = vg::drawNetTargets(tg, in);
    cv::Mat half;
    in.tensor.convertTo(half, CV_16F);
    input.write(half);
    for (const auto& m : maps) {
      m.convertTo(half, CV_16F);
      target.write(half);
    }
    names << img.image << "\n";
  }
  if (auto r = input.close(); !r) return badInput(r.error().message);
  if (auto r = target.close(); !r) return badInput(r.error().message);
  names.close();
  if (!names) return badInput((fs::path(o.out) / "images.txt").string() + ": cannot write");
  std::printf("{\"out\":\"%s\",\"images\":%zu,\"rows\":%d,\"cols\":%d}\n", o.out.c_str(), n, rows, cols);
  return 0;
}

CLI::App* GraspDetectCommand::add(CLI::App& parent) {
  auto& o = options_;
  auto* c = parent.add_subcommand("detect", "grasps in the depth images of a data set, in px, camera and robot frame (docs/grasp.md)");
  c->add_option("--dataset", o.dataset, "a 3D data set with grasps.csv (vgr sim render --3d --grasps)")->required();
  c->add_option("--image", o.image, "only this image of the data set (e.g. images/0003.png)");
  c->add_option("--limit", o.limit, "first N images only")->check(CLI::Range(0, 100000000));
  c->add_option("--detector", o.detector.detector, "ggcnn (default) or analytic");
  c->add_option("--model", o.detector.modelPath, "ggcnn: the ONNX file (models/grasp/ggcnn.onnx)");
  c->add_option("--min-quality", o.detector.minQuality, "ggcnn: peaks below Q are not grasps (default 0.2)")->check(CLI::Range(0.0, 1.0));
  c->add_option("--max-grasps", o.detector.maxGrasps, "at most N grasps per image, best first (default 5)")->check(CLI::Range(1, 100));
  c->add_flag("--no-jaw-check{false}", o.detector.checkJaws, "ggcnn: take the network's maps as they are (default: jaws checked on the height map)");
  c->add_option("--opening-sigma", o.detector.openingSigmaMm, "ggcnn: weigh quality by the opening's agreement, MM (default 3, 0 off)")
      ->check(CLI::Range(0.0, 100.0));
  c->add_option("--gripper-opening", o.detector.gripper.maxOpeningMm, "widest gripper opening, MM (default 60)")->check(CLI::Range(1.0, 1000.0));
  c->add_option("--camera-pose", o.cameraPose, "3D calibration: handeye.yaml of the fixed depth camera (eye-to-hand, X = T_base_cam)");
  c->add_option("--intrinsics", o.intrinsics, "plane calibration: intrinsics.yaml");
  c->add_option("--handeye", o.handEye, "plane calibration: handeye.yaml");
  c->add_option("--plane", o.plane, "plane calibration: plane.yaml");
  return c;
}

CLI::App* GraspTensorsCommand::add(CLI::App& parent) {
  auto& o = options_;
  auto* c = parent.add_subcommand("tensors", "the grasp network's training tensors from a grasp data set (docs/grasp.md)");
  c->add_option("--dataset", o.dataset, "a 3D data set with grasps.csv (vgr sim render --3d --grasps)")->required();
  c->add_option("--out", o.out, "a new folder for input.npy, target.npy and images.txt")->required();
  c->add_option("--limit", o.limit, "first N images only")->check(CLI::Range(0, 100000000));
  return c;
}

}  // namespace vgr::tools
