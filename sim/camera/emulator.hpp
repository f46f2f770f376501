// A GigE Vision camera on a loopback address, built on libaravis' own fake GigE camera
// (arv_gv_fake_camera_new), serving frames over the real GVCP/GVSP protocol: rendered
// scenes (CellScenes: the plate or textured parts, ground truth known to tests) or the
// images of a folder. Frames
// are produced on Aravis' camera thread in the fill-pattern callback. Mono8, Mono16 and
// the Bayer8 formats (a gray scene is its own Bayer mosaic), ROI offsets honoured.
// As a depth camera (`depthDataset`): the scenes of a 3D data-set folder (camera.yaml,
// images/*.png, truth.csv; config/depth_dataset.hpp) as Coord3D_C16, frame id k showing
// image (k - 1) mod n, with a GenICam description extended by Scan3dControl (depth_xml.hpp):
// Scan3dCoordinateScale = depth_scale_mm in Millimeter (or the unit `depthUnit` names, for
// tests of a camera the driver must refuse), offset 0, invalid value 0, the focal length and
// principal point of camera.yaml (fx must equal fy: SFNC has one focal length). The truth
// file gets one JSON line per frame with the image and its parts' poses (camera frame).
// Limits of Aravis 0.8.26's fake camera: no packet resend (a lost packet is a lost frame),
// trigger sources Line0 and Software only, no TriggerDelay.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "core/result.hpp"
#include "sim/cell_scenes.hpp"

namespace vgr::sim {

struct EmulatorOptions {
  std::string address = "127.0.0.1";  // interface address the camera answers on (GVCP port 3956)
  std::string serial = "VGR-SIM-0";
  std::string truthPath;              // if set: one JSON line of ground truth per served frame
  std::string imagesFolder;           // if set: serve these images (name order, looping) instead of scenes
  double lossRatio = 0.0;             // [0, 1]: probability that each GVSP packet is dropped
  double fps = 25.0;                  // free-run frame rate (AcquisitionFrameRate default), (0, 1000]
  std::string depthDataset;           // if set: a depth camera serving this 3D data set
  std::string depthUnit = "Millimeter";  // Scan3dDistanceUnit served: Millimeter, Inch (scale / 25.4) or Pixel
  // > 0: every N-th frame (frame id divisible by N) shows the empty belt (no part, empty
  // truth): a cell where every N-th cycle finds nothing (the archive's tests and bench).
  int emptyEvery = 0;
};

class CameraEmulator {
 public:
  CameraEmulator(CellScenes scenes, EmulatorOptions options);
  ~CameraEmulator();  // stops the camera thread
  CameraEmulator(const CameraEmulator&) = delete;
  CameraEmulator& operator=(const CameraEmulator&) = delete;

  // Checks that the GVCP port is free (Aravis would fail silently), loads the image folder
  // if any, starts the camera.
  Result<void> start();
  std::uint64_t framesServed() const;
  // Simulated hardware trigger: one edge on Line0. Fires a frame if the client configured
  // TriggerMode=On, TriggerSource=Line0; otherwise ignored (as a real camera). Returns
  // whether the camera was armed for it. Any thread.
  bool pulseLine();
  // GVSP packet loss from now on, [0, 1] (fault injection: `vgr soak`). Any thread.
  void setLossRatio(double ratio);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vgr::sim
