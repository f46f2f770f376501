#include "tools/vgr/calibrate_plane.hpp"

#include <cstdio>
#include <fstream>
#include <sstream>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>

#include "core/pose.hpp"
#include "vision/calib/handeye.hpp"
#include "vision/calib/intrinsics.hpp"
#include "vision/calib/mapping.hpp"
#include "vision/calib/se3.hpp"
#include "vision/gray_image.hpp"

namespace vgr::tools {
namespace calib = vision::calib;
namespace se3 = vision::se3;

namespace {

// Object points of a detection: all (patternObjectPoints order) or those its ids name (charuco).
std::vector<cv::Point3f> viewObjectPoints(const calib::PatternSpec& spec, const calib::ViewDetection& d) {
  const auto obj = calib::patternObjectPoints(spec);
  if (d.ids.empty()) return obj;
  std::vector<cv::Point3f> o;
  for (int i : d.ids) o.push_back(obj[static_cast<std::size_t>(i)]);
  return o;
}

}  // namespace

int runCalibratePlane(const CalibPlaneOptions& o) {
  if (auto w = checkOutputPath(o.out); !w) return bad(w.error().message);
  calib::WorkPlane plane;
  std::string source;
  if (!o.points.empty() == !o.image.empty()) return bad("give either --image (a plate on the conveyor) or --points FILE");
  if (!o.points.empty()) {
    std::ifstream f(o.points);
    if (!f) return bad(fmt::format("{}: cannot open", o.points));
    std::vector<Vec3> pts;
    std::string line;
    for (int n = 1; std::getline(f, line); ++n) {
      if (auto h = line.find('#'); h != std::string::npos) line.resize(h);
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
      std::istringstream ls(line);
      Vec3 p;
      std::string extra;
      if (!(ls >> p.x >> p.y >> p.z) || (ls >> extra))
        return bad(fmt::format("{}:{}: expected 'x y z' in mm", o.points, n));
      pts.push_back(p);
    }
    auto fit = calib::planeFromPoints(pts);
    if (!fit) return bad(fmt::format("{}: {}", o.points, fit.error().message));
    plane = *fit;
    source = "points";
    std::printf("plane through %zu touched points: fit rms %.3f mm\n", pts.size(), plane.fitRmsMm);
  } else {
    auto spec = patternSpec(o.pattern);
    if (!spec) return bad(spec.error().message);
    auto cam = calib::readIntrinsics(o.intrinsics);
    if (!cam) return bad(cam.error().message);
    auto he = calib::readHandEye(o.handeye);
    if (!he) return bad(he.error().message);
    if (he->config != calib::HandEyeConfig::EyeToHand)
      return bad(fmt::format("{}: an eye-in-hand calibration needs the snapshot pose; use --points", o.handeye));
    auto read = vision::readGray8(o.image);
    if (!read) return bad(read.error().message);
    const cv::Mat img = *read;
    const auto d = calib::detectPattern(img, *spec, o.image);
    if (!d.found)
      return bad(fmt::format("{}: the {} {}x{} was not found{}", o.image, o.pattern.pattern, o.pattern.cols,
                             o.pattern.rows, d.note.empty() ? "" : " (" + d.note + ")"));
    cv::Vec3d rv, tv;
    cv::solvePnP(viewObjectPoints(*spec, d), d.corners, cam->cameraMatrix, cam->dist, rv, tv);
    plane = calib::planeFromPlate(he->x, se3::toPose(se3::fromRvecTvec(rv, tv)), o.thicknessMm);
    source = "plate";
    std::printf("plane from the plate in %s (thickness %.2f mm)\n", o.image.c_str(), o.thicknessMm);
  }
  std::printf("point %.3f %.3f %.3f mm, normal %.6f %.6f %.6f\n", plane.point.x, plane.point.y, plane.point.z,
              plane.normal.x, plane.normal.y, plane.normal.z);
  if (auto w = calib::writeWorkPlane(o.out, plane, source); !w) return bad(w.error().message);
  std::printf("written: %s\n", o.out.c_str());
  if (o.json) {
    nlohmann::json j{{"point_mm", {plane.point.x, plane.point.y, plane.point.z}},
                     {"normal", {plane.normal.x, plane.normal.y, plane.normal.z}},
                     {"fit_rms_mm", plane.fitRmsMm}, {"source", source}, {"out", o.out}};
    std::printf("%s\n", j.dump().c_str());
  }
  return 0;
}

CLI::App* CalibratePlaneCommand::add(CLI::App& parent) {
  auto& calPl = options_;
  auto* calPlCmd = parent.add_subcommand("plane", "work plane from a plate on the conveyor or robot-touched points");
  calPlCmd->add_option("--image", calPl.image, "image of a plate lying on the conveyor");
  calPlCmd->add_option("--intrinsics", calPl.intrinsics, "intrinsics.yaml (with --image)");
  calPlCmd->add_option("--handeye", calPl.handeye, "eye-to-hand handeye.yaml (with --image)");
  calPlCmd->add_option("--thickness", calPl.thicknessMm, "plate thickness, mm (with --image)");
  calPlCmd->add_option("--points", calPl.points, "file of robot-touched points, 'x y z' mm per line");
  addPatternOptions(*calPlCmd, calPl.pattern);
  calPlCmd->add_option("--out", calPl.out, "plane.yaml to write");
  calPlCmd->add_flag("--json", calPl.json, "end with one JSON line");
  return calPlCmd;
}

}  // namespace vgr::tools
