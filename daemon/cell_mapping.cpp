#include "daemon/cell_mapping.hpp"

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

}  // namespace vgr::daemon
