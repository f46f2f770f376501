// The replay camera: serves the images of a folder (PNG, PGM/PNM, TIFF, BMP, JPEG; 8- or
// 16-bit gray, colour converted to gray) in file-name order, looping or not, behind the
// same Camera interface as a real camera, for offline work and tests (docs/cameras.md).
// With camera.pixel_format Coord3D_C16 the folder is a 3D data set (camera.yaml +
// images/*.png, config/depth_dataset.hpp): frames are DepthMm (z = value x
// depth_scale_mm, 0 = no data) with camera.yaml's intrinsics; a depth image of another size
// or that is not 16-bit single-channel is a Failed frame naming the file.
// Software trigger: each trigger serves the next image at once. Hardware trigger: no line
// exists, so a trigger waits its timeout and reports FrameStatus::Timeout. The folder
// vanishing is a disconnected device; it comes back with open() once the folder is back.
#pragma once

#include <memory>

#include "config/cell_config.hpp"
#include "drivers/camera.hpp"

namespace vgr::drivers {

std::unique_ptr<Camera> makeReplayCamera(const config::CameraConfig& config);

}  // namespace vgr::drivers
