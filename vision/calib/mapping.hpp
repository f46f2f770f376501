// Work plane and pixel <-> robot mapping with a calibrated camera (with lens distortion):
// the ray/plane intersection of paper 002 (eqs. 5-11, the "virtual plane", part height added
// along the plane normal), and the inverse projection for overlays.
// Frames: base = robot base, mm. Pure geometry; cheap to copy; thread-compatible (const).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/pose.hpp"
#include "core/result.hpp"
#include "vision/calib/intrinsics.hpp"
#include "vision/calib/plane_model.hpp"

namespace vgr::vision::calib {

// A plane in the base frame: a point on it and its unit normal.
struct WorkPlane {
  Vec3 point;
  Vec3 normal{0, 0, 1};
  double fitRmsMm = 0;  // planeFromPoints: RMS distance of the points to the plane
};

// (a) From a calibration plate lying on the conveyor, seen by the calibrated camera
// (T_cam_plate from solvePnP) and the camera pose in the base frame (hand-eye). The plate's
// top is plateThicknessMm above the conveyor: the plane is moved down by that much.
WorkPlane planeFromPlate(const Pose& baseFromCamera, const Pose& camFromPlate, double plateThicknessMm = 0);

// (b) From N >= 3 robot-touched points (paper 001's grid at height 0): least-squares plane
// (SVD). Errors name the problem (too few, collinear). Normal points to base +z.
Result<WorkPlane> planeFromPoints(const std::vector<Vec3>& pointsBase);

class CameraPlaneMapping {
 public:
  // baseFromCamera: T_base_cam (eye-to-hand: X; eye-in-hand: T_base_gripper at the
  // snapshot pose times X). The plane normal is turned to face the camera, so heights are
  // measured toward the camera.
  CameraPlaneMapping(const CameraIntrinsics& camera, const Pose& baseFromCamera, const WorkPlane& plane);

  // The point of the pixel's viewing ray (distortion removed) on the plane raised by
  // heightMm along its normal. Empty when the ray misses the plane (parallel or behind).
  std::optional<Vec3> pixelToRobot(PixelPoint p, double heightMm = 0) const;

  // Projection of a base-frame point with the lens distortion; empty when behind the camera.
  std::optional<PixelPoint> robotToPixel(const Vec3& pointBase) const;

  const WorkPlane& plane() const { return plane_; }
  const CameraIntrinsics& camera() const { return camera_; }

 private:
  CameraIntrinsics camera_;
  Pose baseFromCamera_;
  WorkPlane plane_;
};

// Eye-in-hand (the camera on the robot flange): intrinsics, X = T_flange_cam (handeye.yaml,
// eye-in-hand) and the work plane, fixed in the base frame. A snapshot taken with the flange
// at T_base_flange maps exactly like a fixed camera at T_base_cam = T_base_flange * X.
class EyeInHandPlaneMapping {
 public:
  EyeInHandPlaneMapping(const CameraIntrinsics& camera, const Pose& flangeFromCamera, const WorkPlane& plane);

  // CameraPlaneMapping::pixelToRobot of the snapshot taken at baseFromFlange.
  std::optional<Vec3> pixelToRobot(PixelPoint p, double heightMm, const Pose& baseFromFlange) const;
  // T_base_cam of that snapshot.
  Pose baseFromCamera(const Pose& baseFromFlange) const;

  const CameraIntrinsics& camera() const { return camera_; }
  const Pose& flangeFromCamera() const { return flangeFromCamera_; }
  const WorkPlane& plane() const { return plane_; }

 private:
  CameraIntrinsics camera_;
  Pose flangeFromCamera_;
  WorkPlane plane_;
};

}  // namespace vgr::vision::calib

namespace vgr::vision::calib {

// plane.yaml (OpenCV FileStorage): point_mm, normal (base frame), fit_rms_mm and how it was
// made ("plate" or "points").
Result<void> writeWorkPlane(const std::string& path, const WorkPlane& plane, const std::string& source);
Result<WorkPlane> readWorkPlane(const std::string& path);

// The calibration a fixed camera's cell maps with: intrinsics.yaml + handeye.yaml
// (eye-to-hand: X = T_base_cam) + plane.yaml. Errors carry Status::NotCalibrated and name the
// file and why (missing, malformed, eye-in-hand, residuals above the limits).
// loadEyeInHandCalibration: the same for a camera on the flange (handeye.yaml eye-in-hand,
// X = T_flange_cam); pixel_mapping.hpp's loadCalibrationMapping picks by the file.
struct CellCalibrationLimits {
  double maxReprojPx = 1.0;     // intrinsics RMS and hand-eye reprojection RMS
  double maxHandEyeMm = 2.0;    // hand-eye consistency residual
  double maxHandEyeDeg = 0.2;
  double maxPointRmsMm = 1.0;   // depth-camera hand-eye: RMS of the target points through A_i, X, Y
};
Result<CameraPlaneMapping> loadCellCalibration(const std::string& intrinsicsPath, const std::string& handEyePath,
                                               const std::string& planePath, const CellCalibrationLimits& limits = {});
Result<EyeInHandPlaneMapping> loadEyeInHandCalibration(const std::string& intrinsicsPath, const std::string& handEyePath,
                                                       const std::string& planePath,
                                                       const CellCalibrationLimits& limits = {});

}  // namespace vgr::vision::calib
