#include "daemon/cell_mapping.hpp"

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
  auto m = calib::loadCellCalibration(c.intrinsics, c.handeye, c.plane);
  if (!m) return std::unexpected(m.error());
  return calib::cameraPlaneMapping(*m);
}

}  // namespace vgr::daemon
