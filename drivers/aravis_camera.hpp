// GigE Vision cameras through Aravis 0.8 (docs/cameras.md). Opens by IP address (required
// on loopback as root, PITFALLS.md), by serial number or by DeviceUserID through discovery.
// Applies the camera section of the cell config on every open (a camera that rebooted
// comes back with defaults), reads the features back and logs them.
#pragma once

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "config/cell_config.hpp"
#include "core/result.hpp"
#include "drivers/camera.hpp"

namespace vgr::drivers {

std::unique_ptr<Camera> makeAravisCamera(const config::CameraConfig& config);

// One GigE Vision (or USB3 Vision) device found by discovery.
struct DiscoveredCamera {
  std::string id;       // Aravis device id ("Vendor-Serial")
  std::string vendor, model, serial;
  std::string address;  // IPv4 for GigE, empty for USB
  std::string protocol; // "GigEVision", "USB3Vision", ...
};

// Broadcast discovery on every interface (~1 s). Blocking; any thread.
std::vector<DiscoveredCamera> discoverCameras();

// One GVCP discovery request to `address`:3956; true if a camera answered within
// `timeout`. Cheap liveness check used before the (slow, blocking) full open.
bool probeGigECamera(const std::string& address, std::chrono::milliseconds timeout);

}  // namespace vgr::drivers
