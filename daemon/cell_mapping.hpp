// The pixel -> robot mapping a cell config selects (vision/calib/pixel_mapping.hpp):
//   calibration.multiheight            -> paper 001's multi-height map (multiheight.yaml)
//   calibration.intrinsics/handeye/plane -> the calibrated camera and work plane (a camera on
//                                          the flange when handeye.yaml is eye-in-hand: then
//                                          each cycle needs the snapshot's flange pose)
//   no calibration section             -> the config's pinhole `model` (a known camera)
// Errors carry Status::NotCalibrated and name the file and why; vgrd then answers every
// job with -6 NOT_CALIBRATED rather than map with something else.
#pragma once

#include <memory>

#include "config/cell_config.hpp"
#include "core/result.hpp"
#include "vision/calib/pixel_mapping.hpp"

namespace vgr::daemon {

Result<std::unique_ptr<vision::calib::PixelMapping>> makeCellMapping(const config::CellConfig& cell);

// The config's `model` section as a pinhole camera over the conveyor plane.
vision::PinholePlaneModel pinholeModel(const config::PlaneModelConfig& model);

}  // namespace vgr::daemon
