// GigE Vision cameras through Aravis 0.8. Opens by IP address (required on loopback as root,
// PITFALLS.md) or by serial/user name through discovery. Software trigger, Mono8.
#pragma once

#include <memory>

#include "config/cell_config.hpp"
#include "drivers/camera.hpp"

namespace vgr::drivers {

std::unique_ptr<Camera> makeAravisCamera(const config::CameraConfig& config);

}  // namespace vgr::drivers
