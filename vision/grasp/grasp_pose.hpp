// A detected grasp as a pose in the robot's base frame (docs/grasp.md "Robot frame"):
// centre, closing angle and opening.
//   graspToRobot3d    the 3D calibration: the depth camera's intrinsics and its pose in the
//                     base frame (T_base_cam, hand-eye eye-to-hand X): the centre pixel at its
//                     measured depth back-projected exactly
//   graspToRobotPlane the plane calibration of the cell (any calib::PixelMapping: pinhole
//                     model, calibration files, multi-height map): the centre pixel mapped on
//                     the work plane raised by the grasp's height above the floor, which the
//                     depth at the centre gives (Grasp::heightMm; paper 002 eqs. (9)-(11))
// Both map the two jaw points (centre +- half the opening along the closing axis, at the
// centre's depth / height) too: the opening in mm is their distance, the angle is their
// direction's about base z, in (-90, 90]. The pose is poseFromXyzRz(centre, angle): the
// rotation about base z that turns base x onto the closing axis, as 2D part poses are given.
// The centre is the visible surface at the grasp centre; how deep the jaws go below it is
// the cell's (the robot program's) business. Pure geometry, any thread.
#pragma once

#include "core/pose.hpp"
#include "core/result.hpp"
#include "vision/calib/pixel_mapping.hpp"
#include "vision/grasp/grasp_detector.hpp"

namespace vgr::vision::grasp {

struct RobotGrasp {
  Pose pose;              // base frame, mm; rotation about base z by angleDeg
  Vec3 centre;            // = pose's position, mm
  double angleDeg = 0;    // closing axis about base z, (-90, 90]
  double widthMm = 0;     // opening
};

// Errors: Status::BadArgument for a grasp without a depth or with a jaw point that cannot be
// back-projected; Status::NotCalibrated for a closing axis along base z (the camera is not
// looking down on the work plane).
Result<RobotGrasp> graspToRobot3d(const Grasp& g, const DepthIntrinsics& camera, const Pose& baseFromCamera);

// Errors: Status::NotCalibrated when the mapping cannot map the centre or a jaw point
// (outside a multi-height grid, a ray that misses the plane).
Result<RobotGrasp> graspToRobotPlane(const Grasp& g, const calib::PixelMapping& mapping);

}  // namespace vgr::vision::grasp
