// The one pixel -> robot interface the cycle maps with, whatever the cell was calibrated
// with. Four implementations, chosen per cell in the config (daemon/cell_mapping.hpp):
//   - the pinhole model of the config's `model` section (a known camera, the simulated
//     cell's truth): ray/plane intersection, paper 002 eqs. (9)-(11);
//   - the calibration files intrinsics + hand-eye + plane (CameraPlaneMapping): the same
//     ray/plane intersection with lens distortion, paper 002 eqs. (5)-(11);
//   - paper 001's multi-height map (section 4.1, eqs. (1)-(8)): no camera model, a grid
//     touched by the robot on parallel planes, interpolated at the part's height;
//   - eye-in-hand calibration files (the camera on the flange): maps only through a
//     SnapshotMapping, the view of one image with the flange pose the robot sent with it.
// Frames: pixels x right, y down, centres at integers; result in the robot base frame, mm.
// Pure geometry, const and thread-compatible.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "core/pose.hpp"
#include "core/result.hpp"
#include "vision/calib/plane_model.hpp"  // PixelPoint, PinholePlaneModel

namespace vgr::vision::calib {

class CameraPlaneMapping;
class EyeInHandPlaneMapping;
class MultiHeightMap;

struct ImageSize {
  int width = 0, height = 0;  // px
};

class PixelMapping {
 public:
  virtual ~PixelMapping() = default;
  // The base-frame point seen at pixel p on the work plane raised by heightMm (the part's
  // grasp height). Empty when the pixel cannot be mapped (ray misses the plane, outside the
  // multi-height grid).
  virtual std::optional<Vec3> pixelToRobot(PixelPoint p, double heightMm) const = 0;
  // The image size the calibration was made for; empty when any size goes (the pinhole
  // model is given for the camera as configured). A frame of another size is NOT_CALIBRATED.
  virtual std::optional<ImageSize> imageSize() const = 0;
  // "pinhole model", "calibration files", "multi-height map (13 x 15 points, 4 planes)".
  virtual std::string describe() const = 0;
  // Eye-in-hand: the mapping whose snapshots a SnapshotMapping views; its own pixelToRobot()
  // has no answer (no flange pose). Null for a fixed camera (a flange pose is not needed).
  virtual const EyeInHandPlaneMapping* eyeInHand() const { return nullptr; }
};

// One eye-in-hand snapshot: `mapping` with the camera at T_base_flange * X. A view for one
// cycle (stack object, no allocation): `mapping` must outlive it.
class SnapshotMapping final : public PixelMapping {
 public:
  SnapshotMapping(const EyeInHandPlaneMapping& mapping, const Pose& baseFromFlange)
      : mapping_(mapping), baseFromFlange_(baseFromFlange) {}
  std::optional<Vec3> pixelToRobot(PixelPoint p, double heightMm) const override;
  std::optional<ImageSize> imageSize() const override;
  std::string describe() const override;

 private:
  const EyeInHandPlaneMapping& mapping_;
  Pose baseFromFlange_;
};

std::unique_ptr<PixelMapping> pinholeMapping(const PinholePlaneModel& model);
std::unique_ptr<PixelMapping> cameraPlaneMapping(const CameraPlaneMapping& mapping);
std::unique_ptr<PixelMapping> multiHeightMapping(const MultiHeightMap& map, ImageSize imageSize);
std::unique_ptr<PixelMapping> eyeInHandMapping(const EyeInHandPlaneMapping& mapping);

// intrinsics.yaml + handeye.yaml + plane.yaml as the mapping their hand-eye configuration
// calls for: eye-to-hand -> cameraPlaneMapping, eye-in-hand -> eyeInHandMapping. Errors as
// loadCellCalibration (Status::NotCalibrated, naming the file).
Result<std::unique_ptr<PixelMapping>> loadCalibrationMapping(const std::string& intrinsicsPath,
                                                             const std::string& handEyePath,
                                                             const std::string& planePath);

}  // namespace vgr::vision::calib
