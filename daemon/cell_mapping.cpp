#include "daemon/cell_mapping.hpp"

#include <fmt/core.h>

#include "vision/calib/handeye.hpp"
#include "vision/calib/mapping.hpp"
#include "vision/calib/multi_height_file.hpp"

namespace vgr::daemon {

vision::PinholePlaneModel pinholeModel(const config::PlaneModelConfig& m) {
  return vision::PinholePlaneModel(m.fx, m.fy, m.cx, m.cy,
                                   vision::PinholePlaneModel::downLookingCamera(m.camX, m.camY, m.camZ, m.camRzDeg),
                                   m.planeZ);
}

Result<std::unique_ptr<vision::calib::PixelMapping>> makeCellMapping(const config::CellConfig& cell) {
  namespace calib = vision::calib;
  const auto& c = cell.calibration;
  if (!c.enabled) return calib::pinholeMapping(pinholeModel(cell.model));
  if (!c.multiHeight.empty()) {
    auto mh = calib::readMultiHeight(c.multiHeight);
    if (!mh) return std::unexpected(mh.error());
    return calib::multiHeightMapping(mh->map, mh->samples.imageSize);
  }
  return calib::loadCalibrationMapping(c.intrinsics, c.handeye, c.plane);
}

Result<DepthCellFrame> makeDepthCellFrame(const config::CellConfig& cell) {
  namespace calib = vision::calib;
  DepthCellFrame f;
  const auto& c = cell.calibration;
  if (!c.enabled) {
    const auto& m = cell.model;
    f.x = vision::PinholePlaneModel::downLookingCamera(m.camX, m.camY, m.camZ, m.camRzDeg);
    f.description = "the config's model camera pose (no calibration section)";
    return f;
  }
  auto he = calib::readHandEye(c.handeye);
  if (!he) return std::unexpected(he.error());
  const calib::CellCalibrationLimits limits;
  if (he->reprojRmsPx > limits.maxReprojPx || he->transResidMm > limits.maxHandEyeMm ||
      he->rotResidDeg > limits.maxHandEyeDeg || he->pointRmsMm > limits.maxPointRmsMm)
    return fail(Status::NotCalibrated,
                fmt::format("{}: residuals {:.3f} mm / {:.4f} deg / points {:.3f} mm exceed the limits {:.2f} mm / {:.2f} deg / "
                            "{:.2f} mm: recalibrate",
                            c.handeye, he->transResidMm, he->rotResidDeg, he->pointRmsMm, limits.maxHandEyeMm,
                            limits.maxHandEyeDeg, limits.maxPointRmsMm));
  f.eyeInHand = he->config == calib::HandEyeConfig::EyeInHand;
  f.x = he->x;
  f.description = fmt::format("hand-eye {} ({}, method {})", c.handeye, calib::handEyeConfigName(he->config), he->method);
  return f;
}

}  // namespace vgr::daemon
