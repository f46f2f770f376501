#include "vision/grasp/grasp_detector.hpp"

#include <fmt/core.h>

#include "vision/grasp/analytic_detector.hpp"
#include "vision/grasp/ggcnn_detector.hpp"

namespace vgr::vision::grasp {
namespace {

using Factory = Result<std::unique_ptr<GraspDetector>> (*)(const GraspDetectorOptions&);
struct Entry {
  const char* name;
  Factory make;
};
// The one table of grasp detectors.
constexpr Entry kDetectors[] = {
    {"ggcnn", makeGgcnnDetector},
    {"analytic", makeAnalyticDetector},
};

Result<void> checkOptions(const GraspDetectorOptions& o) {
  auto bad = [](const std::string& what) { return fail(Status::BadArgument, "grasp detector: " + what); };
  if (!(o.minQuality >= 0) || o.minQuality > 1) return bad(fmt::format("min quality {}: expected [0, 1]", o.minQuality));
  if (o.maxGrasps < 1 || o.maxGrasps > 100) return bad(fmt::format("max grasps {}: expected 1..100", o.maxGrasps));
  const Gripper& g = o.gripper;
  if (!(g.maxOpeningMm > 0) || g.maxOpeningMm > 1000) return bad(fmt::format("gripper opening {} mm: expected (0, 1000]", g.maxOpeningMm));
  if (!(g.clearanceMm >= 0) || g.clearanceMm > 50) return bad(fmt::format("jaw clearance {} mm: expected [0, 50]", g.clearanceMm));
  if (!(g.jawLengthMm > 0) || g.jawLengthMm > 200) return bad(fmt::format("jaw length {} mm: expected (0, 200]", g.jawLengthMm));
  if (!(g.jawThicknessMm > 0) || g.jawThicknessMm > 50) return bad(fmt::format("jaw thickness {} mm: expected (0, 50]", g.jawThicknessMm));
  if (!(o.jawMarginMm >= 0) || o.jawMarginMm > 100) return bad(fmt::format("jaw margin {} mm: expected [0, 100]", o.jawMarginMm));
  if (!(o.openingSigmaMm >= 0) || o.openingSigmaMm > 100) return bad(fmt::format("opening sigma {} mm: expected [0, 100]", o.openingSigmaMm));
  if (!(o.minObjectHeightMm > 0) || o.minObjectHeightMm > 1000 || !(o.maxObjectHeightMm > o.minObjectHeightMm))
    return bad(fmt::format("object heights {}..{} mm: expected 0 < min < max, min <= 1000", o.minObjectHeightMm, o.maxObjectHeightMm));
  if (o.minObjectAreaPx < 1 || o.minObjectAreaPx > 10000000) return bad(fmt::format("min object area {} px: expected 1..1e7", o.minObjectAreaPx));
  return {};
}

}  // namespace

const std::vector<std::string>& graspDetectorNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> v;
    for (const auto& e : kDetectors) v.emplace_back(e.name);
    return v;
  }();
  return names;
}

Result<std::unique_ptr<GraspDetector>> makeGraspDetector(const GraspDetectorOptions& o) {
  if (auto c = checkOptions(o); !c) return std::unexpected(c.error());
  for (const auto& e : kDetectors)
    if (o.detector == e.name) return e.make(o);
  return fail(Status::BadArgument, fmt::format("unknown grasp detector '{}' (expected ggcnn or analytic)", o.detector));
}

Result<void> checkFrame(const DepthFrame& f) {
  const auto& c = f.camera;
  if (c.width < kMinFrameSide || c.height < kMinFrameSide || !(c.fx > 0) || !(c.fy > 0))
    return fail(Status::BadArgument, fmt::format("{}: camera {}x{} px, f {} / {} px: expected at least {} px each way and f > 0", f.name,
                                                 c.width, c.height, c.fx, c.fy, kMinFrameSide));
  if (f.zMm.empty()) return fail(Status::BadArgument, f.name + ": empty depth image");
  if (f.zMm.type() != CV_32FC1)
    return fail(Status::BadArgument, fmt::format("{}: expected a depth image in mm (32-bit float, 1 channel), got type {}", f.name, f.zMm.type()));
  if (f.zMm.cols != c.width || f.zMm.rows != c.height)
    return fail(Status::BadArgument, fmt::format("{}: {}x{} px, but the camera is {}x{} (camera.yaml)", f.name, f.zMm.cols, f.zMm.rows,
                                                 c.width, c.height));
  return {};
}

}  // namespace vgr::vision::grasp
