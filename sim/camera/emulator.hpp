// A GigE Vision camera on a loopback address, built on libaravis' own fake GigE camera
// (arv_gv_fake_camera_new), serving frames from the SceneRenderer over the real GVCP/GVSP
// protocol. Frames are rendered on Aravis' camera thread in the fill-pattern callback.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "core/result.hpp"
#include "sim/scene.hpp"

namespace vgr::sim {

struct EmulatorOptions {
  std::string address = "127.0.0.1";  // interface address the camera answers on (GVCP port 3956)
  std::string serial = "VGR-SIM-0";
  std::string truthPath;              // if set: one JSON line of ground truth per served frame
};

class CameraEmulator {
 public:
  CameraEmulator(SceneRenderer renderer, EmulatorOptions options);
  ~CameraEmulator();  // stops the camera thread
  CameraEmulator(const CameraEmulator&) = delete;
  CameraEmulator& operator=(const CameraEmulator&) = delete;

  // Checks that the GVCP port is free (Aravis would fail silently), starts the camera.
  Result<void> start();
  std::uint64_t framesServed() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vgr::sim
