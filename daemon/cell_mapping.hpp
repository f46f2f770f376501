// The pixel -> robot mapping a cell config selects (vision/calib/pixel_mapping.hpp):
//   calibration.multiheight            -> paper 001's multi-height map (multiheight.yaml)
//   calibration.intrinsics/handeye/plane -> the calibrated camera and work plane (a camera on
//                                          the flange when handeye.yaml is eye-in-hand: then
//                                          each cycle needs the snapshot's flange pose)
//   no calibration section             -> the config's pinhole `model` (a known camera)
// Errors carry Status::NotCalibrated and name the file and why; vgrd then answers every
// job with -6 NOT_CALIBRATED rather than map with something else.
// A depth camera's cell (camera.depth()) maps 3D poses with makeDepthCellFrame instead:
//   calibration.handeye -> X of `vgr calibrate handeye --cloud` (eye-to-hand: T_base_cam;
//                          eye-in-hand: T_flange_cam, each cycle needs the snapshot's flange)
//   no calibration      -> the config's `model` camera pose (a known camera).
#pragma once

#include <memory>
#include <string>

#include "config/cell_config.hpp"
#include "core/pose.hpp"
#include "core/result.hpp"
#include "vision/calib/pixel_mapping.hpp"

namespace vgr::daemon {

Result<std::unique_ptr<vision::calib::PixelMapping>> makeCellMapping(const config::CellConfig& cell);

// Where a depth camera is, for turning T_cam_grasp into T_base_grasp. Plain value; any thread.
struct DepthCellFrame {
  bool eyeInHand = false;
  Pose x;                    // eye-to-hand: T_base_cam; eye-in-hand: T_flange_cam (mm, unit quaternion)
  std::string description;   // for the log: "hand-eye FILE (eye-to-hand, method refined)"
  // T_base_cam of one image: x, or flange * x on the flange (flange = T_base_flange the robot
  // sent with the trigger; the caller checks an eye-in-hand cycle has one).
  Pose baseFromCamera(const Pose* flange) const { return eyeInHand && flange ? compose(*flange, x) : x; }
};
// Errors (Status::NotCalibrated) name the file: missing, malformed, a 2D plate calibration
// (no point_rms_mm is fine: a depth calibration's residual limits are those of
// vision/calib/mapping.hpp's CellCalibrationLimits), residuals above the limits.
Result<DepthCellFrame> makeDepthCellFrame(const config::CellConfig& cell);

// The config's `model` section as a pinhole camera over the conveyor plane.
vision::PinholePlaneModel pinholeModel(const config::PlaneModelConfig& model);

}  // namespace vgr::daemon
